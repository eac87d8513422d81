"""Bad input: one line naming the problem and the fix, exit status 2, nothing half-written."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mitnerf.cli import main
from mitnerf.data.formats import save_dataset
from mitnerf.errors import OutputError

ROOT = Path(__file__).resolve().parents[1]


def run_cli(args, capsys):
    rc = main([str(a) for a in args])
    err = capsys.readouterr().err.strip()
    return rc, err


def no_leftovers(folder: Path):
    return [p.name for p in folder.iterdir() if p.name.startswith(".")] == []


@pytest.fixture
def polygons(tmp_path):
    files = {}
    for name, pts in {"open": [[0, 0], [1, 0], [1, 1], [0, 1]],
                      "crossing": [[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]],
                      "pixels": [[100, 100], [400, 100], [400, 400], [100, 400], [100, 100]],
                      "wide": [[-1.9, -0.2], [1.9, -0.2], [1.9, 0.2], [-1.9, 0.2], [-1.9, -0.2]]}.items():
        files[name] = tmp_path / f"{name}.json"
        files[name].write_text(json.dumps({"points": pts}))
    bad_xml = tmp_path / "bad.xml"
    bad_xml.write_text('<scene version="3.0.0"><shape type="ply"')
    files["bad_xml"] = bad_xml
    return files


@pytest.mark.parametrize("case, args, words", [
    ("missing xml", ["--scene", "/nonexistent/scene.xml"], "does not exist"),
    ("malformed xml", ["--scene", "{bad_xml}"], "fix the XML"),
    ("unknown scene", ["--scene", "teapot"], "unknown scene 'teapot'; choose one of"),
    ("polygon in pixels", ["--polygon", "{pixels}"], "the cameras stand at 4: they would be inside it; scale it to "
                                                     "about [-1, 1] (divide its points by 566)"),
    ("polygon wider than the view", ["--polygon", "{wide}"], "see 1.79 of it; scale it to about [-1, 1]"),
    ("self-intersecting polygon", ["--polygon", "{crossing}"], "self-intersecting"),
    ("zero views", ["--scene", "square", "--views", "0"], "argument --views: it must be >= 1, got 0"),
    ("resolution 0", ["--scene", "square", "--image-size", "0"], "argument --image-size: it must be >= 1, got 0"),
])
def test_dataset_bad_input(case, args, words, polygons, tmp_path, capsys):
    out = tmp_path / "out"
    args = [a.format(**polygons) for a in args]
    rc, err = run_cli(["dataset", *args, "--out", out, "--views" if "--views" not in args else "--test",
                       "3" if "--views" not in args else "2"], capsys)
    assert rc == 2, case
    assert len(err.splitlines()) == 1 and words in err, err
    assert not out.exists() and no_leftovers(tmp_path)


def test_an_open_ring_is_closed_with_a_note(polygons, tmp_path, capsys):
    assert main(["dataset", "--polygon", str(polygons["open"]), "--views", "2", "--val", "0", "--test", "1",
                 "--image-size", "8", "--out", str(tmp_path / "ds")]) == 0
    err = [x for x in capsys.readouterr().err.splitlines() if x.startswith("mitnerf")]
    assert err == ["mitnerf: note: polygon 'open' was open (its last point differs from its first): closed it with "
                   "an edge from its last point to its first"]
    assert (tmp_path / "ds" / "train" / "transforms.json").exists()


def written(ds, tmp_path):
    save_dataset(ds, tmp_path / "ds")
    return tmp_path / "ds"


def test_unreadable_dataset_folders(tmp_path, capsys):
    rc, err = run_cli(["show", tmp_path / "missing"], capsys)
    assert rc == 2 and "does not exist" in err
    (tmp_path / "empty").mkdir()
    rc, err = run_cli(["show", tmp_path / "empty"], capsys)
    assert rc == 2 and "not a dataset folder" in err and len(err.splitlines()) == 1
    broken = tmp_path / "broken" / "train"
    broken.mkdir(parents=True)
    (broken / "transforms.json").write_text("{not json")
    rc, err = run_cli(["show", tmp_path / "broken"], capsys)
    assert rc == 2 and "not valid JSON" in err


def test_image_pose_count_mismatch(bunny_small, tmp_path, capsys):
    ds = written(bunny_small, tmp_path)
    (ds / "val" / "cam-3.png").unlink()
    rc, err = run_cli(["show", ds], capsys)
    assert rc == 2 and "4 poses but the folder has 3" in err and len(err.splitlines()) == 1


def test_nan_in_poses(vase_small, tmp_path, capsys):
    ds = written(vase_small, tmp_path)
    f = ds / "transforms_train.json"
    data = json.loads(f.read_text())
    data["frames"][2]["transform_matrix"][0][3] = float("nan")
    f.write_text(json.dumps(data))
    rc, err = run_cli(["show", ds], capsys)
    assert rc == 2 and "pose 2 contains NaN" in err


def test_a_3d_field_refuses_harmonics_above_degree_2(vase_small, tmp_path, capsys):
    ds = written(vase_small, tmp_path)
    rc, err = run_cli(["fit", "--data", ds, "--iters", "1", "--sh-degree", "3", "--out", tmp_path / "fit"], capsys)
    assert rc == 2 and len(err.splitlines()) == 1 and "up to degree 2; choose 1 to 2" in err, err
    assert not (tmp_path / "fit").exists()


def test_a_failure_while_writing_leaves_nothing(bunny_small, tmp_path, monkeypatch):
    import imageio.v3 as iio

    calls = {"n": 0}
    real = iio.imwrite

    def flaky(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 5:
            raise OSError("disk full")
        return real(*args, **kwargs)

    monkeypatch.setattr(iio, "imwrite", flaky)
    with pytest.raises(OutputError, match="ds: disk full"):          # named by the output, not its staging
        save_dataset(bunny_small, tmp_path / "ds")
    assert list(tmp_path.iterdir()) == []
    # an existing dataset survives a failed overwrite
    monkeypatch.setattr(iio, "imwrite", real)
    save_dataset(bunny_small, tmp_path / "ds")
    before = sorted(p.name for p in (tmp_path / "ds" / "train").iterdir())
    calls["n"] = 0
    monkeypatch.setattr(iio, "imwrite", flaky)
    with pytest.raises(OutputError):
        save_dataset(bunny_small, tmp_path / "ds")
    assert sorted(p.name for p in (tmp_path / "ds" / "train").iterdir()) == before
    assert [p.name for p in tmp_path.iterdir()] == ["ds"]


def test_the_cli_exits_2_with_one_line():
    r = subprocess.run([sys.executable, "-m", "mitnerf", "dataset", "--scene", "teapot", "--out", "/tmp/never"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("mitnerf: error:")


LLVM15 = Path("/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1")


@pytest.mark.skipif(not LLVM15.exists(), reason="needs Debian's libLLVM-15 to play an old machine")
def test_llvm_older_than_16_is_refused_in_one_line():
    env = {**os.environ, "DRJIT_LIBLLVM_PATH": str(LLVM15)}
    r = subprocess.run([sys.executable, "-m", "mitnerf", "recipes"], capture_output=True, text=True, env=env, cwd=ROOT)
    assert r.returncode == 2
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "LLVM >= 16" in lines[0] and "libllvm19" in lines[0]


def test_import_has_no_side_effects_and_entry_points_choose_the_variant():
    code = ("import sys, mitsuba as mi, mitnerf, mitnerf.train.fit, mitnerf.cli; "
            "print(mi.variant(), 'torch' in sys.modules); mitnerf.set_variant(); print(mi.variant())")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**os.environ, "MITNERF_VARIANT": "scalar_rgb"})
    assert r.stdout.split() == ["None", "False", "scalar_rgb"], r.stderr
    r = subprocess.run([sys.executable, "-m", "mitnerf", "recipes"], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "MITNERF_VARIANT": "cuda_nonexistent"})
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "set MITNERF_VARIANT" in r.stderr
