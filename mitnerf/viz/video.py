"""Turn-table videos of a trained 3D field: an orbit of cameras, colour and depth frames,
GIF and MP4 files.

The buyer's view of "window shopping in 3D": the camera circles the object once
(360 degrees of azimuth about the z axis through ``center``) at a fixed ``elevation``
and ``radius``, always looking at ``center``::

    from mitnerf.viz.video import OrbitConfig, orbit_video
    result = orbit_video(run.backend, OrbitConfig(n_frames=120, resolution=100), "out/video",
                         background=run.model_cfg.render.background)
    print(result.summary())      # video 120 frames 100x100 in 41.2 s (2.9 frames/s)

* ``orbit_cameras(cfg)``: :class:`~mitnerf.data.cameras.Cameras` with OpenGL poses from
  :func:`~mitnerf.data.rig.look_at_3d`; frame ``k`` stands at azimuth
  ``start_azimuth + 360 k / n_frames`` (the first frame of the default orbit is the
  first test view of our 3D rigs).
* ``render_orbit(backend, cams)``: every pixel-centre ray through ``backend.render``
  in a few large batches (``batch_rays`` rays each, a progress bar per batch). Colour is
  what the model renders over its background; depth is the expected termination
  distance ``depth / opacity``, and ``inf`` where ``opacity < min_opacity`` (no surface).
* ``depth_frames``: depth through :func:`~mitnerf.viz.strips.colorize_depth` (near is
  bright) with one ``near, far`` range for the whole video (the 1st and 99th
  percentiles of all hit depths), so colours mean the same distance in every frame;
  pixels without a surface show the background colour.
* ``write_video(path, frames, fps)``: ``.gif`` (Pillow, loops forever; GIF stores delays
  in 1/100 s, so 30 fps plays at ~33 fps) or ``.mp4`` (H.264, yuv420p via imageio-ffmpeg;
  yuv420p needs even sizes, so odd frames get their last row/column repeated).

Frames per second are measured over rendering only (not writing files).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ..data.cameras import Cameras
from ..data.color import to_uint8
from ..data.rig import look_at_3d
from ..errors import MitnerfError
from .strips import colorize_depth


@dataclass
class OrbitConfig:
    """A 360 degree turn-table orbit around ``center``."""

    n_frames: int = 120
    """Frames in one turn (120 at 30 fps: a 4 s turn)."""
    resolution: int = 100
    """Frame width and height in pixels."""
    elevation: float = 25.0
    """Camera height above the horizontal plane through ``center``, in degrees (|e| < 89.9)."""
    radius: float = 3.5
    """Distance from ``center`` to every camera (world units)."""
    fov: float = 40.0
    """Horizontal field of view in degrees."""
    center: tuple = (0.0, 0.0, 0.0)
    """The point every camera looks at and the orbit turns around (z axis through it)."""
    start_azimuth: float = 0.0
    """Azimuth of the first frame in degrees (0: the +x side)."""
    fps: float = 30.0
    """Playback rate of the written videos."""

    def validate(self) -> None:
        if self.n_frames < 1:
            raise MitnerfError(f"need at least one frame, got --frames {self.n_frames}")
        if self.resolution < 2:
            raise MitnerfError(f"--resolution must be at least 2 pixels, got {self.resolution}")
        if not 0 < self.fov < 180:
            raise MitnerfError(f"--fov must be between 0 and 180 degrees, got {self.fov}")
        if not self.radius > 0:
            raise MitnerfError(f"--radius must be positive, got {self.radius}")
        if not abs(self.elevation) < 89.9:
            raise MitnerfError(f"--elevation must be within (-89.9, 89.9) degrees (straight above, the camera "
                               f"has no defined 'up'), got {self.elevation}")
        if not self.fps > 0:
            raise MitnerfError(f"--fps must be positive, got {self.fps}")

    @property
    def focal(self) -> float:
        return self.resolution / 2 / np.tan(np.radians(self.fov) / 2)


def orbit_cameras(cfg: OrbitConfig) -> Cameras:
    """``n_frames`` cameras on the orbit, each looking at ``cfg.center``."""

    cfg.validate()
    az = np.radians(cfg.start_azimuth) + 2 * np.pi * np.arange(cfg.n_frames) / cfg.n_frames   # [n]
    el = np.radians(cfg.elevation)
    c = np.asarray(cfg.center, np.float64)
    pos = c + cfg.radius * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                     np.full_like(az, np.sin(el))], 1)                          # [n, 3]
    return Cameras(look_at_3d(pos, c - pos), cfg.focal, cfg.resolution, cfg.resolution)


@dataclass
class OrbitFrames:
    """Rendered frames of an orbit."""

    rgb: np.ndarray
    """``[n, H, W, 3]`` display-space colour over the model's background."""
    depth: np.ndarray
    """``[n, H, W]`` termination distance ``depth / opacity``; ``inf`` where there is no surface."""
    opacity: np.ndarray
    """``[n, H, W]`` accumulated opacity."""
    seconds: float
    """Wall-clock rendering time."""

    @property
    def fps(self) -> float:
        return len(self.rgb) / max(self.seconds, 1e-9)


def render_orbit(backend, cams: Cameras, batch_rays: int = 1 << 18, min_opacity: float = 0.5,
                 progress: bool = True) -> OrbitFrames:
    """Render every frame of ``cams`` with ``backend.render`` (whole frames per batch)."""
    if cams.dim != 3:
        raise MitnerfError("orbit videos need 3D cameras and a 3D model")
    n, H, W = len(cams), cams.height, cams.width
    per = max(1, batch_rays // (H * W))                   # frames per batch
    rgb = np.empty((n, H, W, 3), np.float32)
    depth = np.empty((n, H, W), np.float32)
    opacity = np.empty((n, H, W), np.float32)
    t0 = time.perf_counter()
    with tqdm(total=n, desc="render orbit", unit="frame", disable=not progress, leave=False) as bar:
        for s in range(0, n, per):
            sub = cams.subset(slice(s, s + per))
            o, d = sub.rays()                             # [m, H, W, 3] each
            out = backend.render(o.reshape(-1, 3).astype(np.float32), d.reshape(-1, 3).astype(np.float32))
            m = len(sub)
            rgb[s:s + m] = out["rgb"].reshape(m, H, W, 3)
            a = out["opacity"].reshape(m, H, W)
            opacity[s:s + m] = a
            with np.errstate(divide="ignore", invalid="ignore"):
                depth[s:s + m] = np.where(a >= min_opacity, out["depth"].reshape(m, H, W) / a, np.inf)
            bar.update(m)
    return OrbitFrames(rgb, depth, opacity, time.perf_counter() - t0)


def depth_frames(depth: np.ndarray, background=(1.0, 1.0, 1.0), near: float | None = None,
                 far: float | None = None) -> np.ndarray:
    """``[n, H, W]`` depths (``inf`` = no surface) -> ``[n, H, W, 3]`` colours on one scale."""
    hit = np.isfinite(depth)
    if hit.any():
        lo, hi = np.percentile(depth[hit], [1, 99])
        near = lo if near is None else near
        far = hi if far is None else far

    rgb = colorize_depth(depth, near, far)                # misses are black ...
    return np.where(hit[..., None], rgb, np.asarray(background, np.float32)).astype(np.float32)  # ... now background


def _even(frames: np.ndarray) -> np.ndarray:
    """Repeat the last row/column so H and W are even (H.264 in yuv420p needs that)."""
    H, W = frames.shape[1:3]
    return np.pad(frames, ((0, 0), (0, H % 2), (0, W % 2), (0, 0)), mode="edge")


def write_video(path: str | Path, frames: np.ndarray, fps: float = 30.0) -> Path:
    """Write ``[n, H, W, 3]`` frames (float [0, 1] or uint8) as ``.gif`` or ``.mp4``."""
    path = Path(path)
    frames = frames if frames.dtype == np.uint8 else to_uint8(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or not len(frames):
        raise MitnerfError(f"frames must be [n, H, W, 3] with n >= 1, got {frames.shape}")
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        import imageio.v3 as iio

        iio.imwrite(path, frames, extension=".gif", duration=1000.0 / fps, loop=0)
    elif suffix == ".mp4":
        import imageio.v2 as iio2

        try:
            writer = iio2.get_writer(path, format="FFMPEG", fps=fps, codec="libx264", pixelformat="yuv420p",
                                     quality=8, macro_block_size=1)
        except (ImportError, RuntimeError) as exc:
            raise MitnerfError(f"cannot write MP4 ({exc}); install ffmpeg support with "
                               "`pip install imageio-ffmpeg`, or write a .gif") from None
        with writer:
            for frame in _even(frames):
                writer.append_data(frame)
    else:
        raise MitnerfError(f"unknown video type {path.suffix!r} for {path}; use .gif or .mp4")
    return path


def read_video(path: str | Path) -> np.ndarray:
    """Frames ``[n, H, W, 3]`` uint8 of a GIF or MP4 written by :func:`write_video`."""
    import imageio.v3 as iio

    path = Path(path)
    if path.suffix.lower() == ".mp4":
        frames = iio.imread(path, index=None, plugin="FFMPEG")
    else:
        frames = iio.imread(path, index=None)
    return np.asarray(frames)[..., :3]


@dataclass
class OrbitVideo:
    """What :func:`orbit_video` wrote and how fast it rendered."""

    paths: dict
    """``{'color_gif', 'color_mp4', 'depth_gif', 'depth_mp4'}`` -> file path."""
    frames: OrbitFrames
    """The rendered frames."""
    write_seconds: float
    """Time spent encoding and writing the files."""

    def summary(self) -> str:
        n, H, W = self.frames.depth.shape
        return f"video {n} frames {W}x{H} in {self.frames.seconds:.3g} s ({self.frames.fps:.3g} frames/s)"


def orbit_video(backend, cfg: OrbitConfig, out: str | Path, background=(1.0, 1.0, 1.0),
                formats=("gif", "mp4"), batch_rays: int = 1 << 18, progress: bool = True) -> OrbitVideo:
    """Render the orbit and write ``color.<fmt>`` and ``depth.<fmt>`` into ``out``."""
    out = Path(out)
    frames = render_orbit(backend, orbit_cameras(cfg), batch_rays, progress=progress)
    t0 = time.perf_counter()
    color = to_uint8(frames.rgb)
    depth = to_uint8(depth_frames(frames.depth, background))
    paths = {}
    for fmt in formats:
        paths[f"color_{fmt}"] = write_video(out / f"color.{fmt}", color, cfg.fps)
        paths[f"depth_{fmt}"] = write_video(out / f"depth.{fmt}", depth, cfg.fps)
    return OrbitVideo(paths, frames, time.perf_counter() - t0)
