"""COLMAP sparse reconstructions::

    DIR/images/                 the photographs (images_N/: the same names N times smaller, as nerfstudio writes)
    DIR/sparse/0/ (or sparse/)  cameras, images, points3D, as .txt or .bin (:mod:`.colmap_files`)

Reading: camera models SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, and FULL_OPENCV with
k4 = k5 = k6 = 0 (lens: :mod:`~mitnerf.data.lens`; COLMAP puts the image's top-left corner at (0, 0), as
mitnerf does). Each image's world-to-camera pose (qvec, tvec, OpenCV axes) becomes an OpenGL camera-to-world
matrix, in the reconstruction's own world units. Images in name order; those absent from the image folder are
skipped with one warning line (too few left is refused); every 8th is a test view, the rest train. The sparse
points a view sees give its depth bounds (their depths' 0.1 and 99.9 percentiles, as LLFF's imgs2poses):
``meta['bounds']``, near and far (:func:`~.capture.near_far`); ``meta['points_bounds']`` is the points' box
(the same percentiles per axis).

Writing (``--format colmap``; ``binary=True`` for .bin): one camera per distinct intrinsics (PINHOLE, OPENCV, or
FULL_OPENCV when k3 is set), the views as ``images/0000.png`` ... over the dataset's background, and up to
:data:`POINTS` points where the depth maps hit, each observed by the view it came from.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ...errors import DataError
from ..cameras import Cameras
from ..dataset import Dataset, Split
from .capture import (absent, capture_dataset, check_downscale, check_intrinsics, check_lens, hold_out, image_folder,
                      layout, near_far, read_views, warn_skipped)
from .colmap_files import Model, read_model, write_model
from .common import check_poses, image_size, write_meta, write_png

PARAMETERS = {"SIMPLE_PINHOLE": "f cx cy", "PINHOLE": "fx fy cx cy", "SIMPLE_RADIAL": "f cx cy k1",
              "RADIAL": "f cx cy k1 k2", "OPENCV": "fx fy cx cy k1 k2 p1 p2",
              "FULL_OPENCV": "fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6"}
"""The camera models mitnerf reads and the meaning of their parameters."""
FLIP = np.diag([1.0, -1.0, -1.0, 1.0])
"""OpenCV camera axes (x right, y down, z forward) <-> OpenGL (x right, y up, z backward)."""
POINTS = 2000
"""Most points the writer puts in points3D."""


def model_folder(root: Path) -> Path | None:
    """``sparse/0/`` or ``sparse/`` when it holds a model."""
    for folder in (root / "sparse" / "0", root / "sparse"):
        if (folder / "cameras.txt").is_file() or (folder / "cameras.bin").is_file():
            return folder
    return None


def camera_lens(model: str, params: np.ndarray, where: str) -> np.ndarray:
    """``[9]``: fx, fy, cx, cy, k1, k2, p1, p2, k3 of a camera."""
    if model not in PARAMETERS:
        raise DataError(f"{where}: camera model {model} is not one mitnerf reads ({', '.join(PARAMETERS)}); undistort "
                        "the images with `colmap image_undistorter` first")
    p = dict(zip(PARAMETERS[model].split(), params))
    if not np.isfinite(params).all():
        raise DataError(f"{where}: a {model} camera's parameters must be finite numbers; fix the camera")
    if any(p.get(k, 0.0) != 0 for k in ("k4", "k5", "k6")):
        raise DataError(f"{where}: FULL_OPENCV's rational terms k4, k5, k6 are not modelled; undistort the images "
                        "with `colmap image_undistorter` first")
    fx, fy = p.get("fx", p.get("f")), p.get("fy", p.get("f"))
    return np.array([fx, fy, p["cx"], p["cy"], *(p.get(k, 0.0) for k in ("k1", "k2", "p1", "p2", "k3"))])


def read_colmap(path: str | Path, downscale: int = 1) -> Dataset:
    """Read a COLMAP folder (module docstring), its views ``downscale`` times smaller."""
    path, downscale = Path(path), check_downscale(downscale)
    folder = model_folder(path)
    if folder is None:
        raise DataError(f"{path} has no COLMAP model (sparse/0/cameras.txt or .bin); point at the capture's folder")
    model, where = read_model(folder), str(folder)
    images, N = image_folder(path, downscale, str(path))
    for name, *_ in model.images:
        if Path(name).is_absolute() or ".." in Path(name).parts:
            raise DataError(f"{where}: image name {name[:60]!r} leaves the image folder; fix images.txt")
    paths = [images / name for name, *_ in model.images]
    gone = set(absent(paths))
    keep = [i for i in range(len(paths)) if i not in gone]
    if gone and len(keep) < 3:
        raise DataError(f"{where} registers {len(paths)} images, {len(gone)} of them absent from {images}, which "
                        "leaves too few (at least 3: 2 to train on, 1 to test); restore the images")
    split = hold_out(len(keep), str(images))
    shots = [model.images[i] for i in keep]
    for name, _, _, cid in shots:
        if cid not in model.cameras:
            raise DataError(f"{where}: image {name} uses camera {cid}, which the cameras file lacks; export the "
                            "model again")
    sizes = {model.cameras[cid][1:3] for *_, cid in shots}
    if len(sizes) != 1:
        raise DataError(f"{where}: the images' cameras have different sizes {sorted(sizes)[:3]}; mitnerf needs one "
                        "resolution: undistort them to one size")
    w0, h0 = sizes.pop()
    K = np.array([camera_lens(model.cameras[cid][0], model.cameras[cid][3], f"{where}, camera {cid}")
                  for *_, cid in shots])
    check_intrinsics(K[:, 0], K[:, 1], K[:, 2], K[:, 3], w0, h0, where)
    poses = np.array([camera_pose(q, t, name, where) for name, q, t, _ in shots])
    check_poses(poses, where)
    H, W = image_size(paths[keep[0]])
    if (H, W) != (h0, w0) and (N == 1 or abs(H - h0 / N) > 1 or abs(W - w0 / N) > 1):
        raise DataError(f"{images}: images of {W} x {H} pixels do not fit cameras of {w0} x {h0}"
                        f"{f' shrunk {N} times' if N > 1 else ''}; use the images the model was made from")
    s = np.array([W / w0, H / h0, W / w0, H / h0])
    cams = Cameras(poses, K[:, 0] * s[0], H, W, K[:, 1] * s[1], K[:, 2] * s[2], K[:, 3] * s[3], K[:, 4:])
    check_lens(cams, where)
    box = max(1, downscale // N)
    color, alpha = read_views([paths[i] for i in keep], box, str(images))
    cams = cams.downscaled(box) if box > 1 else cams
    bounds = view_bounds(cams, model.points, where)
    info = {} if bounds is None else {"bounds": bounds.tolist(),
                                      "points_bounds": np.percentile(model.points, [0.1, 99.9], axis=0).tolist()}

    def depth_range():
        if bounds is None:
            raise DataError(f"{where} has no 3D points in front of its cameras, so the scene's depth is unknown; "
                            "triangulate points (`colmap point_triangulator`)")
        return near_far(cams, bounds)
    ds = capture_dataset(path, "colmap", Split(cams, color, alpha), split, N * box, depth_range, layout=layout(poses),
                         **info)
    warn_skipped(where, [model.images[i][0] for i in sorted(gone)], len(paths))
    return ds


def camera_pose(q: np.ndarray, t: np.ndarray, name: str, where: str) -> np.ndarray:
    """OpenGL camera-to-world ``[4, 4]`` of a COLMAP world-to-camera ``qvec`` (w, x, y, z) and ``tvec``."""
    norm = np.linalg.norm(q)
    if not (np.isfinite(q).all() and np.isfinite(t).all() and abs(norm - 1) <= 1e-3):
        raise DataError(f"{where}: image {name}'s pose (qvec {q.tolist()}, tvec {t.tolist()}) is not a unit "
                        "quaternion and a finite translation; fix it or export the model again")
    R = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R.T, -R.T @ t
    return M @ FLIP


def view_bounds(cams: Cameras, points: np.ndarray, where: str) -> np.ndarray | None:
    """``[n, 2]`` depth bounds of the points each view sees (None when no view sees any); a view that sees none
    takes the others' extremes."""
    if not len(points) or not np.isfinite(points).all():
        if len(points):
            raise DataError(f"{where}: points3D holds NaN or infinite positions; export the model again")
        return None
    out = np.full((len(cams), 2), np.nan)
    for i in range(len(cams)):
        pixel, z = cams.subset([i]).project(points)
        with np.errstate(invalid="ignore"):
            seen = (z[0] > 0) & np.all((pixel[0] >= 0) & (pixel[0] < [cams.height, cams.width]), axis=-1)
        if seen.any():
            out[i] = np.percentile(z[0][seen], [0.1, 99.9])
    if np.isnan(out).all():
        return None
    lo, hi = np.nanmin(out[:, 0]), np.nanmax(out[:, 1])
    return np.where(np.isnan(out), [lo, hi], out)


def write_colmap(dataset: Dataset, folder: Path, binary: bool = False) -> None:
    """Write ``dataset`` (3D) as a COLMAP folder (module docstring)."""
    if dataset.dim != 3:
        raise DataError("the COLMAP format holds 3D captures; use --format nerf2d or nerfstudio for 2D scenes")
    views = Split.concatenate(list(dataset.splits.values()))
    c = views.cameras
    unique, inverse = np.unique(c.intrinsics, axis=0, return_inverse=True)
    cameras = {}
    for g, p in enumerate(unique):
        name = "PINHOLE" if not p[4:].any() else "OPENCV" if p[8] == 0 else "FULL_OPENCV"
        cameras[g + 1] = (name, c.width, c.height, np.r_[p[:4], p[4:8], p[8], 0, 0, 0][:len(PARAMETERS[name].split())])
    shots = []
    for i, M in enumerate(c.poses @ FLIP):
        R = M[:3, :3].T
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        shots.append((f"{i:04d}.png", np.array([w, x, y, z]), -R @ M[:3, 3], int(inverse.reshape(-1)[i]) + 1))
    points, tracks = np.zeros((0, 3)), []
    if views.depth is not None and np.isfinite(views.depth).any():
        o, d = c.rays()
        hit = np.flatnonzero(np.isfinite(views.depth).reshape(-1))
        pick = hit[np.linspace(0, len(hit) - 1, min(POINTS, len(hit))).astype(int)]
        points = (o + np.where(np.isfinite(views.depth), views.depth, 0)[..., None] * d).reshape(-1, 3)[pick]
        i, v, u = np.unravel_index(pick, views.depth.shape)
        tracks = list(zip(i.tolist(), (u + 0.5).tolist(), (v + 0.5).tolist()))
    (folder / "images").mkdir()
    for i, img in enumerate(views.target(dataset.background)):
        write_png(folder / "images" / shots[i][0], img)
    write_model(folder / "sparse" / "0", Model(cameras, shots, points), binary, tracks)
    write_meta(folder, dataset, "colmap")
