"""Geometry: marching-cubes meshes of density fields, PLY export, Chamfer distances."""

import numpy as np
import pytest

from mitnerf.errors import MitnerfError
from mitnerf.geometry import (Mesh, auto_level, chamfer_distance, density_volume, extract_mesh, level_for_opacity,
                              mesh_from_ply, sample_surface)
from mitnerf.scenes.ply import read_ply

R0 = 0.5          # sphere radius
BOUND = 0.6       # grid cube [-0.6, 0.6]^3
RES = 32          # grid spacing h = 1.2 / 31 = 0.0387


def smooth_sphere(points):
    """100 deep inside, 0 far outside, exactly 50 on the sphere |x| = 0.5 (a 0.05 wide tanh step)."""
    return 50.0 * (1.0 + np.tanh((R0 - np.linalg.norm(points, axis=1)) / 0.05))


def step_sphere(points):
    """100 inside the sphere, 0 outside."""
    return np.where(np.linalg.norm(points, axis=1) < R0, 100.0, 0.0)


def pv_sphere(center=(0.0, 0.0, 0.0)):
    import pyvista as pv

    return pv.Sphere(radius=R0, center=center, theta_resolution=120, phi_resolution=120)


@pytest.fixture(scope="module")
def sphere_mesh():
    return extract_mesh(smooth_sphere, BOUND, RES, level=50.0, progress=False)


def test_sphere_field_meshes_to_the_sphere(sphere_mesh):
    m, h = sphere_mesh, 2 * BOUND / (RES - 1)
    assert m.info["spacing"] == pytest.approx(h)
    # Linear interpolation along grid edges of a field that is nearly linear across the surface:
    # vertices sit within ~h^2 / (8 R0) = 4e-4 of the sphere (measured 7e-4); allow h / 20 = 1.9e-3.
    r = np.linalg.norm(m.vertices, axis=1)
    assert np.abs(r - R0).max() < h / 20
    # outward winding: positive signed volume, 4/3 pi 0.5^3 = 0.5236 (the inscribed mesh is a bit smaller)
    assert m.volume == pytest.approx(4 / 3 * np.pi * R0 ** 3, rel=0.01)
    # The Chamfer distance to an analytic sphere mesh is the sampling floor of two samplings of the
    # same surface (0.5 sqrt(pi / 1e5) = 2.8e-3) plus the mesh error: allow h / 10 = 3.9e-3 above it.
    c = chamfer_distance(m, pv_sphere(), n_points=100_000, seed=0)
    same = chamfer_distance(pv_sphere(), pv_sphere(), n_points=100_000, seed=0)
    assert same.chamfer == pytest.approx(same.floor, rel=0.1)
    assert c.chamfer - same.chamfer < h / 10, (c, same)


def test_translated_sphere_is_half_the_shift_away():
    """Two spheres of radius r, centres t apart. A point r n on one is | |r n - t| - r | from the
    other; for t << r that is |t . n|, whose mean over the sphere is t / 2. For r = 0.5, t = 0.1 the
    exact mean (1D integral over cos(angle) in [-1, 1]) is 0.0500 as well."""
    from scipy.integrate import quad

    t = 0.1
    exact = quad(lambda u: abs(np.sqrt(R0 ** 2 + t ** 2 - 2 * R0 * t * u) - R0) / 2, -1, 1)[0]
    assert exact == pytest.approx(t / 2, abs=1e-3)
    c = chamfer_distance(pv_sphere(), pv_sphere((t, 0.0, 0.0)), n_points=50_000, seed=1)
    for value in (c.chamfer, c.a_to_b, c.b_to_a):                # symmetric situation
        assert value == pytest.approx(exact, abs=0.003)           # 0.003: about the sampling floor


def test_one_sided_distances_say_which_mesh_has_extra_parts():
    import pyvista as pv

    a = pv_sphere()
    b = a + pv.Sphere(radius=0.1, center=(3.0, 0.0, 0.0))        # B = A plus a far blob
    c = chamfer_distance(a, b, n_points=20_000, seed=0)
    # every point of A lies on B: a_to_b is the sampling floor; the blob's samples (area 0.126 of
    # 3.27, ~3.8 %) are ~2.5 from A, so b_to_a ~ 0.038 * 2.5 = 0.096
    assert c.a_to_b < 0.01
    assert 0.07 < c.b_to_a < 0.12
    assert c.chamfer == pytest.approx((c.a_to_b + c.b_to_a) / 2)
    again = chamfer_distance(a, b, n_points=20_000, seed=0)
    assert again == c                                             # seeded: same numbers


def test_surface_samples_are_uniform_by_area():
    # a unit square (2 triangles) and a far tiny triangle of area 0.005: ~0.5 % of samples
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 5], [5.1, 5, 5], [5, 5.1, 5]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    p = sample_surface((v, f), 40_000, np.random.default_rng(0))
    far = p[:, 0] > 4
    assert far.mean() == pytest.approx(0.005 / 1.005, abs=0.0015)
    near = p[~far]
    assert np.all((near >= 0) & (near <= 1)) and np.allclose(near[:, 2], 0)
    assert near[:, 0].mean() == pytest.approx(0.5, abs=0.01)     # uniform over the square
    assert near[:, 1].mean() == pytest.approx(0.5, abs=0.01)


def test_mesh_export_reloads(sphere_mesh, tmp_path):
    import pyvista as pv

    path = sphere_mesh.save(tmp_path / "sphere.ply")
    ply = read_ply(path)
    np.testing.assert_allclose(ply["vertices"], sphere_mesh.vertices, atol=1e-6)   # float32 in the file
    np.testing.assert_array_equal(ply["faces"], sphere_mesh.faces)
    back = mesh_from_ply(path)
    assert back.volume == pytest.approx(sphere_mesh.volume, rel=1e-5)
    vtk_mesh = pv.read(str(path))
    assert vtk_mesh.n_points == len(sphere_mesh.vertices) and vtk_mesh.n_cells == len(sphere_mesh.faces)
    np.testing.assert_allclose(vtk_mesh.points, sphere_mesh.vertices, atol=1e-6)


def test_offset_center_and_closing_at_the_cube_faces():
    # a slab |z| < 0.2 fills the cube side to side: closing caps it at x, y = +-0.6 (a box 1.2 x 1.2 x 0.4)
    def slab(p):
        return np.where(np.abs(p[:, 2] - 1.0) < 0.2, 100.0, 0.0)

    m = extract_mesh(slab, BOUND, 25, level=50.0, center=(0.0, 0.0, 1.0), progress=False)
    h = 2 * BOUND / 24
    # a 0/100 step puts the surface half-way between nodes: the box grows by up to h/2 per side
    assert m.vertices[:, 2].min() == pytest.approx(0.8, abs=h) and m.vertices[:, 2].max() == pytest.approx(1.2, abs=h)
    assert m.volume == pytest.approx(1.2 * 1.2 * 0.4, rel=0.25)
    open_ = extract_mesh(slab, BOUND, 25, level=50.0, center=(0.0, 0.0, 1.0), progress=False, close=False)
    assert len(open_.faces) < len(m.faces)                        # the two caps are missing


def test_no_surface_names_the_density_span():
    with pytest.raises(MitnerfError, match=r"no surface at density level 200.*below it.*span \[0, 100\]"):
        extract_mesh(step_sphere, BOUND, 16, level=200.0, progress=False)
    with pytest.raises(MitnerfError, match="no matter"):
        auto_level(np.full((4, 4, 4), 3.0))
    with pytest.raises(MitnerfError, match="NaN"):
        density_volume(lambda p: np.full(len(p), np.nan), 1.0, 4, progress=False)
    with pytest.raises(MitnerfError, match="returned 8 values"):
        density_volume(lambda p: np.zeros(8), 1.0, 4, progress=False)


def test_auto_level_separates_haze_from_matter():
    def hazy(p):
        return 0.01 + 100.0 / (1.0 + np.exp((np.linalg.norm(p, axis=1) - R0) / 0.01))

    # log10 densities: ~70 % of the cube at -2 (haze), ~30 % at 2 (matter): Otsu splits near 0
    m = extract_mesh(hazy, BOUND, RES, level="auto", progress=False)
    assert 0.1 < m.level < 10.0
    # the surface is where the density equals the level: |x| = R0 + 0.01 ln(100 / (level - 0.01) - 1).
    # The density changes on a 0.01 scale, 4x finer than the grid (h = 0.039): interpolating it
    # linearly along cell edges pushes the surface out by up to ~h / 4 (measured 0.005 = 0.13 h);
    # a level 10x off would move it by 0.023 = 0.6 h.
    expected = R0 + 0.01 * np.log(100.0 / (m.level - 0.01) - 1.0)
    assert np.linalg.norm(m.vertices, axis=1).mean() == pytest.approx(expected, abs=2 * BOUND / (RES - 1) / 4)
    assert auto_level(step_sphere(np.random.default_rng(0).uniform(-1, 1, (1000, 3)))) == 50.0   # 0/100: half
    # ln 2 / 0.03 = 23.1: half the light stops within one sample spacing of our 3D rigs
    assert level_for_opacity(0.5, 0.03) == pytest.approx(23.105, abs=1e-3)


def test_mesh_of_a_trained_checkpoint(vase_small, tmp_path):
    from conftest import small

    from mitnerf.train.checkpoint import load_checkpoint, save_checkpoint
    from mitnerf.train.fit import fit

    run = fit(vase_small, small("vanilla-3d", width=16, depth=2, n_coarse=16, n_fine=0, iters=20), "drjit")
    save_checkpoint(run, tmp_path / "ckpt")
    density = load_checkpoint(tmp_path / "ckpt")[0].backend.density
    g = density_volume(density, run.bound, 16, progress=False)
    np.testing.assert_allclose(g[3, 5, 7], density(np.array([[-1.1 + 3 * 2.2 / 15, -1.1 + 5 * 2.2 / 15,
                                                              -1.1 + 7 * 2.2 / 15]]))[0], rtol=1e-5)
    m = extract_mesh(density, run.bound, 16, level="auto", progress=False)
    assert isinstance(m, Mesh) and len(m.faces) > 0
    assert np.abs(m.vertices).max() <= run.bound + 2.2 / 15 + 1e-6      # inside the cube (+ the closing layer)
