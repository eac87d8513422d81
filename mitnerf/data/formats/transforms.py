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

**Reading** these or anyone's instant-ngp / nerfstudio folder: intrinsics (``fl_x``, ``fl_y`` or
``camera_angle_x``/``_y``, ``cx``, ``cy``, ``w``, ``h``) and lens coefficients (``k1``, ``k2``, ``k3``, ``p1``,
``p2``: nerfstudio's ``OPENCV``, ``RADIAL``, ``SIMPLE_RADIAL``; instant-ngp's bare coefficients) in the header or
per frame, one image size. Splits come from ``*_filenames`` lists when present, else every 8th frame is held
out for test (no validation split). In a ``transforms.json`` folder, frames whose image file is absent are
skipped with one warning line (instant-ngp's fox lists 67 frames and ships 50); too few left is refused.
Writers put the intrinsics every frame shares in the header and the others in each frame.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import DataError
from ..cameras import Cameras
from ..color import display_color
from ..dataset import SPLITS, Dataset, Split, bounds_from_cameras, box_downscale
from ..lens import COEFFICIENTS, MODELS
from .capture import absent, check_downscale, check_intrinsics, check_lens, read_views, warn_skipped
from .common import (all_or_none, as_rgba, check_focal, get, number, read_poses, read_json, read_meta, read_npy,
                     read_view, view_size, write_meta, write_png)

NS_DEPTH_UNIT = 1e-3


def _straight(split: Split, i: int) -> np.ndarray:
    a = split.alpha[i][..., None]
    return np.concatenate([np.where(a > 0, split.color[i] / np.maximum(a, 1e-8), 0.0), a], -1)


def write_blender(dataset: Dataset, folder: Path) -> None:
    if dataset.dim != 3:
        raise DataError("the Blender format holds 3D datasets; use --format nerf2d or nerfstudio for 2D scenes")
    for name, split in dataset.splits.items():
        if not len(split):                 # an empty split has no file (a reader refuses one without frames)
            continue
        (folder / name).mkdir()
        c = split.cameras
        frames = []
        for i in range(len(split)):
            stem = f"{name}/r_{i}"
            write_png(folder / f"{stem}.png", _straight(split, i))
            frame = {"file_path": f"./{stem}", "transform_matrix": c.poses[i].tolist()}
            if split.depth is not None:
                np.save(folder / f"{stem}_depth.npy", np.where(np.isfinite(split.depth[i]), split.depth[i], 0.0)
                        .astype(np.float32))
                frame["depth_file_path"] = f"{stem}_depth.npy"
            if split.linear is not None:
                np.save(folder / f"{stem}_linear.npy", np.concatenate([split.linear[i], split.alpha[i][..., None]], -1)
                        .astype(np.float32))
            frames.append(frame)
        header, own = camera_keys(c)
        if "fl_x" in header:
            header["camera_angle_x"] = float(2 * np.arctan(0.5 * c.width / header["fl_x"]))
        header["frames"] = [{**own[i], **f} for i, f in enumerate(frames)]
        (folder / f"transforms_{name}.json").write_text(json.dumps(header, indent=1))
    write_meta(folder, dataset, "blender")


def camera_keys(c: Cameras) -> tuple[dict, list[dict]]:
    """The ``transforms.json`` keys of cameras: those every frame shares (for the header) and each frame's own."""
    values = {"fl_x": c.fx, "fl_y": c.fy, "cx": c.cx, "cy": c.cy}
    if c.distortion is not None:
        values.update({name: c.distortion[:, j] for j, name in enumerate(COEFFICIENTS)})
    shared = {k: float(v[0]) for k, v in values.items() if len(v) and np.all(v == v[0])}
    own = [{k: float(v[i]) for k, v in values.items() if k not in shared} for i in range(len(c))]
    return {"camera_model": "PINHOLE" if c.distortion is None else "OPENCV", **shared, "w": c.width,
            "h": c.height}, own


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
    for sub in ("images", "depths", "masks"):
        (folder / sub).mkdir()
    cams = [s.cameras for s in dataset.splits.values()]
    if len({(c.height, c.width) for c in cams}) != 1:
        raise DataError("the nerfstudio format needs one image size for all splits; use --format blender")
    header, own = camera_keys(Cameras.concatenate(cams))
    header.update(orientation_override="none", mitnerf_dim=dataset.dim,
                  mitnerf_depth={"kind": "z", "unit": NS_DEPTH_UNIT}, frames=[])
    for name, split in dataset.splits.items():
        c = split.cameras
        poses = pose_2d_to_3d(c.poses) if dataset.dim == 2 else c.poses
        zdepth = None
        if split.depth is not None:        # distance along the ray -> along the optical axis
            cos = -c.camera_directions()[..., -1] if dataset.dim == 3 else c.camera_directions()[..., 0]
            zdepth = np.where(np.isfinite(split.depth), split.depth * cos, 0.0) / NS_DEPTH_UNIT
        names = []
        for i in range(len(split)):
            stem = f"{name}_{i:04d}"
            write_png(folder / "images" / f"{stem}.png", _straight(split, i))
            frame = {"file_path": f"images/{stem}.png", "transform_matrix": poses[i].tolist(),
                     **own[len(header["frames"])]}
            if zdepth is not None:
                np.save(folder / "depths" / f"{stem}.npy", zdepth[i].astype(np.float32))
                frame["depth_file_path"] = f"depths/{stem}.npy"
            if split.mask is not None:
                write_png(folder / "masks" / f"{stem}.png", split.mask[i])
                frame["mask_path"] = f"masks/{stem}.png"
            header["frames"].append(frame)
            names.append(frame["file_path"])
        header[f"{name}_filenames"] = names
    for s in SPLITS:
        header.setdefault(f"{s}_filenames", [])
    (folder / "transforms.json").write_text(json.dumps(header, indent=1))
    write_meta(folder, dataset, "nerfstudio")


def _intrinsics(header: dict, frames: list, where: str, W: int, H: int, dim: int) -> dict:
    """Every frame's ``fx, fy, cx, cy`` ``[n]`` and lens ``distortion`` ``[n, 5]`` (a frame's own value, else the
    header's), checked, as :class:`Cameras` arguments."""
    model = header.get("camera_model", "PINHOLE")
    if not isinstance(model, str) or model.upper() not in MODELS:
        raise DataError(f"{where}: camera model {json.dumps(model)[:40]} is not a pinhole camera; mitnerf reads "
                        f"{', '.join(MODELS)}: undistort the images to one of them first")
    out = {k: np.empty(len(frames)) for k in ("fx", "fy", "cx", "cy")}
    out["distortion"] = np.zeros((len(frames), 5))
    for i, f in enumerate(frames):
        v = {k: f.get(k, header.get(k)) for k in (*COEFFICIENTS, "k4", "camera_angle_x", "camera_angle_y", "fl_x",
                                                 "fl_y", "w", "h", "cx", "cy")}
        for j, k in enumerate(COEFFICIENTS):
            out["distortion"][i, j] = 0.0 if v[k] is None else number(v[k], f"{where}: {k}", strict_lo=False)
        if v["k4"] is not None and number(v["k4"], f"{where}: k4", strict_lo=False) != 0:
            raise DataError(f"{where}: frame {i} has k4 = {v['k4']}, which mitnerf's lens model lacks (it has k1, k2, "
                            "k3, p1, p2); undistort the images first")
        focal = []
        for axis, size in (("x", W), ("y", H)):
            ang, fl = v[f"camera_angle_{axis}"], v[f"fl_{axis}"]
            ang = None if ang is None else number(ang, f"{where}: camera_angle_{axis}", 0, 3.14)
            if fl is not None:
                fl = number(fl, f"{where}: fl_{axis}")
                if ang is not None and abs(2 * np.arctan(0.5 * size / fl) - ang) > 1e-3 * ang:
                    # the original NeRF and nerfstudio's Blender loader read camera_angle_x, instant-ngp fl_x
                    raise DataError(f"{where}: camera_angle_{axis} = {ang:g} rad and fl_{axis} = {fl:g} px disagree "
                                    f"for images {size} px {'wide' if axis == 'x' else 'tall'} (fl_{axis} gives "
                                    f"{2 * np.arctan(0.5 * size / fl):.6g} rad); fix or remove one")
            elif ang is not None:
                fl = 0.5 * size / np.tan(0.5 * ang)
            elif axis == "x":
                raise DataError(f"{where} gives neither 'fl_x' nor 'camera_angle_x'; add the focal length")
            focal.append(fl)
        out["fx"][i], out["fy"][i] = focal[0], focal[1] if focal[1] is not None else focal[0]
        for key, size in (("w", W), ("h", H)):
            if v[key] is not None and number(v[key], f"{where}: {key}", strict_lo=False) != size:
                raise DataError(f"{where}: {key} = {v[key]} but the images are {W} x {H}; fix the header")
        for key, size in (("cx", W), ("cy", H)):
            out[key][i] = size / 2 if v[key] is None else number(v[key], f"{where}: {key}", strict_lo=False)
    if dim == 3:
        check_intrinsics(out["fx"], out["fy"], out["cx"], out["cy"], W, H, where)
        return out
    if out["distortion"].any() or np.abs(out["fy"] - out["fx"]).max() > 1e-3 * out["fx"].max():
        raise DataError(f"{where}: 2D views have one focal length and no lens distortion; fix the header")
    for f, cx, cy in zip(out["fx"], out["cx"], out["cy"]):
        check_focal(f, H, where)
        if not (0 <= cx <= W and 0 <= cy <= H):
            raise DataError(f"{where}: the principal point ({cx:g}, {cy:g}) lies off the {W} x {H} px view; fix "
                            "the header")
    return {"fx": out["fx"], "cy": out["cy"]}


def _path(root: Path, value, where: str, suffix: str = ".png") -> Path:
    if not isinstance(value, str) or not value:
        raise DataError(f"{where}: a frame's path must be a non-empty string, got {json.dumps(value)[:40]}")
    p = root / value
    return p if p.suffix else p.with_suffix(suffix)


def _read_frames(root: Path, header: dict, frames: list, where: str, depth_unit: float | None, dim: int,
                 downscale: int) -> Split:
    """One split's views; nerfstudio's z-depths come in ``depth_unit``s (None: Blender's distances). With
    ``downscale`` > 1 the views, masks and linear colours are box-filtered and depth maps left out (a block of
    pixels has no one depth along its centre ray)."""
    if not frames:
        raise DataError(f"{where} lists no frames; add frames or drop the split")
    poses = read_poses(frames, 4, where)
    paths = [_path(root, f.get("file_path"), where) for f in frames]
    H, W = view_size(paths, where, downscale)
    if dim == 2 and W != 1:
        raise DataError(f"{where}: a 2D dataset has views one pixel wide, these are {W} wide")
    cams = Cameras(pose_3d_to_2d(poses) if dim == 2 else poses, height=H, width=W,
                   **_intrinsics(header, frames, where, W, H, dim))
    check_lens(cams, where)
    color, a = read_views(paths, downscale, where, size=(H, W))
    full, cols = (H, W), 1 if dim == 2 else downscale
    cams = cams.downscaled(downscale) if downscale > 1 else cams
    H, W = cams.height, cams.width
    depth = mask = linear = None
    if downscale == 1 and all("depth_file_path" in f for f in frames):          # every frame is a dict
        raw = np.stack([read_npy(p, (H, W), where) if p.suffix == ".npy"
                        else as_rgba(read_view(p, (H, W), "a depth map"))[..., 0]
                        for p in (_path(root, f["depth_file_path"], where, ".npy") for f in frames)])
        if not np.isfinite(raw).all() or (raw < 0).any():
            raise DataError(f"{where}: depth maps must be finite and >= 0 (0 on a miss)")
        if depth_unit is not None:           # nerfstudio: z-depth in units -> distance along the ray
            dirs = cams.camera_directions()
            raw = raw * depth_unit / (dirs[..., 0] if dim == 2 else -dirs[..., -1])
        depth = np.where(raw > 0, raw, np.inf).astype(np.float32)
        mask = np.isfinite(depth)
    if all("mask_path" in f for f in frames):
        mask = np.stack([as_rgba(read_view(p, full, "a mask"))[..., 0]
                         for p in (_path(root, f["mask_path"], where) for f in frames)])
        mask = box_downscale(mask, downscale, cols) > 0.5
    lpaths = [p.with_name(p.stem + "_linear.npy") for p in paths]
    if all_or_none([p.exists() for p in lpaths], paths, where, "_linear.npy"):
        lin = box_downscale(np.stack([read_npy(p, (*full, 4), where) for p in lpaths]), downscale, cols)
        linear, a = lin[..., :3], lin[..., 3]
        if a.min() < 0 or a.max() > 1:
            raise DataError(f"{where}: a _linear.npy file holds alpha outside [0, 1]; regenerate the dataset")
        color = display_color(linear, a)
    return Split(cams, color, a.astype(color.dtype), depth, mask, linear)


def _pick(path: Path, header: dict, where: str) -> tuple[dict[str, list], list[str], int]:
    """The frames of each split of a ``transforms.json`` whose images exist, the skipped frames' paths and the
    number of frames listed."""
    frames = get(header, "frames", list, where)
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
    gone = absent([_path(path, f["file_path"], where) for f in frames])
    skipped = [frames[i]["file_path"] for i in gone]
    frames = [f for i, f in enumerate(frames) if i not in set(gone)]
    pick = ({s: [f for f in frames if f["file_path"] in set(v)] for s, v in lists.items()} if any(lists.values())
            else {"train": [f for i, f in enumerate(frames) if i % 8], "test": frames[::8]})
    if skipped and (len(pick["train"]) < 2 or not pick["test"]):
        raise DataError(f"{where}: {len(skipped)} of {len(frames) + len(skipped)} frames have no image file (the "
                        f"first: {skipped[0]}), which leaves {len(pick['train'])} training and {len(pick['test'])} "
                        "test views (at least 2 and 1 needed); restore the images")
    return pick, skipped, len(frames) + len(skipped)


def read_transforms(path: str | Path, downscale: int = 1) -> Dataset:
    """Read a Blender, nerfstudio or instant-ngp ``transforms.json`` folder, its views box-filtered by ``downscale``
    (depth maps are then left out)."""
    path, downscale = Path(path), check_downscale(downscale)
    splits, skipped, listed = {}, [], 0
    if (path / "transforms_train.json").exists():
        fmt = "blender"
        for s in SPLITS:
            f = path / f"transforms_{s}.json"
            if f.exists():
                header = read_json(f)
                splits[s] = _read_frames(path, header, get(header, "frames", list, str(f)), str(f), None, 3, downscale)
    elif (path / "transforms.json").exists():
        fmt, where = "nerfstudio", str(path / "transforms.json")
        header = read_json(path / "transforms.json")
        dim = header.get("mitnerf_dim", 3)
        if dim not in (2, 3):
            raise DataError(f"{where}: 'mitnerf_dim' must be 2 or 3; fix or remove it")
        pick, skipped, listed = _pick(path, header, where)
        unit = header.get("mitnerf_depth", {"kind": "z", "unit": NS_DEPTH_UNIT})
        if not (isinstance(unit, dict) and unit.get("kind") == "z"):
            raise DataError(f"{where}: 'mitnerf_depth' must be {{'kind': 'z', 'unit': 0.001}}; fix or remove it")
        unit = number(unit.get("unit"), f"{where}: mitnerf_depth unit", 0)
        splits = {s: _read_frames(path, header, fr, f"{where} ({s})", unit, dim, downscale)
                  for s, fr in pick.items() if fr}
    if "train" not in splits:
        raise DataError(f"{path} has neither transforms_train.json nor transforms.json with training frames; "
                        "point at a Blender/nerfstudio dataset folder")
    meta = read_meta(path, fmt, downscale)
    near, far = meta.get("near"), meta.get("far")
    if near is None or far is None:       # Blender scenes: 2..6 at radius 4
        near, far = bounds_from_cameras([s.cameras for s in splits.values()], 2.0, 0.0)
    warn_skipped(str(path / "transforms.json"), skipped, listed)
    return Dataset(splits, float(near), float(far), meta)
