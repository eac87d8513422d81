"""Ground-truth renders with Mitsuba: colour, coverage, exact depth and mask.

Colour is the pixel-footprint average (box filter) rendered through a ``batch``
sensor, many views per launch so that kernels stay wide. Point lights summed by
:func:`~mitnerf.scenes.integrator.all_lights_integrator` make direct lighting
noise-free; a stratified sampler then converges the footprint integral quickly (the
tests require >= 50 dB against a render with 4x the samples).

Depth and mask do not come from a jittered AOV (which averages misses into silhouette
pixels): every pixel-centre ray of :meth:`Cameras.rays` is intersected with the scene,
so depth is the exact distance along that ray and the mask says whether it hits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.cameras import Cameras


@dataclass
class RenderSettings:
    """How ground truth is rendered."""

    spp: int = 64
    """Samples per pixel for colour (the footprint integral)."""
    integrator: str = "all_lights"
    """``all_lights`` (deterministic sum over point lights) or ``scene`` (the XML's own)."""
    sampler: str = "multijitter"
    """Mitsuba sampler: a stratified one converges the footprint integral fastest."""
    seed: int = 0
    """Seed of Mitsuba's sampler (a render is deterministic for a seed)."""
    max_samples_per_launch: int = 8_000_000
    """Views are split into launches of at most this many samples (bounds memory)."""


@dataclass
class Views:
    """Rendered ground truth of one set of cameras, all ``[n, H, W, ...]``."""

    rgb: np.ndarray
    """Linear RGB over a black background (premultiplied by coverage), float32."""
    alpha: np.ndarray
    """Coverage of each pixel's footprint in [0, 1], float32."""
    depth: np.ndarray
    """Distance along the pixel-centre ray to the first hit; ``inf`` on a miss."""
    mask: np.ndarray
    """Whether the pixel-centre ray hits the scene (bool)."""


def _sensor_dict(frames: np.ndarray, fov: float, film_w: int, film_h: int, settings: RenderSettings, spp: int):
    import mitsuba as mi

    sensors = {f"view_{i:04d}": {"type": "perspective", "fov": fov, "fov_axis": "x",
                                 "near_clip": 1e-3, "to_world": mi.ScalarTransform4f(m.tolist())}
               for i, m in enumerate(frames)}
    return {"type": "batch", **sensors,
            "film": {"type": "hdrfilm", "width": film_w, "height": film_h, "pixel_format": "rgba",
                     "rfilter": {"type": "box"}, "sample_border": False},
            "sampler": {"type": settings.sampler, "sample_count": spp}}


def render_color(scene, cams: Cameras, settings: RenderSettings | None = None,
                 spp: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Colour and coverage of every view: ``rgb [n, H, W, 3]``, ``alpha [n, H, W]``."""
    import mitsuba as mi

    from .integrator import all_lights_integrator

    settings = settings or RenderSettings()
    spp = spp or settings.spp
    integrator = all_lights_integrator() if settings.integrator == "all_lights" else scene.integrator()
    frames = cams.mitsuba_frames()
    # Mitsuba film (width x height) per view: 2D -> H x 1, 3D -> W x H
    fw, fh = (cams.height, 1) if cams.dim == 2 else (cams.width, cams.height)
    per_view = fw * fh * spp
    chunk = max(1, settings.max_samples_per_launch // per_view)
    out = np.empty((len(cams), fh, fw, 4), np.float32)
    for start in range(0, len(cams), chunk):
        sub = frames[start:start + chunk]
        sensor = mi.load_dict(_sensor_dict(sub, cams.fov, fw * len(sub), fh, settings, spp))
        img = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, spp=spp,
                                   seed=settings.seed + start))
        out[start:start + len(sub)] = img.reshape(fh, len(sub), fw, 4).transpose(1, 0, 2, 3)
    if cams.dim == 2:   # film column i is pixel row i
        out = out.transpose(0, 2, 1, 3)
    return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3])


def ray_depth(scene, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Distance to the first hit along rays ``[m, 2 or 3]`` (``inf`` on a miss), ``[m]``."""
    import drjit as dr
    import mitsuba as mi

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


def exact_depth(scene, cams: Cameras) -> tuple[np.ndarray, np.ndarray]:
    """Depth and mask of every pixel-centre ray, each ``[n, H, W]``."""
    o, d = cams.rays()
    shape = o.shape[:-1]
    depth = ray_depth(scene, o.reshape(-1, cams.dim), d.reshape(-1, cams.dim)).reshape(shape)
    return depth.astype(np.float32), np.isfinite(depth)


def render_views(scene, cams: Cameras, settings: RenderSettings | None = None) -> Views:
    """Colour, coverage, exact depth and mask of every view of ``cams``."""
    rgb, alpha = render_color(scene, cams, settings)
    depth, mask = exact_depth(scene, cams)
    return Views(rgb, alpha, depth, mask)
