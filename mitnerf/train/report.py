"""Fit, evaluate, and write what a person wants to see: the shared path of ``mitnerf fit``,
``examples/fit_bunny.py`` and the experiments."""

from __future__ import annotations

import json
from pathlib import Path

from ..data.dataset import Dataset
from .checkpoint import save_checkpoint
from .config import ModelConfig, TrainConfig
from .trainer import Run, evaluate, fit


def summary_line(metrics: dict, backend: str, field: str) -> str:
    return f"test PSNR {metrics['psnr']:.2f} dB, train {metrics['train_time']:.1f} s, {backend} {field}"


def fit_and_report(dataset: Dataset, model_cfg: ModelConfig, train_cfg: TrainConfig, backend: str = "drjit",
                   out: str | Path | None = None, figures: bool = True) -> tuple[Run, dict]:
    """Train, evaluate on the test split, and (with ``out``) write the checkpoint,
    ``metrics.json``, the curves, the test renders beside ground truth and the density."""
    run = fit(dataset, model_cfg, train_cfg, backend)
    ev = evaluate(run, dataset, "test")
    metrics = {k: float(v) for k, v in ev.items() if k != "renders"}
    metrics.update(train_time=run.train_time, steps=run.steps, backend=backend, field=model_cfg.field,
                   final_val_psnr=run.history["val_psnr"][-1] if run.history["val_psnr"] else None)
    if out is not None:
        out = Path(out)
        save_checkpoint(run, out, {"metrics": metrics})
        (out / "metrics.json").write_text(json.dumps(metrics, indent=1))
        (out / "history.json").write_text(json.dumps(run.history, default=float))
        if figures:
            from ..viz.training import plot_curves, save_density, save_renders

            title = f"{dataset.meta.get('scene', '')} {backend} {model_cfg.field}"
            plot_curves(run.history, out / "curves.png", title)
            save_renders(ev["renders"], dataset["test"], model_cfg.render.background, out, dataset.near, dataset.far)
            save_density(run.backend, run.bound, dataset.dim, out / "density.png", dataset.meta.get("polygon"),
                         title=f"density ({title})")
    return run, metrics
