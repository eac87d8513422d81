"""Materials and lighting: the library's scenes with view-dependent appearance or a sky.

A scene's *look* is a material and a lighting. The default (``diffuse`` under the XML's point lights) is its XML
file unchanged; any other look is built with ``mitsuba.load_dict`` from the same mesh, albedo and lights.
``textured`` paints a barcode along a 2D outline; ``env`` is a procedural sky with a sun (:func:`sky_image`, needs
the ``path`` integrator): 40 degrees high for 3D scenes, on the horizon (the cameras' plane) for 2D ones.
Named variants: ``<scene>[_<material>[_r<roughness>]][_env]``, ``glossy`` meaning ``roughplastic``
(``bunny_glossy``, ``bunny_glossy_r0.3``, ``vase_roughconductor_r0.1_env``). The rough materials' GGX roughness
(Mitsuba's ``alpha``) defaults to :data:`ROUGHNESS`; how far a field's PSNR falls as highlights sharpen is measured
by ``benchmarks/glossy_sweep.py``.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np

from .._io import cache_entry, digest
from ..errors import DataError
from .gt_render import PATH_INTEGRATOR

MATERIALS = ("diffuse", "plastic", "roughplastic", "roughconductor", "textured")
LIGHTINGS = ("points", "env")
ALIASES = {"glossy": "roughplastic"}
ROUGHNESS = {"roughplastic": 0.25, "roughconductor": 0.3}
"""GGX roughness (``alpha``) of each rough material when none is chosen. ``roughplastic``'s is the roughness at which
the first wave's grid preset scores on the 2D bunny what issue 14's report measured with it on users' glossy renders
(``benchmarks/glossy_sweep.py --parts preset``), so ``bunny_glossy`` is as glossy as what users bring."""
SKY_VERSION = "1"      # bump when sky_image changes
SUN_ELEVATION = {"3d": 40.0, "2d": 0.0}
SUN_AZIMUTH = -40.0    # degrees from +x: the side of the 3D key light


def split_variant(name: str) -> tuple[str, str | None, float | None, bool]:
    """``bunny_glossy_r0.3_env`` -> ``("bunny", "roughplastic", 0.3, True)``; no suffix: ``(name, None, None, False)``.
    A roughness that is not a number, or one without a material, is left in the base name (an unknown scene)."""
    base, env = (name[:-4], True) if name.endswith("_env") else (name, False)
    roughness = None
    head, sep, tail = base.rpartition("_r")
    if sep and head and any(head.endswith("_" + m) for m in (*MATERIALS, *ALIASES)):
        with contextlib.suppress(ValueError):
            roughness, base = float(tail), head
    for m in (*MATERIALS, *ALIASES):
        if base.endswith("_" + m):
            return base[:-len(m) - 1], ALIASES.get(m, m), roughness, env
    return base, None, None, env


def variant_name(base: str, material: str, lighting: str, roughness: float | None = None) -> str:
    rough = "" if roughness is None else f"_r{roughness:g}"
    return (base + ("" if material == "diffuse" else f"_{material}{rough}")
            + ("_env" if lighting == "env" else ""))


def check_look(name: str, kind: str, material: str, lighting: str, has_mesh: bool = True,
               roughness: float | None = None) -> None:
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
    if roughness is not None and material not in ROUGHNESS:
        raise DataError(f"{name}: a roughness applies to {' and '.join(ROUGHNESS)} only; drop --roughness "
                        f"or choose one of those materials")
    if roughness is not None and not 0.0 < roughness <= 1.0:
        raise DataError(f"{name}: roughness {roughness:g} is outside (0, 1]; 0.05 is nearly a mirror, "
                        "1 nearly diffuse")
    if material == "plastic" and lighting == "points":
        raise DataError(f"{name}: smooth plastic mirrors point lights into single directions, so it would render "
                        "as a dimmed diffuse scene; add --env (suffix _env) or use --material roughplastic")


def roughness_of(material: str, roughness: float | None = None) -> float | None:
    """The GGX roughness ``material`` renders with: ``roughness``, else its default; None for a smooth one."""
    if material not in ROUGHNESS:
        return None
    return ROUGHNESS[material] if roughness is None else float(roughness)


def bsdf_dict(material: str, albedo, two_sided: bool, roughness: float | None = None) -> dict:
    """Mitsuba BSDF of ``material`` whose colour is ``albedo`` (a texture dict or object); ``roughness``: the GGX
    alpha of a rough material (None: :data:`ROUGHNESS`)."""
    alpha = lambda m: roughness_of(m, roughness)
    bsdfs = {"diffuse": {"type": "diffuse", "reflectance": albedo},
             "plastic": {"type": "plastic", "diffuse_reflectance": albedo, "int_ior": 1.5},
             "roughplastic": {"type": "roughplastic", "diffuse_reflectance": albedo, "int_ior": 1.5,
                              "distribution": "ggx", "alpha": alpha("roughplastic")},
             "roughconductor": {"type": "roughconductor", "specular_reflectance": albedo,   # a tinted metal
                                "distribution": "ggx", "alpha": alpha("roughconductor")}}
    bsdfs["textured"] = bsdfs["diffuse"]          # check_look has refused other materials
    return {"type": "twosided", "bsdf": bsdfs[material]} if two_sided else bsdfs[material]


def vertex_color_texture():
    """Per-vertex colour as a texture with a mean (``plastic``/``roughplastic`` need one; ``mesh_attribute`` has
    none). Built per call: Python plugins subclass a variant-specific base class."""
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


# ----------------------------------------------------------------------------- the sky
def sky_image(sun_elevation: float = 40.0, width: int = 512, height: int = 256,
              sun_radiance: float = 300.0) -> np.ndarray:
    """Linear radiance of a procedural sky: blue zenith, pale horizon, dark ground and a sun disc of
    2.5 degrees radius at ``sun_elevation`` and :data:`SUN_AZIMUTH` (degrees). A lat-long map for
    Mitsuba's ``envmap`` turned +90 degrees about x (z up, row 0 the zenith), ``[height, width, 3]`` float32."""
    theta = (np.arange(height) + 0.5) / height * np.pi
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    T, P = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(T) * np.sin(P), np.sin(T) * np.cos(P), np.cos(T)], -1)     # [height, width, 3]
    z = d[..., 2:]
    zenith, horizon, ground = np.array([0.18, 0.32, 0.75]), np.array([0.75, 0.8, 0.9]), np.array([0.16, 0.14, 0.12])
    t = (1 - np.clip(z, 0, 1)) ** 3
    above = np.clip(z / 0.03 + 0.5, 0, 1)                    # a soft horizon
    img = (zenith * (1 - t) + horizon * t) * above + ground * (1 - above)
    el, az = np.radians(sun_elevation), np.radians(SUN_AZIMUTH)
    sun = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    angle = np.degrees(np.arccos(np.clip(d @ sun, -1, 1)))
    disc = np.clip((3.0 - angle) / 1.0, 0, 1)                # 2.5 degrees, a 1-degree soft rim
    return (img + disc[..., None] * sun_radiance * np.array([1.0, 0.95, 0.85])).astype(np.float32)


def env_emitter(kind: str) -> dict:
    """The sky of a ``2d`` or ``3d`` scene as an ``envmap`` emitter (its EXR cached on first use)."""
    import mitsuba as mi

    elevation = SUN_ELEVATION[kind]

    def build(tmp: Path) -> None:
        mi.Bitmap(sky_image(elevation)).write(str(tmp / "sky.exr"))

    sky = cache_entry(f"env/sky-{digest(SKY_VERSION, str(elevation))}", build) / "sky.exr"
    return {"type": "envmap", "filename": str(sky), "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], 90)}


# ----------------------------------------------------------------------------- the scene
def styled_scene(info, point_lights) -> "object":
    """The Mitsuba scene of ``info`` (a :class:`~mitnerf.scenes.registry.SceneInfo`) with its
    material and lighting; ``point_lights``: the emitters of its XML scene."""
    import mitsuba as mi

    check_look(info.name, info.kind, info.material, info.lighting, info.mesh is not None, info.roughness)
    if info.texture is not None:                            # the object's colour: its image texture (UVs) ...
        albedo = {"type": "bitmap", "filename": str(info.texture), "filter_type": "bilinear", "wrap_mode": "repeat"}
    elif info.material in ("plastic", "roughplastic"):      # ... or its vertex colours
        albedo = vertex_color_texture()
    else:
        albedo = {"type": "mesh_attribute", "name": "vertex_color"}
    shape = {"type": "ply", "filename": str(info.mesh), "bsdf": bsdf_dict(info.material, albedo, info.kind == "3d",
                                                                               info.roughness)}
    if info.kind == "2d":
        shape["face_normals"] = True
    if info.lighting == "env":
        emitters, integrator = {"sky": env_emitter(info.kind)}, dict(PATH_INTEGRATOR)
    else:                                                   # the XML files' lights and integrator
        emitters = {f"light_{k}": e for k, e in enumerate(point_lights)}
        integrator = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
    return mi.load_dict({"type": "scene", "integrator": integrator, "object": shape, **emitters})
