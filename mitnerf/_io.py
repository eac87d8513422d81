"""Safe outputs: mitnerf never deletes or replaces what it did not write.

A folder a command writes (:class:`Output`, checked before any work starts) is written when missing or
empty, replaced as a whole when it carries mitnerf's marker (``.mitnerf``) of the same kind, and else
refused with one line that names ``--overwrite`` (with it, mitnerf writes its own files into it and
leaves every other file alone). A plain file is never replaced, not even with ``overwrite``.
Writes are atomic: built in a temporary sibling and renamed into place.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Iterator

from . import __version__
from .errors import OutputError

MARKER = ".mitnerf"


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary sibling and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_dir():
        raise OutputError(f"{path} is a folder; mitnerf will not replace it with a file: remove it or choose "
                          "another output")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)      # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def read_marker(path: Path) -> dict | None:
    """The marker of a folder mitnerf wrote, or None."""
    try:
        data = json.loads((Path(path) / MARKER).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("kind"), str) else None


def _first_entry(path: Path) -> str | None:
    with os.scandir(path) as it:
        return next((entry.name for entry in it), None)


class Output:
    """A folder that a command of ``kind`` (``dataset``, ``fit``, ``video``, ...) will write. Construct it
    before any work: it applies the module's rules and raises :class:`~mitnerf.errors.OutputError`."""

    def __init__(self, path: str | Path, kind: str, overwrite: bool = False):
        self.path, self.kind, self.overwrite = Path(path), kind, overwrite
        self.merge = False                  # write into a foreign folder, file by file
        p = self.path
        if p.is_symlink() or (p.exists() and not p.is_dir()):
            raise OutputError(f"{p} exists and is not a folder; mitnerf never replaces a file: "
                              "choose another output folder")
        if p.is_dir():
            try:
                first = _first_entry(p)
            except OSError as exc:
                raise OutputError(f"cannot read {p} ({exc.strerror}); choose another output folder") from None
            marker = read_marker(p)
            if first is not None and (marker is None or marker["kind"] != kind):
                if not overwrite:
                    what = (f"a mitnerf {marker['kind']} output" if marker else f"files mitnerf did not write "
                            f"(such as {first!r})")
                    raise OutputError(f"{p} holds {what}; choose a new or empty folder, or pass --overwrite to "
                                      "write mitnerf's files into it (nothing else there is touched)")
                self.merge = True

    def _marker_bytes(self) -> bytes:
        return json.dumps({"kind": self.kind, "version": __version__}).encode()

    @contextlib.contextmanager
    def staged(self) -> Iterator[Path]:
        """Yield a temporary sibling folder; when the block succeeds it becomes the output
        (or, for a foreign folder with ``overwrite``, its files are moved into it)."""
        p = self.path
        p.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{p.name}.tmp-", dir=p.parent))
        try:
            yield tmp
            (tmp / MARKER).write_bytes(self._marker_bytes())
            if self.merge:
                _move_files_into(tmp, p)
            elif p.is_dir() and _first_entry(p) is not None:          # our own earlier output
                old = p.with_name(f".{p.name}.old-{os.getpid()}")
                os.replace(p, old)
                os.replace(tmp, p)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(tmp, p)                                   # new, or an empty folder
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def claim(self) -> Path:
        """Create the folder now and mark it, for outputs written file by file as work goes
        (experiments, sweeps); every file should then go through :func:`atomic_write_bytes`."""
        self.path.mkdir(parents=True, exist_ok=True)
        if not self.merge or read_marker(self.path) is None:
            atomic_write_bytes(self.path / MARKER, self._marker_bytes())
        return self.path


def _move_files_into(src: Path, dst: Path) -> None:
    for root, _, files in os.walk(src):
        rel = Path(root).relative_to(src)
        (dst / rel).mkdir(parents=True, exist_ok=True)
        for name in files:
            target = dst / rel / name
            if target.is_dir():
                raise OutputError(f"{target} is a folder where mitnerf writes a file; move it away and retry")
            os.replace(Path(root) / name, target)


def cache_entry(name: str, build: Callable[[Path], None]) -> Path:
    """The cache folder ``name`` under ``$MITNERF_CACHE`` (default ``~/.cache/mitnerf``), built by
    ``build(tmp_folder)`` if missing; of concurrent builders the first rename wins."""
    final = Path(os.environ.get("MITNERF_CACHE", Path.home() / ".cache" / "mitnerf")) / name
    if (final / MARKER).exists():
        return final
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=final.parent))
    try:
        build(tmp)
        (tmp / MARKER).write_text(json.dumps({"kind": "cache"}))
        try:
            os.rename(tmp, final)
        except OSError:
            if not (final / MARKER).exists():     # a half-built leftover of a killed process: replace it
                old = final.with_name(f".{final.name}.stale-{os.getpid()}")
                os.rename(final, old)
                shutil.rmtree(old, ignore_errors=True)
                os.rename(tmp, final)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return final


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
