"""The one results file (``$MITNERF_RESULTS``, else ``results.json`` at the top of the source tree): every
measured figure with the command and machine that made it, written by :func:`record_result`; documents are
generated from it (``python benchmarks/report.py``), so a figure is written in exactly one place."""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import platform
from pathlib import Path

from ._io import atomic_write_text, json_text


def results_path() -> Path:
    if os.environ.get("MITNERF_RESULTS"):
        return Path(os.environ["MITNERF_RESULTS"])
    top = Path(__file__).resolve().parents[1]
    return (top if (top / "pyproject.toml").exists() else Path.cwd()) / "results.json"


def load_results(path: Path | None = None) -> dict:
    path = path or results_path()
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def machine() -> dict:
    """What the figures were measured on: CPU, cores, vector width, library versions."""
    cpu, flags = platform.processor() or "unknown", ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
            elif line.startswith("flags"):
                flags = line
    versions = {}
    for mod in ("drjit", "mitsuba", "numpy", "torch"):
        with contextlib.suppress(Exception):
            versions[mod] = __import__(mod).__version__
    return {"cpu": cpu, "cores": os.cpu_count(), "simd": "AVX-512" if "avx512f" in flags else
            "AVX2" if "avx2" in flags else "other", "python": platform.python_version(), **versions}


def machine_line(m: dict) -> str:
    return f"{m.get('cpu', '?')} ({m.get('simd', '?')}), {m.get('threads', '?')} threads"


def record_result(key: str, values: dict, summary: str, command: str, recipe: str | None = None,
                  path: Path | None = None, threads: int | None = None, **extra) -> dict:
    """Store one measurement under ``key`` (replacing an older one), atomically; ``threads``: the CPU threads the
    measured run used (None: the size of Dr.Jit's thread pool now, which a run in this process set)."""
    import fcntl

    from drjit import thread_count

    threads = thread_count() if threads is None else int(threads)
    path = path or results_path()
    entry = {"summary": summary, "values": values, "command": command, "machine": {**machine(), "threads": threads},
             "date": datetime.date.today().isoformat(), **({"recipe": recipe} if recipe else {}), **extra}
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = load_results(path)
        data[key] = entry
        atomic_write_text(path, json_text(dict(sorted(data.items()))) + "\n")
    return entry
