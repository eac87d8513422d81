"""User errors, one type per kind; every message names the problem *and* the fix. Entry points print
them as one line and exit with status 2; library code raises them and never calls ``sys.exit``."""

import math


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


def check_number(name: str, value, lo=None, hi=None, integer: bool = False, strict_lo: bool = False,
                 flag: str | None = None) -> None:
    """Raise :class:`ConfigError` for a setting outside ``[lo, hi]`` (``(lo, hi]`` with
    ``strict_lo``), not finite, or of the wrong type; ``flag`` names it as the user typed it."""
    what = flag or name
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not float(value).is_integer()):
        raise ConfigError(f"{what} must be {'a whole' if integer else 'a'} number, got {value!r}")
    if not math.isfinite(value):
        raise ConfigError(f"{what} must be a finite number, got {value}")
    if lo is not None and (value <= lo if strict_lo else value < lo):
        raise ConfigError(f"{what} must be {'>' if strict_lo else '>='} {lo:g}, got {value:g}")
    if hi is not None and value > hi:
        raise ConfigError(f"{what} must be <= {hi:g}, got {value:g}")
