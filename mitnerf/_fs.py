"""File-system primitives for :mod:`mitnerf._io`'s rules: atomic files, the swap of two folders
(``renameat2``), flushing to disk, per-path locks, the hidden names of staging folders and their recovery after
a crash, and the cache. Library code writes through :mod:`mitnerf._io`."""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import hashlib
import json
import math
import os
import secrets
import shutil
import signal
import threading
import weakref
from pathlib import Path
from typing import Callable, Iterator

from . import __version__
from .errors import OutputError

MARKER = ".mitnerf"
STAGING = ".mitnerf-staging"
"""Written first into every staging folder (and removed once the marker is in): what it is, for a person."""
NOREPLACE, EXCHANGE = 1, 2


def renameat2(src: Path, dst: Path, flags: int) -> bool:
    """``renameat2(src, dst, flags)``; False where the kernel, the C library or the file system lacks it."""
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    if fn(-100, os.fsencode(src), -100, os.fsencode(dst), flags) == 0:         # -100: AT_FDCWD
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(dst))


def rename_new(src: Path, dst: Path) -> None:
    """Rename ``src`` to ``dst``, which must not exist (``FileExistsError`` otherwise)."""
    if not renameat2(src, dst, NOREPLACE):
        if os.path.lexists(dst):
            raise FileExistsError(errno.EEXIST, "exists", str(dst))
        os.rename(src, dst)


def fsync_path(path: Path, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else os.O_NOFOLLOW))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_tree(root: Path) -> None:
    """Flush every file and folder under ``root`` (links are not followed) to disk, folders last."""
    for here, dirs, files in os.walk(root, topdown=False):
        for name in files:
            if not os.path.islink(os.path.join(here, name)):
                fsync_path(Path(here, name))
        fsync_path(Path(here), directory=True)


def remove_tree(path: Path) -> None:
    """Delete a folder mitnerf made (staging or an earlier output of its own); links inside are removed, never
    followed; read-only folders of its own are made writable first."""
    def retry(fn, p, _exc):
        with contextlib.suppress(OSError):
            os.chmod(os.path.dirname(p), 0o700)
            fn(p)
    with contextlib.suppress(OSError):         # best effort: what stays is removed by the next run
        shutil.rmtree(path, onerror=retry)


def atomic_write_bytes(path: str | Path, data: bytes, *, replace: bool = True) -> Path:
    """Write ``data`` to ``path`` through a hidden sibling, flushed, then renamed into place. The parent must be a
    real folder (not a link) and ``path`` not a folder or a link; with ``replace=False`` an existing file is
    refused (:class:`~mitnerf.errors.OutputError`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if replace and path.parent.is_symlink():
        raise OutputError(f"{path.parent} is a link, which mitnerf does not write through; remove it or choose "
                          "another output")
    if path.is_symlink() or path.is_dir() or (path.exists() and not replace):
        what = "a link" if path.is_symlink() else "a folder" if path.is_dir() else "a file"
        raise OutputError(f"{path} is {what}; mitnerf never replaces {'it' if replace else 'a file'}: choose "
                          "another name")
    tmp = path.with_name(hidden(path, "part-") + secrets.token_hex(4))
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        (os.replace if replace else rename_new)(tmp, path)
        fsync_path(path.parent, directory=True)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path: str | Path, text: str, **kw) -> Path:
    return atomic_write_bytes(path, text.encode(), **kw)


def short(name: str, size: int = 80) -> str:
    """``name`` cut to ``size`` bytes (hidden siblings must fit the file system's 255-byte names)."""
    return os.fsdecode(os.fsencode(name)[:size])


def read_marker(path: Path) -> dict | None:
    """The marker of a folder mitnerf wrote, or None."""
    try:
        data = json.loads((Path(path) / MARKER).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("kind"), str) else None


class Lock:
    """An exclusive ``flock`` on ``.<name>.<hash>.mitnerf-lock`` beside a path, removed when released."""

    def __init__(self, target: Path, wait: bool):
        self.path = target.with_name(hidden(target, "lock"))
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
            except BlockingIOError:
                os.close(fd)
                raise OutputError(f"another mitnerf command is writing {target}; wait for it to finish or choose "
                                  "another output") from None
            try:
                same = os.stat(self.path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:        # not a file its last holder unlinked while we waited
                break
            os.close(fd)
        self._done = weakref.finalize(self, _unlock, fd, self.path)

    def release(self) -> None:
        self._done()


def _unlock(fd: int, path: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)         # while still held: a waiter that opened it sees another inode and retries
    os.close(fd)


def hidden(target: Path, what: str) -> str:
    """A hidden sibling's name for ``target``: short enough for any target name, unique to it."""
    h = hashlib.sha1(os.fsencode(target.name)).hexdigest()[:10]
    return f".{short(target.name, 60)}.{h}.mitnerf-{what}"


def recover(target: Path) -> None:
    """Undo what a crashed writer of ``target`` left (call with its lock held: no live writer remains): an
    earlier output set aside by a two-rename swap goes back if the path is empty; staging folders go. They are
    known by their names, which only mitnerf makes (:func:`hidden`, a hash of the target's name in them)."""
    prefix = hidden(target, "")
    with contextlib.suppress(FileNotFoundError):
        for entry in os.scandir(target.parent):
            rest = entry.name[len(prefix):]
            if entry.name.startswith(prefix) and rest[:5] == "part-" and len(rest) == 13:
                os.unlink(entry.path)
            if not (entry.name.startswith(prefix) and rest[:4] in ("tmp-", "old-") and len(rest) == 12
                    and entry.is_dir(follow_symlinks=False)):
                continue
            if rest.startswith("old-") and not os.path.lexists(target) and read_marker(Path(entry.path)):
                os.rename(entry.path, target)
            else:
                remove_tree(Path(entry.path))


def tidy(target: Path) -> None:
    """Remove what a dead writer of ``target`` left beside it (its lock file, staging folders), unless a live
    writer holds the lock; called where a command refuses ``target`` and so will not recover it itself."""
    target = Path(os.path.abspath(target))
    prefix = hidden(target, "")
    with contextlib.suppress(OSError):
        if not any(n.startswith(prefix) for n in os.listdir(target.parent)):
            return
        try:
            lock = Lock(target, wait=False)
        except OutputError:
            return
        try:
            recover(target)
        finally:
            lock.release()


@contextlib.contextmanager
def deferred_signals(second_stops: bool = True) -> Iterator[list]:
    """Record SIGINT and SIGTERM instead of raising; yields the list of the signals. Handlers of the main thread
    hold them (a mask would hold them from this thread only, and the kernel would hand them to another); with
    ``second_stops``, a second Ctrl-C stops at once. Elsewhere than the main thread, which alone receives Python's
    signals, nothing is held."""
    got: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield got
        return

    def handler(signum, frame):
        if second_stops and got and signum == signal.SIGINT:
            raise KeyboardInterrupt
        got.append(signum)

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield got
    finally:
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def no_interrupts() -> Iterator[None]:
    """SIGINT and SIGTERM wait until the block is done (a swap is never cut in half by Ctrl-C), then are raised
    again. A signal the command's handler saw before the block (its ``arrived``, ``mitnerf.cli``) is raised again
    first, so nothing is committed: its exception may have been dropped. A writer that saves after an interrupt (a
    fit's checkpoint) holds the signals with :func:`deferred_signals`, whose handler takes the command's place."""
    arrived = [n for s in (signal.SIGINT, signal.SIGTERM) for n in getattr(signal.getsignal(s), "arrived", ())]
    if arrived and threading.current_thread() is threading.main_thread():
        signal.raise_signal(arrived[0])
    held: list[int] = []
    try:
        with deferred_signals(second_stops=False) as held:
            yield
    finally:
        if held:
            signal.raise_signal(held[0])


def cache_root() -> Path:
    return Path(os.environ.get("MITNERF_CACHE", Path.home() / ".cache" / "mitnerf"))


def cache_entry(name: str, build: Callable[[Path], None]) -> Path:
    """The cache folder ``name`` under ``$MITNERF_CACHE`` (default ``~/.cache/mitnerf``), built by
    ``build(folder)`` when missing. Builders of one entry take turns (a lock): the first builds, the others
    find it built; a crashed build's leftovers are removed by the next."""
    final = cache_root() / name
    if read_marker(final) is not None:
        tidy(final)
        return final
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        lock = Lock(final, wait=True)
        try:
            recover(final)
            if read_marker(final) is None:
                _build_entry(final, build)
        finally:
            lock.release()
    except OSError as exc:
        raise OutputError(f"cannot write mitnerf's cache entry {final} ({exc.strerror or exc}); set MITNERF_CACHE "
                          "to a writable folder with free space") from None
    return final


def _build_entry(final: Path, build: Callable[[Path], None]) -> None:
    tmp = Path(final.parent, hidden(final, "tmp-") + secrets.token_hex(4))
    os.mkdir(tmp)
    try:
        (tmp / STAGING).write_bytes(b"")
        build(tmp)
        (tmp / MARKER).write_text(json.dumps({"kind": "cache", "version": __version__}))
        os.unlink(tmp / STAGING)
        fsync_tree(tmp)
        with no_interrupts():
            if not os.path.lexists(final):
                rename_new(tmp, final)
            elif not renameat2(tmp, final, EXCHANGE):      # a half-built entry of an older mitnerf
                remove_tree(final)
                rename_new(tmp, final)
    finally:
        remove_tree(tmp)


def json_text(obj, indent: int | None = 1) -> str:
    """Strict JSON (RFC 8259) of ``obj``: a NaN or an infinity becomes ``null``, numpy numbers become numbers,
    anything else that JSON lacks its text."""
    def clean(v):
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if hasattr(v, "item") and callable(v.item) and getattr(v, "ndim", 0) == 0:   # a numpy number
            v = v.item()
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if hasattr(v, "tolist"):
            return clean(v.tolist())
        return v if v is None or isinstance(v, (bool, int, str)) else str(v)
    return json.dumps(clean(obj), indent=indent, allow_nan=False)


def digest(*items: bytes | str) -> str:
    """A short content hash used to name cached files."""
    h = hashlib.sha1()
    for item in items:
        h.update(item.encode() if isinstance(item, str) else item)
    return h.hexdigest()[:12]


def available_memory() -> int | None:
    """Bytes available to a new allocation (Linux: MemAvailable, within a cgroup limit; elsewhere the
    free pages), or None when unknown."""
    avail = None
    with contextlib.suppress(OSError, ValueError, IndexError), open("/proc/meminfo") as f:
        avail = next((int(line.split()[1]) * 1024 for line in f if line.startswith("MemAvailable:")), None)
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return None
    with contextlib.suppress(OSError, ValueError):
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit != "max":
            avail = min(avail, int(limit) - int(Path("/sys/fs/cgroup/memory.current").read_text()))
    return max(avail, 0)
