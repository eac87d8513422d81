"""Space carving along the rays: how far matter may go on behind each measured depth."""

import numpy as np
import pytest

from mitnerf.data.cameras import Cameras
from mitnerf.data.carve import carved, pixel_of, solid_extent


def facing_pair(focal: float = 1000.0) -> Cameras:
    """Two 2D cameras of 3 pixels on the x axis, 4 apart, looking at each other: A at (-2, 0) looks along +x,
    B at (2, 0) along -x (turned half a circle)."""
    A = [[1, 0, -2], [0, 1, 0], [0, 0, 1]]
    B = [[-1, 0, 2], [0, -1, 0], [0, 0, 1]]
    return Cameras(np.array([A, B], float), focal, 3)


def test_a_thin_wall_is_as_thick_as_the_views_allow():
    # a wall 0.22 thick (0 <= x <= 0.22) between the cameras; the centre rays (pixel 1) go along the x axis:
    # A measures 2.0 (its front face), B 1.78 (the back face, seen from B). Points behind A's depth lie at
    # x = 0.05 k (reach 0.5, 10 samples); B knows x > 0.22 to be empty (nearer to B than 1.78): x = 0.25 is the
    # first carved point, so the extent is 0.2, the last sample before it; B's ray: 0.2 as well (A carves x < 0).
    cams = facing_pair()
    depth = np.array([[2.0, 2.0, 2.0], [1.78, 1.78, 1.78]])[..., None]  # the off-axis rays: within 1e-6 of it
    hit = np.ones(depth.shape, bool)
    ext = solid_extent(cams, *cams.rays(), depth, hit, depth, reach=0.5, samples=10)
    assert ext[:, 1, 0] == pytest.approx([0.2, 0.2])
    # with a margin of 0.1, B's emptiness starts at x > 0.32: the extent grows to 0.3
    wider = solid_extent(cams, *cams.rays(), depth, hit, depth, reach=0.5, samples=10, margin=0.1)
    assert wider[0, 1, 0] == pytest.approx(0.3)
    # a view that knows nothing (free 0) carves nothing: the reach
    unknown = depth.copy()
    unknown[1] = 0.0
    assert solid_extent(cams, *cams.rays(), depth, hit, unknown, reach=0.5, samples=10)[0, 1, 0] == pytest.approx(0.5)
    # a ray without a depth has no extent
    assert solid_extent(cams, *cams.rays(), depth, ~hit, depth, reach=0.5, samples=10).max() == 0.0


def test_a_point_behind_a_camera_or_off_its_image_is_not_carved():
    cams = facing_pair()
    free = np.full((2, 3, 1), 10.0)          # both views: empty up to 10
    # (0, 5): beside both cameras' narrow views; (-3, 0): behind A, in front of B at 5 < 10
    assert carved(cams, free, np.array([[0.0, 5.0], [-3.0, 0.0]])).tolist() == [False, True]
    row, _, inside = pixel_of(cams, np.array([[-3.0, 0.0]]))
    assert inside[:, 0].tolist() == [False, True] and row[1, 0] == 1


@pytest.mark.parametrize("dim", [2, 3])
def test_a_point_on_a_pixels_ray_projects_into_that_pixel(dim):
    rng = np.random.default_rng(dim)
    if dim == 2:
        a = rng.uniform(0, 2 * np.pi)
        c, s = np.cos(a), np.sin(a)
        pose = [[c, -s, -3 * c], [s, c, -3 * s], [0, 0, 1]]          # at -3 (c, s), looking at the origin
        cams = Cameras(np.array([pose]), 40.0, 16)
    else:
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = q * np.sign(np.linalg.det(q)), rng.normal(size=3)
        cams = Cameras(pose[None], 30.0, 12, 20)
    o, d = cams.rays()
    H, W = cams.height, cams.width
    rows, cols = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    points = (o[0] + 2.5 * d[0]).reshape(-1, dim)
    row, col, inside = pixel_of(cams, points)
    assert inside.all()
    np.testing.assert_array_equal(row[0], rows.ravel())
    np.testing.assert_array_equal(col[0], cols.ravel())
    if dim == 2:                             # the same pixel as Cameras.project
        np.testing.assert_array_equal(row[0], np.floor(cams.project(points)[0][0]))


def test_training_rays_carry_their_extent(bunny_small):
    split = bunny_small["train"]
    rays = split.rays((0, 0, 0), solid_reach=0.3, margin=0.01)
    rays = rays.batch(np.arange(len(rays)))
    hit = rays.hit > 0
    assert (rays.solid[~hit] == 0).all()
    assert (rays.solid[hit] <= 0.3 + 1e-6).all() and np.median(rays.solid[hit]) == pytest.approx(0.3)
    assert (rays.solid[hit] < 0.3).any()     # some rays leave the bunny's back (its ears) within the reach
    assert split.rays((0, 0, 0)).solid is None      # not asked for: none


def test_many_rays_are_carved_by_a_subset_of_the_views(bunny_small, monkeypatch):
    # a budget for 8 of the 12 views at 16 samples: those 8 carve, so an extent can only be longer, never shorter
    import mitnerf.data.carve as carve
    split = bunny_small["train"]
    hit = np.isfinite(split.depth)
    args = (split.cameras, *split.cameras.rays(), split.depth, hit, split.depth)      # free: the depth itself
    full = carve.solid_extent(*args, reach=0.3)
    monkeypatch.setattr(carve, "MAX_TESTS", int(hit.sum()) * 16 * 8)
    fewer = carve.solid_extent(*args, reach=0.3)
    assert (fewer >= full).all() and (fewer > full).any()


def test_a_split_carves_once_per_reach(bunny_small, monkeypatch):
    import mitnerf.data.dataset as dataset
    calls = []
    monkeypatch.setattr(dataset, "solid_extent", lambda *a, **k: calls.append(a[-1]) or np.zeros(a[3].shape))
    split = dataset.Split(**{f: getattr(bunny_small["train"], f)
                             for f in ("cameras", "color", "alpha", "depth", "mask", "linear")})
    for reach in (0.2, 0.2, 0.3):
        split.rays((0, 0, 0), solid_reach=reach)
    assert calls == [0.2, 0.3]
