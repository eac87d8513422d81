"""Benchmarks that measure mitnerf as a user runs it: a command in a fresh process from the repository's root,
timed with its start-up, its printed lines kept."""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(cmd: list, ok=(0,)) -> tuple[list[str], float]:
    """``cmd`` (strings or paths) from the repository's root: (its stdout lines, seconds); an exit status not in
    ``ok`` stops the benchmark with the command and its last error line."""
    cmd = [str(c) for c in cmd]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    if r.returncode not in ok:
        sys.exit(f"`{' '.join(cmd)}` failed: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return r.stdout.strip().splitlines(), wall


def mitnerf(*args, ok=(0,)) -> tuple[list[str], float]:
    """``python -m mitnerf ARGS``: :func:`run`."""
    return run([sys.executable, "-m", "mitnerf", *args], ok)


def said(lines: list[str], head: str) -> str:
    """The first printed line that starts with ``head`` (``?`` if none)."""
    return next((ln for ln in lines if ln.startswith(head)), "?")


def alternating(modes: tuple, repeats: int, measure) -> dict[str, list]:
    """``{mode: [measure(mode), ...]}`` over ``repeats`` rounds, the modes in order on even rounds and reversed on odd
    ones, so that neither always runs first on a machine whose speed drifts."""
    runs: dict = {m: [] for m in modes}
    for k in range(repeats):
        for mode in (modes if k % 2 == 0 else modes[::-1]):
            runs[mode].append(measure(mode))
    return runs


def medians(runs: dict[str, list], keys: tuple) -> dict:
    """``{f"{mode}_{key}": the median of key over that mode's measurements}``."""
    return {f"{m}_{key}": statistics.median(r[key] for r in rs) for m, rs in runs.items() for key in keys}


def child(code: str, *args) -> dict:
    """``python -c CODE ARGS`` (strings or paths) in a fresh process, for a measurement that must not share this one's
    memory or compiled kernels: the JSON of its last printed line."""
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def lego_step_args(name: str, doc: str, argv, data: Path, repeats: int):
    """The ``--data`` and ``--repeats`` of a benchmark timing training steps on the lego (``name``, whose ``doc``'s
    first line is its help); None, after one line saying so, where the folder holds no lego."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--data", type=Path, default=data)
    p.add_argument("--repeats", type=int, default=repeats)
    args = p.parse_args(argv)
    if not (args.data / "transforms_train.json").exists():
        print(f"{name}: no lego at {args.data}; nothing measured")
        return None
    return args
