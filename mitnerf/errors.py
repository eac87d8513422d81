"""User errors, one type per kind; every message names the problem *and* the fix. Entry points print
them as one line and exit with status 2; library code raises them and never calls ``sys.exit``."""

import errno
import os


class MitnerfError(ValueError):
    """Bad input: the message says what is wrong and how to fix it."""


class DataError(MitnerfError):
    """A dataset, polygon or scene file that cannot be used as it is."""


class ConfigError(MitnerfError):
    """A setting out of range (a recipe override, a command-line number)."""


class CheckpointError(MitnerfError):
    """A checkpoint that is missing, corrupt, edited, or of another model or format."""


class OutputError(MitnerfError):
    """An output path that mitnerf refuses to write (it holds what mitnerf did not write)."""


class EnvironmentProblem(MitnerfError):
    """The machine lacks something mitnerf needs (LLVM >= 16, a Mitsuba variant, memory)."""


class Note(UserWarning):
    """Something the user should know that is not an error (an open outline closed, frames skipped): the command
    line prints it as one line, ``mitnerf: note: ...``."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Python runs next (the command line's handler), so that every ``finally`` (staging
    folders, locks) runs as for Ctrl-C."""


_FIXES = {
    errno.ENOSPC: "free some space or choose another place", errno.EDQUOT: "free some space or choose another place",
    errno.EACCES: "check its permissions or choose another place", errno.EPERM: "check its permissions or choose "
    "another place", errno.EROFS: "its file system is read-only: choose another place",
    errno.ENAMETOOLONG: "choose a shorter name", errno.ENOTDIR: "a part of the path is a file, not a folder: choose "
    "another path", errno.EISDIR: "it is a folder where a file was expected: choose another path",
    errno.ENOENT: "it vanished while mitnerf worked: check the path", errno.ELOOP: "it runs through a link mitnerf "
    "does not follow: give the real path", errno.EIO: "the disk reported an error: check it",
    errno.EMFILE: "too many open files: raise the limit (ulimit -n)",
}


def os_error_line(exc: OSError, where=None) -> str:
    """One line for a file-system failure: where (``where``, else the paths the error names), what, and the fix
    (the command line prints it, exit 2)."""
    where = where or " -> ".join(os.fsdecode(f) for f in (exc.filename, exc.filename2) if f is not None) or "a file"
    what = exc.strerror or str(exc) or type(exc).__name__
    return f"{where}: {what}; {_FIXES.get(exc.errno, 'check the path and the disk')}"
