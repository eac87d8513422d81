"""The lens model and the general pinhole camera: distortion against its formula, its inverse, off-centre
principal points and per-frame intrinsics through rays, footprints and project."""

import numpy as np
import pytest

from mitnerf.data.cameras import Cameras
from mitnerf.data.lens import distort, fold_radius, jacobian, undistort
from mitnerf.data.rig import look_at_3d
from mitnerf.errors import MitnerfError

K = np.array([0.1, 0.01, 0.001, 0.002, 0.0001])          # k1, k2, p1, p2, k3


def test_distort_follows_the_formula():
    # (x, y) = (0.3, -0.2): r² = 0.13, q = 1 + 0.1 * 0.13 + 0.01 * 0.0169 + 0.0001 * 0.002197 = 1.0131692197
    # x_d = 0.3 q + 2 * 0.001 * 0.3 * (-0.2) + 0.002 * (0.13 + 2 * 0.09) = 0.30395076591 - 0.00012 + 0.00062
    # y_d = -0.2 q + 0.001 * (0.13 + 2 * 0.04) + 2 * 0.002 * 0.3 * (-0.2) = -0.20263384394 + 0.00021 - 0.00024
    np.testing.assert_allclose(distort(np.array([0.3, -0.2]), K), [0.30445076591, -0.20266384394], atol=1e-12)
    np.testing.assert_array_equal(distort(np.array([0.3, -0.2]), np.zeros(5)), [0.3, -0.2])   # no lens: identity


def test_undistort_inverts_distort_to_1e_9_pixels():
    xy = np.stack(np.meshgrid(np.linspace(-0.6, 0.6, 25), np.linspace(-0.4, 0.4, 17)), -1)
    for k in (K, [-0.3, 0.05, 0.0, 0.0, 0.0], [0.0578421, -0.0805099, -0.000980296, 0.00015575, 0.0]):  # fox's lens
        k = np.asarray(k)
        back = undistort(distort(xy, k), k, tol=1e-9 / 1000)            # 1e-9 px at a focal length of 1000 px
        assert np.abs(back - xy).max() < 1e-11
        np.testing.assert_allclose(distort(back, k), distort(xy, k), atol=1e-12)


def test_jacobian_matches_finite_differences():
    xy, eps = np.array([0.3, -0.2]), 1e-6
    fd = np.stack([(distort(xy + e, K) - distort(xy - e, K)) / (2 * eps) for e in np.eye(2) * eps], -1)
    np.testing.assert_allclose(jacobian(xy, K), fd, atol=1e-8)


def test_fold_radius_and_a_point_beyond_it():
    # k1 = -0.3 alone: d(r q)/dr = 1 + 3 k1 r² = 0 at r² = 1/0.9, r = 1.0540925534
    assert fold_radius([-0.3, 0, 0, 0, 0]) == pytest.approx(1.0540925534)
    assert fold_radius(K) == np.inf                               # positive coefficients never fold
    # k1 = -1: r = 1/sqrt(3) shows at r q = (1/sqrt(3)) (2/3) = 0.385 at most: nothing shows at 0.5
    with pytest.raises(MitnerfError, match="cannot be inverted"):
        undistort(np.array([0.5, 0.0]), np.array([-1.0, 0, 0, 0, 0]))


def test_an_off_centre_principal_point_and_non_square_pixels_set_the_rays():
    cams = Cameras(np.eye(4)[None], 10.0, 4, 6, fy=20.0, cx=4.0, cy=2.0)
    _, d = cams.rays()
    # pixel (row 1, column 5): x = (5.5 - 4) / 10 = 0.15, y = (1.5 - 2) / 20 = -0.025 -> [0.15, 0.025, -1]
    np.testing.assert_allclose(d[0, 1, 5], np.array([0.15, 0.025, -1]) / np.linalg.norm([0.15, 0.025, -1]))
    assert not cams.simple
    with pytest.raises(MitnerfError, match="one focal length"):
        cams.focal


def test_rays_turn_with_the_pose_and_the_directions_alone_skip_the_footprint():
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]                  # 90 degrees about y: camera -z -> world -x
    pose[:3, 3] = [1.0, 2.0, 3.0]
    cams = Cameras(pose[None], 10.0, 4, 6, fy=20.0, cx=4.0, cy=2.0)
    o, d = cams.rays()
    # pixel (row 1, column 5) looks along [0.15, 0.025, -1] in camera space (the test above): [-1, 0.025, -0.15] here
    np.testing.assert_allclose(d[0, 1, 5], np.array([-1, 0.025, -0.15]) / np.linalg.norm([0.15, 0.025, -1]))
    np.testing.assert_array_equal(o[0, 1, 5], [1.0, 2.0, 3.0])
    group, local, extent = cams.local_rays(steps=False)
    assert extent is None
    np.testing.assert_array_equal(local, cams.local_rays()[1])


def test_2d_cameras_keep_their_rays():
    # H = 4, f = 2: row 0 looks along [2, 2 - 0.5] / 2.5 = [0.8, 0.6]; row 3 along [0.8, -0.6]
    _, d = Cameras(np.eye(3)[None], 2.0, 4).rays()
    np.testing.assert_allclose(d[0, [0, 3], 0], [[0.8, 0.6], [0.8, -0.6]], atol=1e-15)
    with pytest.raises(MitnerfError, match="no lens distortion"):
        Cameras(np.eye(3)[None], 2.0, 4, distortion=K)


def rig(n=3, H=12, W=16):
    """Per-frame intrinsics and lenses, cameras looking at the origin."""
    pos = np.array([[3.0, 0.5, 1.0], [-2.0, 2.5, 0.5], [0.5, -3.0, -1.0]])[:n]
    k = np.array([K, [-0.2, 0.03, 0.0, 0.001, 0.0], [0.0578421, -0.0805099, -0.000980296, 0.00015575, 0.0]])[:n]
    return Cameras(look_at_3d(pos, -pos), [14.0, 15.0, 16.0][:n], H, W, [13.0, 15.5, 16.0][:n], [8.5, 7.0, 8.0][:n],
                   [5.5, 6.5, 6.0][:n], k)


def test_project_takes_rays_back_to_their_pixels():
    cams = rig()
    o, d = cams.rays()
    for i in range(len(cams)):
        pts = (o[i] + 2.0 * d[i]).reshape(-1, 3)
        pixel, fwd = cams.project(pts)
        v, u = np.meshgrid(np.arange(cams.height) + 0.5, np.arange(cams.width) + 0.5, indexing="ij")
        np.testing.assert_allclose(pixel[i], np.stack([v, u], -1).reshape(-1, 2), atol=1e-6)
        assert (fwd[i] > 0).all()
    behind = cams.project(cams.origins[:1] - 5 * (cams.poses[0, :3, 2] * -1))[0]      # behind camera 0
    assert np.isnan(behind[0]).all()


def test_the_footprint_follows_the_lens():
    """Moving half a pixel along a column changes the ray as the footprint's step says: shifting the principal
    point by -eps moves every pixel by +eps."""
    cams, eps = rig(1), 1e-4
    _, d = cams.rays()
    s = cams.footprint()[0, ..., 0, :]                                      # [H, W, 3] column step
    shifted = lambda c: Cameras(cams.poses, cams.fx, cams.height, cams.width, cams.fy, c, cams.cy, cams.distortion)
    fd = (shifted(cams.cx - eps).rays()[1] - shifted(cams.cx + eps).rays()[1])[0] / (2 * eps)
    tangent = s - d[0] * (d[0] * s).sum(-1, keepdims=True)              # d/da normalize(d + a s) at a = 0
    np.testing.assert_allclose(fd, tangent, atol=1e-6)


def test_downscaled_cameras_see_the_blocks_centres():
    cams = rig()
    small = cams.downscaled(2)                            # 6 x 8 pixels; pixel (v, u) is the block (2v..2v+1, 2u..2u+1)
    o, d = small.rays()
    pts = (o + d).reshape(len(cams), -1, 3)
    for i in range(len(cams)):
        big = cams.subset([i]).project(pts[i])[0][0]
        v, u = np.meshgrid(np.arange(6) * 2 + 1.0, np.arange(8) * 2 + 1.0, indexing="ij")      # block centres
        np.testing.assert_allclose(big, np.stack([v, u], -1).reshape(-1, 2), atol=1e-6)


def test_subsets_and_concatenation_keep_each_frames_intrinsics():
    cams = rig()
    joined = Cameras.concatenate([cams.subset([2]), cams.subset([0, 1])])
    np.testing.assert_array_equal(joined.intrinsics, cams.intrinsics[[2, 0, 1]])
    np.testing.assert_array_equal(joined.rays()[1], cams.rays()[1][[2, 0, 1]])
