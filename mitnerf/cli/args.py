"""Command-line values checked where they are typed (``--batch 0`` or ``--lr nan`` end in one line before anything
runs), and the flags that override a recipe: they default to ``None``, the value then comes from the recipe."""

from __future__ import annotations

import argparse
import dataclasses
import json

from .._io import available_memory
from ..errors import ConfigError, MitnerfError, check_number
from ..fields import field_config
from ..train.recipes import get_recipe, recipe_for


def number(integer: bool = False, lo=None, hi=None, strict_lo: bool = False):
    """An argparse type: a finite number (a whole one if ``integer``) within the bounds."""
    def parse(text: str):
        try:
            value = float(text)
            if integer and not value.is_integer():
                raise ValueError
            value = int(value) if integer else value
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"expected {'a whole number' if integer else 'a number'}, "
                                             f"got {text!r}") from None
        try:
            check_number("value", value, lo, hi, integer, strict_lo, flag="it")
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return value
    parse.__name__ = "whole number" if integer else "number"
    return parse


def background(text: str) -> str | tuple:
    """``white``, ``black``, ``random`` or ``r,g,b`` (a colour in [0, 1])."""
    if text in ("white", "black", "random"):
        return text
    try:
        values = tuple(map(float, text.split(",")))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(0.0 <= v <= 1.0 for v in values):
        raise argparse.ArgumentTypeError(f"expected white, black, random or r,g,b with values in [0, 1], got {text!r}")
    return values


def key_value(text: str) -> tuple:
    """``key=value``; the value is a JSON literal when it parses, else a string."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected key=value, got {text!r}")
    k, v = text.split("=", 1)
    try:
        return k.strip(), json.loads(v)
    except json.JSONDecodeError:
        return k.strip(), v


# flag, recipe setting, argparse keyword arguments, help
OVERRIDES = [
    ("--iters", "iters", dict(type=number(True, 1, 10 ** 9)), "optimisation steps (an upper bound with a time budget)"),
    ("--time-budget", "time_budget", dict(type=number(False, 0, 10 ** 7, strict_lo=True)), "seconds of training"),
    ("--batch", "batch_rays", dict(type=number(True, 1, 1 << 22)), "rays per step"),
    ("--lr", "lr", dict(type=number(False, 0, 10, strict_lo=True)), "peak learning rate"),
    ("--lr-final", "lr_final", dict(type=number(False, 0, 10, strict_lo=True)), "final learning rate"),
    ("--seed", "seed", dict(type=number(True, 0, 2 ** 32 - 1)), "seed of weights, batches and jitter"),
    ("--test-views", "test_views", dict(type=number(True, 0, 10 ** 6)),
     "evaluate on N evenly spaced test views (a quick check; default: all of them)"),
    ("--val-every", "val_every", dict(type=number(True, 0, 10 ** 9)), "validate every N steps (0: at the end)"),
    ("--threads", "threads", dict(type=number(True, 1, 1024)), "CPU threads"),
    ("--depth-weight", "depth_weight", dict(type=number(False, 0, 1e6)),
     "weight of DS-NeRF's depth loss on the dataset's depth (0: off)"),
    ("--depth-sigma", "depth_sigma", dict(type=number(False, 0, 1e6, strict_lo=True)),
     "width of the depth loss's Gaussian (world units)"),
    ("--free-space-weight", "free_space_weight", dict(type=number(False, 0, 1e6)),
     "weight of the free-space loss on the dataset's depth or alpha (0: off)"),
    ("--solid-weight", "solid_weight", dict(type=number(False, 0, 1e6)),
     "weight of the solid-behind-the-surface loss on the dataset's depth (0: off)"),
    ("--distortion-weight", "distortion_weight", dict(type=number(False, 0, 1e6)),
     "weight of mip-NeRF 360's distortion loss (0: off)"),
    ("--opacity-weight", "opacity_weight", dict(type=number(False, 0, 1e6)), "weight of the opacity entropy (0: off)"),
    ("--samples", "n_coarse", dict(type=number(True, 1, 4096)), "coarse samples per ray"),
    ("--fine", "n_fine", dict(type=number(True, 0, 4096)), "importance samples per ray (0: no fine pass)"),
    ("--background", "background", dict(type=background),
     "white, black, random (a colour per training ray; evaluated over white) or r,g,b (default: the dataset's: "
     "white for Blender folders and 3D objects, black for 2D and tiny-NeRF)"),
    ("--method", "method", dict(choices=["replay", "autodiff"]), "volume integral"),
    ("--occupancy", "occupancy.enabled", dict(action=argparse.BooleanOptionalAction), "empty-space skipping"),
    ("--width", "width", dict(type=number(True, 2, 1024)), "MLP width"),
    ("--depth", "depth", dict(type=number(True, 1, 32)), "MLP layers"),
    ("--pos-L", "pos_L", dict(type=number(True, 0, 24)), "positional-encoding frequencies"),
    ("--dir-L", "dir_L", dict(type=number(True, 0, 12)), "view-direction encoding frequencies"),
    ("--resolution", "resolution", dict(type=number(True, 2, 8193)), "grid vertices per axis"),
    ("--view-dependence", "view_dependent", dict(action=argparse.BooleanOptionalAction), "view-dependent colour"),
    ("--sh-degree", "sh_degree", dict(type=number(True, 1, 8)),
     "grid, hashlinear: degree of the view-dependent harmonics (2D up to 8, 3D up to 2)"),
    ("--density-activation", "density_activation", dict(choices=["relu", "softplus", "trunc_exp"]), "density"),
]


def add_recipe_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("recipe (every flag overrides one setting; unset: the recipe's value)")
    g.add_argument("--recipe", default=None, help="a recipe by name (`mitnerf recipes`)")
    g.add_argument("--field", default=None, help="the tuned recipe of this field family (grid, hashlinear, hashgrid, vanilla)")
    for flag, key, kw, text in OVERRIDES:
        g.add_argument(flag, dest=f"set_{key}", default=None, help=text, **kw)
    g.add_argument("--set", dest="sets", action="append", default=[], type=key_value, metavar="KEY=VALUE",
                   help="any other setting of the recipe (a field, render or train setting; repeatable)")


def overrides(args) -> dict:
    """The settings the user typed, as ``{recipe key: value}``."""
    out = {**{key: getattr(args, f"set_{key}") for _, key, _, _ in OVERRIDES}, **dict(args.sets)}
    return {k: v for k, v in out.items() if v is not None}


def recipe_from_args(args, dataset):
    """The recipe the flags describe for ``dataset`` (sized for it, :meth:`~mitnerf.train.recipes.Recipe.sized`),
    checked."""
    if args.recipe and args.field:
        raise ConfigError("--recipe and --field both choose the recipe; pass one of them")
    base = get_recipe(args.recipe) if args.recipe else recipe_for(args.field, dataset.dim)
    check_set_types(base, args.sets)
    recipe = base.override(**overrides(args)).sized(dataset).validate()
    check_step_memory(recipe)
    return recipe


def _kind(value) -> str:
    if isinstance(value, bool):
        return "true or false"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, (list, tuple)):
        return "a list" + (f" of {_kind(value[0])[2:]}s" if value else "")
    return "a string" if isinstance(value, str) else "null" if value is None else type(value).__name__


def check_set_types(recipe, sets: list) -> None:
    """A ``--set KEY=VALUE`` must have the type of the setting it replaces; unknown keys are left to ``validate``."""
    r = recipe.model.render
    current = {**dataclasses.asdict(recipe.train),
               **{k: v for k, v in dataclasses.asdict(r).items() if k != "occupancy"},
               **{f"occupancy.{k}": v for k, v in dataclasses.asdict(r.occupancy).items()}}
    try:
        current.update(dataclasses.asdict(field_config(recipe.model.field, dim=recipe.dim)))
    except (MitnerfError, TypeError):
        pass
    current.update(recipe.model.field_args)
    for key, value in sets:
        old = current.get(key)
        was = json.dumps(old, default=str).replace(" ", "")
        if value is None and old is not None:         # null would be ignored, silently
            raise ConfigError(f"--set {key}=null: {key} cannot be null; give a value, e.g. --set {key}={was}")
        if value is None and key not in current:
            raise ConfigError(f"--set {key}=null: the recipe has no setting {key!r}; see its settings with "
                              "`mitnerf recipes`")
        ok = _kind(value) == _kind(old) or (isinstance(old, (list, tuple)) and not old and isinstance(value, list))
        if isinstance(value, list) and isinstance(old, (list, tuple)) and old:
            ok = all(_kind(v) == _kind(old[0]) for v in value)
        if old is not None and not ok:
            raise ConfigError(f"--set {key} must be {_kind(old)}, got {json.dumps(value, default=str)[:40]}; "
                              f"write it as the recipe does, e.g. --set {key}={was}")


SAMPLE_BYTES = 32
"""Bytes one sample of a training step costs at least (position, direction, interval, density, colour, weight)."""


def check_step_memory(recipe) -> None:
    """Refuse a step of ``--batch`` x (``--samples`` + ``--fine``) samples that cannot fit in memory (a lower bound)."""
    r, t, args = recipe.model.render, recipe.train, recipe.model.field_args
    samples = int(t.batch_rays) * (int(r.n_coarse) + int(r.n_fine))
    mlp = int(args.get("width", 0) or 0) * int(args.get("depth", 0) or 0) + 2 * int(args.get("hidden", 0) or 0)
    need = samples * (SAMPLE_BYTES + 3 * 4 * mlp)
    avail = available_memory()
    if avail is not None and need > avail:
        raise ConfigError(f"a training step of {t.batch_rays} rays x {r.n_coarse + r.n_fine} samples "
                          f"({samples:,} samples) needs at least {need / 2**30:.1f} GiB; this machine has "
                          f"{avail / 2**30:.1f} GiB available: lower --batch, --samples or --fine")
