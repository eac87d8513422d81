"""Users' data is sacred: outputs never replace what mitnerf did not write, writes are atomic,
and the cache survives two processes filling the same entry."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from conftest import ROOT

from mitnerf._io import MARKER, Output, cache_entry
from mitnerf.cli import main
from mitnerf.errors import OutputError

DATASET = ["dataset", "--scene", "square", "--views", "3", "--val", "1", "--test", "2", "--image-size", "16"]


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
    assert main(["dataset", "--scene", "vase", "--views", "2", "--val", "1", "--test", "1", "--image-size", "8",
                 "--format", "tiny_nerf", "--out", str(tiny)]) == 2
    assert tiny.read_bytes() == b"mine"


def test_overwrite_writes_mitnerfs_files_and_leaves_the_rest(tmp_path):
    mine = tmp_path / "shared"
    mine.mkdir()
    (mine / "README.txt").write_text("mine")
    assert main([*DATASET, "--out", str(mine), "--overwrite"]) == 0
    assert (mine / "README.txt").read_text() == "mine" and (mine / "train" / "transforms.json").exists()


def test_an_earlier_output_of_the_same_kind_is_replaced_whole(tmp_path, capsys):
    out = tmp_path / "ds"
    assert main([*DATASET, "--out", str(out)]) == 0
    marker = json.loads((out / MARKER).read_text())
    assert marker["kind"] == "dataset" and "train/transforms.json" in marker["files"]     # it lists what it wrote
    before = (out / "train" / "transforms.json").read_bytes()
    assert main([*DATASET, "--out", str(out), "--seed", "3"]) == 0
    assert (out / "train" / "transforms.json").read_bytes() != before and leftovers(tmp_path) == []
    with pytest.raises(OutputError, match="holds a mitnerf dataset output"):     # another kind is refused
        Output(out, "fit")
    (out / "train" / "mine.png").write_bytes(b"the user's")        # a file the user put into our output
    capsys.readouterr()
    assert main([*DATASET, "--out", str(out), "--seed", "4"]) == 2
    assert "train/mine.png" in capsys.readouterr().err and (out / "train" / "mine.png").read_bytes() == b"the user's"


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
    """Both ask at the same moment (a barrier makes them overlap): one builds while the other waits for its lock,
    then both get the same, whole entry, built once, and nothing else is left in the cache."""
    script = textwrap.dedent(f"""
        import os, sys, time
        os.environ["MITNERF_CACHE"] = {str(tmp_path / "cache")!r}
        from mitnerf._io import cache_entry
        open({str(tmp_path)!r} + "/ready-" + sys.argv[1], "w").close()
        while len([f for f in os.listdir({str(tmp_path)!r}) if f.startswith("ready-")]) < 2:
            time.sleep(0.01)
        def build(tmp):
            with open({str(tmp_path / "builds")!r}, "a") as log:
                log.write(sys.argv[1])
            time.sleep(0.5)                      # the other process asks meanwhile
            for i in range(50):
                (tmp / f"part{{i}}").write_text(sys.argv[1] * 1000)
        print(cache_entry("datasets/shared", build))
    """)
    procs = [subprocess.Popen([sys.executable, "-c", script, name], stdout=subprocess.PIPE, text=True, cwd=ROOT)
             for name in "ab"]
    outs = [p.communicate(timeout=60)[0].strip() for p in procs]
    assert all(p.returncode == 0 for p in procs) and outs[0] == outs[1]
    assert len((tmp_path / "builds").read_text()) == 1                                           # built once
    entry = tmp_path / "cache" / "datasets" / "shared"
    files = sorted(entry.iterdir())
    assert len(files) == 51 and len({f.read_text() for f in files if f.name != MARKER}) == 1     # one builder's
    assert [p.name for p in entry.parent.iterdir()] == ["shared"]                                  # no leftovers
    monkeypatch.setenv("MITNERF_CACHE", str(tmp_path / "cache"))
    calls = []
    assert cache_entry("datasets/shared", calls.append) == entry and calls == []                   # reused


# ------------------------------------------------------------------- the situations the faults issue lists

def one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [x for x in err.replace("\r", "\n").splitlines() if "mitnerf:" in x]     # not the progress bars
    assert len(lines) == 1 and lines[0].startswith("mitnerf: error: ") and "Traceback" not in err, err
    return lines[0]


def test_overwrite_never_makes_a_users_folder_mitnerfs(tmp_path, capsys):
    """`--overwrite` writes beside the user's files and leaves the folder theirs: the next plain run is refused
    instead of replacing the folder (and the thesis with it)."""
    mine = tmp_path / "F"
    mine.mkdir()
    (mine / "thesis.txt").write_text("mine")
    assert main([*DATASET, "--out", str(mine), "--overwrite"]) == 0
    assert not (mine / MARKER).exists()
    capsys.readouterr()
    assert main([*DATASET, "--out", str(mine)]) == 2
    assert "--overwrite" in one_line(capsys) and (mine / "thesis.txt").read_text() == "mine"


@pytest.mark.parametrize("how", ["equals", "holds", "inside"])
def test_an_output_that_touches_the_input_is_refused(tmp_path, capsys, how):
    data = tmp_path / "run" / "data"
    assert main([*DATASET, "--out", str(data)]) == 0
    out = {"equals": data, "holds": tmp_path / "run", "inside": data / "fit"}[how]
    capsys.readouterr()
    assert main(["fit", "--data", str(data), "--out", str(out), "--overwrite", "--iters", "1"]) == 2
    assert "could destroy what this command reads" in one_line(capsys)
    assert (data / "train" / "transforms.json").exists() and not (data / "fit").exists()


def test_video_into_its_own_checkpoint_is_refused(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text("{}")
    assert main(["video", "--checkpoint", str(run), "--out", str(run), "--overwrite"]) == 2
    assert "could destroy" in one_line(capsys) and (run / "manifest.json").read_text() == "{}"


def test_files_put_into_a_new_output_while_the_work_runs_are_kept(tmp_path):
    out = Output(tmp_path / "run", "fit")
    with pytest.raises(OutputError, match="changed while this command ran"):
        with out.staged() as tmp:
            (tmp / "weights.npz").write_text("model")
            (tmp_path / "run").mkdir()
            (tmp_path / "run" / "notes.txt").write_text("mine")        # the user, while it trained
    assert (tmp_path / "run" / "notes.txt").read_text() == "mine" and (tmp_path / "run-2" / "weights.npz").exists()
    assert leftovers(tmp_path) == []


def test_a_second_command_for_the_same_output_is_refused_at_once(tmp_path, capsys):
    first = Output(tmp_path / "new", "fit")
    assert main([*DATASET, "--out", str(tmp_path / "new")]) == 2
    assert "another mitnerf command is writing" in one_line(capsys)
    first.release()
    assert main([*DATASET, "--out", str(tmp_path / "new")]) == 0


def test_system_errors_are_one_line_before_the_work(tmp_path, capsys):
    (tmp_path / "FILE").write_text("x")
    for out, words in [(tmp_path / "FILE" / "sub", "is a file"), (tmp_path / ("n" * 300), "bytes, more than"),
                       (tmp_path / "a" / ("m" * 256) / "b", "bytes, more than")]:
        assert main([*DATASET, "--out", str(out)]) == 2
        assert words in one_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FILE"]


def test_a_full_disk_while_writing_is_one_line_and_leaves_nothing(tmp_path, capsys):
    from faults.inject import Plan, run_with

    (tmp_path / "out").mkdir()
    assert main([*DATASET, "--out", str(tmp_path / "first")]) == 0        # the scene's cache entry is built
    count = Plan("count")
    assert run_with(count, main, [*DATASET, "--out", str(tmp_path / "whole")]) == (0, None)
    takes_space = [k for k, event in enumerate(count.seen) if event in ("open", "os.mkdir")]
    for k in takes_space[::4]:
        capsys.readouterr()
        assert run_with(Plan("ENOSPC", k), main, [*DATASET, "--out", str(tmp_path / "out" / f"ds{k}")]) == (2, None)
        line = one_line(capsys)
        assert f"ds{k}: No space left on device; free some space" in line, line
    assert list((tmp_path / "out").iterdir()) == []


def test_a_name_that_is_not_utf8_prints(tmp_path):
    out = os.fsencode(str(tmp_path)) + b"/caf\xe9"
    r = subprocess.run([sys.executable, "-m", "mitnerf", *DATASET, "--out", out], capture_output=True, cwd=ROOT,
                       env={**os.environ, "LC_ALL": "C.UTF-8", "PYTHONIOENCODING": "utf-8"})
    assert r.returncode == 0, r.stderr
    assert b"caf\\udce9" in r.stdout or b"caf\\xe9" in r.stdout


@pytest.mark.parametrize("signum,status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_an_interrupted_dataset_says_so_in_one_line_and_leaves_nothing(tmp_path, signum, status):
    cmd = [sys.executable, "-m", "mitnerf", "dataset", "--scene", "vase", "--views", "200", "--image-size", "64",
           "--out", str(tmp_path / "ds")]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,   # Ctrl-C
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))   # reaches it in a job too
    for _ in range(600):                                   # until it renders
        if any(".mitnerf-tmp-" in n for n in os.listdir(tmp_path)):
            break
        time.sleep(0.05)
    p.send_signal(signum)
    out, err = p.communicate(timeout=120)
    lines = [x for x in err.splitlines() if x.startswith("mitnerf")]
    # or death by the signal, which a shell also reports as 130: CPython 3.11 exits so when the KeyboardInterrupt
    # passed through code run by exec() (a dataclass's __init__ being made), even though the command caught it
    assert p.returncode in (status, -signum) and len(lines) == 1 and "interrupted" in lines[0], err
    # the signal may fall in the commit, which holds it: then the whole output is there and the line names it
    whole = f"{tmp_path / 'ds'} was written whole before the signal was taken" in lines[0]
    assert "Traceback" not in err and os.listdir(tmp_path) == (["ds"] if whole else []), err


def test_a_signal_just_after_the_staging_folder_is_made_leaves_nothing(tmp_path, monkeypatch):
    """The interrupt falls between the staging folder's mkdir and anything after it (the moment the subprocess test
    above watches for): the folder goes, for both a staged and a claimed output."""
    from mitnerf._io import Output

    mkdir = os.mkdir

    def mkdir_then_signal(path, *args, **kw):
        mkdir(path, *args, **kw)
        if ".mitnerf-tmp-" in os.fspath(path):
            raise KeyboardInterrupt

    monkeypatch.setattr(os, "mkdir", mkdir_then_signal)
    with pytest.raises(KeyboardInterrupt):
        with Output(tmp_path / "o", "dataset").staged():
            pass
    claimed = Output(tmp_path / "c", "dataset")
    with pytest.raises(KeyboardInterrupt):
        claimed.claim()
    claimed.release()                                   # as the command does at exit
    assert os.listdir(tmp_path) == []


def test_a_signal_held_through_the_commit_leaves_the_whole_output_and_its_line_says_so(tmp_path, monkeypatch):
    """SIGTERM during the commit waits for it (``no_interrupts``): the output is there whole, no staging folder is
    left, and the interrupt carries the note its one line ends with (SIGTERM: a job in the background, as CI may
    run the suite, ignores SIGINT from its start, and so does the command line)."""
    from mitnerf._io import Output
    from mitnerf.cli import _signals_raise
    from mitnerf.errors import Terminated

    out, commit = Output(tmp_path / "o", "dataset"), Output._commit

    def signalled_commit(self, tmp):
        signal.raise_signal(signal.SIGTERM)                  # held until the commit is done
        commit(self, tmp)

    monkeypatch.setattr(Output, "_commit", signalled_commit)
    with _signals_raise(), pytest.raises(Terminated) as info:    # the command line's handlers, as it runs
        with out.staged() as tmp:
            (tmp / "a.txt").write_text("x")
    assert os.listdir(tmp_path) == ["o"] and (tmp_path / "o" / "a.txt").read_text() == "x"
    assert info.value.note == f"; {tmp_path / 'o'} was written whole before the signal was taken"


def test_an_interrupt_frees_what_its_frames_held_and_prints_none_of_their_del_errors(capsys):
    """A writer cut off half made (its ``__del__`` fails) in the frames of the interrupt that a later error came
    from: freed at once, its error unprinted."""
    from mitnerf.cli import _drop_frames

    deleted = []

    class HalfMade:
        def __del__(self):
            deleted.append(True)
            raise AttributeError("HalfMade has no _to_write")

    def writer():
        half = HalfMade()  # noqa: F841 (held by this frame)
        raise KeyboardInterrupt

    try:
        try:
            writer()
        except KeyboardInterrupt:
            raise RuntimeError("the interrupt, changed on its way") from None
    except RuntimeError as exc:
        _drop_frames(exc)
        assert deleted == [True]
    assert "_to_write" not in capsys.readouterr().err


def test_an_interrupt_python_dropped_still_stops_the_commit(tmp_path, capsys):
    """Python drops an exception raised in a callback (a weak reference's during an import, a ``__del__``): the
    command's handler keeps the signal, and the output is not committed; the dropped exception prints nothing."""
    from mitnerf.cli import _signals_raise

    class Dropped:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGTERM)         # the handler runs here: its Terminated is dropped
            time.sleep(0.01)

    before = signal.getsignal(signal.SIGTERM)
    with _signals_raise(), pytest.raises(KeyboardInterrupt):
        with Output(tmp_path / "out", "figures", False).staged() as tmp:
            (tmp / "a.txt").write_text("a")
            Dropped()                                    # deleted at once
    assert signal.getsignal(signal.SIGTERM) is before    # the handler is put back
    assert os.listdir(tmp_path) == [] and capsys.readouterr().err == ""


def test_an_interrupt_python_turned_into_another_error_ends_as_the_interrupt(monkeypatch, capsys):
    """Python turns an exception raised in a class's ``__set_name__`` into a RuntimeError: after a signal, main
    takes such an unexpected error for the signal (one line, 143), not for a bug (a traceback)."""
    import mitnerf.cli as cli

    class Named:
        def __set_name__(self, owner, name):
            os.kill(os.getpid(), signal.SIGTERM)        # the handler's Terminated becomes a RuntimeError
            time.sleep(0.01)

    def run(args):
        type("Owner", (), {"attribute": Named()})

    parsed = type("Args", (), {"run": staticmethod(run)})
    monkeypatch.setattr(cli, "build_parser", lambda: type("P", (), {"parse_args": lambda self, argv: parsed})())
    assert main([]) == 143
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("mitnerf: interrupted (SIGTERM)")


def test_resume_after_the_dataset_moved_names_data(tmp_path, capsys):
    assert main([*DATASET, "--out", str(tmp_path / "ds")]) == 0
    assert main(["fit", "--data", str(tmp_path / "ds"), "--iters", "3", "--no-figures",
                 "--out", str(tmp_path / "run")]) == 0
    os.rename(tmp_path / "ds", tmp_path / "moved")
    capsys.readouterr()
    assert main(["fit", "--resume", str(tmp_path / "run")]) == 2
    assert "pass --data with where it is now" in one_line(capsys)
