"""What ``mitnerf fit --out DIR`` writes: the checkpoint, ``metrics.json``, curves, test views, depth, density."""

from __future__ import annotations

from pathlib import Path

from .._io import atomic_write_text, json_text
from ..data.dataset import Dataset
from ..viz.training import plot_curves, save_density, save_renders
from .checkpoint import save_checkpoint
from .evaluate import RunRecord
from .fit import Run


def write_fit(run: Run, folder: Path, record: RunRecord | None = None, dataset: Dataset | None = None) -> Path:
    """Write ``run`` into ``folder``; with ``record`` and ``dataset`` also the metrics and figures."""
    metrics = record.row() if record is not None else {"interrupted_at": run.state.step}
    save_checkpoint(run, folder, metrics)
    atomic_write_text(folder / "metrics.json", json_text({**metrics, "notes": run.notes}))
    if record is not None and dataset is not None and record.renders is not None:
        title = f"{dataset.name}, {run.recipe.name} ({run.backend.name})"
        plot_curves(run.state.history, folder / "curves.png", title)
        save_renders(record.renders, dataset["test"].subset(record.renders["views"]),
                     run.recipe.model.render.render_background(), folder, dataset.near, dataset.far,
                     title=title)
        save_density(run.backend.density, run.bound, dataset.dim, folder / "density.png",
                     dataset.meta.get("polygon"), title=f"density: {title}")
    return folder
