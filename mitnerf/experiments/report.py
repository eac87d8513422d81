"""Plumbing every experiment shares: one run -> one row (a ``RunRecord`` row plus the experiment's
labels), rows -> CSV, mean and spread over seeds, the Pareto front, markdown tables, ``report.md``."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Callable

import numpy as np

from .._io import atomic_write_text
from ..data.dataset import Dataset
from ..train.fit import fit_and_evaluate
from ..train.recipes import Recipe
from ..viz.panels import num


def train_row(dataset: Dataset, recipe: Recipe, labels: dict, backend: str = "drjit",
              geometry_metrics: bool = True) -> tuple[dict, object, object]:
    """Fit and evaluate one configuration, with a progress bar and a line naming it and its result; -> (row, run,
    record). Never raises for a failed run."""
    name = ", ".join(f"{k} {v}" for k, v in labels.items())
    print(f"{name}: training {recipe.name}", flush=True)
    run, rec = fit_and_evaluate(dataset, recipe, backend, geometry_metrics=geometry_metrics, progress=True)
    print(f"{name}: {rec.line()}", flush=True)
    return {**labels, **rec.row()}, run, rec


def write_csv(path: Path, rows: list[dict]) -> Path:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys)
    w.writeheader()
    w.writerows(rows)
    return atomic_write_text(path, buf.getvalue())


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def summarise(rows: list[dict], by: list[str], metrics=("psnr", "ssim")) -> list[dict]:
    """Rows grouped by the ``by`` columns: ``runs``, ``failed``, ``failure_rate``, ``failures`` (the failed runs'
    distinct reasons, before any detail), and each metric's mean, ``_std``, ``_min``, ``_max``, ``_median``, ``_p10``
    and ``_p90`` over the ok runs."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    out = []
    for key, rs in groups.items():
        ok = [r for r in rs if r.get("status") == "ok"]
        why = sorted({str(r.get("reason")).split(";")[0].split(" (")[0] for r in rs if r.get("status") != "ok"})
        row = {**dict(zip(by, key)), "runs": len(rs), "failed": len(rs) - len(ok),
               "failure_rate": 1 - len(ok) / len(rs), "failures": "; ".join(why) or "-"}
        for m in metrics:
            vals = np.array([num(r.get(m)) for r in ok])
            vals = vals[np.isfinite(vals)]
            stats = ((vals.mean(), vals.std(), vals.min(), vals.max(), *np.percentile(vals, [50, 10, 90])) if vals.size
                     else (math.nan,) * 7)
            row.update({m + k: float(v) for k, v in zip(("", "_std", "_min", "_max", "_median", "_p10", "_p90"),
                                                        stats)})
        out.append(row)
    return out


def is_reference(r: dict) -> bool:
    return str(r.get("reference", "")).lower() in ("true", "1")


def pareto_front(rows: list[dict], x: str = "wall_time", y: str = "psnr", min_gain: float = 0.01) -> list[dict]:
    """The rows no faster row beats by more than ``min_gain`` dB, by increasing ``x``."""
    pts = sorted((r for r in rows if r.get("status") == "ok" and math.isfinite(num(r.get(x)))
                  and math.isfinite(num(r.get(y)))), key=lambda r: (num(r[x]), -num(r[y])))
    front, best = [], -math.inf
    for r in pts:
        if num(r[y]) > best + min_gain:
            front.append(r)
            best = num(r[y])
    return front


def fmt_value(v, spec: str = ".2f") -> str:
    f = num(v)
    return format(f, spec) if math.isfinite(f) else "-" if isinstance(v, float) else str(v)


def markdown_table(rows: list[dict], columns: list[str] | None = None, fmt: dict | None = None,
                   headers: dict | None = None) -> str:
    """A GitHub markdown table; ``fmt`` maps a column to a format spec, ``headers`` renames columns."""
    if not rows:
        return "(no rows)\n"
    columns = columns or list(rows[0])
    fmt, headers = fmt or {}, headers or {}
    cell = lambda r, c: fmt_value(r.get(c, ""), fmt[c]) if c in fmt else str(r.get(c, ""))
    lines = ["| " + " | ".join(headers.get(c, c) for c in columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    lines += ["| " + " | ".join(cell(r, c) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def mean_std(row: dict, metric: str, spec: str = ".2f") -> str:
    """``mean ± std`` of a summarised row (just the mean with one run)."""
    m, s = num(row.get(metric)), num(row.get(f"{metric}_std"))
    if not math.isfinite(m):
        return "failed"
    return f"{m:{spec}}" + (f" ± {s:{spec}}" if row.get("runs", 1) - row.get("failed", 0) > 1 else "")


SMOKE = ("**A smoke run** (`--quick`): a few steps on tiny data, which show that the experiment runs from end to "
         "end and nothing more. Its figures are not results and this report draws no conclusions; a run without "
         "`--quick` does.")
"""What the top of every quick report says."""


def write_report(out: Path, title: str, sections: list[tuple[str, str]], quick: bool = False,
                 judged: Callable[[], list[tuple[str, str]]] | None = None, name: str = "report.md") -> Path:
    """``out/name``: a title, then (heading, markdown body) sections (bodies embed figures relative to ``out``),
    then the sections ``judged()`` draws conclusions in; a ``quick`` run gets :data:`SMOKE` on top instead."""
    sections = [("Smoke run", SMOKE)] + sections if quick else sections + (judged() if judged else [])
    text = [f"# {title}\n"] + [f"## {heading}\n\n{body.strip()}\n" for heading, body in sections]
    return atomic_write_text(out / name, "\n".join(text))
