"""Scenes that are not an object in a box: NDC and the contraction against hand-worked values, the samples' spacing,
the frames derived from cameras, the rule that picks the scene (round trips through our LLFF and COLMAP exports),
parity of the warped grids with their torch twins, and the camera paths of videos."""

import numpy as np
import pytest

from mitnerf.data.dataset import Dataset
from mitnerf.data.formats import load_dataset, save_dataset
from mitnerf.data.formats.common import META
from mitnerf.reference.render.samplers import Stratified as TwinStratified
from mitnerf.reference.render.volume import TORCH
from mitnerf.render.space import Space, contract, ndc, pick_scene, scene_frame, to_s, to_t
from mitnerf.viz.paths import capture_poses, spiral_poses
from mitnerf.viz.video import read_video

NP = type(TORCH)(np.sqrt, lambda a, c: np.minimum(a, c), np.where)


def test_ndc_of_a_point_its_inverse_and_its_stretch():
    q, e = np.array([0.5, 0.25, -2.0]), np.array([0.0, 0.0, -1.0])
    x, s = ndc(list(q), list(e), NP)
    np.testing.assert_allclose(x, [0.25, 0.125, 0.0])          # -q_x / q_z, -q_y / q_z, 1 + 2 / q_z
    qz = 2.0 / (x[2] - 1.0)                                     # the inverse: q_z = 2 / (z' - 1) = -2
    np.testing.assert_allclose([-x[0] * qz, -x[1] * qz, qz], q)
    # d/dt of (x', y', z') along e: ((0.5 * -1) / 4, (0.25 * -1) / 4, 2 / 4) -> |.| = sqrt(0.26953125)
    assert s == pytest.approx(np.sqrt(0.26953125), rel=1e-12)     # 0.5191640
    h = 1e-6
    assert np.linalg.norm((np.array(ndc(list(q + h * e), list(e), NP)[0]) - x) / h) == pytest.approx(s, rel=1e-4)
    assert ndc([0, 0, -1.0], list(e), NP)[0][2] == -1.0         # the near plane
    assert ndc([0, 0, -1e9], list(e), NP)[0][2] == pytest.approx(1.0)     # infinity
    assert abs(ndc([0, 0, 0.5], list(e), NP)[0][2]) > 1         # behind the camera's plane: outside the box


def test_contraction_of_a_point_its_inverse_and_its_stretch():
    x, _ = contract([3.0, 0.0, 4.0], [0.0, 0.0, 1.0], NP)
    np.testing.assert_allclose(x, [1.08, 0.0, 1.44])            # (2 - 1/5) / 5 = 0.36 times (3, 0, 4)
    r = np.linalg.norm(x)
    assert r == pytest.approx(1.8) and 1 / (2 - r) == pytest.approx(5.0)     # the inverse: |q| = 1 / (2 - |x'|)
    assert contract([0.3, 0.4, 0.0], [0.0, 0.0, 2.0], NP)[0] == [0.3, 0.4, 0.0]
    assert contract([0.3, 0.4, 0.0], [0.0, 0.0, 2.0], NP)[1] == 2.0      # inside: the identity, |e|
    assert contract([3.0, 0.0, 4.0], [0.6, 0.0, 0.8], NP)[1] == pytest.approx(1 / 25)   # radial: 1 / |q|^2
    assert contract([3.0, 0.0, 4.0], [0.0, 1.0, 0.0], NP)[1] == pytest.approx(9 / 25)   # across: (2|q| - 1) / |q|^2
    q, e, h = np.array([1.5, -2.0, 0.7]), np.array([0.3, 0.5, -0.8]), 1e-6
    x, s = contract(list(q), list(e), NP)
    assert np.linalg.norm((np.array(contract(list(q + h * e), list(e), NP)[0]) - x) / h) == pytest.approx(s, rel=1e-4)
    far = contract([1e9, 0.0, 0.0], [1.0, 0.0, 0.0], NP)[0]
    assert far[0] == pytest.approx(2.0)                         # all of space inside the ball of radius 2


def test_samples_are_even_in_disparity_past_the_knee():
    t = lambda s, k: to_t(np.asarray(s, float), k, np.where)
    assert to_s(np.array(4.0), 2.0, np.where) == 3.0            # 2 k - k^2 / t = 4 - 1
    assert t(3.0, 2.0) == 4.0 and t(1.5, 2.0) == 1.5            # linear before the knee
    # knee = near = 1: s = 2 - 1 / t from 1 to ~2; bin centres s = 1.125, 1.375, 1.625, 1.875
    twin = TwinStratified(4, 0, jitter=False, knee=1.0).points(1, 1.0, 1e9)[0].numpy()[0]
    np.testing.assert_allclose(twin, [8 / 7, 1.6, 8 / 3, 8.0], rtol=1e-5)
    np.testing.assert_allclose(np.diff(1 / twin), -0.25, rtol=1e-4)    # disparities 0.875, 0.625, 0.375, 0.125
    # knee 2, near 1: s from 1 to ~4: centres 1.375 (linear), then 4 / (4 - s) for 2.125, 2.875, 3.625
    mixed = TwinStratified(4, 0, jitter=False, knee=2.0).points(1, 1.0, 1e9)[0].numpy()[0]
    np.testing.assert_allclose(mixed, [1.375, 32 / 15, 32 / 9, 32 / 3], rtol=1e-5)


def test_the_distortion_loss_is_taken_along_the_unit_spacing_coordinate():
    # knee 2, near 1, far 6: s(1) = 1, s(6) = 4 - 4 / 6 = 10 / 3; a sample from t = 1.5 (s 1.5) to t = 3
    # (s = 4 - 4 / 3 = 8 / 3) starts at (1.5 - 1) / (7 / 3) = 3 / 14 and spans (8 / 3 - 1.5) / (7 / 3) = 0.5
    one = lambda k, c: Space("forward", {"knee": k}).spacing(np.array([1.5 * c]), np.array([1.5 * c]),
                                                             np.array(1.0 * c), np.array(6.0 * c), np.where)
    np.testing.assert_allclose(np.ravel(one(2.0, 1.0)), [3 / 14, 0.5])
    # the same capture with poses ten times larger (COLMAP's scale is arbitrary): the same coordinates
    np.testing.assert_allclose(np.ravel(one(20.0, 10.0)), [3 / 14, 0.5])


def test_the_drjit_sampler_places_the_twins_samples():
    import drjit as dr
    from drjit.auto.ad import Float, UInt32

    from mitnerf.render.samplers import Stratified

    for knee in (None, 1.0, 2.0):
        t, delta = Stratified(16, UInt32(5), jitter=True, knee=knee).points(3, Float(1.0), Float(50.0))
        tt, dd = TwinStratified(16, 5, jitter=True, knee=knee).points(3, 1.0, 50.0)
        np.testing.assert_allclose(np.asarray(t), tt.numpy().ravel(), rtol=1e-5)
        np.testing.assert_allclose(np.asarray(delta), dd.numpy().ravel(), rtol=1e-4, atol=1e-5)
        assert dr.all(delta > 0)


def forward_capture(n: int = 9) -> Dataset:
    """``n`` opaque views of 16 x 12 pixels from cameras on a small grid, all looking down -z (every 8th a test
    view), with LLFF's depth bounds 2 to 5."""
    from mitnerf.data.cameras import Cameras
    from mitnerf.data.dataset import Split

    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, 0, 3], poses[:, 1, 3] = np.arange(n) % 3 * 0.2 - 0.2, np.arange(n) // 3 * 0.15 - 0.15
    rng = np.random.default_rng(2)
    views = Split(Cameras(poses, 14.0, 12, 16), rng.random((n, 12, 16, 3), np.float32), np.ones((n, 12, 16), np.float32))
    test = np.arange(n) % 8 == 0
    return Dataset({"train": views.subset(np.flatnonzero(~test)), "test": views.subset(np.flatnonzero(test))},
                   1.8, 5.5, {"bounds": [[2.0, 5.0]] * n})


@pytest.mark.parametrize("fmt", ["llff", "colmap"])
def test_the_layout_rule_picks_each_scene_for_our_exports(vase_small, tmp_path, fmt):
    assert pick_scene(vase_small)[0] == "object"                # our render: alpha, a known background
    back = load_dataset(save_dataset(vase_small, tmp_path / "ours", fmt))
    assert pick_scene(back)[0] == "object"                      # our provenance file names the background
    (tmp_path / "ours" / META).unlink()                          # a foreign capture: opaque views, no provenance
    assert pick_scene(load_dataset(tmp_path / "ours")) == (
        "unbounded", "the cameras look around a point, and the views have no alpha: a room lies behind it")
    save_dataset(forward_capture(), tmp_path / "fwd", fmt)
    assert pick_scene(load_dataset(tmp_path / "fwd"))[0] == "forward"


def test_the_frames_fit_the_cameras(vase_small):
    fwd = forward_capture()
    f = scene_frame(fwd, "forward")
    space = Space("forward", f)
    for split in fwd.splits.values():
        o, d = (a.reshape(-1, 3) for a in split.cameras.rays())
        for t in (f["near"] + 0.7, 4.0, 1e6):                   # every ray stays in the box once past the near plane
            x, s = space.warp(list((o + t * d).T), list(d.T), NP)
            assert np.abs(np.array(x)[:2]).max() <= 1 + 1e-9 and np.all(s > 0)
    m = np.array(f["matrix"])
    assert m[2, 2] == pytest.approx(1 / 1.8)                   # q_z in units of the near plane: 0.9 x bound 2
    assert f["near"] == pytest.approx(1.8) and f["far"] == 7.5 and f["bound"] == 1.0 and f["knee"] == f["near"]
    u = scene_frame(vase_small, "unbounded")
    m = np.array(u["matrix"])
    poses = np.concatenate([s.cameras.poses for s in vase_small.splits.values()])
    r = np.linalg.norm(poses[:, :3, 3] @ m[:, :3].T + m[:, 3], axis=1)
    assert np.median(r) == pytest.approx(2.0)                   # the inner ball reaches half-way to the cameras
    assert np.linalg.norm(m[:, 3]) < 0.05                        # looking at the vase at the origin
    assert u["bound"] == 2.0 and u["knee"] == pytest.approx(2 / m[0, 0])


@pytest.mark.parametrize("scene", ["unbounded", "forward"])
@pytest.mark.parametrize("field", ["grid", "hashlinear"])
def test_the_warped_grids_agree_with_their_torch_twins(field, scene):
    from mitnerf.reference.parity import check_parity

    p = check_parity(field, 3, rays=16, samples=12, fine=6, scene=scene)
    assert p.ok, (p.values, p.grads, p.fd)


def test_a_spiral_looks_at_its_focus():
    rng = np.random.default_rng(0)
    poses = np.tile(np.eye(4), (6, 1, 1))
    poses[:, :3, 3] = rng.normal(0, 0.3, (6, 3)) * [1, 1, 0.2]           # cameras spread in front of z < 0
    out = spiral_poses(poses, near=2.0, far=10.0, n=30)
    focus = 1 / (0.25 / 1.8 + 0.75 / 50)                                  # 0.9 near, 5 far
    target = np.array([0, 0, -focus]) + poses[:, :3, 3].mean(0)
    to_f = target - out[:, :3, 3]
    axis = -out[:, :3, 2]
    np.testing.assert_allclose(axis, to_f / np.linalg.norm(to_f, axis=1, keepdims=True), atol=1e-9)
    assert np.ptp(out[:, 0, 3]) > 0.2                                     # it moves


def test_a_capture_path_passes_through_the_cameras():
    rng = np.random.default_rng(1)
    ring = np.linspace(0, np.pi, 7)
    pos = np.stack([3 * np.cos(ring), 3 * np.sin(ring), rng.normal(0, 0.2, 7)], 1)
    from mitnerf.data.rig import look_at_3d

    poses = look_at_3d(pos, -pos)
    path = capture_poses(poses, 6 * 5 + 1)                                # 5 frames per gap
    np.testing.assert_allclose(path[::5], poses, atol=1e-9)
    steps = np.linalg.norm(np.diff(path[:, :3, 3], axis=0), axis=1)
    assert steps.max() < 2 * steps.min()                                  # smooth, no jumps
    rot = path[:, :3, :3]
    np.testing.assert_allclose(np.einsum("nij,nik->njk", rot, rot), np.tile(np.eye(3), (31, 1, 1)), atol=1e-9)


def test_fit_says_the_scene_it_picked_and_video_follows_it(vase_small, tmp_path, capsys):
    """`mitnerf fit` on a forward-facing LLFF export trains in NDC and says why in one line; `mitnerf video` then
    takes the spiral, and on an unbounded capture (our vase exported without its provenance) the capture's path."""
    from mitnerf.cli import main

    save_dataset(forward_capture(), tmp_path / "fwd", "llff")
    save_dataset(vase_small, tmp_path / "ring", "colmap")
    (tmp_path / "ring" / META).unlink()
    quick = ["--iters", "3", "--batch", "64", "--samples", "8", "--no-figures", "--no-progress"]
    for data, scene, path in (("fwd", "forward-facing, rendered in NDC (every camera looks within 30 degrees",
                               "path: a spiral in front of the capture (the run is of a forward-facing scene"),
                              ("ring", "unbounded, in mip-NeRF 360's contracted space (the cameras look around",
                               "path: along the capture's own camera path (the run is of an unbounded scene")):
        rc = main(["fit", "--data", str(tmp_path / data), "--out", str(tmp_path / f"{data}-run"), *quick])
        out = capsys.readouterr().out
        assert rc == 0 or rc == 1 and "[collapsed: " in out          # 3 steps may learn nothing; the run is kept
        assert f"scene: {scene}" in out and "; --scene-type chooses)" in out
        assert main(["video", "--checkpoint", str(tmp_path / f"{data}-run"), "--out", str(tmp_path / f"{data}-video"),
                     "--frames", "3", "--image-size", "8"]) == 0
        out = capsys.readouterr().out
        assert path in out and "mesh" not in out                    # no mesh of a warped space
        assert read_video(tmp_path / f"{data}-video" / "color.gif").shape[1] == (6 if data == "fwd" else 8)  # 4:3
    main(["fit", "--data", str(tmp_path / "fwd"), "--scene-type", "object", "--out", str(tmp_path / "obj"), *quick])
    assert "scene: an object in a box (--scene-type object; --scene-type chooses)" in capsys.readouterr().out


def test_the_occupancy_sampler_follows_rays_out_of_the_world_box_in_contracted_space():
    """Contracted space: every world point lands inside the ball of radius 2, so a fresh grid (all cells occupied)
    over [-2, 2]^3 holds every bin of a ray from the origin to distance 100, though the ray leaves the world box
    [-2, 2]^3 at distance 2 (16 bins even in the spacing past the knee at 1: all 16 occupied, 8 samples of two
    bins each), and the Dr.Jit sampler places the twin's samples."""
    import torch
    from drjit.auto.ad import Float, UInt32

    from mitnerf.reference.render.occupancy import OccupancyGrid as TwinGrid, occupied_samples
    from mitnerf.render.occupancy import OccupancyConfig, OccupancyGrid, OccupiedSampler

    space = Space("unbounded", dict(matrix=np.eye(3, 4).tolist(), bound=2.0, near=0.5, far=100.0, knee=1.0))
    cfg = OccupancyConfig(enabled=True, resolution=4, march_bins=16)
    grid = OccupancyGrid(cfg, 3, bound=2.0)
    o, d = [Float([0.0]), Float([0.0]), Float([0.0])], [Float([1.0]), Float([0.0]), Float([0.0])]
    got = OccupiedSampler(*grid.lookup, 8, 16, 2.0, 4, UInt32(3), jitter=False, space=space).build(o, d, 0.5, 100.0)
    assert np.asarray(got.count).tolist() == [8]
    twin = occupied_samples(TwinGrid(cfg, 3, 2.0), torch.zeros(1, 3), torch.tensor([[1.0, 0.0, 0.0]]), 0.5, 100.0,
                            8, 3, False, space)
    np.testing.assert_allclose(np.asarray(got.t_flat), twin.t.numpy().ravel(), rtol=1e-5)
    assert np.asarray(got.delta_flat).sum() == pytest.approx(99.5, rel=1e-4)   # far - near: the whole ray
    # early stop in the warped space, the field's density 1 there stretched per unit of distance as rendered (by
    # 1 / t^2 past the knee): optical depth 0.5 + (1 - 1 / t) from near 0.5, which reaches -ln 0.3 = 1.20 at
    # t = 3.3 (unstretched, at t = 1.7): the samples end in the bin around 3.3, in both engines alike
    got = OccupiedSampler(*grid.lookup, 8, 16, 2.0, 4, UInt32(3), jitter=False, space=space, early_stop=0.3,
                          density=lambda x: 1.0 + 0.0 * x[0]).build(o, d, 0.5, 100.0)
    twin = occupied_samples(TwinGrid(cfg, 3, 2.0), torch.zeros(1, 3), torch.tensor([[1.0, 0.0, 0.0]]), 0.5, 100.0,
                            8, 3, False, space, density=lambda x: torch.ones(x.shape[0]), early_stop=0.3)
    ends = (np.asarray(got.t_flat) + np.asarray(got.delta_flat))[np.asarray(got.delta_flat) > 0]
    assert 3.3 < ends.max() < 10.0
    np.testing.assert_allclose(np.asarray(got.t_flat), twin.t.numpy().ravel(), rtol=1e-5)
    np.testing.assert_allclose(np.asarray(got.delta_flat), twin.delta.numpy().ravel(), rtol=1e-5)
