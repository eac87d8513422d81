"""Users' data is sacred: outputs never replace what mitnerf did not write, writes are atomic,
and the cache survives two processes filling the same entry."""

import json
import subprocess
import sys
import textwrap

import pytest
from conftest import ROOT

from mitnerf._io import MARKER, Output, cache_entry
from mitnerf.cli import main
from mitnerf.errors import OutputError

DATASET = ["dataset", "--scene", "square", "--views", "3", "--val", "1", "--test", "2", "--resolution", "16"]


def leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_a_folder_with_a_users_file_is_refused_and_the_file_stays(tmp_path, capsys):
    mine = tmp_path / "Documents"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    assert main([*DATASET, "--out", str(mine)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--overwrite" in err and "thesis.tex" in err
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"] and (mine / "thesis.tex").read_text() == "years of work"
    assert leftovers(tmp_path) == []


def test_a_plain_file_is_never_replaced(tmp_path, capsys):
    f = tmp_path / "notes"
    f.write_text("keep me")
    for args in ([*DATASET, "--out", str(f)], [*DATASET, "--out", str(f), "--overwrite"]):
        assert main(args) == 2
        assert "never replaces a file" in capsys.readouterr().err
    assert f.read_text() == "keep me"
    tiny = tmp_path / "tiny.npz"
    tiny.write_bytes(b"mine")
    assert main(["dataset", "--scene", "vase", "--views", "2", "--val", "1", "--test", "1", "--resolution", "8",
                 "--format", "tiny_nerf", "--out", str(tiny)]) == 2
    assert tiny.read_bytes() == b"mine"


def test_overwrite_writes_mitnerfs_files_and_leaves_the_rest(tmp_path):
    mine = tmp_path / "shared"
    mine.mkdir()
    (mine / "README.txt").write_text("mine")
    assert main([*DATASET, "--out", str(mine), "--overwrite"]) == 0
    assert (mine / "README.txt").read_text() == "mine" and (mine / "train" / "transforms.json").exists()


def test_an_earlier_output_of_the_same_kind_is_replaced_whole(tmp_path):
    out = tmp_path / "ds"
    assert main([*DATASET, "--out", str(out)]) == 0
    assert json.loads((out / MARKER).read_text())["kind"] == "dataset"
    (out / "train" / "stale.png").write_bytes(b"from before")      # inside our own output: replaced with it
    assert main([*DATASET, "--out", str(out), "--seed", "3"]) == 0
    assert not (out / "train" / "stale.png").exists() and leftovers(tmp_path) == []
    with pytest.raises(OutputError, match="holds a mitnerf dataset output"):     # another kind is refused
        Output(out, "fit")


def test_an_empty_folder_is_used_and_a_failure_leaves_nothing(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    target = Output(empty, "test")
    with pytest.raises(RuntimeError):
        with target.staged() as tmp:
            (tmp / "half.txt").write_text("half")
            raise RuntimeError("disk full")
    assert list(empty.iterdir()) == [] and leftovers(tmp_path) == []
    with target.staged() as tmp:
        (tmp / "whole.txt").write_text("whole")
    assert sorted(p.name for p in empty.iterdir()) == [MARKER, "whole.txt"]


def test_two_processes_filling_one_cache_entry(tmp_path, monkeypatch):
    """Both builders run at once (a barrier file makes them overlap); both get the same, whole entry."""
    script = textwrap.dedent(f"""
        import os, sys, time
        os.environ["MITNERF_CACHE"] = {str(tmp_path / "cache")!r}
        from mitnerf._io import cache_entry
        def build(tmp):
            open({str(tmp_path)!r} + "/started-" + sys.argv[1], "w").close()
            while len([f for f in os.listdir({str(tmp_path)!r}) if f.startswith("started-")]) < 2:
                time.sleep(0.01)
            for i in range(50):
                (tmp / f"part{{i}}").write_text(sys.argv[1] * 1000)
        print(cache_entry("datasets/shared", build))
    """)
    procs = [subprocess.Popen([sys.executable, "-c", script, name], stdout=subprocess.PIPE, text=True, cwd=ROOT)
             for name in "ab"]
    outs = [p.communicate(timeout=60)[0].strip() for p in procs]
    assert all(p.returncode == 0 for p in procs) and outs[0] == outs[1]
    entry = tmp_path / "cache" / "datasets" / "shared"
    files = sorted(entry.iterdir())
    assert len(files) == 51 and len({f.read_text() for f in files if f.name != MARKER}) == 1     # one builder's
    assert [p.name for p in entry.parent.iterdir()] == ["shared"]                                  # no leftovers
    monkeypatch.setenv("MITNERF_CACHE", str(tmp_path / "cache"))
    calls = []
    assert cache_entry("datasets/shared", calls.append) == entry and calls == []                   # reused
