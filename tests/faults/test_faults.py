"""Every writer of mitnerf under every fault, at every file-system event (in the spirit of SQLite's tests):

* crash (what SIGKILL leaves) at each event, then the next run;
* ENOSPC, EACCES and EROFS raised at each event, then the next run;
* a second writer of the same path let loose while the first waits at each event;
* links at each level of an output.

After each: the user's files are intact; the path holds the previous output or the new one, whole (outputs
written file by file, and files written into a folder the user owns, hold whole files of one run or the
other); once a run has finished, no staging folder, lock or part file is left. The case count is printed at
the end of the pytest run.
"""

from __future__ import annotations

import collections
import os
import threading

import pytest

from mitnerf._io import Output, tidy
from mitnerf.errors import OutputError, os_error_line

from .inject import WRITERS, Plan, check, in_child, leftovers, place_user_files, run_with

CASES: collections.Counter = collections.Counter()
STATES = {name: ("new", "own", "foreign") for name in WRITERS}
STATES.update(tiny_nerf=("new",), cache=("new", "half"))
COMBOS = [(w, s) for w, states in STATES.items() for s in states]


@pytest.fixture(autouse=True)
def no_fsync(monkeypatch):
    """``fsync`` makes writes last through a power cut, which no test here can make; a no-op keeps them fast."""
    monkeypatch.setattr(os, "fsync", lambda fd: None)


@pytest.fixture(scope="module", autouse=True)
def summary(request):
    yield
    n = sum(CASES.values())
    lines = [f"faults: {n} cases (crashes, full disks, denied writes, two writers, links), every writer, every "
             "file-system event: the user's files intact, one whole output at the path"]
    lines += [f"  {v:5d}  {k}" for k, v in sorted(CASES.items())]
    request.config.mitnerf_summary = getattr(request.config, "mitnerf_summary", []) + lines


def prepare(root, writer: str, state: str):
    """A fresh place: the user's files, and the target as ``state`` says; returns (target, versions before)."""
    root.mkdir(parents=True)
    place_user_files(root)
    write, names = WRITERS[writer]
    target = root / ("out.npz" if names is None else "out")
    if state == "own":
        write(target, "v1")
        return target, {"v1"}
    if state == "foreign":
        target.mkdir()
        (target / "notes.txt").write_text("the user's own words")
    if state == "half":                          # a cache entry an older mitnerf left half-built
        target.mkdir()
        (target / "mesh.ply").write_text("half")
    return target, {None}


def events(tmp_path, writer: str, state: str) -> int:
    target, _ = prepare(tmp_path / "count", writer, state)
    plan = Plan("count")
    _, exc = run_with(plan, WRITERS[writer][0], target, "v2", state == "foreign")
    assert exc is None, exc
    return len(plan.seen)


def mode(writer: str, state: str) -> str:
    """How the output lands: ``whole`` (swapped in), ``files`` (file by file: an incremental output, or files
    written into a folder the user owns), ``file`` (one new file)."""
    return "file" if WRITERS[writer][1] is None else "files" if state == "foreign" or writer == "experiment" \
        else "whole"


def next_run(root, target, writer: str, state: str) -> None:
    """The next run of the same command succeeds, leaves one whole output and nothing hidden behind."""
    write, names = WRITERS[writer]
    if names is None and target.exists():            # a new file is never replaced: a finished one stays
        with pytest.raises(OutputError, match="never replaces a file"):
            write(target, "v3")
        assert not leftovers(root), leftovers(root)
        return
    write(target, "v3", state == "foreign")
    built = {"v2", "v3"} if writer == "cache" else {"v3"}        # a finished cache entry is reused
    assert check(root, target, names, built, mode(writer, state), foreign=state == "foreign") in built
    if names is not None:
        assert all((target / n).exists() for n in names)
    assert leftovers(root) == [], leftovers(root)


@pytest.mark.parametrize("writer,state", COMBOS)
def test_a_crash_at_every_event(tmp_path, writer, state):
    n = events(tmp_path, writer, state)
    write, names = WRITERS[writer]
    for k in range(n):
        root = tmp_path / f"crash{k}"
        target, before = prepare(root, writer, state)
        status = in_child(Plan("crash", k), write, target, "v2", state == "foreign")
        assert status == 137, f"event {k} of {n} was not reached"
        found = check(root, target, names, before | {"v2"}, mode(writer, state), foreign=state == "foreign")
        if state == "own" and mode(writer, state) == "whole":
            assert found in ("v1", "v2"), f"neither the old nor the new output after a crash at event {k}"
        next_run(root, target, writer, state)
        CASES[f"crash: {writer} ({state})"] += 1


@pytest.mark.parametrize("writer", ["dataset", "fit", "video"])
def test_a_crash_between_two_renames_is_undone_by_the_next_run(tmp_path, monkeypatch, writer):
    """Where the kernel lacks ``RENAME_EXCHANGE`` the swap is two renames (the old output aside, the new one in);
    after a crash between them the path is empty until the next run for it puts the old output back."""
    import mitnerf._io as io
    exchange = io.renameat2
    monkeypatch.setattr(io, "renameat2", lambda src, dst, flags: flags != io.EXCHANGE and exchange(src, dst, flags))
    n = events(tmp_path, writer, "own")
    write, names = WRITERS[writer]
    for k in range(n):
        root = tmp_path / f"crash{k}"
        target, before = prepare(root, writer, "own")
        assert in_child(Plan("crash", k), write, target, "v2") == 137
        tidy(target)                                       # what the next run does first
        assert check(root, target, names, {"v1", "v2"}) in ("v1", "v2"), f"a crash at event {k}"
        next_run(root, target, writer, "own")
        CASES[f"crash between two renames: {writer}"] += 1


@pytest.mark.parametrize("writer,state", COMBOS)
@pytest.mark.parametrize("error", ["ENOSPC", "EACCES", "EROFS"])
def test_a_failed_write_at_every_event(tmp_path, writer, state, error):
    n = events(tmp_path, writer, state)
    write, names = WRITERS[writer]
    for k in range(n):
        root = tmp_path / f"{error}{k}"
        target, before = prepare(root, writer, state)
        _, exc = run_with(Plan(error, k), write, target, "v2", state == "foreign")
        if exc is not None:
            assert isinstance(exc, (OSError, OutputError)), repr(exc)
            line = os_error_line(exc) if isinstance(exc, OSError) else str(exc)
            assert "\n" not in line and line
        found = check(root, target, names, before | {"v2"}, mode(writer, state), foreign=state == "foreign")
        if exc is not None and mode(writer, state) != "files" and "changed while" not in str(exc):
            assert found in before, f"{error} at event {k} left a new output and an error: {exc}"
        next_run(root, target, writer, state)
        CASES[f"{error}: {writer} ({state})"] += 1


@pytest.mark.parametrize("writer,state", [(w, s) for w, s in COMBOS if s != "foreign"])
def test_two_writers_interleaved_at_every_event(tmp_path, writer, state):
    n = events(tmp_path, writer, state)
    write, names = WRITERS[writer]
    for k in range(n + 1):
        root = tmp_path / f"both{k}"
        target, before = prepare(root, writer, state)
        plan, results = Plan("pause", k), {}

        def first():
            results["a"] = run_with(plan, write, target, "vA")

        def second():
            try:
                results["b"] = (write(target, "vB"), None)
            except (OSError, OutputError) as exc:
                results["b"] = (None, exc)
        a = threading.Thread(target=first)
        a.start()
        while a.is_alive() and not plan.paused.wait(0.001):     # A waits at event k (or has finished: k == n)
            pass
        b = threading.Thread(target=second)
        b.start()
        b.join(0.02)                                     # B is done, refused, or waits for A's lock
        plan.go.set()
        a.join(30)
        b.join(30)
        assert not a.is_alive() and not b.is_alive(), f"a deadlock at event {k}"
        for who in "ab":
            exc = results[who][1]
            assert exc is None or (isinstance(exc, OutputError) and "\n" not in str(exc)), f"{who}: {exc!r}"
            if exc is not None:
                assert any(why in str(exc) for why in ("another mitnerf command is writing", "changed while",
                                                       "never replaces a file")), str(exc)
        check(root, target, names, before | {"vA", "vB"}, mode(writer, state))
        assert leftovers(root) == [], leftovers(root)
        CASES[f"two writers: {writer} ({state})"] += 1


# ------------------------------------------------------------------------------------ links at each level

@pytest.mark.parametrize("writer", ["dataset", "fit", "experiment"])
def test_an_output_that_is_a_link_is_refused(tmp_path, writer):
    place_user_files(tmp_path)
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "photos")
    with pytest.raises(OutputError, match="symbolic link"):
        WRITERS[writer][0](link, "v2", True)
    assert os.readlink(link) == str(tmp_path / "photos") and os.listdir(tmp_path / "photos") == ["IMG_0001.jpg"]
    assert leftovers(tmp_path) == []
    CASES["links: the output is a link"] += 1


def test_a_parent_that_is_a_link_is_written_through(tmp_path):
    place_user_files(tmp_path)
    (tmp_path / "big").mkdir()
    (tmp_path / "mnt").symlink_to(tmp_path / "big")
    WRITERS["dataset"][0](tmp_path / "mnt" / "out", "v2")
    assert check(tmp_path, tmp_path / "big" / "out", WRITERS["dataset"][1], {"v2"}) == "v2"
    CASES["links: a parent is a link"] += 1


@pytest.mark.parametrize("inside", ["train", "train/r_0.png", "mitnerf.json"])
def test_a_link_inside_a_foreign_folder_is_never_written_through(tmp_path, inside):
    """--overwrite into a folder whose ``train/`` (or a file mitnerf writes) is a link to the user's photos: the
    result goes to a sibling, the photos stay as they were."""
    place_user_files(tmp_path)
    out = tmp_path / "out"
    (out / "train").mkdir(parents=True) if "/" in inside else out.mkdir()
    (out / "notes.txt").write_text("the user's own words")
    (out / inside).symlink_to(tmp_path / ("photos" if inside == "train" else "thesis.txt"))
    with pytest.raises(OutputError, match="link"):
        WRITERS["dataset"][0](out, "v2", True)
    assert check(tmp_path, tmp_path / "out-2", WRITERS["dataset"][1], {"v2"}) == "v2"
    assert os.path.islink(out / inside) and leftovers(tmp_path) == []
    CASES["links: inside a folder the user owns"] += 1


def test_a_link_put_into_an_own_output_makes_it_the_users(tmp_path):
    place_user_files(tmp_path)
    out = tmp_path / "out"
    WRITERS["video"][0](out, "v1")
    (out / "photos").symlink_to(tmp_path / "photos")
    with pytest.raises(OutputError, match="did not write"):
        WRITERS["video"][0](out, "v2")
    assert os.listdir(tmp_path / "photos") == ["IMG_0001.jpg"] and (out / "mesh.ply").read_text() == "v1"
    CASES["links: inside an own output"] += 1


def test_a_link_planted_at_the_lock_is_not_followed(tmp_path):
    place_user_files(tmp_path)
    out = tmp_path / "out"
    probe = Output(out, "dataset")                      # find the lock's name
    lock = probe._lock.path
    probe.release()
    lock.symlink_to(tmp_path / "thesis.txt")
    with pytest.raises(OutputError, match="symbolic links; it runs through a link mitnerf does not follow"):
        Output(out, "dataset")
    check(tmp_path, out, WRITERS["dataset"][1], {None})
    assert (tmp_path / "thesis.txt").read_text() == "the user's own words"
    CASES["links: at the lock file"] += 1


def test_a_link_inside_an_incremental_output_is_not_written_through(tmp_path):
    place_user_files(tmp_path)
    out = tmp_path / "out"
    WRITERS["experiment"][0](out, "v1")
    (out / "pe" / "curve.png").unlink()
    (out / "pe").rmdir()
    (out / "pe").symlink_to(tmp_path / "photos")
    with pytest.raises(OutputError, match="link"):
        WRITERS["experiment"][0](out, "v2")
    assert os.listdir(tmp_path / "photos") == ["IMG_0001.jpg"]
    CASES["links: inside an incremental output"] += 1
