"""LLFF captures (NeRF's forward-facing real scenes, e.g. fern)::

    DIR/poses_bounds.npy   float [N, 17]: per image a 3 x 5 matrix [R | t | (h, w, focal)] (camera-to-world, R's
                           columns along LLFF's [down, right, back] camera axes; h, w and focal at full size),
                           then the near and far depth bounds (along the optical axis) of what it sees
    DIR/images/            the photographs at full size; sorted names pair with rows (may be absent)
    DIR/images_N/          the same N times smaller (fern ships images_4/ and images_8/ only)

Reading: poses become OpenGL camera-to-world matrices ([right, up, back]) in the capture's own world units (no
recentring or rescaling); the focal length is scaled by the size of the images read (``fx = focal * w_img / w``,
``fy = focal * h_img / h``) and the principal point is the image centre. ``downscale`` picks ``images_N/`` as
:func:`~.capture.image_folder` says. ``meta['bounds']`` holds the per-image depth bounds ``[N, 2]``,
``meta['layout']`` ``"forward"`` for a forward-facing capture; near and far follow from them
(:func:`~.capture.near_far`). Every 8th image is a test view (NeRF's LLFF protocol), the rest train.

Writing (``--format llff``): every split's views in order (train, val, test) as ``images/0000.png`` ...,
composited over the dataset's background, the bounds from the depth maps (:func:`~.capture.depth_bounds`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import DataError
from ..cameras import Cameras
from ..dataset import Dataset, Split
from .capture import (IMAGE_SUFFIXES, MAX_VIEWS, capture_dataset, check_downscale, depth_bounds, hold_out,
                      image_folder, layout, near_far, read_views)
from .common import check_focal, check_poses, image_size, integer, npy_shape, read_npy, write_meta, write_png


def read_llff(path: str | Path, downscale: int = 1) -> Dataset:
    """Read an LLFF folder (module docstring), its views ``downscale`` times smaller."""
    path, downscale = Path(path), check_downscale(downscale)
    file = path / "poses_bounds.npy"
    where = str(file)
    shape, dtype = npy_shape(file)
    if len(shape) != 2 or shape[1] != 17 or dtype.kind not in "uif" or not 1 <= shape[0] <= MAX_VIEWS:
        raise DataError(f"{where} holds a {shape} {dtype} array; LLFF's poses_bounds.npy is [N, 17] numbers (a 3 x 5 "
                        "pose and two depth bounds per image): regenerate it with LLFF's imgs2poses.py")
    rows = read_npy(file, shape, where, np.float64)
    n = len(rows)
    m, bounds = rows[:, :15].reshape(n, 3, 5), rows[:, 15:]
    sizes = {(integer(h, f"{where}: image height"), integer(w, f"{where}: image width")) for h, w in m[:, :2, 4]}
    if len(sizes) != 1:
        raise DataError(f"{where}: rows give different image sizes {sorted(sizes)[:3]}; LLFF's images share one size")
    H0, W0 = sizes.pop()
    focal = np.array([check_focal(f, W0, f"{where} (row {i})") for i, f in enumerate(m[:, 2, 4])])
    bad = np.flatnonzero(~((bounds[:, 0] > 0) & (bounds[:, 0] < bounds[:, 1])))
    if len(bad):
        raise DataError(f"{where}: image {bad[0]}'s depth bounds {bounds[bad[0]].tolist()} must satisfy "
                        "0 < near < far; regenerate the file")
    poses = np.zeros((n, 4, 4))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = m[:, :, 1], -m[:, :, 0], m[:, :, 2]
    poses[:, :3, 3], poses[:, 3, 3] = m[:, :, 3], 1.0
    check_poses(poses, where)
    folder, N = image_folder(path, downscale, str(path))
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if len(files) != n:
        raise DataError(f"{folder} holds {len(files)} images but {where} has {n} rows; LLFF pairs sorted image "
                        "names with rows: add or remove images")
    H, W = image_size(files[0])
    if abs(H * W0 / W - H0) > W0 / W:
        raise DataError(f"{folder}: images of {W} x {H} pixels are not {W0} x {H0} (the size in {file.name}) "
                        "scaled; use the images the poses were made from")
    box = max(1, downscale // N)          # downscale 1 may take a smaller folder (image_folder)
    cams = Cameras(poses, focal * W / W0, H, W, focal * H / H0)
    color, alpha = read_views(files, box, str(folder))
    cams = cams.downscaled(box) if box > 1 else cams
    return capture_dataset(path, "llff", Split(cams, color, alpha), hold_out(n, str(path)), N * box,
                           lambda: near_far(cams, bounds), bounds=bounds.tolist(), layout=layout(poses))


def write_llff(dataset: Dataset, folder: Path) -> None:
    """Write ``dataset`` (3D, pinhole views with square pixels and centred principal points) as an LLFF folder."""
    if dataset.dim != 3:
        raise DataError("the LLFF format holds 3D captures; use --format nerf2d or nerfstudio for 2D scenes")
    views = Split.concatenate(list(dataset.splits.values()))
    c = views.cameras
    if c.distortion is not None or np.any(c.fy != c.fx) or np.any(c.cx != c.width / 2) or np.any(c.cy != c.height / 2):
        raise DataError("the LLFF format holds pinhole views with square pixels and a centred principal point; "
                        "use --format colmap or nerfstudio")
    R, n = c.poses[:, :3, :3], len(c)
    hwf = np.c_[np.full(n, c.height), np.full(n, c.width), c.fx]
    m = np.stack([-R[..., 1], R[..., 0], R[..., 2], c.poses[:, :3, 3], hwf], -1)          # [n, 3, 5]
    np.save(folder / "poses_bounds.npy", np.c_[m.reshape(n, 15), depth_bounds(views, dataset.near, dataset.far)])
    (folder / "images").mkdir()
    for i, img in enumerate(views.target(dataset.background)):
        write_png(folder / "images" / f"{i:04d}.png", img)
    write_meta(folder, dataset, "llff")
