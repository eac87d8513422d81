"""IDR / NeuS captures (the layout in which DTU is shared)::

    DIR/cameras_sphere.npz   world_mat_i (K [R | t] of image i as 4 x 4: world to pixels) and scale_mat_i (4 x 4:
                             the unit sphere around the object to the world), i = 0 .. N-1 (IDR: cameras.npz)
    DIR/image/ (or images/)  the photographs, paired with i in sorted name order
    DIR/mask/ (optional)     one mask per image in sorted order, white where the object is

Reading: ``P = world_mat @ scale_mat`` maps the sphere's coordinates to pixels, so mitnerf's world is that
normalised one (the object inside the unit sphere). scipy's RQ decomposition of P's 3 x 3 part gives K (positive
focal lengths) and the rotation, P's null space the centre. IDR and NeuS cast pixel ``(v, u)``'s ray through
``K^-1 (u, v, 1)`` (pixel centres at whole coordinates), so mitnerf's principal point is K's plus half a pixel.
A skewed K (more than :data:`MAX_SKEW` pixels of shift across the image) is refused. A mask is its view's alpha
(the colour premultiplied by it), so training can put its own background behind the object. Every 8th image is
a test view; near and far bound the unit sphere seen from the cameras; ``meta['scale_mat']`` is image 0's.

Writing (``--format idr``, pinhole views without lens distortion): ``scale_mat = diag(r, r, r, 1)`` with ``r``
the dataset's bound / 1.1 (1 for mitnerf's renders, whose objects lie inside the unit sphere), the views as
``image/000000.png`` (the colour where alpha > 0, the background elsewhere) and ``mask/000000.png`` (8-bit alpha).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.linalg import rq

from ...errors import DataError
from ..cameras import Cameras
from ..dataset import Dataset, Split, bounds_from_cameras
from .capture import IMAGE_SUFFIXES, capture_dataset, check_downscale, check_intrinsics, hold_out, read_views
from .colmap import FLIP
from .common import check_poses, npz_shapes, read_npz, view_size, write_meta, write_png

CAMERA_FILES = ("cameras_sphere.npz", "cameras.npz")
MAX_SKEW = 0.05
"""Pixels: the most K's skew may shift a pixel across the image's height (mitnerf's cameras have none)."""


def camera_file(root: Path) -> Path | None:
    return next((root / n for n in CAMERA_FILES if (root / n).is_file()), None)


def _views(root: Path, names: tuple[str, ...]) -> list[Path] | None:
    folder = next((root / n for n in names if (root / n).is_dir()), None)
    return None if folder is None else sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)


def read_idr(path: str | Path, downscale: int = 1) -> Dataset:
    """Read an IDR / NeuS folder (module docstring), its views ``downscale`` times smaller."""
    path, downscale = Path(path), check_downscale(downscale)
    file = camera_file(path)
    if file is None:
        raise DataError(f"{path} has no cameras_sphere.npz (nor cameras.npz); point at an IDR / NeuS capture")
    where = str(file)
    images = _views(path, ("image", "images"))
    if not images:
        raise DataError(f"{path} has no images in image/ (nor images/); add the photographs")
    n = len(images)
    shapes = npz_shapes(file)
    for i in range(n):
        for key in (f"world_mat_{i}", f"scale_mat_{i}"):
            shape, dtype = shapes.get(key, (None, None))
            if shape is None:
                raise DataError(f"{where} lacks {key!r} for image {i} of {n} ({images[i].name}); image/ and the "
                                "camera file must describe the same views")
            if shape not in ((4, 4), (3, 4)) or dtype.kind not in "uif":
                raise DataError(f"{where}: {key!r} is a {shape} {dtype} array, expected 4 x 4 numbers")
    if f"world_mat_{n}" in shapes:
        raise DataError(f"{where} holds more cameras than the {n} images in {images[0].parent}; add the images "
                        "or drop the cameras")
    data = read_npz(file, keys=[f"{k}_{i}" for i in range(n) for k in ("world_mat", "scale_mat")])
    cams = [_camera(data[f"world_mat_{i}"], data[f"scale_mat_{i}"], f"{where}: image {i}") for i in range(n)]
    K, poses = np.array([c[0] for c in cams]), np.array([c[1] for c in cams])
    check_poses(poses, where)
    H, W = view_size(images, str(images[0].parent), downscale)
    skew = np.abs(K[:, 0, 1]) * H / K[:, 1, 1]
    if skew.max() > MAX_SKEW:
        raise DataError(f"{where}: image {int(skew.argmax())}'s K has a skew shifting pixels by {skew.max():.3g} px "
                        "across the image, which mitnerf's cameras do not model; resample the images without skew")
    fx, fy, cx, cy = K[:, 0, 0], K[:, 1, 1], K[:, 0, 2] + 0.5, K[:, 1, 2] + 0.5
    check_intrinsics(fx, fy, cx, cy, W, H, where)
    masks = _views(path, ("mask", "masks"))
    if masks is not None and len(masks) != n:
        raise DataError(f"{path}'s mask folder holds {len(masks)} masks for {n} images; masks pair with images in "
                        "sorted order: one each")
    color, alpha = read_views(images, downscale, str(images[0].parent), masks, size=(H, W))
    cameras = Cameras(poses, fx, H, W, fy, cx, cy)
    cameras = cameras.downscaled(downscale) if downscale > 1 else cameras
    return capture_dataset(path, "idr", Split(cameras, color, alpha), hold_out(n, str(path)), downscale,
                           lambda: bounds_from_cameras([cameras], 1.0, 0.0), scale_mat=data["scale_mat_0"].tolist(),
                           masks=masks is not None)


def _camera(world: np.ndarray, scale: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``(K [3, 3], OpenGL camera-to-world [4, 4])`` of one image's matrices."""
    world, scale = world.astype(np.float64), scale.astype(np.float64)
    if not (np.isfinite(world).all() and np.isfinite(scale).all()):
        raise DataError(f"{where}: world_mat or scale_mat holds NaN or infinity; fix the camera file")
    S = scale[:3, :3]
    if scale.shape != (4, 4) or not (S[0, 0] > 0 and np.allclose(S, S[0, 0] * np.eye(3), atol=1e-6 * S[0, 0])
                                     and np.allclose(scale[3], [0, 0, 0, 1])):
        raise DataError(f"{where}: scale_mat must be a uniform positive scale and a translation (4 x 4); fix the "
                        "camera file")
    P = (np.r_[world[:3], [[0, 0, 0, 1]]] @ scale)[:3]
    M = P[:, :3]
    d = np.linalg.det(M)
    if not abs(d) > 1e-12 * max(1.0, np.abs(M).max()) ** 3:
        raise DataError(f"{where}: world_mat is degenerate (its 3 x 3 part has no inverse); fix the camera file")
    if d < 0:                                     # P is defined up to scale: keep the rotation proper
        P, M = -P, -M
    K, R = rq(M)
    D = np.diag(np.sign(np.diag(K)))
    K, R = K @ D, D @ R
    M_ = np.eye(4)
    M_[:3, :3], M_[:3, 3] = R.T, -np.linalg.solve(M, P[:, 3])
    return K / K[2, 2], M_ @ FLIP


def write_idr(dataset: Dataset, folder: Path) -> None:
    """Write ``dataset`` (3D, no lens distortion) as an IDR / NeuS folder with masks (module docstring)."""
    if dataset.dim != 3:
        raise DataError("the IDR format holds 3D captures; use --format nerf2d or nerfstudio for 2D scenes")
    views = Split.concatenate(list(dataset.splits.values()))
    c = views.cameras
    if c.distortion is not None:
        raise DataError("the IDR format holds pinhole views without lens distortion; use --format colmap")
    r = dataset.bound / 1.1
    mats = {}
    for i, M in enumerate(c.poses @ FLIP):
        R = M[:3, :3].T
        K = np.array([[c.fx[i], 0, c.cx[i] - 0.5], [0, c.fy[i], c.cy[i] - 0.5], [0, 0, 1]])
        mats[f"world_mat_{i}"] = np.r_[K @ np.c_[R, -R @ M[:3, 3]], [[0, 0, 0, 1]]]
        mats[f"scale_mat_{i}"] = np.diag([r, r, r, 1.0])
    np.savez(folder / "cameras_sphere.npz", **mats)
    (folder / "image").mkdir()
    (folder / "mask").mkdir()
    a = views.alpha[..., None]
    straight = np.where(a > 0, views.color / np.maximum(a, 1e-8), np.asarray(dataset.background, np.float32))
    for i in range(len(c)):
        write_png(folder / "image" / f"{i:06d}.png", straight[i])
        write_png(folder / "mask" / f"{i:06d}.png", views.alpha[i])
    write_meta(folder, Dataset(dataset.splits, dataset.near / r, dataset.far / r, dataset.meta), "idr")
