"""Camera poses compared across worlds: structure from motion recovers a capture up to a similarity (scale,
rotation, translation), so recovered cameras are aligned to the true ones before their errors are measured
(tests/test_poses.py; benchmarks/poses.py, results.json keys ``poses/fern``, ``poses/renders``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``(s, R, t)`` minimising ``sum |s R src_i + t - dst_i|^2`` over points ``src, dst [n, 3]`` (Umeyama's
    least-squares similarity; ``n >= 3`` points not on one line): the rotation of the centred points (Kabsch),
    then ``s = sum(dst_c . R src_c) / sum |src_c|^2`` and ``t = mean(dst) - s R mean(src)``."""
    src, dst = np.asarray(src, np.float64), np.asarray(dst, np.float64)
    a, b = src - src.mean(0), dst - dst.mean(0)
    R = Rotation.align_vectors(b, a)[0].as_matrix()
    s = float(np.sum(b * (a @ R.T)) / np.sum(a * a))
    return s, R, dst.mean(0) - s * R @ src.mean(0)


@dataclass
class PoseErrors:
    """How far recovered cameras lie from the true ones after the similarity that best maps their centres."""

    rotation: np.ndarray
    """``[n]`` degrees between each aligned camera's orientation and the true one."""
    position: np.ndarray
    """``[n]`` distance between each aligned camera centre and the true one, in the true world's units."""
    scale: float
    """The similarity's scale (true units per recovered unit)."""


def pose_errors(poses: np.ndarray, truth: np.ndarray) -> PoseErrors:
    """Errors of camera-to-world ``poses [n, 4, 4]`` against ``truth [n, 4, 4]`` (the same cameras in the same
    order, any one camera convention shared by both) after :func:`similarity` of their centres."""
    s, R, t = similarity(poses[:, :3, 3], truth[:, :3, 3])
    centres = poses[:, :3, 3] @ (s * R).T + t
    turn = np.einsum("nji,njk->nik", truth[:, :3, :3], R @ poses[:, :3, :3])        # R_true^T R_aligned
    return PoseErrors(np.degrees(Rotation.from_matrix(turn).magnitude()),
                      np.linalg.norm(centres - truth[:, :3, 3], axis=1), s)
