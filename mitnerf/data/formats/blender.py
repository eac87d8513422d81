"""Blender-synthetic / nerfstudio ``transforms.json`` datasets (3D).

Written (Blender-synthetic layout, with nerfstudio's intrinsics keys)::

    DIR/transforms_{train,val,test}.json   {"camera_angle_x", "fl_x", "fl_y", "cx", "cy", "w", "h",
                                             "frames": [{"file_path": "./train/r_0",
                                                         "transform_matrix": 4x4,
                                                         "depth_file_path": "train/r_0_depth.npy"}]}
    DIR/{split}/r_{i}.png                  RGBA, 8-bit sRGB, straight alpha (as NeRF loaders expect)
    DIR/{split}/r_{i}_depth.npy            float32 H x W, distance along the ray, 0 on a miss
    DIR/{split}/r_{i}_linear.npy           float32 H x W x 4: exact linear RGB over black, alpha

Read: that layout, or a nerfstudio folder with one ``transforms.json`` (its
``train_filenames`` / ``val_filenames`` / ``test_filenames`` lists when present,
otherwise every 8th frame is held out for test). Poses use the OpenGL camera
(-z forward, +y up); the principal point must be the image centre.
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


def write_blender(dataset: Dataset, out: str | Path) -> Path:
    import imageio.v3 as iio

    if dataset.dim != 3:
        raise MitnerfError("the Blender format holds 3D datasets; use --format nerf2d for 2D scenes")
    out = Path(out)
    with atomic_dir(out) as tmp:
        for name, split in dataset.splits.items():
            (tmp / name).mkdir()
            c = split.cameras
            frames = []
            for i in range(len(split)):
                stem = f"{name}/r_{i}"
                a = split.alpha[i][..., None]
                straight = np.where(a > 0, split.color[i] / np.maximum(a, 1e-8), 0.0)
                iio.imwrite(tmp / f"{stem}.png", to_uint8(np.concatenate([straight, a], -1)))
                frame = {"file_path": f"./{stem}", "transform_matrix": c.poses[i].tolist()}
                if split.depth is not None:
                    np.save(tmp / f"{stem}_depth.npy", np.where(np.isfinite(split.depth[i]), split.depth[i], 0.0)
                            .astype(np.float32))
                    frame["depth_file_path"] = f"{stem}_depth.npy"
                if split.linear is not None:
                    np.save(tmp / f"{stem}_linear.npy", np.concatenate([split.linear[i], a], -1).astype(np.float32))
                frames.append(frame)
            header = {"camera_angle_x": float(np.radians(c.fov)), "fl_x": c.focal, "fl_y": c.focal,
                      "cx": c.width / 2, "cy": c.height / 2, "w": c.width, "h": c.height,
                      "camera_model": "OPENCV", "frames": frames}
            (tmp / f"transforms_{name}.json").write_text(json.dumps(header, indent=1))
        write_meta(tmp, dataset, "blender")
    return out


def _frame_path(root: Path, file_path: str) -> Path:
    p = root / file_path
    return p if p.suffix else p.with_suffix(".png")


def _read_frames(root: Path, header: dict, frames: list[dict], where: str) -> Split:
    if not frames:
        raise MitnerfError(f"{where} lists no frames; add frames or drop the split")
    try:
        poses = np.array([f["transform_matrix"] for f in frames], dtype=np.float64)
        paths = [_frame_path(root, f["file_path"]) for f in frames]
    except (KeyError, TypeError, ValueError) as exc:
        raise MitnerfError(f"{where}: every frame needs 'file_path' and a 4x4 'transform_matrix' ({exc!r})") from None
    missing = [p for p in paths if not p.exists()]
    if missing:
        raise MitnerfError(f"{where} has {len(frames)} poses but {len(missing)} of their images are missing "
                           f"(first: {missing[0]}); add the images or remove those frames")
    images = [read_image(p) for p in paths]
    if len({im.shape for im in images}) != 1:
        raise MitnerfError(f"{where}: images differ in size; all frames need one resolution")
    img = np.stack(images)
    if img.ndim == 3:
        img = np.repeat(img[..., None], 3, -1)
    H, W = img.shape[1:3]
    if "fl_x" in header:
        focal = float(header["fl_x"])
    elif "camera_angle_x" in header:
        focal = 0.5 * W / np.tan(0.5 * float(header["camera_angle_x"]))
    else:
        raise MitnerfError(f"{where} gives neither 'fl_x' nor 'camera_angle_x'; add the focal length")
    for key, centre in (("cx", W / 2), ("cy", H / 2)):
        if key in header and abs(float(header[key]) - centre) > 0.51:
            raise MitnerfError(f"{where}: principal point {key}={header[key]} is off-centre; "
                               "mitnerf's cameras need cx = w/2 and cy = h/2 (crop or re-render)")
    cams = Cameras(poses, focal, H, W)
    a = img[..., 3] if img.shape[-1] == 4 else np.ones(img.shape[:3], np.float32)
    color = img[..., :3] * a[..., None]
    depth = mask = linear = None
    dpaths = [root / f["depth_file_path"] for f in frames if "depth_file_path" in f]
    if len(dpaths) == len(frames) and all(p.exists() for p in dpaths):
        raw = np.stack([np.load(p) if p.suffix == ".npy" else read_image(p) for p in dpaths]).astype(np.float32)
        depth = np.where(raw > 0, raw, np.inf).astype(np.float32)
        mask = np.isfinite(depth)
    lpaths = [p.with_name(p.stem + "_linear.npy") for p in paths]
    if all(p.exists() for p in lpaths):
        lin = np.stack([np.load(p) for p in lpaths])
        linear, a = lin[..., :3], lin[..., 3]
        color = display_color(linear, a)
    return Split(cams, color.astype(np.float32), a.astype(np.float32), depth, mask, linear)


def read_blender(path: str | Path) -> Dataset:
    path = Path(path)
    splits = {}
    if (path / "transforms_train.json").exists():
        for s in SPLITS:
            f = path / f"transforms_{s}.json"
            if f.exists():
                header = read_json(f)
                splits[s] = _read_frames(path, header, header.get("frames", []), str(f))
    elif (path / "transforms.json").exists():
        header = read_json(path / "transforms.json")
        frames = header.get("frames", [])
        names = {s: set(header.get(f"{s}_filenames", [])) for s in SPLITS}
        if names["train"]:
            pick = {s: [f for f in frames if f.get("file_path") in names[s]] for s in SPLITS}
        else:
            test = [f for i, f in enumerate(frames) if i % 8 == 0]
            pick = {"train": [f for i, f in enumerate(frames) if i % 8], "test": test}
        for s, fr in pick.items():
            if fr:
                splits[s] = _read_frames(path, header, fr, f"{path / 'transforms.json'} ({s})")
    if "train" not in splits:
        raise MitnerfError(f"{path} has neither transforms_train.json nor transforms.json with training frames; "
                           "point at a Blender/nerfstudio dataset folder")
    meta = read_meta(path)
    meta.setdefault("format", "blender")
    near, far = meta.get("near"), meta.get("far")
    if near is None or far is None:
        dist = np.concatenate([np.linalg.norm(s.cameras.origins, axis=1) for s in splits.values()])
        near, far = max(0.05, dist.min() - 2.0), dist.max() + 2.0   # Blender scenes: 2..6 at radius 4
    return Dataset(splits, float(near), float(far), meta)
