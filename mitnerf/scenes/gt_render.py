"""Ground-truth rendering with Mitsuba (not the NeRF renderer): colour, coverage, exact depth, mask.

Colour is the pixel-footprint average (box filter) rendered through a ``batch``
sensor, many views per launch so that kernels stay wide. Point lights summed by
:func:`~mitnerf.scenes.integrator.all_lights_integrator` make direct lighting
noise-free, for glossy materials too (a BSDF evaluated towards a point light needs no
sampling); a stratified sampler then converges the footprint integral quickly (the
tests require >= 50 dB against a render with 4x the samples). An environment light
needs Mitsuba's ``path`` integrator: Monte Carlo noise that fades with ``spp``.

Depth and mask do not come from a jittered AOV (which averages misses into silhouette
pixels): every pixel-centre ray is intersected with the scene, so depth is the exact distance along that
ray and the mask says whether it hits. :func:`aov_depth` renders Mitsuba's own ``aov``
depth at the film's pixel centres, to check the two against each other.

Cameras enter as arrays (Mitsuba ``to_world`` frames, the field of view, the film size,
pixel-centre rays), so this stage knows nothing of the data stage's camera objects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._variant import ensure_variant
from ..errors import ConfigError, DataError
from .integrator import all_lights_integrator

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


def _sensor_dict(frames: np.ndarray, fov: float, film_w: int, film_h: int, sampler: dict, near_clip: float = 1e-3):
    import mitsuba as mi

    sensors = {f"view_{i:04d}": {"type": "perspective", "fov": fov, "fov_axis": "x",
                                 "near_clip": near_clip, "to_world": mi.ScalarTransform4f(m.tolist())}
               for i, m in enumerate(frames)}
    return {"type": "batch", **sensors,
            "film": {"type": "hdrfilm", "width": film_w, "height": film_h, "pixel_format": "rgba",
                     "rfilter": {"type": "box"}, "sample_border": False},
            "sampler": sampler}


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


def render_color(scene, frames: np.ndarray, fov: float, height: int, width: int,
                 settings: RenderSettings | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Colour and coverage of every view: ``rgb [n, H, W, 3]``, ``alpha [n, H, W]``.

    ``frames [n, 4, 4]``: Mitsuba ``to_world`` matrices; ``fov`` in degrees along the
    film's x axis; a 2D view (``width == 1``) is an ``H x 1`` film whose column ``i`` is
    pixel row ``i``."""
    import mitsuba as mi

    ensure_variant()
    settings = settings or RenderSettings()
    spp = settings.spp
    integrator = make_integrator(scene, settings.integrator)
    flat = width == 1                       # 2D: film H x 1
    fw, fh = (height, 1) if flat else (width, height)
    per_view = fw * fh * spp
    chunk = max(1, settings.max_samples_per_launch // per_view)
    out = np.empty((len(frames), fh, fw, 4), np.float32)
    for start in range(0, len(frames), chunk):
        sub = frames[start:start + chunk]
        sampler = {"type": settings.sampler, "sample_count": spp}
        sensor = mi.load_dict(_sensor_dict(sub, fov, fw * len(sub), fh, sampler))
        img = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, spp=spp,
                                   seed=settings.seed + start))
        out[start:start + len(sub)] = img.reshape(fh, len(sub), fw, 4).transpose(1, 0, 2, 3)
    if flat:   # film column i is pixel row i
        out = out.transpose(0, 2, 1, 3)
    return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3])


def aov_depth(scene, frames: np.ndarray, fov: float, height: int, width: int) -> np.ndarray:
    """Mitsuba's ``aov`` depth (``dd.y:depth``, 0 on a miss) at every pixel centre,
    ``[n, H, W]``: one sample per pixel from a stratified sampler without jitter lands on
    the pixel centre, and the near clip is moved to 1e-7 (perspective rays start there)."""
    import mitsuba as mi

    ensure_variant()
    flat = width == 1
    fw, fh = (height, 1) if flat else (width, height)
    sampler = {"type": "stratified", "sample_count": 1, "jitter": False}
    sensor = mi.load_dict(_sensor_dict(frames, fov, fw * len(frames), fh, sampler, near_clip=1e-7))
    img = mi.render(scene, sensor=sensor, integrator=mi.load_dict({"type": "aov", "aovs": "dd.y:depth"}), spp=1)
    out = np.asarray(img)[..., -1].reshape(fh, len(frames), fw).transpose(1, 0, 2)
    return np.ascontiguousarray(out.transpose(0, 2, 1) if flat else out)


def ray_depth(scene, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Distance to the first hit along rays ``[m, 2 or 3]`` (``inf`` on a miss), ``[m]``."""
    import drjit as dr
    import mitsuba as mi

    ensure_variant()
    if origins.shape[-1] == 2:   # 2D rays live in the z = 0 plane
        origins = np.c_[origins, np.zeros(len(origins))]
        dirs = np.c_[dirs, np.zeros(len(dirs))]
    if dr.is_jit_v(mi.Float):
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(c) for c in origins.T.astype(np.float32))),
                       mi.Vector3f(*(mi.Float(c) for c in dirs.T.astype(np.float32))))
        si = scene.ray_intersect(ray)
        t = np.asarray(si.t, dtype=np.float64)
        return np.where(np.asarray(si.is_valid()), t, np.inf)
    out = np.full(len(origins), np.inf)       # scalar variants: one ray at a time
    for k, (o, d) in enumerate(zip(origins, dirs)):
        si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*d)))
        if si.is_valid():
            out[k] = float(si.t)
    return out


def exact_depth(scene, origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth and mask of pixel-centre rays ``[..., D]`` (any leading shape), each ``[...]``."""
    shape = origins.shape[:-1]
    D = origins.shape[-1]
    depth = ray_depth(scene, origins.reshape(-1, D), dirs.reshape(-1, D)).reshape(shape)
    return depth.astype(np.float32), np.isfinite(depth)
