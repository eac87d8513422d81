"""Datasets: round trips in every format, the NeRF2D convention, rig statistics, determinism."""

import json

import numpy as np
import pytest

from mitnerf.data.color import to_uint8
from mitnerf.data.formats import load_dataset, read_tiny_nerf, save_dataset
from mitnerf.data.rig import RigConfig, make_rig
from mitnerf.scenes.polygon import Polygon


def assert_same(a, b, depth=True):
    for s in a.splits:
        x, y = a[s], b[s]
        for u, v in zip(x.cameras.rays(), y.cameras.rays()):
            np.testing.assert_array_equal(u, v)
        np.testing.assert_array_equal(x.target(a.background), y.target(a.background))
        if depth:
            np.testing.assert_array_equal(x.depth, y.depth)
            np.testing.assert_array_equal(x.mask, y.mask)


def test_nerf2d_round_trip(bunny_small, tmp_path):
    save_dataset(bunny_small, tmp_path / "ds")
    back = load_dataset(tmp_path / "ds")
    assert_same(bunny_small, back)
    assert (back.near, back.far) == (bunny_small.near, bunny_small.far)


def test_blender_round_trip(vase_small, tmp_path):
    save_dataset(vase_small, tmp_path / "ds")
    assert (tmp_path / "ds" / "transforms_train.json").exists()
    assert_same(vase_small, load_dataset(tmp_path / "ds"))


@pytest.mark.parametrize("ds_name", ["bunny_small", "vase_small"])
def test_nerfstudio_round_trip(ds_name, request, tmp_path):
    """The nerfstudio layout holds 2D and 3D datasets: rays, colours, depth (written as
    nerfstudio's z-depth in thousandths) and masks come back."""
    ds = request.getfixturevalue(ds_name)
    save_dataset(ds, tmp_path / "ns", "nerfstudio")
    header = json.loads((tmp_path / "ns" / "transforms.json").read_text())
    assert {"fl_x", "fl_y", "cx", "cy", "w", "h"} <= set(header) and header["orientation_override"] == "none"
    assert header["frames"][0]["file_path"].endswith(".png") and "depth_file_path" in header["frames"][0]
    back = load_dataset(tmp_path / "ns")
    assert back.dim == ds.dim and back.meta["format"] == "nerfstudio"
    for s in ds.splits:
        for u, v in zip(ds[s].cameras.rays(), back[s].cameras.rays()):
            np.testing.assert_allclose(u, v, atol=1e-9)
        np.testing.assert_allclose(back[s].color, ds[s].color, atol=1.0 / 255)       # 8-bit straight alpha
        np.testing.assert_array_equal(back[s].mask, ds[s].mask)
        hit = ds[s].mask
        np.testing.assert_allclose(back[s].depth[hit], ds[s].depth[hit], rtol=1e-5)


def test_tiny_nerf_round_trip(vase_small, tmp_path):
    save_dataset(vase_small, tmp_path / "tiny.npz", "tiny_nerf")
    back = read_tiny_nerf(tmp_path / "tiny.npz")
    for s in ("train", "val", "test"):
        for u, v in zip(vase_small[s].cameras.rays(), back[s].cameras.rays()):
            np.testing.assert_allclose(u, v, atol=1e-6)          # poses are stored as float32
        np.testing.assert_array_equal(back[s].color, vase_small[s].target(vase_small.background))


def hit_points(split):
    o, d = split.cameras.rays()
    hit = np.isfinite(split.depth)
    return (o + split.depth[..., None] * d)[hit]


def test_rays_from_a_nerf2d_folder_hit_the_outline(bunny_small, tmp_path):
    """The stored convention (row 0 towards camera +y) puts every hit point of every
    view on one outline; flipping the rows breaks it."""
    save_dataset(bunny_small, tmp_path / "ds")
    back = load_dataset(tmp_path / "ds")
    poly = Polygon.from_points(back.meta["polygon"])
    for split in back.splits.values():
        o, d = split.cameras.rays()
        ref = poly.intersect(o.reshape(-1, 2), d.reshape(-1, 2)).reshape(split.depth.shape)
        np.testing.assert_allclose(split.depth[split.mask], ref[split.mask], atol=1e-4)
    pts = np.concatenate([hit_points(s) for s in back.splits.values()])
    dist = distance_to_outline(pts, poly)
    assert np.median(dist) < 1e-5 and dist.max() < 1e-4
    flipped = back["train"]
    wrong = flipped.depth[:, ::-1]
    o, d = flipped.cameras.rays()
    bad = (o + np.where(np.isfinite(wrong), wrong, 0)[..., None] * d)[np.isfinite(wrong)]
    assert np.median(distance_to_outline(bad, poly)) > 1e-2


def distance_to_outline(p, poly):
    a, b = poly.edges
    ab = b - a
    t = np.clip(np.einsum("mnk,nk->mn", p[:, None] - a[None], ab) / (ab ** 2).sum(1), 0, 1)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None] - closest, axis=-1).min(1)


def test_an_addon_style_nerf2d_folder_loads(bunny_small, tmp_path):
    """The original add-on writes focal as an int, RGBA PNGs and npz files with only
    depth_map and intrinsic_mat (plus camera_info.json), and no mitnerf.json."""
    import imageio.v3 as iio

    root = tmp_path / "addon"
    for name in ("train", "val", "test"):
        split = bunny_small[name]
        d = root / name
        d.mkdir(parents=True)
        frames = [{"transform_matrix": p.tolist()} for p in split.cameras.poses]
        (d / "transforms.json").write_text(json.dumps({"focal": 100, "frames": frames}))
        (d / "camera_info.json").write_text(json.dumps({"img_res_x": 1, "img_res_y": 100}))
        for i in range(len(split)):
            rgba = np.concatenate([split.color[i], np.ones_like(split.alpha[i])[..., None]], -1)
            iio.imwrite(d / f"cam-{i}.png", to_uint8(rgba))
            depth = np.where(split.mask[i], split.depth[i], -1.0)
            K = np.array([[100.0, 0, 0], [0, 100.0, 49.5], [0, 0, 1]])
            np.savez(d / f"cam-{i}.npz", depth_map=depth, intrinsic_mat=K)
    back = load_dataset(root)
    assert back.meta["format"] == "nerf2d" and "near" not in back.meta
    np.testing.assert_array_equal(back["train"].mask, bunny_small["train"].mask)
    np.testing.assert_allclose(back["train"].color, bunny_small["train"].color, atol=0.5 / 255 + 1e-6)
    assert 0 < back.near < bunny_small.near + 0.1 and back.far > 4.0
    poly = Polygon.from_points(bunny_small.meta["polygon"])
    assert np.median(distance_to_outline(hit_points(back["train"]), poly)) < 1e-4


def angles_2d(cams):
    o = cams.origins
    fwd = cams.poses[:, :2, 0]
    look = np.arctan2(fwd[:, 1], fwd[:, 0]) - np.arctan2(-o[:, 1], -o[:, 0])
    return np.linalg.norm(o, axis=1), (look + np.pi) % (2 * np.pi) - np.pi


def test_2d_noise_has_the_requested_statistics():
    cfg = RigConfig(dim=2, n_train=20000, n_val=0, n_test=16, radius_std=0.2, look_std=3.0, seed=5)
    rig = make_rig(cfg)
    r, look = angles_2d(rig.train)
    assert np.mean(r) == pytest.approx(4.0, abs=0.01) and np.std(r) == pytest.approx(0.2, rel=0.03)
    assert np.degrees(np.std(look)) == pytest.approx(3.0, rel=0.03)
    jit = make_rig(RigConfig(dim=2, n_train=20000, n_val=0, n_test=0, position_std=0.05, seed=5)).train
    assert np.std(np.linalg.norm(jit.origins, axis=1) - 4.0) == pytest.approx(0.05, rel=0.03)
    even = make_rig(RigConfig(dim=2, n_train=20000, n_val=0, n_test=0, layout="even", angle_std=2.0, seed=5)).train
    az = np.arctan2(even.origins[:, 1], even.origins[:, 0])
    base = np.arctan2(*np.mean([np.sin(az - 2 * np.pi * np.arange(20000) / 20000),
                                np.cos(az - 2 * np.pi * np.arange(20000) / 20000)], axis=1))
    dev = (az - 2 * np.pi * np.arange(20000) / 20000 - base + np.pi) % (2 * np.pi) - np.pi
    assert np.degrees(np.std(dev)) == pytest.approx(2.0, rel=0.03)
    # test views: evenly spaced, on the circle, looking at the origin
    r, look = angles_2d(rig.test)
    np.testing.assert_allclose(r, 4.0)
    np.testing.assert_allclose(look, 0.0, atol=1e-12)
    az = np.unwrap(np.arctan2(rig.test.origins[:, 1], rig.test.origins[:, 0]))
    np.testing.assert_allclose(np.diff(az), 2 * np.pi / 16)


def test_3d_noise_and_the_test_orbit():
    rig = make_rig(RigConfig(dim=3, n_train=20000, n_val=0, n_test=12, radius_std=0.1, look_std=2.0, seed=1))
    r = np.linalg.norm(rig.train.origins, axis=1)
    assert np.std(r) == pytest.approx(0.1, rel=0.03)
    assert (rig.train.origins[:, 2] > -0.3).all()                      # upper hemisphere (+ noise)
    fwd = -rig.train.poses[:, :3, 2]
    ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", fwd, -rig.train.origins / r[:, None]), -1, 1)))
    # yaw and pitch are each N(0, 2 deg): the total angle is Rayleigh with mean 2 * sqrt(pi/2)
    assert np.mean(ang) == pytest.approx(2.0 * np.sqrt(np.pi / 2), rel=0.03)
    t = rig.test
    np.testing.assert_allclose(np.linalg.norm(t.origins, axis=1), 3.5)
    np.testing.assert_allclose(np.degrees(np.arcsin(t.origins[:, 2] / 3.5)), 25.0)
    centre_ray = -t.poses[:, :3, 2]
    np.testing.assert_allclose(np.cross(centre_ray, -t.origins), 0, atol=1e-12)   # they look at the origin


def test_same_seed_same_bytes(tmp_path):
    from mitnerf.cli import main

    for k in (1, 2):
        assert main(["dataset", "--scene", "square", "--out", str(tmp_path / f"d{k}"), "--views", "5",
                     "--val", "2", "--test", "3", "--seed", "11"]) == 0
    files = sorted(p.relative_to(tmp_path / "d1") for p in (tmp_path / "d1").rglob("*")
                   if p.is_file() and p.name != ".mitnerf")          # the marker names each output by its own id
    assert len(files) > 20
    for f in files:
        assert (tmp_path / "d1" / f).read_bytes() == (tmp_path / "d2" / f).read_bytes(), f
    assert main(["dataset", "--scene", "square", "--out", str(tmp_path / "d3"), "--views", "5",
                 "--val", "2", "--test", "3", "--seed", "12"]) == 0
    assert (tmp_path / "d3/train/cam-0.npz").read_bytes() != (tmp_path / "d1/train/cam-0.npz").read_bytes()


def test_show_writes_strips_and_rig(bunny_small, vase_small, tmp_path):
    from mitnerf.cli import main

    for name, ds in (("bunny", bunny_small), ("vase", vase_small)):
        save_dataset(ds, tmp_path / name)
        assert main(["show", str(tmp_path / name), "--out", str(tmp_path / "figures" / name)]) == 0
        figs = {p.name for p in (tmp_path / "figures" / name).iterdir()}
        assert {"train_views.png", "val_views.png", "test_views.png", "rig.png"} <= figs
    import imageio.v3 as iio

    for name in ("bunny", "vase"):
        for png in (tmp_path / "figures" / name).glob("*.png"):
            assert max(iio.imread(png).shape[:2]) <= 4096, png               # a picture a person opens


def test_the_cache_renders_again_when_a_default_look_changes(tmp_path, monkeypatch):
    """``square_glossy`` names no roughness: a new default must not be served the old render."""
    from mitnerf.data.cache import cached_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.scenes import looks

    monkeypatch.setenv("MITNERF_CACHE", str(tmp_path))
    rig = RigConfig(dim=2, n_train=2, n_val=1, n_test=1, resolution=16, seed=0)
    first = cached_dataset("square_glossy", rig)
    again = cached_dataset("square_glossy", rig)
    np.testing.assert_array_equal(first["train"].color, again["train"].color)           # served from the cache
    monkeypatch.setitem(looks.ROUGHNESS, "roughplastic", 0.6)
    broad = cached_dataset("square_glossy", rig)
    assert len(list((tmp_path / "datasets").iterdir())) == 2
    assert not np.array_equal(first["train"].color, broad["train"].color)
