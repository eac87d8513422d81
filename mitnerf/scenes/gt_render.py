"""Ground-truth rendering with Mitsuba (not the NeRF renderer): colour, coverage, exact depth, mask.

Colour is the pixel-footprint average (box filter) of views rendered many at a time through a ``batch`` sensor:
noise-free direct lighting summed over point lights (:func:`all_lights_integrator`), or Mitsuba's ``path``
integrator for an environment light (noise fades with ``spp``). Depth and mask intersect every pixel-centre ray
with the scene; :func:`aov_depth` checks them against Mitsuba's depth AOV. Cameras enter as arrays
(``to_world`` frames, field of view, film size, rays).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .._variant import ensure_variant, set_variant
from ..errors import ConfigError, DataError

INTEGRATORS = ("all_lights", "path", "scene")
PATH_INTEGRATOR = {"type": "path", "max_depth": 8, "hide_emitters": True}
"""Misses stay black with zero alpha (the film's alpha is coverage), like the other integrators."""


@dataclass
class RenderSettings:
    """How ground truth is rendered."""

    spp: int = 64
    """Samples per pixel for colour (the footprint integral)."""
    integrator: str = "all_lights"
    """``all_lights`` (deterministic sum over point lights), ``path`` (Mitsuba's path tracer,
    needed for an environment light; noisy at low ``spp``) or ``scene`` (the scene's own)."""
    sampler: str = "multijitter"
    """Mitsuba sampler: a stratified one converges the footprint integral fastest."""
    seed: int = 0
    """Seed of Mitsuba's sampler (a render is deterministic for a seed)."""
    max_samples_per_launch: int = 8_000_000
    """Views are split into launches of at most this many samples (bounds memory)."""


def all_lights_integrator():
    """``all_lights``: direct lighting summed over every (point) emitter, none picked at random as by Mitsuba's
    ``direct``. Built per call: Python integrators subclass a variant-specific class."""
    import drjit as dr
    import mitsuba as mi

    class AllLightsIntegrator(mi.SamplingIntegrator):
        def __init__(self):
            super().__init__(mi.Properties())

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            valid = si.is_valid() & active
            if not dr.is_jit_v(mi.Float) and not valid:   # scalar: no masking, si.bsdf() would crash
                return mi.Spectrum(0.0), False, []
            bsdf = si.bsdf(ray)
            result = mi.Spectrum(0.0)
            for emitter in scene.emitters():      # unrolled: ground-truth scenes have few lights
                ds, weight = emitter.sample_direction(si, mi.Point2f(0.5, 0.5), valid)
                lit = valid & (ds.pdf > 0)
                # dr.select, not ~: in scalar variants ~True is the int -2
                visible = lit & dr.select(scene.ray_test(si.spawn_ray_to(ds.p), lit), False, True)
                f = bsdf.eval(mi.BSDFContext(), si, si.to_local(ds.d), visible)
                result += dr.select(visible, f * weight, 0.0)
            return result, valid, []

        def to_string(self):
            return "AllLightsIntegrator[]"

    return AllLightsIntegrator()


def make_integrator(scene, name: str):
    """The integrator ``name`` of :data:`INTEGRATORS` for ``scene``, refused where it would be wrong."""
    import mitsuba as mi

    if name == "all_lights":
        if not all(mi.has_flag(e.flags(), mi.EmitterFlags.Delta) for e in scene.emitters()):
            raise DataError("the all_lights integrator sums point lights, but this scene has an environment "
                            "or area light; render it with the path integrator (--integrator path)")
        return all_lights_integrator()
    if name == "path":
        return mi.load_dict(PATH_INTEGRATOR)
    if name == "scene":
        return scene.integrator()
    raise ConfigError(f"unknown integrator {name!r}; choose one of {', '.join(INTEGRATORS)}")


def _render_views(scene, frames, fov, height, width, sampler: dict, integrator, spp: int, seed: int = 0,
                  near_clip: float = 1e-3) -> np.ndarray:
    """Film values ``[n, H, W, channels]`` of views ``frames`` rendered through one ``batch`` sensor
    (a 2D view, ``width == 1``, is an ``H x 1`` film whose column ``i`` is pixel row ``i``)."""
    import mitsuba as mi

    fw, fh = (height, 1) if width == 1 else (width, height)
    sensors = {f"view_{i:04d}": {"type": "perspective", "fov": fov, "fov_axis": "x",
                                 "near_clip": near_clip, "to_world": mi.ScalarTransform4f(m.tolist())}
               for i, m in enumerate(frames)}
    film = {"type": "hdrfilm", "width": fw * len(frames), "height": fh, "pixel_format": "rgba",
            "rfilter": {"type": "box"}, "sample_border": False}
    sensor = mi.load_dict({"type": "batch", **sensors, "film": film, "sampler": sampler})
    img = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, spp=spp, seed=seed))
    views = img.reshape(fh, len(frames), fw, -1).transpose(1, 0, 2, 3)
    return views.transpose(0, 2, 1, 3) if width == 1 else views


def render_color(scene, frames: np.ndarray, fov: float, height: int, width: int,
                 settings: RenderSettings | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Colour and coverage of every view: ``rgb [n, H, W, 3]``, ``alpha [n, H, W]``. ``frames [n, 4, 4]``: Mitsuba
    ``to_world`` matrices; ``fov`` in degrees along the film's x axis; a 2D view has ``width == 1``."""
    ensure_variant()
    settings = settings or RenderSettings()
    spp, integrator = settings.spp, make_integrator(scene, settings.integrator)
    sampler = {"type": settings.sampler, "sample_count": spp}
    chunk = max(1, settings.max_samples_per_launch // (height * width * spp))
    out = np.empty((len(frames), height, width, 4), np.float32)
    for start in range(0, len(frames), chunk):
        out[start:start + chunk] = _render_views(scene, frames[start:start + chunk], fov, height, width, sampler,
                                                 integrator, spp, settings.seed + start)
    return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3])


def aov_depth(scene, frames: np.ndarray, fov: float, height: int, width: int) -> np.ndarray:
    """Mitsuba's ``aov`` depth (``dd.y:depth``, 0 on a miss) at every pixel centre, ``[n, H, W]``: one unjittered
    stratified sample per pixel lands there; the near clip is 1e-7 (perspective rays start there)."""
    import mitsuba as mi

    ensure_variant()
    sampler = {"type": "stratified", "sample_count": 1, "jitter": False}
    aov = mi.load_dict({"type": "aov", "aovs": "dd.y:depth"})
    depth = _render_views(scene, frames, fov, height, width, sampler, aov, 1, near_clip=1e-7)[..., -1]
    return np.ascontiguousarray(depth)


def exact_depth(scene, origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth (distance to the first hit, ``inf`` on a miss) and mask of pixel-centre rays ``[..., D]``
    (any leading shape; ``D = 2``: rays in the z = 0 plane), each ``[...]``."""
    import drjit as dr
    import mitsuba as mi

    ensure_variant()
    D = origins.shape[-1]
    o, d = origins.reshape(-1, D), dirs.reshape(-1, D)
    if D == 2:
        o, d = np.c_[o, np.zeros(len(o))], np.c_[d, np.zeros(len(d))]
    if dr.is_jit_v(mi.Float):
        si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in o.T.astype(np.float32))),
                                          mi.Vector3f(*(mi.Float(c) for c in d.T.astype(np.float32)))))
        depth = np.where(np.asarray(si.is_valid()), np.asarray(si.t, dtype=np.float64), np.inf)
    else:                                      # scalar variants: one ray at a time
        depth = np.full(len(o), np.inf)
        for k, (ok, dk) in enumerate(zip(o, d)):
            si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*ok), mi.Vector3f(*dk)))
            if si.is_valid():
                depth[k] = float(si.t)
    depth = depth.reshape(origins.shape[:-1])
    return depth.astype(np.float32), np.isfinite(depth)


def compare_variants(load, frames: np.ndarray, fov: float, height: int, width: int, origins: np.ndarray,
                     dirs: np.ndarray, spp: int, variants=("scalar_rgb", "llvm_ad_rgb")) -> dict:
    """The same views in two Mitsuba variants (``load()`` builds the scene in the variant set; cameras as
    :func:`render_color` and :func:`exact_depth` take them): ``psnr`` of one's linear colour against the other's
    (they draw different samples), ``depth_error`` (max abs where both hit), ``masks_equal``, ``seconds`` per
    variant. Leaves the last variant set."""
    import mitsuba as mi

    out = []
    for variant in variants:
        set_variant(variant)
        mi.set_log_level(mi.LogLevel.Error)   # scalar variants warn that Python integrators are slow
        t0, scene = time.perf_counter(), load()
        rgb = render_color(scene, frames, fov, height, width, RenderSettings(spp=spp))[0]
        out.append((rgb, *exact_depth(scene, origins, dirs), time.perf_counter() - t0))
    (a, da, ma, ta), (b, db, mb, tb) = out
    hit = ma & mb
    return {"psnr": float(10 * np.log10(1.0 / max(np.mean((a - b) ** 2), 1e-20))),
            "max_diff": float(np.abs(a - b).max()),
            "depth_error": float(np.abs(da[hit] - db[hit]).max()) if hit.any() else 0.0,
            "masks_equal": bool(np.array_equal(ma, mb)), "seconds": (ta, tb)}
