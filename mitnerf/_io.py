"""Safe outputs: mitnerf never deletes, replaces or writes through what it did not write.

The rules, checked when an :class:`Output` is made (before any work) and again at its commit:

* A command writes a new folder, an empty one, or its own earlier output of the same kind: a folder whose
  marker (``.mitnerf``) names that kind and lists every entry mitnerf put there. A folder holding anything
  else is foreign: refused with one line naming ``--overwrite``, with which mitnerf writes its files into
  it and leaves it foreign (no marker, so the next run needs ``--overwrite`` again).
* A plain file or a symbolic link at the path is never replaced; nothing is written through a link inside
  an output; an output that equals, holds or lies inside an input of the same command is refused.
* The work is staged in a hidden sibling, its files and folders flushed to disk (``fsync``), then swapped
  in by one ``renameat2(RENAME_EXCHANGE)`` (two renames where the kernel lacks it; a crash between them is
  undone by the next run for the path): the path always holds the previous output or the new one, whole.
* One writer per path: a lock file beside it (``fcntl.flock``) from the moment the output is made; a
  second command for the same path is refused at once. If the path changed while the work ran (someone
  put files into it), the result goes to a fresh sibling (``NAME-2``) and the command says so.
* A crashed run's staging folders and lock files are removed by the next run for the same path.

``tests/faults`` crashes, fills the disk, denies access and interleaves two writers at every file-system
event of these writers and checks the rules after each.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import secrets
import shutil
import stat
import weakref
from pathlib import Path
from typing import Iterator

from . import __version__
from ._fs import (EXCHANGE, MARKER, STAGING, Lock, atomic_write_bytes, atomic_write_text, cache_entry, cache_root,
                  digest, available_memory, fsync_path, fsync_tree, hidden, json_text, no_interrupts, read_marker, recover,
                  remove_tree, rename_new, renameat2, tidy)
from .errors import OutputError, os_error_line


def write_new_file(path: str | Path, data: bytes) -> Path:
    """Write ``data`` as the new file ``path`` (an existing one is refused), holding the path's lock; what a
    crashed writer of it left is removed first."""
    path = Path(os.path.abspath(path))
    check_place(path, len(data))
    lock = Lock(path, wait=False)
    try:
        recover(path)
        return atomic_write_bytes(path, data, replace=False)
    finally:
        lock.release()


def _entries(root: Path) -> set[str]:
    """Every entry under ``root`` (files, folders, links; links not followed), relative, but the marker."""
    out = set()
    for here, dirs, files in os.walk(root):
        rel = os.path.relpath(here, root)
        out.update(os.path.normpath(os.path.join(rel, n)) for n in dirs + files)
    out.discard(MARKER)
    return out


def _state(p: Path, kind: str, incremental: bool = False) -> tuple:
    """What ``p`` holds: ``("absent",)``, ``("empty",)``, ``("own", id)`` (an earlier output of ``kind``,
    nothing but its listed entries and no links; with ``incremental``, any folder marked as written file by
    file by ``kind``), ``("file",)``, ``("link",)`` or ``("foreign", what)``."""
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        return ("absent",)
    if stat.S_ISLNK(st.st_mode):
        return ("link",)
    if not stat.S_ISDIR(st.st_mode):
        return ("file",)
    entries = _entries(p)
    marker = read_marker(p)
    if not entries and marker is None:
        return ("empty",)
    if marker is not None and marker["kind"] != kind:
        return ("foreign", f"a mitnerf {marker['kind']} output")
    listed = marker.get("files") if marker else []
    if incremental and marker is not None and listed is None:
        return ("own", marker.get("id"))
    if not isinstance(listed, list):
        return ("foreign", f"a mitnerf {kind} output that does not list its files (from an older mitnerf, or "
                           "written file by file), so mitnerf cannot tell them from yours")
    links = sorted(e for e in entries if os.path.islink(p / e))
    extra = links or sorted(entries - set(listed))
    if marker is not None and not extra:
        return ("own", marker.get("id"))
    return ("foreign", f"files mitnerf did not write (such as {extra[0]!r})")


# ------------------------------------------------------------------------------------------- outputs

class Output:
    """A folder a command of ``kind`` (``dataset``, ``fit``, ``video``, ...) will write, checked now, before any
    work, against the module's rules (raising :class:`~mitnerf.errors.OutputError`): ``inputs`` are the paths
    the command reads, ``size`` the bytes it will write (refused when the disk lacks them). It holds the path's
    lock until :meth:`staged` commits or the process ends. ``incremental`` outputs are written file by file as
    the work goes (:meth:`claim`: experiments, sweeps) and may be continued by a later run of their kind."""

    def __init__(self, path: str | Path, kind: str, overwrite: bool = False, inputs=(), size: int = 0,
                 incremental: bool = False):
        self.path = self.requested = Path(os.path.abspath(os.fspath(path)))
        self.kind, self.overwrite, self.incremental = kind, overwrite, incremental
        p = self.path
        if p.parent == p:
            raise OutputError(f"mitnerf will not write the root folder {p}; choose an output folder")
        check_place(p, size)
        _check_inputs(p, [i for i in inputs if i is not None])
        self._judge(_state(p, kind, incremental))               # refused before anything is made
        try:
            made = _make_parents(p.parent)
            self._made = weakref.finalize(self, _remove_empty, made)
            try:
                self._lock = Lock(p, wait=False)
            except BaseException:
                self._made()
                raise
            try:
                recover(p)
                self.state = self._judge(_state(p, kind, incremental))
            except BaseException:
                self.release()
                raise
        except OSError as exc:
            raise OutputError(f"cannot write {os_error_line(exc, where=p)}") from None

    def _judge(self, state: tuple) -> tuple:
        p = self.path
        if state[0] in ("file", "link") or (state[0] == "foreign" and not self.overwrite):
            tidy(p)
        if state[0] == "file":
            raise OutputError(f"{p} exists and is not a folder; mitnerf never replaces a file: choose another "
                              "output folder")
        if state[0] == "link":
            raise OutputError(f"{p} is a symbolic link; mitnerf does not write through links: give the folder "
                              "it points to, or another output folder")
        if state[0] == "foreign" and not self.overwrite:
            raise OutputError(f"{p} holds {state[1]}; choose a new or empty folder, or pass --overwrite to write "
                              "mitnerf's files into it (nothing else there is touched)")
        return state

    def release(self) -> None:
        """Give up the path's lock (done by :meth:`staged` and at exit)."""
        self._lock.release()
        self._made()

    def _marker(self, files) -> bytes:
        return json.dumps({"kind": self.kind, "version": __version__, "id": secrets.token_hex(8),
                           "files": files}).encode()

    @contextlib.contextmanager
    def staged(self) -> Iterator[Path]:
        """Yield a hidden staging folder beside the output; when the block succeeds its content becomes the output
        (see the module's rules; a foreign folder with ``overwrite`` gets the files, not the folder)."""
        tmp, committed = None, False
        try:
            tmp = self._staging_name()      # named before it is made: the finally removes it whenever a signal falls
            self._make_staging(tmp)
            yield tmp
            with no_interrupts():
                self._commit(tmp)
                committed = True
        except OSError as exc:          # named by the output, not by the hidden folder it was staged in
            raise OutputError(f"cannot write {os_error_line(exc, where=self.requested)}") from None
        except KeyboardInterrupt as exc:
            if committed:               # the signal waited for the commit: the interrupt's line says so
                exc.note = f"; {self.requested} was written whole before the signal was taken"
            raise
        finally:
            if tmp is not None:
                remove_tree(tmp)       # the staging folder, or (after an exchange) the previous output
            self.release()

    def _staging_name(self) -> Path:
        """A fresh staging folder's name beside the output (:meth:`_make_staging` makes it)."""
        return Path(self.path.parent, hidden(self.path, "tmp-") + secrets.token_hex(4))

    @staticmethod
    def _make_staging(tmp: Path) -> None:
        """Make the staging folder ``tmp`` with its staging note; the caller, which holds its name, removes it."""
        os.mkdir(tmp)
        (tmp / STAGING).write_bytes(b"")

    def _commit(self, tmp: Path) -> None:
        p, merge = self.path, self.state[0] == "foreign"
        if not merge:               # the marker first, then the staging note: a leftover always has one of them
            (tmp / MARKER).write_bytes(self._marker(sorted(_entries(tmp) - {STAGING})))
            os.unlink(tmp / STAGING)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)
        fsync_tree(tmp)
        now = _state(p, self.kind, self.incremental)
        why = None
        if merge and now[0] == "foreign":
            why = _merge_conflict(tmp, p)
            if why is None:
                _merge(tmp, p)
        elif now[0] == "own" and now == self.state:
            if not renameat2(tmp, p, EXCHANGE):        # two renames: the next run undoes a crash between them
                old = Path(p.parent, hidden(p, "old-") + secrets.token_hex(4))
                os.rename(p, old)
                os.rename(tmp, old.with_name(p.name))
                remove_tree(old)
        elif now[0] in ("absent", "empty") and (merge or self.state[0] in ("absent", "empty")):
            try:
                (os.rename if now[0] == "empty" else rename_new)(tmp, p)
            except OSError as exc:
                if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR, errno.EISDIR):
                    raise
                why = "something else was put there"
        else:
            why = {"own": "another mitnerf output replaced it", "foreign": now[1] if len(now) > 1 else "",
                   "file": "a file was put there", "link": "a link was put there"}.get(now[0], now[0])
            why = f"it now holds {why}" if now[0] == "foreign" else why
        if why is not None:
            self._divert(tmp, why)
        fsync_path(p.parent, directory=True)

    def _divert(self, tmp: Path, why: str) -> None:
        """Keep the result in a fresh sibling ``NAME-k`` (an output of its own) and stop with the line that says
        where."""
        if not (tmp / MARKER).exists():
            (tmp / MARKER).write_bytes(self._marker(sorted(_entries(tmp) - {STAGING})))
            fsync_path(tmp / MARKER)
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp / STAGING)
        for k in range(2, 10 ** 6):
            other = self.path.with_name(f"{self.path.name}-{k}")
            try:
                rename_new(tmp, other)
                break
            except FileExistsError:
                continue
        self.path = other
        raise OutputError(f"{self.requested} changed while this command ran ({why}); nothing there was touched, "
                          f"and the result is in {other}")

    def claim(self) -> Path:
        """Make the folder now, for an incremental output written file by file as the work goes (each file through
        :func:`atomic_write_bytes`); a new or empty folder gets the marker of ``kind``, a foreign one none."""
        p = self.path
        if self.state[0] in ("absent", "empty"):
            tmp = self._staging_name()
            try:
                self._make_staging(tmp)
                (tmp / MARKER).write_bytes(self._marker(None))
                os.unlink(tmp / STAGING)
                fsync_tree(tmp)
                (os.rename if self.state[0] == "empty" else rename_new)(tmp, p)
            finally:
                remove_tree(tmp)
        else:                           # an earlier run's: parts of files a crash cut short go
            for here, _, files in os.walk(p):
                for name in files:
                    if name.startswith(".") and ".mitnerf-part-" in name:
                        os.unlink(os.path.join(here, name))
        self._made.detach()
        return p


def check_place(p: Path, size: int) -> None:
    """The checks that need no work: the nearest existing folder above ``p`` is a folder, writable, with room
    for ``size`` bytes, and every name on the way fits the file system."""
    here, missing = p.parent, [p.name]
    while not os.path.lexists(here):
        missing.append(here.name)
        here = here.parent
    if not here.is_dir():
        raise OutputError(f"{here} is a file, so {p} cannot be made; choose an output folder elsewhere")
    limit = os.pathconf(here, "PC_NAME_MAX") if hasattr(os, "pathconf") else 255
    long = next((n for n in missing if len(os.fsencode(n)) > limit), None)
    if long is not None:
        raise OutputError(f"the name {long[:40]!r}... is {len(os.fsencode(long))} bytes, more than the {limit} the "
                          f"file system allows; choose a shorter output name")
    if not os.access(here, os.W_OK | os.X_OK):
        ro = os.statvfs(here).f_flag & os.ST_RDONLY
        raise OutputError(f"cannot write in {here}: {'its file system is read-only' if ro else 'permission denied'}; "
                          "choose an output folder elsewhere")
    free = shutil.disk_usage(here).free
    if size > free:
        raise OutputError(f"{p} needs about {size / 2**20:,.0f} MiB and {here} has {free / 2**20:,.0f} MiB free; "
                          "free some space or choose an output folder elsewhere")


def _check_inputs(p: Path, inputs: list) -> None:
    out = Path(os.path.realpath(p))
    for given in inputs:
        src = Path(os.path.realpath(given))
        how = "is" if src == out else "holds" if src.is_relative_to(out) else "lies inside" \
            if out.is_relative_to(src) else None
        if how:
            raise OutputError(f"the output {p} {how} the input {given}; writing it could destroy what this command "
                              "reads: choose an output folder outside it")


def _make_parents(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; the ones made, deepest first."""
    made = []
    while not os.path.lexists(folder):
        made.append(folder)
        folder = folder.parent
    for f in reversed(made):
        with contextlib.suppress(FileExistsError):
            os.mkdir(f)
    return made


def _remove_empty(folders: list[Path]) -> None:
    for f in folders:
        with contextlib.suppress(OSError):
            os.rmdir(f)


def _merge_conflict(src: Path, dst: Path) -> str | None:
    """Why the entries of ``src`` cannot be moved into the foreign folder ``dst`` (a link or a file where they
    go, a folder where a file goes), or None."""
    for rel in sorted(_entries(src) - {STAGING}):
        here = dst / rel
        try:
            st = os.lstat(here)
        except FileNotFoundError:
            continue
        if stat.S_ISLNK(st.st_mode):
            return f"{here} is a link, which mitnerf does not write through"
        if stat.S_ISDIR(st.st_mode) != (src / rel).is_dir():
            return f"{here} is a {'folder' if stat.S_ISDIR(st.st_mode) else 'file'} where mitnerf writes the other"
    return None


def _merge(src: Path, dst: Path) -> None:
    """Move the files of ``src`` into ``dst``, folder by folder, never following a link (``O_NOFOLLOW``)."""
    def into(folder: Path, fd: int) -> None:
        for entry in os.scandir(folder):
            if entry.name == STAGING and folder == src:
                continue
            if entry.is_dir(follow_symlinks=False):
                with contextlib.suppress(FileExistsError):
                    os.mkdir(entry.name, dir_fd=fd)
                sub = os.open(entry.name, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW, dir_fd=fd)
                try:
                    into(Path(entry.path), sub)
                    os.fsync(sub)
                finally:
                    os.close(sub)
            else:
                os.replace(entry.path, entry.name, dst_dir_fd=fd)
    top = os.open(dst, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    try:
        into(src, top)
        os.fsync(top)
    finally:
        os.close(top)


__all__ = ["MARKER", "Output", "atomic_write_bytes", "atomic_write_text", "available_memory", "cache_entry",
           "cache_root", "check_place", "digest", "json_text", "read_marker", "tidy", "write_new_file"]
