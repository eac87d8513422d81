"""Materials and lighting: the library's scenes with view-dependent appearance or a sky.

A scene's *look* is a material and a lighting. The default (``diffuse`` under the
scene's own point lights) is loaded from its XML file unchanged; any other look is
built here with ``mitsuba.load_dict`` from the same mesh, albedo and lights:

* materials: ``plastic`` (Mitsuba's smooth ``plastic``), ``roughplastic`` and
  ``roughconductor`` keep the object's colour as the diffuse colour (plastics) or as the
  tint of the metal, with a specular layer on top; ``textured`` is diffuse with a
  high-frequency 1D texture (a barcode) along a 2D outline;
* lighting: ``points`` (the XML's point lights) or ``env``, a procedural sky with a
  sun (:func:`sky_image`) as an ``envmap`` emitter, which needs the ``path`` integrator.
  3D scenes see the sun 40 degrees high; 2D scenes on the horizon, in the plane of their
  cameras (and of their point lights), where mirror reflections of 1D views can see it.

Named variants: ``<scene>[_<material>][_env]``, with ``glossy`` for ``roughplastic``
(``bunny_glossy``, ``vase_roughconductor_env``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import cache_entry, digest
from ..errors import DataError
from .gt_render import PATH_INTEGRATOR

MATERIALS = ("diffuse", "plastic", "roughplastic", "roughconductor", "textured")
LIGHTINGS = ("points", "env")
ALIASES = {"glossy": "roughplastic"}
SKY_VERSION = "1"      # bump when sky_image changes
SUN_ELEVATION = {"3d": 40.0, "2d": 0.0}
SUN_AZIMUTH = -40.0    # degrees from +x: the side of the 3D key light


def split_variant(name: str) -> tuple[str, str | None, bool]:
    """``bunny_glossy_env`` -> ``("bunny", "roughplastic", True)``; no suffix: ``(name, None, False)``."""
    base, env = (name[:-4], True) if name.endswith("_env") else (name, False)
    for m in (*MATERIALS, *ALIASES):
        if base.endswith("_" + m):
            return base[:-len(m) - 1], ALIASES.get(m, m), env
    return base, None, env


def variant_name(base: str, material: str, lighting: str) -> str:
    return base + ("" if material == "diffuse" else f"_{material}") + ("_env" if lighting == "env" else "")


def check_look(name: str, kind: str, material: str, lighting: str, has_mesh: bool = True) -> None:
    """Refuse looks that cannot render sensibly, with the fix."""
    if (material, lighting) != ("diffuse", "points") and not has_mesh:
        raise DataError(f"{name}: materials and --env apply to mitnerf's scenes; set the BSDF and "
                        "emitters in your XML file instead")
    if material not in MATERIALS:
        raise DataError(f"unknown material {material!r}; choose one of {', '.join(MATERIALS)}")
    if lighting not in LIGHTINGS:
        raise DataError(f"unknown lighting {lighting!r}; choose one of {', '.join(LIGHTINGS)}")
    if material == "textured" and kind != "2d":
        raise DataError(f"{name} is a 3D object and carries its own texture; the textured material paints "
                        "a 1D texture along a 2D outline: drop --material textured or pick a 2D scene")
    if material == "plastic" and lighting == "points":
        raise DataError(f"{name}: smooth plastic mirrors point lights into single directions, so it would render "
                        "as a dimmed diffuse scene; add --env (suffix _env) or use --material roughplastic")


def bsdf_dict(material: str, albedo, two_sided: bool) -> dict:
    """Mitsuba BSDF of ``material`` whose colour is ``albedo`` (a texture dict or object)."""
    if material in ("diffuse", "textured"):
        bsdf = {"type": "diffuse", "reflectance": albedo}
    elif material == "plastic":
        bsdf = {"type": "plastic", "diffuse_reflectance": albedo, "int_ior": 1.5}
    elif material == "roughplastic":
        bsdf = {"type": "roughplastic", "diffuse_reflectance": albedo, "int_ior": 1.5,
                "distribution": "ggx", "alpha": 0.12}
    elif material == "roughconductor":   # material "none": a perfect mirror tinted by the albedo
        bsdf = {"type": "roughconductor", "specular_reflectance": albedo, "distribution": "ggx", "alpha": 0.3}
    else:
        raise DataError(f"unknown material {material!r}; choose one of {', '.join(MATERIALS)}")
    return {"type": "twosided", "bsdf": bsdf} if two_sided else bsdf


def vertex_color_texture():
    """Per-vertex colour as a texture that has a mean. Mitsuba's ``mesh_attribute`` has
    none, and ``plastic``/``roughplastic`` need one for their sampling weight. Built per
    call: Python plugins subclass a variant-specific base class."""
    import mitsuba as mi

    class VertexColor(mi.Texture):
        def __init__(self):
            super().__init__(mi.Properties())

        def eval(self, si, active=True):
            return mi.Color3f(si.shape.eval_attribute_3("vertex_color", si, active))

        def mean(self):
            return 0.5    # only sets how often the specular lobe is sampled

        def to_string(self):
            return "VertexColor[]"

    return VertexColor()


def albedo_texture(texture: Path | None, material: str):
    """The object's colour: its image texture (UV meshes) or its vertex colours."""
    if texture is not None:
        return {"type": "bitmap", "filename": str(texture), "filter_type": "bilinear", "wrap_mode": "repeat"}
    if material in ("plastic", "roughplastic"):
        return vertex_color_texture()
    return {"type": "mesh_attribute", "name": "vertex_color"}


# ----------------------------------------------------------------------------- the sky
def sky_directions(width: int, height: int) -> np.ndarray:
    """World direction (z up) of every texel of a lat-long map read by Mitsuba's ``envmap``
    with ``to_world`` = a +90 degree turn about x. ``[height, width, 3]``."""
    theta = (np.arange(height) + 0.5) / height * np.pi        # row 0: the zenith
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(T) * np.sin(P), np.sin(T) * np.cos(P), np.cos(T)], -1)


def sky_image(sun_elevation: float = 40.0, width: int = 512, height: int = 256,
              sun_radiance: float = 300.0) -> np.ndarray:
    """Linear radiance of a procedural sky: blue zenith, pale horizon, dark ground and a
    sun disc of 2.5 degrees radius at ``sun_elevation`` and :data:`SUN_AZIMUTH` (degrees).
    ``[height, width, 3]`` float32."""
    d = sky_directions(width, height)
    z = d[..., 2:]
    zenith, horizon, ground = np.array([0.18, 0.32, 0.75]), np.array([0.75, 0.8, 0.9]), np.array([0.16, 0.14, 0.12])
    t = (1 - np.clip(z, 0, 1)) ** 3
    sky = zenith * (1 - t) + horizon * t
    above = np.clip(z / 0.03 + 0.5, 0, 1)                    # a soft horizon
    img = sky * above + ground * (1 - above)
    el, az = np.radians(sun_elevation), np.radians(SUN_AZIMUTH)
    sun = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    angle = np.degrees(np.arccos(np.clip(d @ sun, -1, 1)))
    disc = np.clip((3.0 - angle) / 1.0, 0, 1)                # 2.5 degrees, a 1-degree soft rim
    img = img + disc[..., None] * sun_radiance * np.array([1.0, 0.95, 0.85])
    return img.astype(np.float32)


def sky_envmap(sun_elevation: float) -> Path:
    """The sky as an EXR in the cache (written on first use)."""
    import mitsuba as mi

    def build(tmp: Path) -> None:
        mi.Bitmap(sky_image(sun_elevation)).write(str(tmp / "sky.exr"))

    return cache_entry(f"env/sky-{digest(SKY_VERSION, str(sun_elevation))}", build) / "sky.exr"


def env_emitter(kind: str) -> dict:
    import mitsuba as mi

    return {"type": "envmap", "filename": str(sky_envmap(SUN_ELEVATION[kind])),
            "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], 90)}


# ----------------------------------------------------------------------------- the scene
def styled_scene(info, point_lights) -> "object":
    """The Mitsuba scene of ``info`` (a :class:`~mitnerf.scenes.registry.SceneInfo`) with its
    material and lighting; ``point_lights``: the emitters of its XML scene."""
    import mitsuba as mi

    check_look(info.name, info.kind, info.material, info.lighting, info.mesh is not None)
    shape = {"type": "ply", "filename": str(info.mesh),
             "bsdf": bsdf_dict(info.material, albedo_texture(info.texture, info.material), info.kind == "3d")}
    if info.kind == "2d":
        shape["face_normals"] = True
    if info.lighting == "env":
        emitters = {"sky": env_emitter(info.kind)}
        integrator = dict(PATH_INTEGRATOR)
    else:
        emitters = {f"light_{k}": e for k, e in enumerate(point_lights)}
        integrator = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}   # as in the XML files
    return mi.load_dict({"type": "scene", "integrator": integrator, "object": shape, **emitters})
