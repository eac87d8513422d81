"""``mitnerf compare --data DIR [RECIPE ...]``: recipes side by side on your data (:mod:`mitnerf.experiments.compare`):
``compare.png`` (validation PSNR against training time), ``compare.csv``, ``report.md``, and the winner named."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .._io import Output
from ..data.formats import load_dataset
from ..errors import ConfigError
from ..experiments.compare import compare, write
from ..train.fit import check_dataset
from ..settings import setting
from ..train.recipes import DEFAULT, RECIPES, get_recipe
from .command import Writes, add_command, parse
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
