"""``mitnerf fit --data DIR [--out RUN] [--field F | --recipe R] [--lr ...] [--auto]`` or ``mitnerf fit --resume RUN``:
train a recipe (default: that of the dataset's dimension) on any dataset mitnerf reads, evaluate it, write it; the
dataset (all splits), the flags and the output folder are checked first. The last line is ``test PSNR <x> dB, ...``;
Ctrl-C or SIGTERM writes the checkpoint (with ``--out``) and prints how to resume. ``mitnerf recipes [--dim D]``
lists the recipes, their settings, and the figures measured for them."""

from __future__ import annotations

import math
import os
import signal
from dataclasses import dataclass
from pathlib import Path

from .._io import Output
from ..data.formats import load_dataset
from ..errors import ConfigError, Terminated
from ..results import load_results
from ..train.auto import AutoConfig, choose_recipe
from ..train.checkpoint import checkpoint_bytes, load_checkpoint, read_manifest, write_fit
from ..data.rays import background_name
from ..train.fit import check_dataset, fit, resolve_background
from .._fs import deferred_signals
from ..train.loop import Interrupted, TrainingFailed
from ..train.recipes import DEFAULT, RECIPES
from ..settings import setting
from .args import (Writes, add_command, add_recipe_flags, overrides, parse, recipe_from_args,
                   scene_from_args)


MAX_TRAIN_PIXELS = 100_000_000
"""Training pixels that ``fit`` reads at most unless ``--downscale`` says otherwise. Views are held in 8 bits and
decoded per batch (4 bytes a pixel), so a Blender scene at 800 x 800 (64 million pixels) and instant-ngp's fox (89
million) are read at their own size. Reading needs more (:data:`mitnerf.data.formats.common.BYTES_PER_PIXEL`): a
capture that cannot be read at its own size is refused with the fix (``--downscale``)."""


def read_views(path: str, downscale: int | None) -> tuple:
    """``(dataset, what to say)``: the dataset at ``path``, ``downscale`` times smaller; None: as it is, or as many
    times smaller as it takes to keep its training pixels under :data:`MAX_TRAIN_PIXELS` (read again so; the line
    that says so, else None). The views it is not trained on are held packed (:meth:`Dataset.packed`)."""
    dataset = load_dataset(path, downscale or 1)
    train = dataset["train"] if "train" in dataset.splits else None
    pixels = 0 if train is None else len(train) * train.cameras.height * train.cameras.width
    if downscale is not None or pixels <= MAX_TRAIN_PIXELS:
        return dataset.packed(), None
    k, n = math.ceil(math.sqrt(pixels / MAX_TRAIN_PIXELS)), len(train)
    scale = int(dataset.meta.get("downscale", 1)) * k
    del dataset, train                                  # not held while the smaller views are read
    smaller = load_dataset(path, scale).packed()
    c = smaller["train"].cameras
    return smaller, (f"views: read {k} times smaller, {c.width} x {c.height} (the {n} training views hold "
                     f"{pixels:,} pixels; --downscale 1 keeps them all)")


@dataclass(kw_only=True)
class FitCommand(Writes):
    """``mitnerf fit``: train a recipe on a dataset, evaluate it on the test views, write it."""

    data: str | None = setting(None, flag="--data", metavar="DIR", shown="none; give --data or --resume")
    """Dataset folder (NeRF2D, Blender, nerfstudio, instant-ngp) or tiny-NeRF .npz."""
    out: str | None = setting(None, flag="--out", metavar="DIR", shown="a new folder out/<data>-<recipe>")
    """Folder for the checkpoint, metrics and figures."""
    resume: str | None = setting(None, flag="--resume", metavar="RUN", shown="none")
    """Continue a run from its folder: an interrupted one to its end, a finished one for --time-budget seconds
    (or --iters steps) more."""
    backend: str | None = setting(None, choices=("drjit", "torch"), flag="--backend",
                                  shown="drjit, or a resumed run's own")
    """Engine: drjit, or torch (the PyTorch twin: pip install -e .[torch])."""
    auto: bool = setting(False, flag="--auto")
    """Choose the field, its size, view dependence and the losses from probe runs as long as the real one, and
    say why."""
    figures: bool = setting(True, flag="--figures")
    """Write figures beside the checkpoint and metrics."""
    downscale: int | None = setting(None, lo=1, hi=64, flag="--downscale", unit="times smaller",
                                    shown=f"1, or the least that leaves at most {MAX_TRAIN_PIXELS // 10 ** 6} million "
                                          "training pixels (said)")
    """Read the views this many times smaller (box-filtered; LLFF and COLMAP captures: from their images_N/ folder
    where there is one: 8 reads LLFF's 504 x 378 views)."""


@dataclass(kw_only=True)
class RecipesCommand:
    """``mitnerf recipes``: the training recipes with their measured figures."""

    dim: int | None = setting(None, choices=(2, 3), flag="--dim", shown="both")
    """Only the recipes for datasets of this dimension."""
    verbose: bool = setting(False, flag="--verbose")
    """Every recipe's settings, how it is made, and every figure measured for it."""


def register(sub) -> None:
    add_recipe_flags(add_command(sub, "fit", FitCommand, run_fit,
                                 help="train a field on a dataset (the default recipe unless told otherwise)"))
    add_command(sub, "recipes", RecipesCommand, run_recipes,
                help="list the training recipes with their measured figures")


SCENE_LABELS = {"object": "an object in a box", "forward": "forward-facing, rendered in NDC",
                "unbounded": "unbounded, in mip-NeRF 360's contracted space"}

RESUMABLE = ("time_budget", "iters", "threads", "progress")
"""What ``--resume`` lets a flag change: how much longer (seconds or steps more), and how it runs."""


def run_fit(args) -> int:
    resume, cmd, said = None, parse(args), []
    if cmd.resume:
        if set(overrides(args)) - set(RESUMABLE) or args.recipe or args.field or cmd.auto or cmd.out:
            raise ConfigError("--resume continues the run as it was, into its own folder; of the other flags it "
                              "takes --time-budget (seconds more), --iters (steps more) and --threads")
        prior, resume = load_checkpoint(cmd.resume, cmd.backend, need="--resume")
        data = cmd.data or prior.dataset_meta.get("path")
        if not data:
            raise ConfigError(f"{cmd.resume} does not record its dataset; pass --data DIR")
        if not cmd.data and not os.path.lexists(data):
            raise ConfigError(f"the dataset {cmd.resume} was trained on is no longer at {data}; pass --data with "
                              "where it is now")
        evaluated = "psnr" in read_manifest(cmd.resume).get("metrics", {})
        recipe, backend, out_path = extended(prior.recipe, resume["state"], overrides(args), cmd.resume,
                                             evaluated), prior.backend.name, Path(cmd.resume)
        dataset = load_dataset(data, int(prior.dataset_meta.get("downscale", 1))).packed()
    else:
        if not cmd.data:
            raise ConfigError("pass --data DIR (a dataset folder), or --resume RUN")
        data, (dataset, shrunk) = cmd.data, read_views(cmd.data, cmd.downscale)
        scene, why = scene_from_args(args, dataset)
        recipe = recipe_from_args(args, dataset, scene)
        said += [shrunk] if shrunk else []
        if dataset.dim == 3:                                            # 2D data is always an object in a box
            said.append(f"scene: {SCENE_LABELS[scene]} ({why}; --scene-type chooses)")
        backend = cmd.backend or "drjit"
        out_path = Path(cmd.out) if cmd.out else fresh_folder(Path("out"), f"{dataset.name}-{recipe.name.rstrip('+')}")
    check_dataset(dataset, need_test=True)
    out = Output(out_path, "fit", cmd.overwrite, inputs=[data],
                 size=checkpoint_bytes(recipe, dataset.dim))                  # refused before training
    for line in said:                                                         # said once nothing is refused
        print(line, flush=True)
    if cmd.auto:
        if args.recipe:
            raise ConfigError("--auto chooses the recipe; drop --recipe (--field limits the search to one family)")
        cfg = AutoConfig(scene=recipe.model.render.scene, **({"families": (args.field,)} if args.field else {}))
        print("auto: probing candidates (each trains as long as the real run)", flush=True)
        recipe, reasons = choose_recipe(dataset, cfg, overrides(args), say=lambda line: print(f"auto: {line}",
                                                                                               flush=True))
        recipe = recipe.sized(dataset)
        for line in reasons:
            print(f"auto: {line}")
    print(f"recipe {recipe.summary()} ({backend})")
    n, views = len(dataset["test"]), recipe.train.test_views
    where = (resolve_background(recipe, dataset) if not cmd.resume
             else f"background {background_name(recipe.model.render.background)}")
    print(f"{where}; test on " + (f"{views} of {n} views (--test-views)" if 0 < views < n else f"all {n} views"))
    print(f"writing to {out.path}" + ("" if cmd.out or cmd.resume else " (choose with --out)"), flush=True)
    return train_and_report(dataset, recipe, backend, out, resume, figures=cmd.figures)


def fresh_folder(parent: Path, name: str) -> Path:
    """``parent/name``, or ``name-2``, ``name-3``, ... : the first that does not exist."""
    path, k = parent / name, 1
    while os.path.lexists(path):
        k += 1
        path = parent / f"{name}-{k}"
    return path


def extended(recipe, state, more: dict, where, evaluated: bool) -> object:
    """The recipe of a run resumed from ``state``: as it was, or ``more`` seconds (``time_budget``) or steps
    (``iters``) beyond where it stopped; refused when it has finished and been evaluated and no more is asked
    for."""
    t = recipe.train
    if "time_budget" in more:
        recipe = recipe.override(time_budget=state.train_time + more["time_budget"], iters=max(t.iters, 10 ** 6))
    if "iters" in more:
        recipe = recipe.override(iters=state.step + more["iters"])
    recipe = recipe.override(**{k: v for k, v in more.items() if k in ("threads", "progress")})
    t = recipe.train
    budget = f"{state.train_time:.1f} s of {t.time_budget:g} s" if t.time_budget else f"step {state.step} of {t.iters}"
    finished = state.step >= t.iters or (t.time_budget is not None and state.train_time >= t.time_budget)
    if finished and evaluated:
        raise ConfigError(f"{where} has finished its training ({budget}); pass --time-budget SECONDS or --iters "
                          "STEPS to train that much more")
    print(f"resuming at step {state.step} ({budget})" + ("; evaluating" if finished else ""))
    return recipe


def train_and_report(dataset, recipe, backend: str, out: Output, resume=None, figures: bool = True) -> int:
    """Fit, evaluate and write; turn a stopped or interrupted run into its message and exit status."""
    run = None
    try:
        run = fit(dataset, recipe, backend, resume=resume)
        record = run.record(dataset)
    except Interrupted as exc:
        save(out, exc.run)
        print(f"mitnerf: interrupted ({exc}) at step {exc.run.state.step}; wrote {out.path}; resume with "
              f"`mitnerf fit --resume {out.path}`")
        return 128 + int(exc.signum) if exc.signum in (signal.SIGINT, signal.SIGTERM) else 1
    except TrainingFailed as exc:
        rec = exc.run.record(dataset, geometry_metrics=False)
        rec.status, rec.reason = exc.status, str(exc)
        save(out, exc.run, rec)
        print(f"mitnerf: training stopped: {exc}; wrote {out.path}")
        return 1
    except KeyboardInterrupt as exc:            # while evaluating: the training is done, keep it
        if run is not None:
            save(out, run)
            exc.note = f"; the trained model is in {out.path}: evaluate it with `mitnerf fit --resume {out.path}`"
        raise
    for note in run.notes:
        print(note)
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


FIRST = ("demo/", "fit/", "lego/", "fern/", "fox/", "fits/", "glossy/")
"""The results a recipe's line names first: what users run, before the benchmarks' internals."""


def run_recipes(args) -> int:
    args = parse(args)
    results = load_results()
    for name, r in RECIPES.items():
        if args.dim and r.dim != args.dim:
            continue
        t = r.train
        budget = f"{t.time_budget:g} s" if t.time_budget else f"{t.iters} steps"
        default = next((k for k, v in DEFAULT.items() if v == name), None)
        default = "" if default is None else ", the default" + (f" for {default} scenes" if isinstance(default, str)
                                                                 else "")
        print(f"{name} ({r.dim}D, {budget}{default}): {r.purpose}")
        mine = sorted(((k, e) for k, e in results.items() if e.get("recipe") == name),
                      key=lambda ke: (not ke[0].startswith(FIRST), ke[0]))
        for key, entry in mine if args.verbose else mine[:1]:
            print(f"    measured: {entry['summary']} ({key}; `{entry['command']}`)")
        if args.verbose:
            print(f"    how: {r.about}\n    settings: {r.summary().split(': ', 1)[1]}")
    print("(`mitnerf recipes --verbose`: settings and every measured figure)" if not args.verbose else "")
    if not results:
        print("(no measured figures: results.json is missing; `make bench` writes it)")
    return 0
