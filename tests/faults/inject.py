"""Faults at every file-system event of mitnerf's writers, injected in-process.

An audit hook (``sys.addaudithook``) sees every event a writer causes: files opened for writing, folders made,
renames (``os.rename``/``os.replace``), removals, ``chmod``, and the C call behind ``renameat2``. A
:class:`Plan` picks one of them, counted from 0 in the writer's own thread, and at it:

* ``crash``: ends the process at once (``os._exit(137)``, what SIGKILL leaves: no ``finally`` runs); the
  writer runs in a forked child so the test process goes on;
* ``ENOSPC`` / ``EACCES`` / ``EROFS``: raises that ``OSError`` where the operation would have run; a full
  disk stays full: ``ENOSPC`` fails every later event that takes space too (files opened for writing, folders
  made), while removals go on working as they do on a full disk;
* ``pause``: waits until the test lets it go (two writers interleaved at that step).

Writers (:data:`WRITERS`) model every way mitnerf writes: a folder staged then swapped in (``dataset``,
``fit``, ``video``, ``show``), a folder filled file by file (``experiment``, ``sweep``), a single new file
(``tiny_nerf``), a cache entry. Each writes a version tag into every file, so :func:`check` can tell a
whole output of one version from a mix.
"""

from __future__ import annotations

import errno
import json
import os
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path

from mitnerf._io import MARKER, Output, atomic_write_text, cache_entry, read_marker

WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND
EVENTS = {"os.mkdir", "os.rename", "os.remove", "os.rmdir", "shutil.rmtree", "os.chmod", "os.truncate",
          "os.link", "os.symlink", "ctypes.call_function"}


@dataclass
class Plan:
    """What to do at event ``at`` (counted from 0) of thread ``thread``; ``seen`` lists the events so far."""

    action: str = "count"
    at: int = -1
    thread: int = field(default_factory=threading.get_ident)
    seen: list = field(default_factory=list)
    paused: threading.Event = field(default_factory=threading.Event)
    go: threading.Event = field(default_factory=threading.Event)


_PLAN: list = []
"""The plan in force (at most one); the hook is installed once per process and only reads this."""


def _writes(event: str, args: tuple) -> bool:
    if event == "open":
        mode, flags = args[1], args[2]
        return bool((isinstance(mode, str) and any(c in mode for c in "wax+")) or
                    (isinstance(flags, int) and flags & WRITE_FLAGS))
    return event in EVENTS


def _hook(event: str, args: tuple) -> None:
    if not _PLAN or not _writes(event, args):
        return
    plan = _PLAN[0]
    if threading.get_ident() != plan.thread:
        return
    k = len(plan.seen)
    plan.seen.append(event)
    full = plan.action == "ENOSPC" and 0 <= plan.at < k and event in ("open", "os.mkdir")
    if k != plan.at and not full:
        return
    if plan.action == "crash":
        os._exit(137)
    if plan.action == "pause":
        plan.paused.set()
        plan.go.wait(30)
        return
    code = getattr(errno, plan.action)
    raise OSError(code, os.strerror(code), str(args[0]) if args and isinstance(args[0], (str, bytes)) else None)


_installed: list = []


def run_with(plan: Plan, fn, *args):
    """``fn(*args)`` under ``plan`` (in this thread); returns ``(result, exception)``."""
    if not _installed:
        sys.addaudithook(_hook)
        _installed.append(True)
    plan.thread = threading.get_ident()
    _PLAN[:] = [plan]
    try:
        return fn(*args), None
    except (OSError, ValueError) as exc:        # OutputError is a ValueError (MitnerfError)
        return None, exc.with_traceback(None)   # as the command line drops it: the writer's frames go
    finally:
        _PLAN.clear()


def in_child(plan: Plan, fn, *args) -> int:
    """Run ``fn(*args)`` under ``plan`` in a forked child; its exit status (137: crashed at the event)."""
    pid = os.fork()
    if pid == 0:
        try:
            run_with(plan, fn, *args)
        finally:
            os._exit(0)
    return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])


# ------------------------------------------------------------------------------------------ writers

def _files(folder: Path, version: str, names) -> None:
    for name in names:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(version)


DATASET = ["train/transforms.json", "train/r_0.png", "train/r_1.png", "test/transforms.json", "test/r_0.png",
           "mitnerf.json"]
CHECKPOINT = ["weights.npz", "state.npz"]
CHECKPOINT_ATOMIC = ["history.json", "manifest.json", "metrics.json"]


def staged(kind: str, names, atomic=()):
    """A command that stages its whole output and swaps it in (``overwrite`` writes into a foreign folder)."""
    def write(target: Path, version: str, overwrite: bool = False) -> Path:
        out = Output(target, kind, overwrite)
        with out.staged() as tmp:
            _files(tmp, version, names)
            for name in atomic:
                atomic_write_text(tmp / name, version)
        return out.path
    return write


def incremental(target: Path, version: str, overwrite: bool = False) -> Path:
    """``mitnerf experiment`` / ``sweep``: the folder claimed first, then files written one by one, atomically."""
    out = Output(target, "experiment pe", overwrite, incremental=True)
    root = out.claim()
    for name in ("rows.csv", "pe/curve.png", "report.md"):
        (root / name).parent.mkdir(exist_ok=True)
        atomic_write_text(root / name, version)
    out.release()
    return root


def new_file(target: Path, version: str, overwrite: bool = False) -> Path:
    """``mitnerf dataset --format tiny_nerf``: one new file, never replacing one."""
    from mitnerf._io import write_new_file
    from mitnerf.data.formats import check_output
    check_output(target, "tiny_nerf")
    return write_new_file(target, version.encode())


def cached(target: Path, version: str, overwrite: bool = False) -> Path:
    """A cache entry (``$MITNERF_CACHE`` is the target's parent)."""
    os.environ["MITNERF_CACHE"] = str(target.parent)
    return cache_entry(target.name, lambda tmp: _files(tmp, version, ["mesh.ply", "texture.png"]))


WRITERS = {
    "dataset": (staged("dataset", DATASET), DATASET),
    "fit": (staged("fit", CHECKPOINT, CHECKPOINT_ATOMIC), CHECKPOINT + CHECKPOINT_ATOMIC),
    "video": (staged("video", ["color.gif", "mesh.ply", "chamfer.json"]), ["color.gif", "mesh.ply", "chamfer.json"]),
    "experiment": (incremental, ["rows.csv", "pe/curve.png", "report.md"]),
    "tiny_nerf": (new_file, None),
    "cache": (cached, ["mesh.ply", "texture.png"]),
}
"""name -> (write(target, version, overwrite), the files a whole output holds; None: a single file)."""


# -------------------------------------------------------------------------------------- the invariant

USER = "the user's own words"


def place_user_files(root: Path) -> None:
    """A file of the user's beside every output, and a photos folder a link may point at."""
    (root / "thesis.txt").write_text(USER)
    (root / "photos").mkdir(exist_ok=True)
    (root / "photos" / "IMG_0001.jpg").write_text(USER)


def check(root: Path, target: Path, names, versions: set, mode: str = "whole", foreign: bool = False):
    """The rules after any fault: the user's files intact, and at ``target`` (``mode``) ``whole``: nothing (where
    ``None`` is in ``versions``) or one whole output of one of ``versions``; ``files``: whole files, each of one of
    ``versions`` (an output written file by file); ``file``: nothing or one whole file. Returns the version found."""
    assert (root / "thesis.txt").read_text() == USER
    assert (root / "photos" / "IMG_0001.jpg").read_text() == USER and len(os.listdir(root / "photos")) == 1
    if foreign:
        assert (target / "notes.txt").read_text() == USER
    if mode == "file":
        found = target.read_text() if target.exists() else None
        assert found in versions, f"{found!r} at {target}"
        return found
    if mode == "whole" and read_marker(target) is None:        # no output (a half-built cache entry at most)
        assert None in versions, f"neither output is at {target}"
        return None
    present = [n for n in names if (target / n).exists()]
    found = {(target / n).read_text() for n in present}
    assert found <= versions, f"files of another run at {target}: {found}"
    if mode == "files":
        return found.pop() if len(found) == 1 else None
    assert len(present) == len(names), f"a partial output at {target}: only {present}"
    assert len(found) == 1, f"a mix of outputs at {target}: {found}"
    m = read_marker(target)
    assert m is not None and set(m.get("files") or names) >= set(names), f"no marker listing the output at {target}"
    return found.pop()


def leftovers(root: Path) -> list[str]:
    """Hidden entries mitnerf may leave only while it runs (staging folders, lock files, parts)."""
    out = []
    for here, dirs, files in os.walk(root):
        out += [os.path.join(here, n) for n in dirs + files if ".mitnerf-" in n]
    return out


def describe(plan: Plan) -> str:
    return json.dumps({"action": plan.action, "at": plan.at, "events": plan.seen[-3:]})


__all__ = ["MARKER", "Plan", "WRITERS", "check", "describe", "in_child", "leftovers", "place_user_files", "run_with"]
