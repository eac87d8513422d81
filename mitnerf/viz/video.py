"""Videos of a trained 3D field: a turn-table orbit (cameras circling ``center`` once, 360 degrees about the z axis
through it, at a fixed ``elevation`` and ``radius``, looking at ``center``) or a path that fits a capture
(:mod:`.paths`), colour and depth frames, GIF and MP4 files.
Depth is ``depth / opacity`` (``inf``: no surface), coloured on one ``near, far`` range for the whole video.
Frames per second count rendering only (not writing files)."""

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
from ..settings import check, setting
from .panels import colorize_depth
from .paths import PATHS


@dataclass
class OrbitConfig:
    """A video's camera path: a 360 degree turn-table orbit around ``center``, or a path that fits the capture."""

    path: str = setting("auto", choices=("auto", *PATHS), flag="--path")
    """The camera path: an orbit around the object, a spiral in front of a forward-facing capture (as LLFF renders)
    or the capture's own path (its training cameras, interpolated); auto: the one that fits the scene the run was
    fitted in."""
    n_frames: int = setting(120, lo=1, hi=100_000, flag="--frames")
    """Frames in one turn (120 at 30 fps: a 4 s turn)."""
    resolution: int = setting(100, lo=2, hi=4096, flag="--image-size", unit="pixels")
    """Frame width in pixels (and height: an orbit's frames are square, a capture's path and spiral keep its
    aspect)."""
    elevation: float = setting(25.0, lo=-89.8999, hi=89.8999, flag="--elevation", unit="degrees")
    """Camera height above the horizontal plane through ``center``, in degrees (|e| < 89.9)."""
    radius: float = setting(3.5, lo=0, above=True, hi=1e4, flag="--radius", unit="world units")
    """Distance from ``center`` to every camera (world units)."""
    fov: float = setting(40.0, lo=0, above=True, hi=179, flag="--fov", unit="degrees")
    """Horizontal field of view in degrees."""
    center: tuple = setting((0.0, 0.0, 0.0), lo=-1e4, hi=1e4)
    """The point every camera looks at and the orbit turns around (z axis through it)."""
    start_azimuth: float = setting(0.0, lo=-360, hi=360, unit="degrees")
    """Azimuth of the first frame in degrees (0: the +x side)."""
    fps: float = setting(30.0, lo=0, above=True, hi=1000, flag="--fps", unit="frames per second")
    """Playback rate of the written videos."""

    def validate(self) -> None:
        check(self)


def orbit_cameras(cfg: OrbitConfig) -> Cameras:
    """``n_frames`` cameras on the orbit, each looking at ``cfg.center``; frame ``k`` at azimuth
    ``start_azimuth + 360 k / n_frames`` degrees, OpenGL poses from :func:`~mitnerf.data.rig.look_at_3d`."""
    cfg.validate()
    az = np.radians(cfg.start_azimuth) + 2 * np.pi * np.arange(cfg.n_frames) / cfg.n_frames   # [n]
    el = np.radians(cfg.elevation)
    c = np.asarray(cfg.center, np.float64)
    pos = c + cfg.radius * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                     np.full_like(az, np.sin(el))], 1)                          # [n, 3]
    focal = cfg.resolution / 2 / np.tan(np.radians(cfg.fov) / 2)
    return Cameras(look_at_3d(pos, c - pos), focal, cfg.resolution, cfg.resolution)


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
    """Render every frame of ``cams`` with ``backend.render`` (whole frames, about ``batch_rays`` rays per
    batch); depth is ``inf`` where ``opacity < min_opacity``."""
    if cams.dim != 3:
        raise MitnerfError("orbit videos need 3D cameras and a 3D model")
    n, H, W = len(cams), cams.height, cams.width
    per = max(1, batch_rays // (H * W))                   # frames per batch
    rgb = np.empty((n, H, W, 3), np.float32)
    depth, opacity = np.empty((n, H, W), np.float32), np.empty((n, H, W), np.float32)
    t0 = time.perf_counter()
    with tqdm(total=n, desc="render orbit", unit="frame", disable=not progress, leave=False) as bar:
        for s in range(0, n, per):
            sub = cams.subset(slice(s, s + per))
            out = backend.render(*(x.reshape(-1, 3).astype(np.float32) for x in sub.rays()))   # rays [m, H, W, 3]
            m = len(sub)
            rgb[s:s + m] = out["rgb"].reshape(m, H, W, 3)
            a = opacity[s:s + m] = out["opacity"].reshape(m, H, W)
            with np.errstate(divide="ignore", invalid="ignore"):
                depth[s:s + m] = np.where(a >= min_opacity, out["depth"].reshape(m, H, W) / a, np.inf)
            bar.update(m)
    return OrbitFrames(rgb, depth, opacity, time.perf_counter() - t0)


def depth_frames(depth: np.ndarray, background=(1.0, 1.0, 1.0), near: float | None = None,
                 far: float | None = None) -> np.ndarray:
    """``[n, H, W]`` depths (``inf`` = no surface) -> ``[n, H, W, 3]`` colours on one scale (near is bright;
    ``near, far`` default to the 1st and 99th percentiles of all hit depths); misses show ``background``."""
    hit = np.isfinite(depth)
    if hit.any():
        lo, hi = np.percentile(depth[hit], [1, 99])
        near, far = lo if near is None else near, hi if far is None else far
    rgb = np.where(hit[..., None], colorize_depth(depth, near, far), np.asarray(background, np.float32))
    return rgb.astype(np.float32)


def write_video(path: str | Path, frames: np.ndarray, fps: float = 30.0) -> Path:
    """Write ``[n, H, W, 3]`` frames (float [0, 1] or uint8) as ``.gif`` (Pillow, loops forever; delays in
    1/100 s, so 30 fps plays at ~33 fps) or ``.mp4`` (H.264 in yuv420p via imageio-ffmpeg)."""
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
        H, W = frames.shape[1:3]
        with writer:                            # yuv420p needs even sizes: repeat the last row/column
            for frame in np.pad(frames, ((0, 0), (0, H % 2), (0, W % 2), (0, 0)), mode="edge"):
                writer.append_data(frame)
    else:
        raise MitnerfError(f"unknown video type {path.suffix!r} for {path}; use .gif or .mp4")
    return path


def read_video(path: str | Path) -> np.ndarray:
    """Frames ``[n, H, W, 3]`` uint8 of a GIF or MP4 written by :func:`write_video`."""
    import imageio.v3 as iio

    plugin = {"plugin": "FFMPEG"} if Path(path).suffix.lower() == ".mp4" else {}
    return np.asarray(iio.imread(Path(path), index=None, **plugin))[..., :3]


@dataclass
class OrbitVideo:
    """What :func:`orbit_video` wrote and how fast it rendered."""

    paths: dict
    """``{'color_gif', 'color_mp4', 'depth_gif', 'depth_mp4'}`` -> file path."""
    frames: OrbitFrames
    """The rendered frames."""

    def summary(self) -> str:
        n, H, W = self.frames.depth.shape
        return f"video {n} frames {W}x{H} in {self.frames.seconds:.3g} s ({self.frames.fps:.3g} frames/s)"


def orbit_video(backend, cfg: OrbitConfig, out: str | Path, background=(1.0, 1.0, 1.0),
                formats=("gif", "mp4"), batch_rays: int = 1 << 18, progress: bool = True,
                cameras: Cameras | None = None) -> OrbitVideo:
    """Render the orbit (or ``cameras``, another path) and write ``color.<fmt>`` and ``depth.<fmt>`` into ``out``."""
    frames = render_orbit(backend, orbit_cameras(cfg) if cameras is None else cameras, batch_rays, progress=progress)
    videos = {"color": to_uint8(frames.rgb), "depth": to_uint8(depth_frames(frames.depth, background))}
    paths = {f"{kind}_{fmt}": write_video(Path(out) / f"{kind}.{fmt}", v, cfg.fps) for fmt in formats
             for kind, v in videos.items()}
    return OrbitVideo(paths, frames)
