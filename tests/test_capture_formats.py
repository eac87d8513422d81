"""Real-capture formats: LLFF, COLMAP (text and binary), IDR / NeuS, and instant-ngp / nerfstudio
transforms.json with lenses; round trips through our writers, hand-made files, downscaling, the held-out
test views, absent frames, and the real fern and fox (skipped with one line when /work/shared/data is absent)."""

import warnings

from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, small

from mitnerf.cli import main
from mitnerf.data.cameras import Cameras
from mitnerf.data.color import display_color
from mitnerf.data.dataset import Dataset, Split
from mitnerf.data.formats import detect_format, load_dataset, save_dataset
from mitnerf.data.formats.colmap import write_colmap
from mitnerf.errors import DataError, Note
from mitnerf.train.fit import fit_and_evaluate

DATA = ROOT.parent / "shared" / "data"
if not DATA.is_dir():
    DATA = Path("/work/shared/data")


def all_views(ds: Dataset) -> Split:
    return Split.concatenate(list(ds.splits.values()))


def held_out(n: int) -> dict:
    """Every 8th view is a test view (NeRF's LLFF protocol), the rest train."""
    return {"train": [i for i in range(n) if i % 8], "test": list(range(0, n, 8))}


def save(ds: Dataset, out: Path, fmt: str) -> Path:
    if fmt == "colmap-binary":
        out.mkdir()
        write_colmap(ds, out, binary=True)
        return out
    return save_dataset(ds, out, fmt)


def assert_same_views(ds: Dataset, back: Dataset, atol_color: float) -> None:
    """``back`` holds ``ds``'s views in order, every 8th a test view: the same rays within 1e-5."""
    src = all_views(ds)
    o0, d0 = src.cameras.rays()
    target = src.target(ds.background)
    assert set(back.splits) == {"train", "test"}                # no validation split: never validate on test
    for name, idx in held_out(len(src)).items():
        o, d = back[name].cameras.rays()
        np.testing.assert_allclose(o, o0[idx], atol=1e-5)
        np.testing.assert_allclose(d, d0[idx], atol=1e-5)
        np.testing.assert_allclose(back[name].target(back.background), target[idx], atol=atol_color)


@pytest.mark.parametrize("fmt", ["llff", "colmap", "colmap-binary", "idr"])
def test_round_trip_through_our_writer(vase_small, tmp_path, fmt):
    back = load_dataset(save(vase_small, tmp_path / "ds", fmt))
    assert back.meta["format"] == fmt.split("-")[0] and detect_format(tmp_path / "ds") == fmt.split("-")[0]
    assert_same_views(vase_small, back, 1.5 / 255)              # 8-bit images
    assert (back.near, back.far) == (vase_small.near, vase_small.far)          # our mitnerf.json keeps them
    if fmt == "idr":                                            # the mask is the alpha: the background comes off
        src = all_views(vase_small)
        np.testing.assert_allclose(back["test"].alpha, src.alpha[::8], atol=0.5 / 255)


@pytest.mark.parametrize("fmt", ["llff", "colmap"])
def test_bounds_come_from_the_depth_maps_or_the_points(vase_small, tmp_path, fmt):
    """Without our mitnerf.json: LLFF's bounds (from the depth maps) and COLMAP's points bound every hit."""
    out = save(vase_small, tmp_path / "ds", fmt)
    (out / "mitnerf.json").unlink()
    back = load_dataset(out)
    assert np.array(back.meta["bounds"]).shape == (11, 2) and back.meta["layout"] == "around"
    hits = np.concatenate([s.depth[np.isfinite(s.depth)] for s in vase_small.splits.values()])
    assert back.near <= hits.min() and back.far >= hits.max()


def with_lenses(ds: Dataset) -> Dataset:
    """``ds`` with per-frame intrinsics and lenses (the images stay: only the rays are compared)."""
    out = {}
    for name, s in ds.splits.items():
        c, n = s.cameras, len(s)
        k = np.c_[np.linspace(-0.1, 0.1, n), np.full(n, 0.02), np.full(n, 0.001), np.zeros(n), np.linspace(0, 0.01, n)]
        cams = Cameras(c.poses, c.fx * np.linspace(0.9, 1.1, n), c.height, c.width, c.fy * 1.05, c.cx + 1.5,
                       c.cy - np.linspace(0, 2, n), k)
        out[name] = Split(cams, s.color, s.alpha, s.depth, s.mask, s.linear)
    return Dataset(out, ds.near, ds.far, dict(ds.meta))


@pytest.mark.parametrize("fmt", ["colmap", "colmap-binary", "nerfstudio"])
def test_lenses_and_per_frame_intrinsics_round_trip(vase_small, tmp_path, fmt):
    ds = with_lenses(vase_small)
    back = load_dataset(save(ds, tmp_path / "ds", fmt))
    if fmt == "nerfstudio":                     # its own split lists
        for s in ds.splits:
            for u, v in zip(ds[s].cameras.rays(), back[s].cameras.rays()):
                np.testing.assert_allclose(u, v, atol=1e-9)
            np.testing.assert_allclose(back[s].cameras.intrinsics, ds[s].cameras.intrinsics)
    else:
        assert_same_views(ds, back, 1.5 / 255)


@pytest.mark.parametrize("fmt", ["llff", "idr", "nerf2d", "tiny_nerf"])
def test_formats_without_lenses_refuse_them(vase_small, bunny_small, tmp_path, fmt):
    ds = with_lenses(vase_small)
    if fmt == "nerf2d":
        s = bunny_small["train"]
        ds = Dataset({"train": Split(Cameras(s.cameras.poses, s.cameras.fx * 1.1, s.cameras.height, cy=40.0),
                                     s.color, s.alpha)}, 1.0, 2.0)
    with pytest.raises(DataError, match="use --format"):
        save_dataset(ds, tmp_path / ("ds.npz" if fmt == "tiny_nerf" else "ds"), fmt)


def write_text_model(root: Path, camera: str) -> None:
    """A hand-made COLMAP text model: one camera, three images at the world's origin looking down +z (OpenCV), the
    camera 5 units behind it, and one point at the origin."""
    (root / "sparse" / "0").mkdir(parents=True)
    (root / "images").mkdir()
    (root / "sparse" / "0" / "cameras.txt").write_text(f"# a comment\n1 {camera}\n")
    lines = "".join(f"{i + 1} 1 0 0 0 0 0 5 1 im{i}.png\n\n" for i in range(3))
    (root / "sparse" / "0" / "images.txt").write_text(lines)
    (root / "sparse" / "0" / "points3D.txt").write_text("1 0 0 0 255 0 0 0.5 1 0\n")
    import imageio.v3 as iio
    for i in range(3):
        iio.imwrite(root / "images" / f"im{i}.png", np.full((6, 8, 3), 100 + i, np.uint8))


def test_a_hand_made_colmap_model_with_a_simple_radial_lens(tmp_path):
    write_text_model(tmp_path, "SIMPLE_RADIAL 8 6 10 4 3 0.1")     # f = 10, cx = 4, cy = 3, k1 = 0.1
    ds = load_dataset(tmp_path)
    c = ds["test"].cameras
    np.testing.assert_allclose(c.intrinsics[0], [10, 10, 4, 3, 0.1, 0, 0, 0, 0])
    np.testing.assert_allclose(c.origins[0], [0, 0, -5], atol=1e-12)     # C = -R^T t
    # the origin projects to the principal point (row 3, column 4); (0.5, 0, 0): x = 0.5 / 5 = 0.1, r² = 0.01,
    # x_d = 0.1 (1 + 0.1 * 0.01) = 0.1001, column 4 + 10 * 0.1001 = 5.001
    pixel, fwd = c.project(np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]))
    np.testing.assert_allclose(pixel[0], [[3.0, 4.0], [3.0, 5.001]], atol=1e-12)
    np.testing.assert_allclose(fwd[0], [5.0, 5.0])
    assert ds.meta["bounds"][0] == pytest.approx([5.0, 5.0])          # the one point, 5 units deep
    assert len(ds["train"]) == 2 and len(ds["test"]) == 1


@pytest.mark.parametrize("camera, words", [("OPENCV_FISHEYE 8 6 10 10 4 3 0 0 0 0", "not one mitnerf reads"),
                                           ("FULL_OPENCV 8 6 10 10 4 3 0 0 0 0 0 0.1 0 0", "rational"),
                                           ("SIMPLE_RADIAL 8 6 10 4 3 -5", "folds over"),
                                           ("PINHOLE 8 6 10 10 4", "has 4 parameters"),
                                           ("PINHOLE 8 6 10 10 40 3", "off the image")])
def test_bad_colmap_cameras_are_refused_in_one_line(tmp_path, camera, words, capsys):
    write_text_model(tmp_path, camera)
    assert main(["show", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err


def test_downscale_box_filters_views_and_scales_intrinsics(vase_small, tmp_path):
    for fmt in ("blender", "colmap", "idr"):
        save_dataset(vase_small, tmp_path / fmt, fmt)
        back = load_dataset(tmp_path / fmt, downscale=2)
        assert back.meta["downscale"] == 2 and back["test"].color.shape == (len(back["test"]), 12, 12, 3)
        src = vase_small["test"] if fmt == "blender" else all_views(vase_small).subset([0, 8])
        np.testing.assert_allclose(back["test"].cameras.rays()[1], src.cameras.downscaled(2).rays()[1], atol=1e-9)
        alpha = src.alpha.reshape(len(src), 12, 2, 12, 2).mean((2, 4))
        if fmt == "blender":                                # its exact linear colour, averaged
            box = display_color(src.linear.reshape(len(src), 12, 2, 12, 2, 3).mean((2, 4)), alpha)
        else:                                               # the premultiplied display colour, averaged
            box = src.color.reshape(len(src), 12, 2, 12, 2, 3).mean((2, 4))
        want = box + (1 - alpha[..., None]) * np.asarray(vase_small.background)
        np.testing.assert_allclose(back["test"].target(back.background), want, atol=2 / 255)
        assert back["test"].depth is None                   # a block of pixels has no one depth


def test_absent_frames_are_skipped_with_one_note(vase_small, tmp_path, capsys):
    out = save_dataset(vase_small, tmp_path / "ns", "nerfstudio")
    for name in ("train_0001.png", "train_0004.png"):
        (out / "images" / name).unlink()
    with pytest.warns(Note) as notes:
        ds = load_dataset(out)
    assert len(notes) == 1 and "2 of 11 frames have no image file" in str(notes[0].message)
    assert len(ds["train"]) == 4 and len(ds["test"]) == 4
    assert main(["show", str(out), "--out", str(tmp_path / "fig")]) == 0           # on the command line: one line
    err = [x for x in capsys.readouterr().err.splitlines() if x.startswith("mitnerf")]
    assert len(err) == 1 and err[0].startswith("mitnerf: note: ") and "2 of 11 frames" in err[0]
    for name in ("train_0000.png", "train_0002.png", "train_0003.png"):
        (out / "images" / name).unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error")                                          # no note before the refusal
        with pytest.raises(DataError, match="5 of 11 frames have no image file"):  # 1 training view would be left
            load_dataset(out)


def test_an_unknown_folder_names_every_layout(tmp_path):
    with pytest.raises(DataError) as err:
        detect_format(tmp_path)
    for layout in ("NeRF2D", "Blender", "nerfstudio", "instant-ngp", "LLFF", "IDR", "COLMAP"):
        assert layout in str(err.value)


def test_a_capture_without_validation_views_trains_and_tests(vase_small, tmp_path):
    ds = load_dataset(save_dataset(vase_small, tmp_path / "llff", "llff"))
    run, rec = fit_and_evaluate(ds, small("vanilla-3d", iters=12, val_every=4), "drjit")
    assert "val" not in ds.splits and rec.status == "ok" and np.isfinite(rec.psnr)
    assert not run.state.history.get("val_psnr")


def test_the_dataset_command_writes_the_capture_formats(tmp_path, capsys):
    args = ["dataset", "--scene", "vase", "--views", "3", "--val", "0", "--test", "1", "--image-size", "6",
            "--spp", "1"]
    for fmt in ("blender", "nerfstudio", "llff", "colmap", "idr"):   # no empty val split written
        assert main([*args, "--format", fmt, "--out", str(tmp_path / fmt)]) == 0
        assert len(load_dataset(tmp_path / fmt)["train"]) == 3
    capsys.readouterr()
    assert main(["dataset", "--scene", "bunny", "--format", "llff", "--out", str(tmp_path / "2d")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot hold a 2D dataset" in err and not (tmp_path / "2d").exists()


def need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"{path} is absent (real data: /work/shared/data)")
    return path


def test_fern_loads_from_its_smaller_folders():
    fern = need(DATA / "llff" / "fern")
    ds = load_dataset(fern, downscale=8)                     # images_8/: 504 x 378
    c = ds["train"].cameras
    assert (c.width, c.height) == (504, 378) and len(ds["train"]) == 17 and len(ds["test"]) == 3   # 0, 8, 16
    # focal 3260.526 px at 4032 px wide: 3260.526 / 8 = 407.566 px
    np.testing.assert_allclose(c.fx, 407.566, atol=1e-3)
    assert (c.cx[0], c.cy[0]) == (252.0, 189.0) and ds.meta["layout"] == "forward" and ds.meta["downscale"] == 8
    assert 0 < ds.near < min(b[0] for b in ds.meta["bounds"]) and ds.far >= max(b[1] for b in ds.meta["bounds"])
    assert load_dataset(fern, downscale=16)["test"].color.shape == (3, 189, 252, 3)   # images_8 box-filtered
    assert load_dataset(fern).meta["downscale"] == 4          # no full-size folder ships: the finest there is


def test_the_fox_loads_with_its_lens_and_absent_frames_skipped():
    fox = need(DATA / "instant_ngp" / "fox")
    with pytest.warns(Note, match="17 of 67 frames") as notes:
        ds = load_dataset(fox, downscale=8)
    assert len(notes) == 1
    assert len(ds["train"]) + len(ds["test"]) == 50 and len(ds["test"]) == 7
    c = ds["train"].cameras
    assert (c.height, c.width) == (240, 135)                 # 1920 x 1080 / 8
    np.testing.assert_allclose(c.intrinsics[0], [1375.52 / 8, 1374.49 / 8, 554.558 / 8, 965.268 / 8, 0.0578421,
                                                 -0.0805099, -0.000980296, 0.00015575, 0.0])
    o, d = c.subset([0]).rays()
    pixel = c.subset([0]).project((o + 3 * d).reshape(-1, 3))[0][0]
    v, u = np.meshgrid(np.arange(240) + 0.5, np.arange(135) + 0.5, indexing="ij")
    np.testing.assert_allclose(pixel, np.stack([v, u], -1).reshape(-1, 2), atol=1e-6)


def test_views_read_as_eight_bits_unless_one_is_not(tmp_path):
    """8-bit views come back as the 8 bits a split holds (no float copy of the split); one 16-bit view among them
    turns the whole read to float32 (values, not file types, decide: a 16-bit 0.2 would be 8 bits), and both hold
    what the images do: 51 / 255 = 0.2 at alpha 1, and the 16-bit grey 13000 / 65535 = 0.19837."""
    import imageio.v3 as iio

    from mitnerf.data.dataset import decode
    from mitnerf.data.formats.capture import read_views

    grey8 = np.full((4, 6, 3), 51, np.uint8)
    for i in range(3):
        iio.imwrite(tmp_path / f"{i}.png", grey8)
    paths = [tmp_path / f"{i}.png" for i in range(3)]
    c8, a8 = read_views(paths, 1, str(tmp_path))
    assert c8.dtype == a8.dtype == np.uint8 and c8.shape == (3, 4, 6, 3) and a8.shape == (3, 4, 6)
    color, alpha = decode(c8, a8)
    np.testing.assert_allclose(color, 0.2, atol=1e-7)
    np.testing.assert_array_equal(alpha, 1.0)
    iio.imwrite(tmp_path / "1.png", np.full((4, 6), 13000, np.uint16))          # the middle one, 16-bit grey
    cf, af = read_views(paths, 1, str(tmp_path))
    assert cf.dtype == af.dtype == np.float32
    np.testing.assert_array_equal(cf[0], color[0])                 # the 8-bit view before it, decoded exactly
    np.testing.assert_allclose(cf[[0, 2]], 0.2, atol=1e-7)
    np.testing.assert_allclose(cf[1], 13000 / 65535, atol=1e-7)
    checker = np.zeros((4, 6, 3), np.uint8)
    checker[::2, ::2] = checker[1::2, 1::2] = 255
    iio.imwrite(tmp_path / "c.png", checker)
    halved, _ = read_views([tmp_path / "c.png"], 2, str(tmp_path))    # 2 x 2 boxes of 0 and 255: 0.5, not 8 bits
    assert halved.dtype == np.float32 and halved.shape == (1, 2, 3, 3)
    np.testing.assert_allclose(halved, 0.5, atol=1e-7)
