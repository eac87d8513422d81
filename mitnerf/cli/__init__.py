"""mitnerf: neural radiance fields on a CPU. Render a ground truth with Mitsuba 3 (`dataset`) or pose your own
photographs (`poses`), fit a field to either (`fit`), look at both (`show`, `video`), and run the experiments
(`experiment`, `sweep`).

Every bad input and every file-system failure (a full disk, a read-only folder) ends in one line on stderr
(``mitnerf: error: ...``, naming the problem and the fix) and exit status 2, with nothing written. A training run
that stops (NaN, collapse) exits 1. Ctrl-C or SIGTERM ends any command with one line, its temporary files removed,
and exit status 130 (SIGINT) or 143 (SIGTERM); ``fit`` first writes its checkpoint and says how to resume. (CPython
3.11 ends a process by SIGINT itself, which a shell also reports as 130, when a KeyboardInterrupt passed through
code that ``exec()`` ran, caught or not.)"""

from __future__ import annotations

import argparse
import contextlib
import gc
import signal
import sys
import traceback
import warnings

from .._variant import set_variant
from ..errors import ConfigError, MitnerfError, Note, Terminated, os_error_line
from . import compare_cmd, data_cmds, experiment_cmd, fit_cmd, poses_cmd, video_cmd


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (a :class:`ConfigError`), not usage text."""

    def error(self, message: str):
        raise ConfigError(f"{self.prog}: {message}; see `{self.prog} --help`")

    def _get_values(self, action, arg_strings):
        if action.nargs is None and action.option_strings and arg_strings == ["--"]:   # "--frames=--"
            self.error(f"argument {'/'.join(action.option_strings)}: expected one value, got '--'")
        return super()._get_values(action, arg_strings)


def build_parser() -> Parser:
    parser = Parser(prog="mitnerf", description=" ".join(__doc__.split("\n\n")[0].split()))
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in (data_cmds, poses_cmd, fit_cmd, compare_cmd, video_cmd, experiment_cmd):
        module.register(sub)
    return parser


@contextlib.contextmanager
def _signals_raise():
    """SIGTERM and SIGINT raise :class:`Terminated` and :class:`KeyboardInterrupt`; yields the signals the handler saw
    (its ``arrived``). Python drops an exception raised inside a callback (a weak reference's, during an import) and
    turns one raised in a class's ``__set_name__`` into a RuntimeError, so an output checks ``arrived`` before it is
    committed (:func:`mitnerf._fs.no_interrupts`), and after a signal :func:`main` takes an unexpected error for it."""
    def interrupt(signum, frame):
        interrupt.arrived.append(signum)
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
    def unraisable(info):               # an interrupt dropped by Python: in ``arrived``, raised again before a commit
        if not isinstance(info.exc_value, KeyboardInterrupt):
            hook(info)
    interrupt.arrived = []
    try:                                # a signal ignored from the start (a job in the background) stays ignored
        old = {s: signal.signal(s, interrupt) for s in (signal.SIGTERM, signal.SIGINT)
               if signal.getsignal(s) is not signal.SIG_IGN}
    except ValueError:                  # not the main thread: leave signals alone
        yield interrupt.arrived
        return
    hook, sys.unraisablehook = sys.unraisablehook, unraisable
    try:
        yield interrupt.arrived
    finally:
        sys.unraisablehook = hook
        for s, handler in old.items():
            signal.signal(s, handler)


class _NotesFirst:
    """The command's stdout, which prints the notes heard so far (to stderr, one line each) before its first line:
    notes come once the inputs are checked and the work begins, never beside a refusal's one line."""

    def __init__(self, out, notes: list):
        self._out, self.notes = out, notes

    def flush_notes(self) -> None:
        while self.notes:
            print(f"mitnerf: note: {self.notes.pop(0)}", file=sys.stderr, flush=True)

    def write(self, text: str) -> int:
        self.flush_notes()
        return self._out.write(text)

    def __getattr__(self, name):
        return getattr(self._out, name)


def main(argv: list[str] | None = None) -> int:
    for stream in (sys.stdout, sys.stderr):         # a folder name that is not UTF-8 still prints
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="backslashreplace")
    out, arrived = _NotesFirst(sys.stdout, []), []
    try:
        with _signals_raise() as arrived, warnings.catch_warnings(), contextlib.redirect_stdout(out):
            warnings.simplefilter("always", Note)             # a Note waits for the work; other warnings as usual
            show = warnings.showwarning
            warnings.showwarning = lambda message, category, *a, **k: out.notes.append(str(message)) \
                if issubclass(category, Note) else show(message, category, *a, **k)
            args = build_parser().parse_args(argv)
            set_variant()
            status = int(args.run(args) or 0)
            out.flush_notes()
            return status
    except (MitnerfError, OSError) as exc:
        print(f"mitnerf: error: {os_error_line(exc) if isinstance(exc, OSError) else exc}", file=sys.stderr)
        return 2
    except Exception as exc:
        if not arrived:
            raise
        _drop_frames(exc)
        return _interrupted(arrived[0] == signal.SIGTERM, "")    # the signal's exception, changed on its way
    except KeyboardInterrupt as exc:
        _drop_frames(exc)
        return _interrupted(isinstance(exc, Terminated), getattr(exc, "note", ""))


def _drop_frames(exc: BaseException) -> None:
    """Free what the interrupted frames held, unprinted whatever its ``__del__`` raises (an image writer cut off half
    made cannot close): the interrupt's one line says what happened."""
    hook, sys.unraisablehook = sys.unraisablehook, lambda info: None
    try:
        seen = set()
        while exc is not None and id(exc) not in seen:        # the exceptions it was raised from hold frames too
            seen.add(id(exc))
            traceback.clear_frames(exc.__traceback__)
            exc = exc.__cause__ or exc.__context__
        gc.collect()
    finally:
        sys.unraisablehook = hook


def _interrupted(term: bool, note: str) -> int:
    """The line and the exit status of a command stopped by SIGTERM (``term``) or SIGINT."""
    print(f"mitnerf: interrupted ({'SIGTERM' if term else 'SIGINT'}); temporary files removed, earlier outputs "
          f"untouched{note}", file=sys.stderr)
    return 143 if term else 130


def example_main(name: str, doc: str, argv=None) -> int:
    """What an ``examples/`` script of an experiment runs: ``mitnerf experiment <name>`` with
    ``--out`` defaulting to ``out/experiments/<name>`` (other flags pass through)."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=f"out/experiments/{name}")
    a, rest = p.parse_known_args(argv)
    return main(["experiment", name, "--out", a.out, *(["--quick"] if a.quick else []), *rest])


if __name__ == "__main__":
    sys.exit(main())
