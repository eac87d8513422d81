"""What the sub-commands share. A sub-command is a dataclass: its fields (made with :func:`mitnerf.settings.setting`,
each with its flag and the string under it as its help) are the command's options; configs of the library add theirs
beside them. The flags that override a recipe are generated from the settings' declarations (:mod:`mitnerf.settings`):
each training, rendering and occupancy setting and each field setting that declares a flag. Unset, a value comes from
the recipe; ``--set KEY=VALUE`` reaches every other setting, checked by the same declarations."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

from .._io import available_memory
from ..errors import ConfigError
from ..fields import CONDITIONED, FIELDS
from ..render.occupancy import OccupancyConfig
from ..render.pipeline import RenderConfig
from ..render.space import pick_scene
from ..settings import add_flags, check, check_value, parse_set, setting, show_value
from ..train.config import TrainConfig
from ..train.recipes import DEFAULT, RECIPES, get_recipe, recipe_for

@dataclass(kw_only=True)
class Writes:
    """What every command that writes an output folder takes."""

    overwrite: bool = setting(False, flag="--overwrite")
    """Write into a folder that holds other files (they are left alone)."""


def add_command(sub, name: str, cls, run, *configs, help: str) -> argparse.ArgumentParser:
    """The sub-command ``name``: the flags of the dataclass ``cls`` and of each ``(config class, prefix[, shown])``
    in ``configs`` (their flags unset hold None: the config's own default, named by ``shown(key)`` or else the
    declaration's, applies)."""
    p = sub.add_parser(name, help=help, description=f"{help[0].upper()}{help[1:]}.")
    add_flags(p, cls)
    for config, prefix, *shown in configs:
        add_flags(p, config, prefix=prefix, overrides=True, shown=shown[0] if shown else None)
    p.set_defaults(run=run, command=cls)
    return p


def options(cls, args, prefix: str = "") -> dict:
    """The values of ``cls``'s fields in the parsed ``args`` (a config's: only the flags given)."""
    given = vars(args)
    return {f.name: given[prefix + f.name] for f in dataclasses.fields(cls)
            if prefix + f.name in given and (given[prefix + f.name] is not None or not prefix)}


def parse(args):
    """The command's dataclass, filled from ``args`` and checked."""
    cmd = args.command(**options(args.command, args))
    check(cmd)
    return cmd


DEST = "recipe:"
"""Where the parsed recipe flags land (``args.<DEST><key>``), apart from the command's own options."""
GROUPS = [(TrainConfig, ""), (RenderConfig, ""), (OccupancyConfig, "occupancy."),
          *((cls, "") for name, (cls, _) in FIELDS.items() if name not in CONDITIONED)]
"""The configs whose flagged settings a recipe flag overrides, in the order the help lists them."""


def recipe_default(key: str) -> str:
    """The default a recipe flag's help names: the default recipes' values, else those of the recipes that have
    the setting (``grid-2d 10, grid-3d 60``; one value where they agree)."""
    names = [DEFAULT[2], DEFAULT[3]] if get_recipe(DEFAULT[2]).has(key) else \
        [n for n, r in RECIPES.items() if r.has(key) and r.model.field not in CONDITIONED]
    values = {n: show_value(get_recipe(n).get(key)) for n in names}
    if len(set(values.values())) == 1:
        return f"{next(iter(values.values()))} in {'the default recipes' if names[:1] == [DEFAULT[2]] else 'the ' + ', '.join(names)}"
    return ", ".join(f"{n} {v}" for n, v in values.items())


def add_recipe_flags(p) -> None:
    g = p.add_argument_group("recipe: each flag overrides one setting of the recipe")
    g.add_argument("--recipe", default=None, help="a recipe by name: `mitnerf recipes` lists them (default: grid-2d "
                   "for 2D data, grid-3d for 3D)")
    g.add_argument("--field", default=None, choices=sorted({r.model.field for r in RECIPES.values()} - set(CONDITIONED)),
                   help="the tuned recipe of this field family for the data's dimension (default: grid)")
    seen: set = set()
    for cls, prefix in GROUPS:
        add_flags(g, cls, prefix=prefix, dest=DEST, overrides=True, shown=recipe_default, seen=seen)
    g.add_argument("--set", dest="sets", action="append", default=[], type=parse_set, metavar="KEY=VALUE",
                   help="any other setting of the recipe, by its name in `mitnerf recipes --verbose`; "
                        "repeatable, the value in JSON (default: the recipe's)")


def overrides(args) -> dict:
    """The settings the user typed, as ``{recipe key: value}``."""
    out = {k[len(DEST):]: v for k, v in vars(args).items() if k.startswith(DEST) and v is not None}
    return {**out, **dict(args.sets)}


def scene_from_args(args, dataset) -> tuple[str, str]:
    """``(scene, why)``: the one ``--scene`` names, else the one a recipe named by ``--recipe`` is for, else the one
    the data shows (:func:`~mitnerf.render.space.pick_scene`)."""
    typed = overrides(args).get("scene", "auto")
    if typed != "auto":
        return typed, f"--scene-type {typed}"
    named = get_recipe(args.recipe).model.render.scene if args.recipe else "auto"
    return (named, f"the recipe {args.recipe} is for it") if named != "auto" else pick_scene(dataset)


def recipe_from_args(args, dataset, scene: str = "object"):
    """The recipe the flags describe for ``dataset`` showing ``scene``, sized for it
    (:meth:`~mitnerf.train.recipes.Recipe.sized`), checked."""
    if args.recipe and args.field:
        raise ConfigError("--recipe and --field both choose the recipe; pass one of them")
    base = get_recipe(args.recipe) if args.recipe else recipe_for(args.field, dataset.dim, scene)
    base.model.render.scene = scene                            # sized for the scene it is trained in
    for key, value in args.sets:
        where = base.declared(key)
        if where is None:
            raise ConfigError(f"--set {key}: the recipe {base.name} has no setting {key!r}; "
                              f"`mitnerf recipes --verbose` lists its settings")
        check_value(*where, value, prefix="occupancy." if key.startswith("occupancy.") else "")
    flags = {k: v for k, v in overrides(args).items() if k not in dict(args.sets)}
    recipe = base.override(**flags).override(nulls=True, **dict(args.sets))._marked(base).sized(dataset)
    check_step_memory(recipe.validate())
    return recipe


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
