"""Plumbing shared by the experiments: cached datasets, tables, reports."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

from .._io import cache_dir, digest
from ..data.dataset import Dataset


def cached_dataset(scene: str, rig, render=None) -> Dataset:
    """Render a dataset once per (scene, rig, render settings) and reuse it from the cache."""
    from ..data.formats import load_dataset, save_dataset
    from ..data.generate import make_dataset
    from ..scenes.registry import get_scene
    from ..scenes.render import RenderSettings

    render = render or RenderSettings()
    key = digest(scene, json.dumps(dataclasses.asdict(rig), sort_keys=True),
                 json.dumps(dataclasses.asdict(render), sort_keys=True))
    folder = cache_dir("datasets") / f"{scene}-{key}"
    try:
        return load_dataset(folder)
    except Exception:  # noqa: BLE001 - missing or stale cache: render again
        ds = make_dataset(get_scene(scene), rig, render, progress=False)
        save_dataset(ds, folder)
        return load_dataset(folder)


def write_csv(path: Path, rows: list[dict]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    return path


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def markdown_table(rows: list[dict], columns: list[str] | None = None, fmt: dict | None = None) -> str:
    """A GitHub markdown table; ``fmt`` maps a column to a format spec (e.g. ``'.2f'``)."""
    if not rows:
        return "(no rows)\n"
    columns = columns or list(rows[0])
    fmt = fmt or {}

    def cell(r, c):
        v = r.get(c, "")
        if c in fmt and v not in ("", None):
            try:
                return format(float(v), fmt[c])
            except (TypeError, ValueError):
                return str(v)
        return str(v)

    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    lines += ["| " + " | ".join(cell(r, c) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_report(out: Path, title: str, sections: list[tuple[str, str]]) -> Path:
    """``report.md``: a title, then (heading, markdown body) sections. Images are embedded
    by the bodies as ``![caption](file.png)`` relative to ``out``."""
    text = [f"# {title}\n"]
    for heading, body in sections:
        text.append(f"## {heading}\n\n{body.strip()}\n")
    path = out / "report.md"
    path.write_text("\n".join(text))
    return path


def train_eval(dataset: Dataset, model_cfg, train_cfg, backend: str = "drjit") -> tuple[object, dict]:
    """Train and evaluate on the test split. A run that diverges or collapses
    (``TrainingFailed``) returns ``run=None`` and a row with ``status='collapsed'``."""
    import time

    import numpy as np

    from ..train.trainer import TrainingFailed, evaluate, fit

    t0 = time.perf_counter()
    try:
        run = fit(dataset, model_cfg, train_cfg, backend)
    except TrainingFailed as exc:
        return None, {"status": "collapsed", "error": str(exc), "wall_time": time.perf_counter() - t0}
    ev = evaluate(run, dataset, "test")
    rgb = ev["renders"]["rgb"]
    row = {"status": "ok", "psnr": ev["psnr"], "ssim": ev["ssim"], "depth_error": ev.get("depth_error", float("nan")),
           "train_time": run.train_time, "steps": run.steps, "wall_time": time.perf_counter() - t0,
           "render_std": float(np.std(rgb))}
    if not np.isfinite(rgb).all() or row["render_std"] < 1e-2 * max(float(np.std(dataset["test"].color)), 1e-6):
        row["status"] = "collapsed"              # constant (or NaN) renders at the end
        row["error"] = "constant renders"
    return (run, ev), row
