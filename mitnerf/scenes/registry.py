"""Named scenes and how to load them into Mitsuba.

2D scenes (``square``, ``square_concave``, ``bunny``, ``tu``) are outlines stored in
``scenes_xml/polygons/<name>.json``; mitnerf extrudes them into a prism PLY and loads
``scenes_xml/<name>.xml`` with ``$mesh`` pointing at it. A user polygon goes through
the same path with ``scenes_xml/custom2d.xml``. 3D objects (``vase``, ``ant``,
``airplane``, ``nut``) write their mesh and texture on first use. Generated assets
are cached under ``$MITNERF_CACHE`` with a content hash in the file name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from .._io import cache_entry, digest
from .._variant import ensure_variant
from ..errors import DataError
from .objects3d import OBJECTS_3D, build_object
from .polygon import Polygon
from .ply import write_ply

SCENES_XML = Path(__file__).resolve().parents[2] / "scenes_xml"
SCENES_2D = ("square", "square_concave", "bunny", "tu")
ASSET_VERSION = "2"  # bump when a builder changes what it writes


def scene_names() -> tuple[str, ...]:
    return SCENES_2D + OBJECTS_3D


@dataclass
class SceneInfo:
    """Everything needed to render a scene and to check renders against it."""

    name: str
    """Scene name (a registry name, ``custom`` for a user polygon, or the XML stem)."""
    kind: Literal["2d", "3d"]
    """``2d``: a prism seen from the z = 0 plane (1D views). ``3d``: an object."""
    xml: Path
    """The Mitsuba scene file."""
    variables: dict[str, str] = field(default_factory=dict)
    """``$variables`` passed to ``mitsuba.load_file`` (asset paths)."""
    polygon: Polygon | None = None
    """The outline (2D scenes): the analytic reference for depth tests and plots."""
    mesh: Path | None = None
    """The object's mesh (PLY): for rig plots, Chamfer distances and mesh export."""
    radius: float = 1.0
    """Radius of a sphere (2D: circle) around the origin that holds the object."""

    def load(self, **overrides):
        """Load into the current Mitsuba variant. Errors name the file and the fix."""
        return load_xml(self.xml, **{**self.variables, **overrides})


def load_xml(path: Path, **variables):
    import mitsuba as mi

    ensure_variant()
    path = Path(path)
    if not path.is_file():
        raise DataError(f"scene file {path} does not exist; check the path (scenes live in {SCENES_XML})")
    try:
        return mi.load_file(str(path), **{k: str(v) for k, v in variables.items()})
    except RuntimeError as exc:
        msg = " ".join(str(exc).split())
        msg = msg.split("] ", 1)[-1] if msg.startswith("[") else msg
        raise DataError(f"cannot load scene file {path}: {msg}; fix the XML") from None


def prism_mesh(polygon: Polygon) -> Path:
    """Write (or reuse) the prism PLY of ``polygon``."""
    def build(tmp: Path) -> None:
        v, f, c = polygon.prism()
        write_ply(tmp / "prism.ply", v, f, colors=c)

    key = digest(ASSET_VERSION, polygon.points.tobytes())
    return cache_entry(f"meshes/{polygon.name}-{key}", build) / "prism.ply"


def scene_2d(polygon: Polygon, xml: Path | None = None) -> SceneInfo:
    """A 2D scene from any valid polygon (the registry's or a user's)."""
    mesh = prism_mesh(polygon)
    xml = xml or SCENES_XML / "custom2d.xml"
    return SceneInfo(polygon.name, "2d", xml, {"mesh": str(mesh)}, polygon=polygon,
                     mesh=mesh, radius=polygon.radius())


def object_3d(name: str) -> SceneInfo:
    def build(tmp: Path) -> None:
        variables = build_object(name, tmp)
        (tmp / "variables.txt").write_text("\n".join(f"{k}={Path(v).name}" for k, v in variables.items()))

    folder = cache_entry(f"objects/{name}-{digest(ASSET_VERSION, name)}", build)
    variables = {k: str(folder / v) for k, v in
                 (line.split("=", 1) for line in (folder / "variables.txt").read_text().splitlines())}
    return SceneInfo(name, "3d", SCENES_XML / f"{name}.xml", variables, mesh=Path(variables["mesh"]), radius=1.0)


def get_scene(scene: str | Path | None = None, *, polygon=None, kind: str | None = None) -> SceneInfo:
    """Resolve a scene: a registry name, a path to an XML file, or a user polygon.

    ``polygon`` may be a :class:`Polygon`, a list of points (a closed ring) or a
    path to a JSON file; it takes precedence over ``scene``.
    """
    if polygon is not None:
        if not isinstance(polygon, Polygon):
            polygon = (Polygon.from_json(polygon) if isinstance(polygon, (str, Path))
                       else Polygon.from_points(polygon))
        return scene_2d(polygon)
    if scene is None:
        raise DataError(f"no scene given; pass one of {', '.join(scene_names())} or a polygon")
    name = str(scene)
    if name in SCENES_2D:
        poly = Polygon.from_json(SCENES_XML / "polygons" / f"{name}.json")
        return scene_2d(poly, SCENES_XML / f"{name}.xml")
    if name in OBJECTS_3D:
        return object_3d(name)
    if name.endswith(".xml"):
        path = Path(name)
        if not path.is_file():
            raise DataError(f"scene file {path} does not exist; check the path")
        info = SceneInfo(path.stem, "2d" if kind == "2d" else "3d", path.resolve())
        info.load()  # fail early on malformed XML
        return info
    raise DataError(
        f"unknown scene {name!r}; choose one of {', '.join(scene_names())}, "
        "give a path to a Mitsuba XML file, or pass --polygon FILE")
