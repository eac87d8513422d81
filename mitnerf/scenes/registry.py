"""Named scenes and how to load them into Mitsuba.

2D scenes (``square``, ``square_concave``, ``bunny``, ``tu``) are outlines in ``scenes_xml/polygons/<name>.json``,
extruded into a prism PLY that ``scenes_xml/<name>.xml`` loads as ``$mesh`` (a user polygon:
``scenes_xml/custom2d.xml``). 3D objects write their mesh and texture on first use. Generated assets are cached
under ``$MITNERF_CACHE`` with a content hash in the file name. Other looks (:mod:`mitnerf.scenes.looks`) are
chosen by arguments of :func:`get_scene` or by a name such as ``bunny_glossy`` or ``vase_roughconductor_env``.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from .._io import cache_entry, digest
from .._variant import ensure_variant
from ..errors import DataError
from .looks import check_look, split_variant, styled_scene, variant_name
from .objects3d import OBJECTS_3D, build_object, table_texture
from .polygon import Polygon, outline_stripes
from .ply import read_ply, write_ply

SCENES_XML = Path(__file__).resolve().parents[2] / "scenes_xml"
SCENES_2D = ("square", "square_concave", "bunny", "tu")
SCENE_NAMES = SCENES_2D + OBJECTS_3D
ASSET_VERSION = "2"  # bump when a builder changes what it writes
TABLE = "_table"
"""``<object>_table``: a 3D object standing on a square table with a print that repeats nowhere
(:func:`~.objects3d.table_texture`), what structure from motion needs (``mitnerf poses``' tests and benchmark)."""
TABLE_HALF = 1.6
"""Half the side of the table (world units)."""


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
    """The object's mesh (PLY): for rig plots, Chamfer distances and mesh export; the
    shape that non-default looks render (the ``textured`` outline: the prism with UVs)."""
    radius: float = 1.0
    """Radius of a sphere (2D: circle) around the origin that holds the object."""
    texture: Path | None = None
    """The image texture of a mesh with UVs (``vase``, ``brick``, a ``textured`` outline)."""
    material: str = "diffuse"
    """``diffuse``, ``plastic``, ``roughplastic``, ``roughconductor`` or ``textured`` (2D)."""
    lighting: str = "points"
    """``points`` (the XML's point lights) or ``env`` (a sky with a sun: render with ``path``)."""
    roughness: float | None = None
    """GGX roughness of a rough material; None: the material's default (:data:`~mitnerf.scenes.looks.ROUGHNESS`)."""

    def load(self, **overrides):
        """Load into the current Mitsuba variant (``overrides``: more ``$variables``); errors name the file and fix."""
        import mitsuba as mi

        ensure_variant()
        path = Path(self.xml)
        if not path.is_file():
            raise DataError(f"scene file {path} does not exist; check the path (scenes live in {SCENES_XML})")
        try:
            scene = mi.load_file(str(path), **{k: str(v) for k, v in {**self.variables, **overrides}.items()})
        except RuntimeError as exc:
            msg = " ".join(str(exc).split())
            msg = msg.split("] ", 1)[-1] if msg.startswith("[") else msg
            raise DataError(f"cannot load scene file {path}: {msg}; fix the XML") from None
        if not isinstance(scene, mi.Scene):      # a root <shape>, <bsdf>, ... loads as that object
            raise DataError(f"scene file {path} holds a {type(scene).__name__}, not a scene; wrap it in "
                            '<scene version="3.0.0"> ... </scene>')
        if not scene.shapes():
            raise DataError(f"scene file {path} has no shapes, so every view would be empty; add a <shape>")
        plain = self.material == "diffuse" and self.lighting == "points"
        return scene if plain else styled_scene(self, scene.emitters())


def prism_assets(polygon: Polygon, textured: bool = False) -> Path:
    """The cache folder of ``polygon``'s prism, written on first use: ``prism.ply`` (vertex colours) or, ``textured``,
    ``prism_uv.ply`` (UVs) and its barcode ``stripes.exr``; the polygon's name is made a safe file name."""
    def build(tmp: Path) -> None:
        if textured:
            import mitsuba as mi
            v, f, uv = polygon.prism_uv()
            write_ply(tmp / "prism_uv.ply", v, f, uv=uv)
            mi.Bitmap(outline_stripes(polygon.perimeter())).write(str(tmp / "stripes.exr"))
        else:
            v, f, c = polygon.prism()
            write_ply(tmp / "prism.ply", v, f, colors=c)

    if textured:
        ensure_variant()
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(polygon.name)).strip("._")[:40] or "polygon"
    kind = "-textured" if textured else ""
    return cache_entry(f"meshes/{slug}{kind}-{digest(ASSET_VERSION, polygon.points.tobytes())}", build)


def with_look(info: SceneInfo, material: str = "diffuse", lighting: str = "points",
              roughness: float | None = None) -> SceneInfo:
    """``info`` in another look, renamed ``<name>[_<material>[_r<roughness>]][_env]``."""
    check_look(info.name, info.kind, material, lighting, info.mesh is not None, roughness)
    if (material, lighting) == ("diffuse", "points"):
        return info
    mesh, texture = info.mesh, info.texture
    if material == "textured":
        folder = prism_assets(info.polygon, textured=True)
        mesh, texture = folder / "prism_uv.ply", folder / "stripes.exr"
    return dataclasses.replace(info, name=variant_name(info.name, material, lighting, roughness), mesh=mesh,
                               texture=texture, material=material, lighting=lighting, roughness=roughness)


def scene_2d(polygon: Polygon, xml: Path | None = None) -> SceneInfo:
    """A 2D scene from any valid polygon (the registry's or a user's)."""
    mesh = prism_assets(polygon) / "prism.ply"
    return SceneInfo(polygon.name, "2d", xml or SCENES_XML / "custom2d.xml", {"mesh": str(mesh)}, polygon=polygon,
                     mesh=mesh, radius=polygon.radius())


def object_3d(name: str) -> SceneInfo:
    def build(tmp: Path) -> None:
        variables = build_object(name, tmp)
        (tmp / "variables.txt").write_text("\n".join(f"{k}={Path(v).name}" for k, v in variables.items()))

    folder = cache_entry(f"objects/{name}-{digest(ASSET_VERSION, name)}", build)
    variables = {k: str(folder / v) for k, v in
                 (line.split("=", 1) for line in (folder / "variables.txt").read_text().splitlines())}
    return SceneInfo(name, "3d", SCENES_XML / f"{name}.xml", variables, mesh=Path(variables["mesh"]), radius=1.0,
                     texture=Path(variables["texture"]) if "texture" in variables else None)


def on_table(info: SceneInfo) -> SceneInfo:
    """``info`` (a 3D object of the registry) on the table of :data:`TABLE`, its top at the mesh's lowest point. The
    mesh stays the object's alone (no Chamfer distance is measured against it)."""
    top = float(read_ply(info.mesh)["vertices"][:, 2].min())

    def build(tmp: Path) -> None:
        import imageio.v3 as iio

        iio.imwrite(tmp / "table.png", table_texture())
        (tmp / "scene.xml").write_text(f"""<scene version="3.0.0">
    <include filename="{info.xml}"/>
    <shape type="rectangle">
        <transform name="to_world"><scale value="{TABLE_HALF}"/><translate z="{top!r}"/></transform>
        <bsdf type="diffuse"><texture type="bitmap" name="reflectance">
            <string name="filename" value="$table"/></texture></bsdf>
    </shape>
</scene>""")
    folder = cache_entry(f"tables/{info.name}-{digest(ASSET_VERSION, str(info.xml), repr(top))}", build)
    return dataclasses.replace(info, name=info.name + TABLE, xml=folder / "scene.xml", mesh=None,
                               variables={**info.variables, "table": str(folder / "table.png")},
                               radius=float((2 * TABLE_HALF ** 2 + top ** 2) ** 0.5))


def get_scene(scene: str | Path | None = None, *, polygon=None, kind: str | None = None,
              material: str | None = None, env: bool = False, roughness: float | None = None) -> SceneInfo:
    """Resolve a scene: a registry name, a path to an XML file, or a user polygon.

    ``polygon`` may be a :class:`Polygon`, a list of points (a closed ring) or a path to a JSON
    file; it takes precedence over ``scene``. A registry name may carry a look (``bunny_glossy``,
    ``vase_plastic_env``, ``bunny_glossy_r0.3``); ``material``, ``env`` and ``roughness`` choose one too."""
    lighting = "env" if env else "points"
    if polygon is not None:
        if not isinstance(polygon, Polygon):
            polygon = (Polygon.from_json(polygon) if isinstance(polygon, (str, Path))
                       else Polygon.from_points(polygon))
        return with_look(scene_2d(polygon), material or "diffuse", lighting, roughness)
    if scene is None:
        raise DataError(f"no scene given; pass one of {', '.join(SCENE_NAMES)} or a polygon")
    name = str(scene)
    if name.endswith(TABLE) and name[:-len(TABLE)] in OBJECTS_3D:
        if material or env or roughness is not None:
            raise DataError(f"{name} is drawn in its plain look; drop --material, --env and --roughness")
        return on_table(object_3d(name[:-len(TABLE)]))
    base, named_material, named_roughness, named_env = split_variant(name)
    if base in SCENE_NAMES:
        if named_material and material and named_material != material:
            raise DataError(f"scene {name} already has material {named_material}; drop --material {material} "
                            f"or pass --scene {base}")
        if named_roughness is not None and roughness is not None and named_roughness != roughness:
            raise DataError(f"scene {name} already has roughness {named_roughness:g}; drop --roughness "
                            f"{roughness:g} or the name's _r suffix")
        info = (scene_2d(Polygon.from_json(SCENES_XML / "polygons" / f"{base}.json"), SCENES_XML / f"{base}.xml")
                if base in SCENES_2D else object_3d(base))
        return with_look(info, material or named_material or "diffuse", "env" if named_env else lighting,
                         named_roughness if roughness is None else roughness)
    if name.endswith(".xml"):
        path = Path(name)
        if not path.is_file():
            raise DataError(f"scene file {path} does not exist; check the path")
        info = SceneInfo(path.stem, "2d" if kind == "2d" else "3d", path.resolve())
        info.load()  # fail early on malformed XML
        return with_look(info, material or "diffuse", lighting, roughness)
    raise DataError(f"unknown scene {name!r}; choose one of {', '.join(SCENE_NAMES)} (optionally with a look, "
                    "e.g. bunny_glossy or vase_roughconductor_env) or on a table (brick_table), give a path to a "
                    "Mitsuba XML file, or pass --polygon FILE")
