"""Camera paths for videos that fit the scene: a turn-table orbit around an object (:func:`~.video.orbit_cameras`),
a spiral in front of a forward-facing capture (as LLFF renders its scenes) and a path along an unbounded capture
(its training cameras, smoothly interpolated in the order they were taken). :func:`path_cameras` picks one from the
scene a run was fitted in (``--path auto``).

The spiral circles the capture's average camera (:func:`~mitnerf.render.space.average_pose`) twice in its image
plane, with radii the 90th percentile of the cameras' offsets from it along each of its axes, moving along its view
axis at half that rate, and always looks at the focus point straight ahead of it: at the depth whose disparity is
``0.25 / (0.9 near) + 0.75 / (5 far)`` of the capture's depth bounds (LLFF's choice). The capture path passes
through every training camera: positions by a cubic spline, orientations by a rotation spline
(:class:`scipy.spatial.transform.RotationSpline`), both over the frame index.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

from ..data.cameras import Cameras
from ..data.rig import look_at_3d
from ..errors import MitnerfError
from ..render.space import average_pose

PATHS = ("orbit", "spiral", "capture")
PATH_OF = {"object": "orbit", "forward": "spiral", "unbounded": "capture"}
"""The path ``--path auto`` takes for each scene."""


def spiral_poses(poses: np.ndarray, near: float, far: float, n: int, turns: float = 2.0) -> np.ndarray:
    """``n`` OpenGL poses ``[n, 4, 4]`` on the spiral in front of a forward-facing capture of ``poses [m, 4, 4]`` whose
    depths lie in ``[near, far]`` (module docstring)."""
    ref = average_pose(poses)
    R, c = ref[:3, :3], ref[:3, 3]
    radii = np.percentile(np.abs((poses[:, :3, 3] - c) @ R), 90, axis=0)          # along right, up, back
    focus = 1.0 / (0.25 / (0.9 * near) + 0.75 / (5.0 * far))
    theta = 2 * np.pi * turns * np.arange(n) / n
    local = np.stack([np.cos(theta), -np.sin(theta), -np.sin(0.5 * theta)], 1) * radii
    pos = c + local @ R.T
    target = c - focus * R[:, 2]
    return look_at_3d(pos, target - pos, up=R[:, 1])


def capture_poses(poses: np.ndarray, n: int) -> np.ndarray:
    """``n`` OpenGL poses ``[n, 4, 4]`` along the capture ``poses [m, 4, 4]`` (in the order taken), evenly spaced in
    the frame index: frame ``k`` is camera ``k (m - 1) / (n - 1)`` where that is whole."""
    if len(poses) < 2:
        raise MitnerfError("a path along the capture needs at least 2 training cameras; pass --path orbit")
    u, at = np.arange(len(poses), dtype=np.float64), np.linspace(0, len(poses) - 1, n)
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, 3] = CubicSpline(u, poses[:, :3, 3])(at)
    out[:, :3, :3] = RotationSpline(u, Rotation.from_matrix(poses[:, :3, :3]))(at).as_matrix()
    return out


def path_cameras(kind: str, capture: dict, n: int, width: int, near: float, far: float) -> Cameras:
    """``n`` cameras of ``width`` pixels on the ``spiral`` or ``capture`` path of a capture ``{'poses' [m, 4, 4],
    'focal' (fx, fy), 'size' (W, H)}``, its aspect and field of view kept."""
    poses = np.asarray(capture["poses"], np.float64)
    W, H = capture["size"]
    scale = width / W
    path = spiral_poses(poses, near, far, n) if kind == "spiral" else capture_poses(poses, n)
    return Cameras(path, capture["focal"][0] * scale, max(2, round(H * scale)), width, capture["focal"][1] * scale)
