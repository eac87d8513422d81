"""The NeRF2D format (the original NeRF2D code and its Blender add-on).

::

    DIR/mitnerf.json                      (ours only: bounds and provenance)
    DIR/{train,val,test}/transforms.json  {"focal": f_px, "frames": [{"transform_matrix": 3x3}]}
    DIR/{split}/cam-{i}.png               H x 1 RGBA, 8-bit sRGB, colour over black + coverage
    DIR/{split}/cam-{i}.npz               depth_map (H x 1, -1 on a miss), intrinsic_mat (3x3)

Frame ``i`` of ``transforms.json`` belongs to ``cam-{i}.*``. Pixel row ``i`` looks
along ``normalize([f, H/2 - (i + 0.5)])`` rotated by the pose's 2x2 block (see
:mod:`mitnerf.data.cameras`). Our ``.npz`` files add ``rgb_linear``, ``alpha`` and
``mask``, which the original loader ignores; datasets from the add-on load without them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..._io import atomic_dir
from ...errors import MitnerfError
from ..cameras import Cameras
from ..color import display_color, to_uint8
from ..dataset import SPLITS, Dataset, Split
from .common import read_image, read_json, read_meta, write_meta


def write_nerf2d(dataset: Dataset, out: str | Path) -> Path:
    """Write ``dataset`` (2D) atomically to the folder ``out``."""
    import imageio.v3 as iio

    if dataset.dim != 2:
        raise MitnerfError("the NeRF2D format holds 2D datasets only; use --format blender for 3D")
    out = Path(out)
    with atomic_dir(out) as tmp:
        for name, split in dataset.splits.items():
            d = tmp / name
            d.mkdir()
            cams = split.cameras
            frames = [{"transform_matrix": p.tolist()} for p in cams.poses]
            (d / "transforms.json").write_text(json.dumps({"focal": cams.focal, "frames": frames}, indent=1))
            K = np.array([[cams.focal, 0, 0], [0, cams.focal, (cams.height - 1) / 2], [0, 0, 1]])
            for i in range(len(split)):
                rgba = np.concatenate([split.color[i], split.alpha[i][..., None]], -1)
                iio.imwrite(d / f"cam-{i}.png", to_uint8(rgba))
                extra = {}
                if split.depth is not None:
                    extra["depth_map"] = np.where(np.isfinite(split.depth[i]), split.depth[i], -1.0).astype(np.float32)
                if split.mask is not None:
                    extra["mask"] = split.mask[i]
                if split.linear is not None:
                    extra["rgb_linear"] = split.linear[i]
                np.savez(d / f"cam-{i}.npz", intrinsic_mat=K, alpha=split.alpha[i], **extra)
        write_meta(tmp, dataset, "nerf2d")
    return out


def _read_split(d: Path) -> Split:
    data = read_json(d / "transforms.json")
    try:
        focal = float(data["focal"])
        poses = np.array([f["transform_matrix"] for f in data["frames"]], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as exc:
        raise MitnerfError(f"{d / 'transforms.json'} is not a NeRF2D transforms file ({exc!r} missing or "
                           "malformed); it needs 'focal' and 'frames' with 3x3 'transform_matrix'") from None
    n = len(poses)
    pngs = sorted(d.glob("cam-*.png"))
    if len(pngs) != n:
        raise MitnerfError(f"{d}: transforms.json has {n} poses but the folder has {len(pngs)} cam-*.png images; "
                           "every frame i needs its cam-i.png")
    if n == 0:
        raise MitnerfError(f"{d}: the split has no frames; add views or drop the split folder")
    if poses.shape[1:] != (3, 3):
        raise MitnerfError(f"{d}: NeRF2D poses are 3x3 matrices, got {poses.shape[1:]}")
    images = []
    for i in range(n):
        img = read_image(d / f"cam-{i}.png")
        if img.ndim == 2:            # a greyscale H x 1 image
            img = np.repeat(img[..., None], 3, -1)
        images.append(img)
    shapes = {im.shape[:2] for im in images}
    if len(shapes) != 1:
        raise MitnerfError(f"{d}: images have different sizes {sorted(shapes)}; all views need one resolution")
    img = np.stack(images)
    H, W = img.shape[1:3]
    if W != 1 and H == 1:            # written as a 1 x H row: turn it into H x 1
        img = img.transpose(0, 2, 1, 3)
        H, W = W, 1
    cams = Cameras(poses, focal, H, 1)
    color = img[..., :3]
    alpha = img[..., 3] if img.shape[-1] == 4 else np.ones(img.shape[:3], np.float32)
    depth = mask = linear = None
    npz = [d / f"cam-{i}.npz" for i in range(n)]
    if all(p.exists() for p in npz):
        files = [np.load(p) for p in npz]
        if all("depth_map" in f for f in files):
            raw = np.stack([np.asarray(f["depth_map"], np.float32).reshape(H, 1) for f in files])
            depth = np.where(raw < 0, np.inf, raw).astype(np.float32)
            mask = (np.stack([f["mask"].reshape(H, 1) for f in files]) if all("mask" in f for f in files)
                    else np.isfinite(depth))
        if all("rgb_linear" in f and "alpha" in f for f in files):
            linear = np.stack([f["rgb_linear"].reshape(H, 1, 3) for f in files]).astype(np.float32)
            alpha = np.stack([f["alpha"].reshape(H, 1) for f in files]).astype(np.float32)
            color = display_color(linear, alpha)
    return Split(cams, color.astype(np.float32), alpha.astype(np.float32), depth, mask, linear)


def read_nerf2d(path: str | Path) -> Dataset:
    """Read a NeRF2D-format folder (ours or the original add-on's)."""
    path = Path(path)
    splits = {s: _read_split(path / s) for s in SPLITS if (path / s / "transforms.json").exists()}
    if "train" not in splits:
        raise MitnerfError(f"{path} has no train/transforms.json; point at a NeRF2D dataset folder")
    meta = read_meta(path)
    near, far = meta.get("near"), meta.get("far")
    if near is None or far is None:
        near, far = _infer_bounds(list(splits.values()))
    meta.setdefault("format", "nerf2d")
    return Dataset(splits, float(near), float(far), meta)


def _infer_bounds(splits: list[Split]) -> tuple[float, float]:
    """Bounds of foreign datasets: from the depth maps when present, else from the rig."""
    depths = [s.depth[np.isfinite(s.depth)] for s in splits if s.depth is not None]
    depths = np.concatenate(depths) if depths else np.zeros(0)
    if depths.size:
        return float(max(0.05, depths.min() - 0.5)), float(depths.max() + 1.0)
    dist = np.concatenate([np.linalg.norm(s.cameras.origins, axis=1) for s in splits])
    return float(max(0.05, dist.min() - 2.0)), float(dist.max() + 2.0)
