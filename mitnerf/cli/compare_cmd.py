"""``mitnerf compare --data DIR [RECIPE ...]``: recipes side by side on your data. Each trains for the same budget,
its validation PSNR is followed against training time (the learning curves, on one chart: ``compare.png``), the test
views score it (``compare.csv``), ``report.md`` holds both, and the winner is the best test PSNR."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .._io import Output
from ..data.dataset import Dataset
from ..data.formats import load_dataset
from ..errors import ConfigError
from ..experiments.report import markdown_table, write_csv, write_report
from ..settings import setting
from ..train.fit import check_dataset, fit_and_evaluate
from ..train.recipes import DEFAULT, RECIPES, Recipe, get_recipe
from ..viz.panels import series_figure
from .args import Writes, add_command, parse
from .fit_cmd import fresh_folder


@dataclass(kw_only=True)
class CompareCommand(Writes):
    """``mitnerf compare``: recipes side by side on a dataset."""

    data: str = setting(flag="--data", metavar="DIR")
    """The dataset (any format `mitnerf fit` reads)."""
    recipes: tuple = setting((), flag="recipes", metavar="RECIPE",
                             shown="the tuned recipe of every field family for the data's dimension")
    """Recipes by name (`mitnerf recipes` lists them)."""
    time_budget: float | None = setting(None, lo=0, above=True, hi=10 ** 7, flag="--time-budget", unit="seconds",
                                        shown="each recipe's own")
    """Seconds of training for every recipe (the same for all: a fair race)."""
    out: str | None = setting(None, flag="--out", metavar="DIR", shown="a new folder out/<data>-compare")
    """Folder for the chart, the table and the report."""


def register(sub) -> None:
    add_command(sub, "compare", CompareCommand, run, help="compare recipes on your data: PSNR against training time, "
                "a table, the winner")


def run(args) -> int:
    args = parse(args)
    dataset = load_dataset(args.data)
    check_dataset(dataset, need_test=True)
    names = args.recipes or tuple(n for n, r in RECIPES.items() if r.dim == dataset.dim and
                                  r.model.field != "pixelnerf")
    recipes = [get_recipe(n).override(time_budget=args.time_budget, progress=False).validate() for n in names]
    wrong = [r.name for r in recipes if r.dim != dataset.dim]
    if wrong:
        raise ConfigError(f"{', '.join(wrong)}: not for {dataset.dim}D data; `mitnerf recipes --dim {dataset.dim}` "
                          "lists the recipes for this dataset")
    out = Output(Path(args.out) if args.out else fresh_folder(Path("out"), f"{dataset.name}-compare"), "compare",
                 args.overwrite, inputs=[args.data])
    budget = f"{args.time_budget:g} s" if args.time_budget else "its own budget"
    print(f"comparing {', '.join(r.name for r in recipes)} on {dataset.name} ({budget} each; default: "
          f"{DEFAULT[dataset.dim]}); writing to {out.path}", flush=True)
    rows, curves = compare(dataset, recipes, say=lambda line: print(line, flush=True))
    with out.staged() as tmp:
        line = write(tmp, dataset, rows, curves, budget)
    print(f"wrote {out.path}")
    print(line)
    return 0


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
    """Validation PSNR against training time, one line per recipe (:func:`~mitnerf.viz.panels.series_figure`)."""
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
