"""``transforms.json`` datasets: Blender-synthetic, nerfstudio and instant-ngp (3D, and 2D
written by mitnerf). Poses are OpenGL camera-to-world matrices (-z forward, +y up).

**Blender layout** (written by ``--format blender``)::

    DIR/transforms_{train,val,test}.json  {"camera_angle_x", "fl_x", "fl_y", "cx", "cy", "w", "h",
                                            "frames": [{"file_path": "./train/r_0", "transform_matrix",
                                                        "depth_file_path": "train/r_0_depth.npy"}]}
    DIR/{split}/r_{i}.png                 RGBA, 8-bit sRGB, straight alpha
    DIR/{split}/r_{i}_depth.npy           float32 H x W, distance along the ray, 0 on a miss
    DIR/{split}/r_{i}_linear.npy          float32 H x W x 4: exact linear RGB over black, alpha

**nerfstudio layout** (``--format nerfstudio``; nerfstudio's ``nerfstudio-data`` parser loads it as is)::

    DIR/transforms.json   {"camera_model": "PINHOLE", "fl_x", "fl_y", "cx", "cy", "w", "h",
                           "orientation_override": "none", "frames": [{"file_path": "images/train_0000.png",
                           "transform_matrix", "depth_file_path": "depths/train_0000.npy",
                           "mask_path": "masks/train_0000.png"}], "train_filenames", "val_filenames",
                           "test_filenames", "mitnerf_depth": {"kind": "z", "unit": 0.001}}

Depth follows nerfstudio's convention: distance along the camera's optical axis (z), in thousandths of a
world unit (its default ``depth_unit_scale_factor`` 1e-3), 0 on a miss. Masks are 8-bit, 255 where the
pixel-centre ray hits the object. A 2D dataset is written as ``H x 1`` images of cameras in the z = 0 plane
(``"mitnerf_dim": 2``) and read back as 2D.

**Reading** these or anyone's instant-ngp / nerfstudio folder: intrinsics shared or per frame (equal within a
split), square pixels, the principal point at the image centre, no lens distortion. Splits come from
``*_filenames`` lists when present, else every 8th frame is held out for test.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import DataError
from ..cameras import Cameras
from ..color import display_color, to_uint8
from ..dataset import SPLITS, Dataset, Split, bounds_from_cameras
from .common import (as_rgba, check_focal, check_memory, get, image_size, number, read_image, read_poses,
                     read_json, read_meta, read_npy, write_meta)

PINHOLE_MODELS = ("PINHOLE", "SIMPLE_PINHOLE", "OPENCV", "RADIAL", "SIMPLE_RADIAL")
DISTORTION = ("k1", "k2", "k3", "k4", "p1", "p2")
NS_DEPTH_UNIT = 1e-3


def _straight(split: Split, i: int) -> np.ndarray:
    a = split.alpha[i][..., None]
    return np.concatenate([np.where(a > 0, split.color[i] / np.maximum(a, 1e-8), 0.0), a], -1)


def write_blender(dataset: Dataset, folder: Path) -> None:
    import imageio.v3 as iio

    if dataset.dim != 3:
        raise DataError("the Blender format holds 3D datasets; use --format nerf2d or nerfstudio for 2D scenes")
    for name, split in dataset.splits.items():
        (folder / name).mkdir()
        c = split.cameras
        frames = []
        for i in range(len(split)):
            stem = f"{name}/r_{i}"
            iio.imwrite(folder / f"{stem}.png", to_uint8(_straight(split, i)))
            frame = {"file_path": f"./{stem}", "transform_matrix": c.poses[i].tolist()}
            if split.depth is not None:
                np.save(folder / f"{stem}_depth.npy", np.where(np.isfinite(split.depth[i]), split.depth[i], 0.0)
                        .astype(np.float32))
                frame["depth_file_path"] = f"{stem}_depth.npy"
            if split.linear is not None:
                np.save(folder / f"{stem}_linear.npy", np.concatenate([split.linear[i], split.alpha[i][..., None]], -1)
                        .astype(np.float32))
            frames.append(frame)
        header = {"camera_angle_x": float(np.radians(c.fov)), "fl_x": c.focal, "fl_y": c.focal,
                  "cx": c.width / 2, "cy": c.height / 2, "w": c.width, "h": c.height, "frames": frames}
        (folder / f"transforms_{name}.json").write_text(json.dumps(header, indent=1))
    write_meta(folder, dataset, "blender")


def pose_2d_to_3d(P: np.ndarray) -> np.ndarray:
    """NeRF2D 3x3 poses -> OpenGL 4x4 cameras in the z = 0 plane whose image column is the 1D view."""
    M = np.zeros((len(P), 4, 4))
    f, u = P[:, :2, 0], P[:, :2, 1]
    M[:, :2, 1], M[:, :2, 2] = u, -f                     # +y: the view's up, +z: backwards
    M[:, 2, 0] = f[:, 0] * u[:, 1] - f[:, 1] * u[:, 0]   # +x = y x z, along the world's z axis
    M[:, :2, 3], M[:, 3, 3] = P[:, :2, 2], 1
    return M


def pose_3d_to_2d(M: np.ndarray) -> np.ndarray:
    P = np.zeros((len(M), 3, 3))
    P[:, :2, 0], P[:, :2, 1], P[:, :2, 2], P[:, 2, 2] = -M[:, :2, 2], M[:, :2, 1], M[:, :2, 3], 1
    return P


def write_nerfstudio(dataset: Dataset, folder: Path) -> None:
    import imageio.v3 as iio

    for sub in ("images", "depths", "masks"):
        (folder / sub).mkdir()
    c0 = dataset["train"].cameras
    W, H = c0.width, c0.height
    header = {"camera_model": "PINHOLE", "fl_x": c0.focal, "fl_y": c0.focal, "cx": W / 2, "cy": H / 2, "w": W,
              "h": H, "orientation_override": "none", "mitnerf_dim": dataset.dim,
              "mitnerf_depth": {"kind": "z", "unit": NS_DEPTH_UNIT}, "frames": []}
    for name, split in dataset.splits.items():
        c = split.cameras
        if (c.focal, c.height, c.width) != (c0.focal, H, W):
            raise DataError("the nerfstudio format needs one camera model for all splits; use --format blender")
        poses = pose_2d_to_3d(c.poses) if dataset.dim == 2 else c.poses
        zdepth = None
        if split.depth is not None:        # distance along the ray -> along the optical axis
            cos = -c.camera_directions()[..., -1] if dataset.dim == 3 else c.camera_directions()[..., 0]
            zdepth = np.where(np.isfinite(split.depth), split.depth * cos, 0.0) / NS_DEPTH_UNIT
        names = []
        for i in range(len(split)):
            stem = f"{name}_{i:04d}"
            iio.imwrite(folder / "images" / f"{stem}.png", to_uint8(_straight(split, i)))
            frame = {"file_path": f"images/{stem}.png", "transform_matrix": poses[i].tolist()}
            if zdepth is not None:
                np.save(folder / "depths" / f"{stem}.npy", zdepth[i].astype(np.float32))
                frame["depth_file_path"] = f"depths/{stem}.npy"
            if split.mask is not None:
                iio.imwrite(folder / "masks" / f"{stem}.png", (split.mask[i] * 255).astype(np.uint8))
                frame["mask_path"] = f"masks/{stem}.png"
            header["frames"].append(frame)
            names.append(frame["file_path"])
        header[f"{name}_filenames"] = names
    for s in SPLITS:
        header.setdefault(f"{s}_filenames", [])
    (folder / "transforms.json").write_text(json.dumps(header, indent=1))
    write_meta(folder, dataset, "nerfstudio")


def _intrinsics(header: dict, frames: list, where: str, W: int, H: int, dim: int) -> float:
    """The one focal length of a split's frames (checked: shared, square pixels, centred, no distortion)."""
    model = header.get("camera_model", "PINHOLE")
    if not isinstance(model, str) or model.upper() not in PINHOLE_MODELS:
        raise DataError(f"{where}: camera model {model!r} is not a pinhole camera; mitnerf reads pinhole cameras "
                        "only: undistort the images first")
    values = []
    for i, f in enumerate(frames):      # a frame's own value, else the header's
        v = {k: f.get(k, header.get(k)) for k in (*DISTORTION, "camera_angle_x", "fl_x", "fl_y", "w", "h", "cx", "cy")}
        for k in DISTORTION:
            if v[k] is not None and number(v[k], f"{where}: {k}", strict_lo=False) != 0:
                raise DataError(f"{where}: frame {i} has lens distortion ({k} = {v[k]}); mitnerf reads pinhole "
                                "cameras only: undistort the images first")
        ang = None if v["camera_angle_x"] is None else number(v["camera_angle_x"], f"{where}: camera_angle_x", 0, 3.14)
        if v["fl_x"] is not None:
            fx = number(v["fl_x"], f"{where}: fl_x")
            fy = number(v["fl_y"] if v["fl_y"] is not None else fx, f"{where}: fl_y")
            if ang is not None and abs(2 * np.arctan(0.5 * W / fx) - ang) > 1e-3 * ang:
                # the original NeRF and nerfstudio's Blender loader read camera_angle_x, instant-ngp fl_x
                raise DataError(f"{where}: camera_angle_x = {ang:g} rad and fl_x = {fx:g} px disagree for images "
                                f"{W} px wide (fl_x gives {2 * np.arctan(0.5 * W / fx):.6g} rad); fix or remove one")
        elif ang is not None:
            fx = fy = 0.5 * W / np.tan(0.5 * ang)
        else:
            raise DataError(f"{where} gives neither 'fl_x' nor 'camera_angle_x'; add the focal length")
        if abs(fx - fy) > 1e-3 * fx:
            raise DataError(f"{where}: fl_x = {fx:g} and fl_y = {fy:g} differ; mitnerf needs square pixels")
        for key, size in (("w", W), ("h", H)):
            if v[key] is not None and number(v[key], f"{where}: {key}", strict_lo=False) != size:
                raise DataError(f"{where}: {key} = {v[key]} but the images are {W} x {H}; fix the header")
        for key, centre in (("cx", W / 2), ("cy", H / 2)):
            if v[key] is not None and abs(number(v[key], f"{where}: {key}", strict_lo=False) - centre) > 0.51:
                raise DataError(f"{where}: principal point {key} = {v[key]} is off-centre; mitnerf's cameras need "
                                "cx = w/2 and cy = h/2 (crop or re-render)")
        values.append(fx)
    if max(values) - min(values) > 1e-3 * max(values):
        raise DataError(f"{where}: frames have different focal lengths; mitnerf needs one camera per split")
    return check_focal(values[0], H if dim == 2 else W, where)


def _plane(img: np.ndarray, H: int, W: int, path: Path) -> np.ndarray:
    """A one-channel image (a depth map or mask) of the views' size ``H x W``."""
    if img.ndim == 3:
        img = img[..., 0]
    if img.shape != (H, W):
        raise DataError(f"{path} is {img.shape[1]} x {img.shape[0]} pixels but the views are {W} x {H}; "
                        "depth maps and masks need the size of their view")
    return img


def _path(root: Path, value, where: str, suffix: str = ".png") -> Path:
    if not isinstance(value, str) or not value:
        raise DataError(f"{where}: a frame's path must be a non-empty string, got {json.dumps(value)[:40]}")
    p = root / value
    return p if p.suffix else p.with_suffix(suffix)


def _read_frames(root: Path, header: dict, frames: list, where: str, depth_unit: float | None, dim: int) -> Split:
    """One split's views; nerfstudio's z-depths come in ``depth_unit``s (None: Blender's distances)."""
    if not frames:
        raise DataError(f"{where} lists no frames; add frames or drop the split")
    poses = read_poses(frames, 4, where)
    paths = [_path(root, f.get("file_path"), where) for f in frames]
    sizes = {image_size(p) for p in paths}
    if len(sizes) != 1:
        raise DataError(f"{where}: images differ in size {sorted(sizes)}; all frames need one resolution")
    H, W = sizes.pop()
    if dim == 2 and W != 1:
        raise DataError(f"{where}: a 2D dataset has views one pixel wide, these are {W} wide")
    check_memory(len(frames) * H * W, where)
    focal = _intrinsics(header, frames, where, W, H, dim)
    img = np.stack([as_rgba(read_image(p)) for p in paths])
    a = img[..., 3]
    color = img[..., :3] * a[..., None]
    cams = Cameras(pose_3d_to_2d(poses) if dim == 2 else poses, focal, H, W)
    depth = mask = linear = None
    if all("depth_file_path" in f for f in frames):          # every frame is a dict (read_poses() checked)
        raw = np.stack([read_npy(p, (H, W), where) if p.suffix == ".npy" else _plane(read_image(p), H, W, p)
                        for p in (_path(root, f["depth_file_path"], where, ".npy") for f in frames)])
        if not np.isfinite(raw).all() or (raw < 0).any():
            raise DataError(f"{where}: depth maps must be finite and >= 0 (0 on a miss)")
        if depth_unit is not None:           # nerfstudio: z-depth in units -> distance along the ray
            dirs = cams.camera_directions()
            raw = raw * depth_unit / (dirs[..., 0] if dim == 2 else -dirs[..., -1])
        depth = np.where(raw > 0, raw, np.inf).astype(np.float32)
        mask = np.isfinite(depth)
    if all("mask_path" in f for f in frames):
        mask = np.stack([_plane(as_rgba(read_image(p))[..., 0], H, W, p) > 0.5
                         for p in (_path(root, f["mask_path"], where) for f in frames)])
    lpaths = [p.with_name(p.stem + "_linear.npy") for p in paths]
    have = [p.exists() for p in lpaths]
    if any(have) and not all(have):
        raise DataError(f"{where}: {lpaths[have.index(False)]} is missing while other frames have their "
                        "_linear.npy; restore it (or delete them all)")
    if all(have):
        lin = np.stack([read_npy(p, (H, W, 4), where) for p in lpaths])
        linear, a = lin[..., :3], lin[..., 3]
        if a.min() < 0 or a.max() > 1:
            raise DataError(f"{where}: a _linear.npy file holds alpha outside [0, 1]; regenerate the dataset")
        color = display_color(linear, a)
    return Split(cams, color.astype(np.float32), a.astype(np.float32), depth, mask, linear)


def read_transforms(path: str | Path) -> Dataset:
    """Read a Blender, nerfstudio or instant-ngp ``transforms.json`` folder."""
    path = Path(path)
    splits = {}
    if (path / "transforms_train.json").exists():
        fmt = "blender"
        for s in SPLITS:
            f = path / f"transforms_{s}.json"
            if f.exists():
                header = read_json(f)
                splits[s] = _read_frames(path, header, get(header, "frames", list, str(f)), str(f), None, 3)
    elif (path / "transforms.json").exists():
        fmt, where = "nerfstudio", str(path / "transforms.json")
        header = read_json(path / "transforms.json")
        frames = get(header, "frames", list, where)
        dim = header.get("mitnerf_dim", 3)
        if dim not in (2, 3):
            raise DataError(f"{where}: 'mitnerf_dim' must be 2 or 3; fix or remove it")
        for i, f in enumerate(frames):
            if not isinstance(f, dict):
                raise DataError(f"{where}: frame {i} must be an object with 'file_path' and 'transform_matrix'")
            _path(path, f.get("file_path"), f"{where}: frame {i}")          # a non-empty string
        lists = {s: get(header, f"{s}_filenames", list, where, None) or [] for s in SPLITS}
        names = {f["file_path"] for f in frames}
        for s, v in lists.items():
            for name in v:
                if not (isinstance(name, str) and name in names):   # nerfstudio refuses these too
                    raise DataError(f"{where}: {s}_filenames lists {json.dumps(name)[:60]}, the file_path of no "
                                    "frame; fix the list or add the frame")
        pick = ({s: [f for f in frames if f["file_path"] in set(v)] for s, v in lists.items()} if any(lists.values())
                else {"train": [f for i, f in enumerate(frames) if i % 8], "test": frames[::8]})
        unit = header.get("mitnerf_depth", {"kind": "z", "unit": NS_DEPTH_UNIT})
        if not (isinstance(unit, dict) and unit.get("kind") == "z"):
            raise DataError(f"{where}: 'mitnerf_depth' must be {{'kind': 'z', 'unit': 0.001}}; fix or remove it")
        unit = number(unit.get("unit"), f"{where}: mitnerf_depth unit")
        splits = {s: _read_frames(path, header, fr, f"{where} ({s})", unit, dim) for s, fr in pick.items() if fr}
    if "train" not in splits:
        raise DataError(f"{path} has neither transforms_train.json nor transforms.json with training frames; "
                        "point at a Blender/nerfstudio dataset folder")
    meta = read_meta(path)
    meta.setdefault("format", fmt)
    near, far = meta.get("near"), meta.get("far")
    if near is None or far is None:       # Blender scenes: 2..6 at radius 4
        near, far = bounds_from_cameras([s.cameras for s in splits.values()], 2.0, 0.0)
    return Dataset(splits, float(near), float(far), meta)
