"""``mitnerf poses``: the similarity that aligns two camera sets, hand-worked; structure from motion (pycolmap) on our
own renders with known poses (the brick on its noise-printed table, a ring of views), read back by ``load_dataset``;
too few registered images is one line, exit 2, nothing written. Tests that run COLMAP skip with one line where
pycolmap is absent (``pip install -e .[poses]``)."""

from __future__ import annotations

import json
import os

import imageio.v3 as iio
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mitnerf.cli import main
from mitnerf.data.align import pose_errors, similarity
from mitnerf.data.color import to_uint8
from mitnerf.data.formats import load_dataset
from mitnerf.data.rig import look_at_3d

RING = 24
"""Views on the ring (15 degrees apart, elevation 25, radius 3.5, 300 px, 40 degree field of view)."""


def needs_pycolmap():
    pytest.importorskip("pycolmap", reason="pycolmap is absent: pip install -e .[poses]")


def test_similarity_recovers_a_known_scale_rotation_and_shift():
    src = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    Rz = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])            # 90 degrees about z
    dst = 2.0 * src @ Rz.T + [1.0, 2.0, 3.0]                        # (1, 0, 0) -> (1, 4, 3)
    s, R, t = similarity(src, dst)
    assert s == pytest.approx(2.0) and np.allclose(R, Rz) and np.allclose(t, [1.0, 2.0, 3.0])


def test_pose_errors_are_zero_after_a_similarity_and_see_one_turned_camera():
    pos = np.array([[3.0, 0, 1], [0, 3, 1], [-3, 0, 1], [0, -3, 2]])
    truth = look_at_3d(pos, -pos)
    world = np.eye(4)
    world[:3, :3], world[:3, 3] = 0.5 * Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix(), [1, 2, 3]
    moved = world @ truth                       # scaled by 0.5: rescale the rotation columns back to unit length
    moved[:, :3, :3] *= 2.0
    e = pose_errors(moved, truth)
    assert e.scale == pytest.approx(2.0) and e.rotation.max() < 1e-6 and e.position.max() < 1e-9
    turned = moved.copy()
    turned[1, :3, :3] = turned[1, :3, :3] @ Rotation.from_euler("y", 1.0, degrees=True).as_matrix()
    assert pose_errors(turned, truth).rotation == pytest.approx([0, 1, 0, 0], abs=1e-6)   # camera 1 by 1 degree


@pytest.fixture(scope="module")
def ring(tmp_path_factory):
    """``(folder of the ring's PNGs over white, their true poses [RING, 4, 4], focal)``, rendered once (cached)."""
    from mitnerf.data.cache import cached_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.scenes.gt_render import RenderSettings

    ds = cached_dataset("brick_table", RigConfig(dim=3, n_train=1, n_val=1, n_test=RING, resolution=300, seed=0),
                        RenderSettings(spp=16))
    folder = tmp_path_factory.mktemp("photos")
    views = ds["test"]
    for i, img in enumerate(views.target((1.0, 1.0, 1.0))):
        iio.imwrite(folder / f"{i:03d}.png", to_uint8(img))
    return folder, views.cameras.poses, float(views.cameras.fx[0])


def test_poses_recovers_the_cameras_of_our_renders(ring, tmp_path, capsys):
    needs_pycolmap()
    folder, truth, focal = ring
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    out = tmp_path / "data"
    assert main(["poses", "--images", str(folder), "--out", str(out), "--camera-model", "SIMPLE_PINHOLE",
                 "--downscale", "2"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert [line.split(":")[1].strip() for line in printed[1:4]] == ["features", "matching (exhaustive)", "mapping"]
    assert printed[-1].startswith(f"wrote {out} ({RING} of {RING} images posed")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before                 # the photos untouched
    assert all((out / "images" / n).read_bytes() == b for n, b in before.items())      # and copied byte for byte
    header = json.loads((out / "transforms.json").read_text())
    assert header["camera_model"] == "PINHOLE" and header["ply_file_path"] == "sparse_pc.ply"
    names = [f["file_path"] for f in header["frames"]]
    assert names == [f"images_2/{i:03d}.png" for i in range(RING)]                    # 150 x 150, box-filtered
    assert (header["w"], header["h"], header["cx"], header["cy"]) == (150, 150, 75.0, 75.0)
    poses = np.array([f["transform_matrix"] for f in header["frames"]])
    e = pose_errors(poses, truth)
    assert e.rotation.max() < 0.5                                  # the goal, degrees
    assert e.position.max() < 0.01 * 3.5                          # 1 % of the ring's radius
    assert header["fl_x"] == pytest.approx(focal / 2, rel=0.01)
    ds = load_dataset(out)                                        # what `mitnerf fit` reads: every 8th held out
    assert {k: len(v) for k, v in ds.splits.items()} == {"train": RING - RING // 8, "test": RING // 8}
    assert ds["test"].color.shape == (RING // 8, 150, 150, 3)
    assert ds.meta["layout"] == "around" and len(ds.meta["bounds"]) == RING
    assert 0 < ds.near < 3.5 - 1.0 and ds.far > 3.5                # the brick lies within 1 of the origin
    centres = np.concatenate([s.cameras.origins for s in ds.splits.values()])
    assert np.median(np.linalg.norm(centres, axis=1)) == pytest.approx(3.5)     # the written world's scale


def test_too_few_registered_images_is_one_line_and_nothing_written(tmp_path, capsys):
    needs_pycolmap()
    photos = tmp_path / "photos"
    photos.mkdir()
    rng = np.random.default_rng(0)
    for i in range(4):                          # unrelated noise: no two images share a point
        iio.imwrite(photos / f"{i}.png", rng.integers(0, 256, (64, 64, 3), dtype=np.uint8))
    out = tmp_path / "data"
    assert main(["poses", "--images", str(photos), "--out", str(out)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("mitnerf: error: COLMAP"), err
    assert sorted(os.listdir(tmp_path)) == ["photos"]


def test_without_pycolmap_the_command_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pycolmap", None)             # `import pycolmap` raises ImportError
    assert main(["poses", "--images", str(tmp_path), "--out", str(tmp_path / "data")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "pip install -e .[poses]" in err[0]
    assert not (tmp_path / "data").exists()


def test_the_fern_is_posed_like_llff(tmp_path):
    """Every image registered and camera centres within 1 % of LLFF's camera spread (the benchmark times it)."""
    needs_pycolmap()
    from benchmarks.poses import FERN as fern, llff_errors

    if not (fern / "images_8").is_dir():
        pytest.skip(f"{fern} is absent (real data: /work/shared/data)")
    out = tmp_path / "fern"
    assert main(["poses", "--images", str(fern / "images_8"), "--out", str(out)]) == 0
    e, spread, registered = llff_errors(fern, out, downscale=8)
    assert registered == 20 and e.position.max() < 0.01 * spread and e.rotation.max() < 0.5
