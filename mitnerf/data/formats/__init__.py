"""Dataset file formats: NeRF2D (2D, ours and the original add-on's), Blender, nerfstudio and instant-ngp
``transforms.json`` (3D; nerfstudio also 2D), tiny-NeRF (3D, one file), and real captures: LLFF, COLMAP (text
or binary), IDR / NeuS. Every input is checked (:mod:`.common`, :mod:`.capture`); every reader takes an integer
``downscale``.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from ..._io import Output, check_place, tidy, write_new_file
from ...errors import DataError, OutputError
from ..cameras import Cameras
from ..dataset import SPLITS, Dataset, Split
from .capture import check_downscale
from .colmap import model_folder, read_colmap, write_colmap
from .common import MAX_SIDE, check_focal, check_memory, check_poses, integer, npz_shapes, read_npz
from .idr import camera_file, read_idr, write_idr
from .llff import read_llff, write_llff
from .nerf2d import read_nerf2d, write_nerf2d
from .transforms import read_transforms, write_blender, write_nerfstudio

WRITERS = {"nerf2d": write_nerf2d, "blender": write_blender, "nerfstudio": write_nerfstudio, "llff": write_llff,
           "colmap": write_colmap, "idr": write_idr}
FORMATS = (*WRITERS, "tiny_nerf")
DIMS = {"nerf2d": (2,), "nerfstudio": (2, 3)}
"""The dimensions a format holds where not 3D only."""


def detect_format(path: str | Path) -> str:
    path = Path(path)
    if path.is_file() and path.suffix == ".npz":
        return "tiny_nerf"
    if not path.exists():
        raise DataError(f"dataset {path} does not exist; create it with `mitnerf dataset --out {path}`")
    if not path.is_dir():
        raise DataError(f"{path} is neither a dataset folder nor a tiny-NeRF .npz file")
    try:
        names = {p.name for p in path.iterdir()}
    except OSError as exc:
        raise DataError(f"cannot list dataset folder {path}: {exc.strerror}; check its permissions") from None
    if (path / "train" / "transforms.json").is_file():
        return "nerf2d"
    if "transforms_train.json" in names or "transforms.json" in names:
        return "transforms"
    if "poses_bounds.npy" in names:
        return "llff"
    if camera_file(path) is not None:
        return "idr"
    if model_folder(path) is not None:
        return "colmap"
    raise DataError(f"{path} is not a dataset folder: it has no train/transforms.json (NeRF2D), no "
                    "transforms_train.json or transforms.json (Blender/nerfstudio/instant-ngp), no poses_bounds.npy "
                    "(LLFF), no cameras_sphere.npz (IDR/NeuS) and no sparse/0/cameras.txt or .bin (COLMAP); "
                    "write one with `mitnerf dataset --out DIR`")


def load_dataset(path: str | Path, downscale: int = 1) -> Dataset:
    """Read and check a dataset in any supported format, its views box-filtered ``downscale`` times smaller (LLFF
    and COLMAP: from ``images_N/`` where it exists); ``meta['path']`` records where from."""
    fmt, downscale = detect_format(path), check_downscale(downscale)
    read = {"nerf2d": read_nerf2d, "transforms": read_transforms, "tiny_nerf": read_tiny_nerf, "llff": read_llff,
            "colmap": read_colmap, "idr": read_idr}[fmt]
    ds = read(path, downscale=downscale)
    ds.meta["path"] = str(Path(path).resolve())
    return ds


DATASET_BYTES_PER_PIXEL = 32
"""The most a written pixel costs: 8-bit RGBA, depth, exact linear colour and alpha as float32, a mask."""


def check_output(out: str | Path, fmt: str, overwrite: bool = False, inputs=(), size: int = 0) -> Output | None:
    """Apply the output rules to ``out`` now, before any work (a file is never replaced): the folder's
    :class:`~mitnerf._io.Output`, or None for a one-file format."""
    if fmt not in FORMATS:
        raise DataError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    if fmt == "tiny_nerf":
        if os.path.lexists(out):
            tidy(out)
            raise OutputError(f"{out} exists; mitnerf never replaces a file: choose another file name")
        check_place(Path(os.path.abspath(out)), size)
        return None
    return Output(out, "dataset", overwrite, inputs=inputs, size=size)


def save_dataset(dataset: Dataset, out: str | Path, fmt: str | None = None, overwrite: bool = False) -> Path:
    """Write ``dataset`` in ``fmt`` (default: NeRF2D for 2D, Blender for 3D); a folder follows the output rules
    (:class:`mitnerf._io.Output`), a file is never replaced."""
    fmt = fmt or ("nerf2d" if dataset.dim == 2 else "blender")
    target = check_output(out, fmt, overwrite)
    if target is None:
        return write_new_file(out, tiny_nerf_bytes(dataset))
    with target.staged() as tmp:
        WRITERS[fmt](dataset, tmp)
    return target.path


def read_tiny_nerf(path: str | Path, near: float = 2.0, far: float = 6.0, downscale: int = 1) -> Dataset:
    """The classic ``tiny_nerf_data.npz``: ``images [N, H, W, 3]`` (sRGB floats), ``poses [N, 4, 4]`` (OpenGL
    cameras), ``focal`` (pixels); no depth or alpha. Splits follow the tiny-NeRF notebook: the first
    ``min(100, N - 2)`` frames train, the next one validates, the rest test (frame 101, the notebook's test view,
    among them); files written here add ``n_train`` and ``n_val`` keys, which take precedence."""
    path = Path(path)
    shape = npz_shapes(path).get("images", ((),))[0]
    if len(shape) == 4:                 # refuse huge images from the header, before loading them
        n, H, W = shape[:3]
        if max(H, W) > MAX_SIDE:
            raise DataError(f"{path}: views of {H} x {W} pixels are too large (at most {MAX_SIDE} per side); "
                            "downsample them")
        check_memory(n * H * W, str(path))
    data = read_npz(path)
    missing = [k for k in ("images", "poses", "focal") if k not in data]
    if missing:
        raise DataError(f"{path} lacks {', '.join(missing)}; a tiny-NeRF file has 'images', 'poses' and 'focal'")
    images, poses, focal = data["images"], data["poses"], data["focal"]
    if images.ndim != 4 or images.shape[-1] not in (3, 4) or images.dtype.kind not in "uif":
        raise DataError(f"{path}: 'images' must be [N, H, W, 3] numbers, got {images.shape} {images.dtype}")
    if poses.shape != (len(images), 4, 4) or poses.dtype.kind not in "if":
        raise DataError(f"{path}: {len(images)} images need 'poses' of shape [{len(images)}, 4, 4], got {poses.shape}")
    if focal.size != 1 or focal.dtype.kind not in "if":
        raise DataError(f"{path}: 'focal' must be one number (pixels), got {focal.shape} {focal.dtype}")
    n, H, W = images.shape[:3]          # their size and memory were checked from the header
    if n < 3:
        raise DataError(f"{path} has {n} frames; need at least 3 (train, val, test)")
    check_poses(poses.astype(np.float64), str(path))
    focal = check_focal(float(focal.reshape(-1)[0]), W, str(path))
    n_train = _count(data, "n_train", path, 1, n - 1) if "n_train" in data else min(100, n - 2)
    n_val = _count(data, "n_val", path, 0, n - n_train - 1) if "n_val" in data else 1
    img = images[..., :3].astype(np.float32) / (255.0 if images.dtype == np.uint8 else 1.0)
    if not np.isfinite(img).all():
        raise DataError(f"{path}: 'images' contains NaN or infinity; replace the file")
    cuts = {"train": slice(0, n_train), "val": slice(n_train, n_train + n_val), "test": slice(n_train + n_val, None)}
    splits = {s: Split(Cameras(poses[c], focal, H, W), np.clip(img[c], 0, 1), np.ones(img[c].shape[:3], np.float32))
              .downscaled(check_downscale(downscale)) for s, c in cuts.items()}
    meta = {"format": "tiny_nerf", "scene": path.stem, "background": [0.0] * 3}
    if downscale > 1:
        meta["downscale"] = downscale
    return Dataset(splits, near, far, meta)


def _count(data: dict, key: str, path: Path, lo: int, hi: int) -> int:
    if data[key].size != 1:
        raise DataError(f"{path}: {key!r} must be one number, got an array of shape {data[key].shape}; fix the file")
    return integer(data[key].reshape(-1)[0], f"{path}: {key}", lo, hi)


def tiny_nerf_bytes(dataset: Dataset) -> bytes:
    """The file of train + val + test (in that order, composited over the dataset's background)."""
    if dataset.dim != 3:
        raise DataError("tiny-NeRF files hold 3D datasets only")
    order = [dataset[s] for s in SPLITS]
    cams = Cameras.concatenate([s.cameras for s in order])
    if not cams.simple:
        raise DataError("tiny-NeRF files hold one focal length, square pixels, centred principal points and no lens "
                        "distortion; use --format colmap or nerfstudio")
    images = np.concatenate([s.target(dataset.background) for s in order]).astype(np.float32)
    buf = io.BytesIO()
    np.savez(buf, images=images, poses=cams.poses.astype(np.float32), focal=np.float32(cams.focal),
             n_train=len(order[0]), n_val=len(order[1]))
    return buf.getvalue()


__all__ = ["FORMATS", "DIMS", "check_output", "load_dataset", "save_dataset", "detect_format", "read_nerf2d",
           "write_nerf2d", "read_transforms", "write_blender", "write_nerfstudio", "read_tiny_nerf", "tiny_nerf_bytes",
           "read_llff", "write_llff", "read_colmap", "write_colmap", "read_idr", "write_idr"]
