"""Recipes side by side on the user's own data (``mitnerf compare --data DIR RECIPE ...``): each trains for the
same budget, its validation PSNR is followed against training time (the learning curves, on one chart), the test
views score it (a table), and the winner is the best test PSNR."""

from __future__ import annotations

from pathlib import Path

from ..data.dataset import Dataset
from ..train.fit import fit_and_evaluate
from ..train.recipes import Recipe
from ..viz.charts import series_figure
from .report import markdown_table, write_csv, write_report

COLUMNS = ["recipe", "psnr", "ssim", "train_time", "steps", "params", "status"]


def compare(dataset: Dataset, recipes: list[Recipe], say=print) -> tuple[list[dict], dict]:
    """Fit and evaluate each recipe on ``dataset``; ``(rows, curves)``: a row per recipe (:data:`COLUMNS`) and its
    curve ``(training seconds, validation PSNR)``. ``say`` hears of each as it ends."""
    rows, curves = [], {}
    for recipe in recipes:
        run, rec = fit_and_evaluate(dataset, recipe, geometry_metrics=False)
        row = {**{k: v for k, v in rec.row().items() if k in COLUMNS}, "recipe": recipe.name}
        rows.append(row)
        h = run.state.history
        curves[recipe.name] = (h["val_time"], h["val_psnr"])
        say(f"{recipe.name}: test PSNR {rec.psnr:.2f} dB, SSIM {rec.ssim:.3f} in {rec.train_time:.1f} s "
            f"({rec.steps} steps, {rec.params:,} parameters){'' if rec.status == 'ok' else ', ' + rec.status}")
    return rows, curves


def winner(rows: list[dict]) -> str:
    """The line that names the best recipe by test PSNR and its lead over the next."""
    ok = sorted((r for r in rows if r["status"] == "ok"), key=lambda r: -r["psnr"])
    if not ok:
        return "no recipe trained without failing"
    if len(ok) == 1:
        return f"winner: {ok[0]['recipe']} ({ok[0]['psnr']:.2f} dB), the only one that trained"
    return (f"winner: {ok[0]['recipe']} ({ok[0]['psnr']:.2f} dB test PSNR), {ok[0]['psnr'] - ok[1]['psnr']:.2f} dB "
            f"ahead of {ok[1]['recipe']}")


def draw(path: Path, curves: dict, title: str) -> Path:
    """Validation PSNR against training time, one line per recipe (:func:`~mitnerf.viz.charts.series_figure`)."""
    points = [{"recipe": name, "time": t, "psnr": p} for name, (ts, ps) in curves.items() for t, p in zip(ts, ps)]
    return series_figure(path, [dict(title=title, rows=points, x="time", by=("recipe",), err=False,
                                     xlabel="training time [s]", ylabel="validation PSNR [dB]")], cell=(7, 4.2))


def write(out: Path, dataset: Dataset, rows: list[dict], curves: dict, budget: str) -> str:
    """``compare.csv``, ``compare.png`` and ``report.md`` in ``out``; returns the winner's line."""
    write_csv(out / "compare.csv", rows)
    draw(out / "compare.png", curves, f"{dataset.name}: {budget} each")
    line = winner(rows)
    table = markdown_table(rows, COLUMNS, fmt={"psnr": ".2f", "ssim": ".3f", "train_time": ".1f", "params": ","},
                           headers={"psnr": "test PSNR [dB]", "train_time": "training [s]"})
    write_report(out, f"{dataset.name}: recipes compared", [
        ("Set-up", f"Each recipe trains for {budget} on {len(dataset['train'])} training views and is scored on "
                   f"{len(dataset['test'])} test views ({dataset.meta.get('path', dataset.name)})."),
        ("Results", f"{table}\n**{line}**\n\n![learning curves](compare.png)")])
    return line
