"""``mitnerf fit --data DIR [--out RUN] [--field F | --recipe R] [--lr ...] [--auto]`` or ``mitnerf fit --resume RUN``:
train a recipe (default: that of the dataset's dimension) on any dataset mitnerf reads, evaluate it, write it; the
dataset (all splits), the flags and the output folder are checked first. The last line is ``test PSNR <x> dB, ...``;
Ctrl-C or SIGTERM writes the checkpoint (with ``--out``) and prints how to resume. ``mitnerf recipes [--dim D]``
lists the recipes, their settings, and the figures measured for them."""

from __future__ import annotations

import os
import signal
from pathlib import Path

from .._io import Output
from ..data.formats import load_dataset
from ..errors import ConfigError, Terminated
from ..results import load_results
from ..train.auto import AutoConfig, choose_recipe
from ..train.checkpoint import checkpoint_bytes, load_checkpoint
from ..data.rays import background_name
from ..train.fit import check_dataset, fit, resolve_background
from ..train.loop import Interrupted, TrainingFailed, deferred_signals
from ..train.recipes import DEFAULT, RECIPES
from ..train.report import write_fit
from .args import add_recipe_flags, overrides, recipe_from_args


def register(sub) -> None:
    p = sub.add_parser("fit", help="train a field on a dataset (the default recipe unless told otherwise)")
    p.add_argument("--data", help="dataset folder (NeRF2D, Blender, nerfstudio) or tiny-NeRF .npz")
    p.add_argument("--out", help="folder for the checkpoint, metrics and figures")
    p.add_argument("--overwrite", action="store_true",
                   help="write into an --out folder that holds other files (they are left alone)")
    p.add_argument("--resume", metavar="RUN", help="continue an interrupted run from its --out folder")
    p.add_argument("--backend", choices=["drjit", "torch"], help="engine (default: drjit)")
    p.add_argument("--auto", action="store_true", help="choose the field, its size, view dependence and the losses "
                   "from probe runs as long as the real one, and say why")
    p.add_argument("--no-figures", action="store_true", help="write the checkpoint and metrics only")
    add_recipe_flags(p)
    p.set_defaults(run=run_fit)
    r = sub.add_parser("recipes", help="list the training recipes with their measured figures")
    r.add_argument("--dim", type=int, choices=[2, 3], help="only the recipes for this dimension")
    r.set_defaults(run=run_recipes)


def run_fit(args) -> int:
    resume = None
    if args.resume:
        if overrides(args) or args.recipe or args.field or args.auto:
            raise ConfigError("--resume continues the run as it was; drop the recipe flags")
        prior, resume = load_checkpoint(args.resume, args.backend, need="--resume")
        data = args.data or prior.dataset_meta.get("path")
        if not data:
            raise ConfigError(f"{args.resume} does not record its dataset; pass --data DIR")
        if not args.data and not os.path.lexists(data):
            raise ConfigError(f"the dataset {args.resume} was trained on is no longer at {data}; pass --data with "
                              "where it is now")
        recipe, backend, out_path = prior.recipe, prior.backend.name, Path(args.resume)
        dataset = load_dataset(data)
    else:
        if not args.data:
            raise ConfigError("pass --data DIR (a dataset folder), or --resume RUN")
        data, dataset = args.data, load_dataset(args.data)
        recipe = recipe_from_args(args, dataset)
        backend, out_path = args.backend or "drjit", Path(args.out) if args.out else None
    check_dataset(dataset, need_test=True)
    out = Output(out_path, "fit", args.overwrite, inputs=[data],
                 size=checkpoint_bytes(recipe, dataset.dim)) if out_path else None      # refused before training
    if args.auto:
        if args.recipe:
            raise ConfigError("--auto chooses the recipe; drop --recipe (--field limits the search to one family)")
        cfg = AutoConfig(families=(args.field,)) if args.field else None
        recipe, reasons = choose_recipe(dataset, cfg, overrides(args))
        recipe = recipe.sized(dataset)
        for line in reasons:
            print(f"auto: {line}")
    print(f"recipe {recipe.summary()} ({backend})")
    n, views = len(dataset["test"]), recipe.train.test_views
    where = (resolve_background(recipe, dataset) if not args.resume
             else f"background {background_name(recipe.model.render.background)}")
    print(f"{where}; test on " + (f"{views} of {n} views (--test-views)" if 0 < views < n else f"all {n} views"))
    return train_and_report(dataset, recipe, backend, out, resume, figures=not args.no_figures)


def train_and_report(dataset, recipe, backend: str, out: Output | None, resume=None, figures: bool = True) -> int:
    """Fit, evaluate and write; turn a stopped or interrupted run into its message and exit status."""
    run = None
    try:
        run = fit(dataset, recipe, backend, resume=resume)
        record = run.record(dataset)
    except Interrupted as exc:
        where = "nothing was written (pass --out to keep checkpoints)"
        if out is not None:
            save(out, exc.run)
            where = f"wrote {out.path}; resume with `mitnerf fit --resume {out.path}`"
        print(f"mitnerf: interrupted ({exc}) at step {exc.run.state.step}; {where}")
        return 128 + int(exc.signum) if exc.signum in (signal.SIGINT, signal.SIGTERM) else 1
    except TrainingFailed as exc:
        rec = exc.run.record(dataset, geometry_metrics=False)
        rec.status, rec.reason = exc.status, str(exc)
        if out is not None:
            save(out, exc.run, rec)
        print(f"mitnerf: training stopped: {exc}" + (f"; wrote {out.path}" if out is not None else ""))
        return 1
    except KeyboardInterrupt as exc:            # while evaluating: the training is done, keep it
        if run is not None and out is not None:
            save(out, run)
            exc.note = f"; the trained model is in {out.path}: evaluate it with `mitnerf fit --resume {out.path}`"
        raise
    for note in run.notes:
        print(note)
    if out is not None:
        signals = save(out, run, record, dataset if figures else None)
        print(f"wrote {out.path}")
        if signals:
            raise (Terminated if signals[0] == signal.SIGTERM else KeyboardInterrupt)()
    print(f"evaluated {record.views} views in {record.eval_time:.1f} s; peak memory {record.peak_memory:.2f} GiB")
    print(record.line() + f" ({backend})")
    return 0 if record.status == "ok" else 1


def save(out: Output, run, record=None, dataset=None) -> list:
    """Write the run; Ctrl-C or SIGTERM while it writes waits until it is written (the signals are returned)."""
    with deferred_signals() as signals:
        with out.staged() as tmp:
            write_fit(run, tmp, record, dataset)
    return signals


def run_recipes(args) -> int:
    results = load_results()
    for name, r in RECIPES.items():
        if args.dim and r.dim != args.dim:
            continue
        print(f"{r.summary()}{' [default]' if DEFAULT[r.dim] == name else ''}\n    {r.about}")
        for key, entry in sorted(results.items()):
            if entry.get("recipe") == name:
                print(f"    measured: {entry['summary']} ({key}; `{entry['command']}`)")
    if not results:
        print("(no measured figures: results.json is missing; `make bench` writes it)")
    return 0
