"""Scenes that are not an object in a box: the space the fields live in, and how samples are spaced along a ray.

A scene is one of :data:`SCENES`:

* ``object``: an object in the box ``[-bound, bound]^3`` of world space (our renders, data with alpha or masks);
  samples linear in distance.
* ``forward``: a forward-facing capture (LLFF's fern) in normalised device coordinates, as NeRF renders its LLFF
  scenes: ``q = A x + b`` puts the world in the frame of the capture's average camera (looking down -z), with
  depth in units of the near plane ``n = 0.75 x`` the nearest depth bound (NeRF scales the nearest bound to
  ``1 / 0.75``) and ``x, y`` scaled so every camera's rays stay inside ``|x'|, |y'| <= 1``; then
  ``x' = -q_x / q_z, y' = -q_y / q_z, z' = 1 + 2 / q_z``: the frustum from the near plane to infinity fills
  ``[-1, 1]^3``. Samples are spaced linearly in disparity (``1 / t``), which is linear in ``z'``, from the near plane
  to 1.5 x the farthest depth bound.
* ``unbounded``: a room around the object (instant-ngp's fox): ``q = (x - c) / r`` with ``c`` the point the cameras
  look at and ``r`` half their median distance from it (what they look at lies nearer that point than they stand,
  so the inner ball's lattice goes to it, and most cameras stand in the shell), then mip-NeRF 360's contraction
  ``x' = q`` for ``|q| <= 1``, ``(2 - 1 / |q|) q / |q|`` beyond: all of space fills the ball of radius 2. Samples
  are linear in distance up to the knee ``2 r`` (the cameras' median distance from the point they look at) and
  linear in disparity beyond, as nerfacc and nerfstudio place them.

The fields see ``x'`` (their box ``[-bound, bound]^3`` is the warped space: 1 for NDC, 2 for the contraction); the
volume integral stays in world distance along unit directions, with the field's density, which is per unit of
warped length, multiplied by the warp's stretch ``|J(x) d|`` (the optical depth ``sigma' ds' = sigma' |J d| dt``
is the same in both spaces). View directions, depth outputs and evaluation are therefore those of world space. The
warps are written once for Dr.Jit arrays and torch tensors (lists of components; ``ops`` gives the three functions
that differ); :mod:`mitnerf.reference.render.volume` uses them with torch's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import numpy as np

from ..data.dataset import Dataset
from ..data.formats.capture import FORWARD_CONE, focus_point, layout
from ..errors import ConfigError

SCENES = ("object", "forward", "unbounded")
NEAR_SCALE, FAR_SCALE = 0.9, 1.5
"""The NDC near plane as a share of the nearest depth bound, and the samples' far end as a multiple of the farthest
(the bounds come from the sparse points LLFF and COLMAP saw)."""
EPS = 1e-6
INNER = 0.5
"""The inner ball's radius in an unbounded scene, as a share of the cameras' median distance from their focus."""


@dataclass(frozen=True)
class Ops:
    """What the warps need beyond arithmetic: ``sqrt``, ``clamp_max(a, c)``, ``select(cond, a, b)``."""

    sqrt: object
    clamp_max: object
    select: object


DRJIT = Ops(dr.sqrt, dr.minimum, dr.select)


def ndc(q: list, e: list, ops: Ops) -> tuple[list, object]:
    """``q`` (3 components, the frame of the reference camera, the near plane at ``q_z = -1``) -> NDC, and the
    stretch ``|dx'/dt|`` along ``e`` (``dq/dt``). Points at or behind the camera's plane land outside the box."""
    qz = ops.clamp_max(q[2], -EPS)
    inv = 1.0 / qz
    x = [-q[0] * inv, -q[1] * inv, 1.0 + 2.0 * inv]
    inv2 = inv * inv
    dx = [(q[0] * e[2] - e[0] * qz) * inv2, (q[1] * e[2] - e[1] * qz) * inv2, -2.0 * e[2] * inv2]
    return x, ops.sqrt(dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2])


def contract(q: list, e: list, ops: Ops) -> tuple[list, object]:
    """mip-NeRF 360's contraction of ``q`` (3 components) and its stretch ``|J e|``: inside the unit ball the
    identity (``|e|``); outside, ``J`` scales the radial part of ``e`` by ``1 / |q|^2`` and the rest by
    ``(2 |q| - 1) / |q|^2``."""
    r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2]
    e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
    inside = r2 <= 1.0
    r2 = ops.select(inside, 1.0, r2)
    r = ops.sqrt(r2)
    scale = ops.select(inside, 1.0, (2.0 * r - 1.0) / r2)
    radial = (q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) / r
    across = ops.select(inside, e2, e2 - radial * radial)
    across = ops.select(across > 0.0, across, 0.0)
    stretch = ops.sqrt(scale * scale * across + ops.select(inside, 0.0, radial * radial / (r2 * r2)))
    return [qi * scale for qi in q], stretch


@dataclass(frozen=True)
class Space:
    """A scene's space, from a render configuration's ``scene`` and ``frame`` (:func:`scene_frame`)."""

    kind: str = "object"
    frame: dict | None = None

    @property
    def warped(self) -> bool:
        return self.kind != "object"

    @property
    def knee(self) -> float | None:
        """Distance along a ray where samples turn from linear to linear in disparity (None: linear throughout)."""
        return self.frame["knee"] if self.warped else None

    def spacing(self, t, delta, near, far, select) -> tuple:
        """Samples' ``t`` and ``delta`` (world distances, any engine's arrays) along the distortion loss's coordinate:
        in a warped scene the spacing coordinate (:func:`to_s`) normalised to [0, 1] over ``[near, far]``, where
        mip-NeRF 360 takes it (its world units are whatever its poses' were, COLMAP's scale, so a loss in them would
        weigh differently on every capture); in an object scene world distance, which the data's bound normalises.
        ``select``: ``dr.select`` or ``torch.where``."""
        if not self.warped:
            return t, delta
        k = self.knee
        lo, hi = (to_s(v, k, select) for v in (near, far))
        s0, s1 = to_s(t, k, select), to_s(t + delta, k, select)
        scale = 1.0 / (hi - lo)
        return (s0 - lo) * scale, (s1 - s0) * scale

    def warp(self, x: list, d: list, ops: Ops) -> tuple[list, object]:
        """World points and directions (3 components each) -> the field's points and the density stretch."""
        m = self.frame["matrix"]
        q = [m[i][0] * x[0] + m[i][1] * x[1] + m[i][2] * x[2] + m[i][3] for i in range(3)]
        e = [m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2] for i in range(3)]
        return (ndc if self.kind == "forward" else contract)(q, e, ops)


def to_s(t, knee: float, select):
    """Distance -> spacing coordinate: ``t`` before the knee ``k``, ``2 k - k^2 / t`` after (continuous, with a
    continuous slope; uniform steps in it are linear in disparity past the knee)."""
    return select(t < knee, t, 2.0 * knee - knee * knee / t)


def to_t(s, knee: float, select):
    """The inverse of :func:`to_s`."""
    return select(s < knee, s, knee * knee / (2.0 * knee - s))


def pick_scene(dataset: Dataset) -> tuple[str, str]:
    """``(scene, why)``: ``object`` for 2D data, views with alpha or masks, or data that names its background (our
    renders, tiny-NeRF); else ``forward`` when every camera looks within 30 degrees of their mean view axis
    (``meta['layout']``, else :func:`~mitnerf.data.formats.capture.layout`), ``unbounded`` when they look around."""
    if dataset.dim == 2:
        return "object", "2D data"
    splits = dataset.splits.values()
    if any(s.mask is not None or s.has_alpha for s in splits):
        return "object", "its views have alpha (the object is separated from its background)"
    if "background" in dataset.meta or "kind" in dataset.meta:
        return "object", "the views show an object over a known background"
    poses = np.concatenate([s.cameras.poses for s in splits])
    if dataset.meta.get("layout", layout(poses)) == "forward":
        return "forward", f"every camera looks within {FORWARD_CONE:g} degrees of the cameras' mean view axis"
    return "unbounded", "the cameras look around a point, and the views have no alpha: a room lies behind it"


def average_pose(poses: np.ndarray) -> np.ndarray:
    """The mean camera of OpenGL poses ``[n, 4, 4]``: the centres' mean, the view axes' mean direction and the up
    vectors' mean made orthogonal to it -> ``[4, 4]``."""
    back = poses[:, :3, 2].sum(0)
    back /= np.linalg.norm(back)
    right = np.cross(poses[:, :3, 1].sum(0), back)
    right /= np.linalg.norm(right)
    out = np.eye(4)
    out[:3, 0], out[:3, 1], out[:3, 2], out[:3, 3] = right, np.cross(back, right), back, poses[:, :3, 3].mean(0)
    return out


def edge_rays(dataset: Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Origins and unit directions ``[m, 3]`` of every camera's border pixels (the extremes of its frustum)."""
    os, ds = [], []
    for s in dataset.splits.values():
        c = s.cameras
        group, local, _ = c.local_rays(steps=False)                    # camera space, per group of intrinsics
        border = np.zeros((c.height, c.width), bool)
        border[[0, -1], :] = border[:, [0, -1]] = True
        ds.append(np.einsum("nij,nbj->nbi", c.poses[:, :3, :3], local[:, border][group]).reshape(-1, 3))
        os.append(np.repeat(c.origins, int(border.sum()), axis=0))
    return np.concatenate(os), np.concatenate(ds)


def scene_frame(dataset: Dataset, kind: str) -> dict:
    """The ``frame`` of a ``forward`` or ``unbounded`` scene (module docstring) from all the dataset's cameras (poses
    only): ``matrix`` (3 x 4, world -> the frame), ``bound`` (the fields' half-extent there), ``near``, ``far`` (world
    distances along the rays) and ``knee`` (:func:`to_s`)."""
    poses = np.concatenate([s.cameras.poses for s in dataset.splits.values()])
    o, d = edge_rays(dataset)
    if kind == "forward":
        ref = average_pose(poses)
        bounds = np.asarray(dataset.meta.get("bounds", [[dataset.near, dataset.far]]), np.float64)
        n = NEAR_SCALE * float(bounds[:, 0].min())
        A, c = ref[:3, :3].T / n, ref[:3, 3]
        q_cam = (poses[:, :3, 3] - c) @ A.T                             # the camera centres in the frame
        q, e = (o - c) @ A.T, d @ A.T
        ahead = e[:, 2] < -EPS
        if not ahead.any():
            raise ConfigError("no camera looks along the capture's mean view axis: not a forward-facing scene; "
                              "pass --scene-type unbounded")
        q, e = q[ahead], e[ahead]
        t = np.maximum((-1.0 - q[:, 2]) / e[:, 2], 0.0)              # where each ray crosses the near plane
        p = q + t[:, None] * e
        extent = np.maximum(np.abs(p[:, :2] / -p[:, 2:]).max(0), np.abs(e[:, :2] / e[:, 2:]).max(0))
        A = np.diag([1 / extent[0], 1 / extent[1], 1.0]) @ A
        near = n * max(float((1.0 + q_cam[:, 2]).min()), 0.05)     # the nearest crossing: along the axis
        far_bound = float(bounds[:, 1].max())
        frame = dict(bound=1.0, near=near, far=max(FAR_SCALE * far_bound, 2.0 * near), knee=near)
    elif kind == "unbounded":
        c = focus_point(poses)
        r = INNER * float(np.median(np.linalg.norm(poses[:, :3, 3] - c, axis=1)))
        if not r > 0:
            raise ConfigError("the cameras all stand at one point: an unbounded scene needs cameras that move")
        A = np.eye(3) / r
        frame = dict(bound=2.0, near=0.02 * r, far=1e4 * r, knee=2.0 * r)
    else:
        raise ConfigError(f"scene {kind!r} has no frame; choose one of {', '.join(SCENES[1:])}")
    return dict(matrix=np.c_[A, -A @ c].tolist(), **frame)


def check_frame(frame: dict) -> None:
    """Refuse a frame that is not :func:`scene_frame`'s shape (a hand-edited ``--set frame=...``)."""
    try:
        m = np.asarray(frame["matrix"], np.float64)
        values = [float(frame[k]) for k in ("bound", "near", "far", "knee")]
        ok = m.shape == (3, 4) and np.isfinite(m).all() and all(math.isfinite(v) and v > 0 for v in values) \
            and values[1] < values[2]
    except (KeyError, TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError("frame must hold matrix (3 x 4 numbers), bound, near < far and knee (positive numbers); "
                          "leave it out to derive it from the cameras")
