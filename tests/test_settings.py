"""One declaration per setting: every flag, every ``--set`` key and every checked range comes from a dataclass
field made by ``mitnerf.settings.setting``, and each such field reaches the command line, ``--set`` and
``validate()``."""

from __future__ import annotations

import argparse
import dataclasses
from types import SimpleNamespace

import pytest

from mitnerf import settings
from mitnerf.cli import build_parser
from mitnerf.cli.compare_cmd import CompareCommand
from mitnerf.cli.data_cmds import DatasetCommand, ShowCommand
from mitnerf.cli.experiment_cmd import ExperimentCommand, SweepCommand
from mitnerf.cli.fit_cmd import FitCommand, RecipesCommand
from mitnerf.cli.poses_cmd import PosesCommand
from mitnerf.cli.video_cmd import VideoCommand
from mitnerf.data.rig import RigConfig
from mitnerf.data.sfm import SfmConfig
from mitnerf.errors import ConfigError
from mitnerf.experiments import EXPERIMENTS
from mitnerf.experiments.sweep import Config as SweepConfig
from mitnerf.fields import FIELDS
from mitnerf.render.occupancy import OccupancyConfig
from mitnerf.render.pipeline import RenderConfig
from mitnerf.train.config import TrainConfig
from mitnerf.train.recipes import RECIPES
from mitnerf.viz.video import OrbitConfig

FIELD_CONFIGS = [cls for cls, _ in FIELDS.values()]
CONFIGS = [TrainConfig, RenderConfig, OccupancyConfig, RigConfig, OrbitConfig, SfmConfig, SweepConfig, *FIELD_CONFIGS,
           *(m.Config for m in EXPERIMENTS.values())]
COMMANDS = {"dataset": [DatasetCommand, RigConfig], "show": [ShowCommand], "recipes": [RecipesCommand],
            "fit": [FitCommand, TrainConfig, RenderConfig, OccupancyConfig, *FIELD_CONFIGS],
            "video": [VideoCommand, OrbitConfig], "poses": [PosesCommand, SfmConfig], "experiment": [ExperimentCommand],
            "sweep": [SweepCommand, SweepConfig], "compare": [CompareCommand]}
NOT_SETTINGS = {"-h", "--help", "--set", "--recipe", "--field"}
"""Options that choose among declarations rather than set one: help, ``--set KEY=VALUE``, a recipe by name."""


def declared_flags(classes) -> dict[str, tuple]:
    """flag -> (class, field) of every declaration in ``classes``."""
    out = {}
    for cls in classes:
        for f in dataclasses.fields(cls):
            flag = settings.spec(f).get("flag")
            if flag:
                out.setdefault(flag, (cls, f))
    return out


def subparsers() -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def parser_flags(p: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    out = {}
    for a in p._actions:
        names = a.option_strings or [a.dest]
        for n in names:
            if n.startswith("--no-") and isinstance(a, argparse.BooleanOptionalAction):
                continue
            out[n] = a
    return out


def test_every_flag_is_a_declared_setting_and_every_declared_flag_exists():
    parsers = subparsers()
    assert set(parsers) == set(COMMANDS)
    for name, p in parsers.items():
        have = {f for f in parser_flags(p) if f not in NOT_SETTINGS}
        want = set(declared_flags(COMMANDS[name]))
        assert have == want, f"{name}: flags without a declaration {have - want}, declarations without a flag " \
                             f"{want - have}"


def test_no_flag_name_means_two_things_across_commands():
    meaning: dict[str, set] = {}
    for name, classes in COMMANDS.items():
        for flag, (cls, f) in declared_flags(classes).items():
            meaning.setdefault(flag, set()).add(f.name)
    assert {flag: names for flag, names in meaning.items() if len(names) > 1} == {}
    for flag in ("--resolution", "--width", "--depth"):           # names that meant different things
        assert flag not in meaning


def test_every_flag_has_help_with_its_default():
    for name, p in subparsers().items():
        for flag, action in parser_flags(p).items():
            if flag in ("-h", "--help"):
                continue
            assert action.help and len(action.help) > 15, (name, flag)
            assert "(default: " in action.help or "(required" in action.help, (name, flag, action.help)
            assert "None" not in action.help and "``" not in action.help, (name, flag, action.help)


@pytest.mark.parametrize("cls", CONFIGS, ids=lambda c: f"{c.__module__.rsplit('.', 1)[-1]}.{c.__name__}")
def test_every_field_of_every_config_is_declared_and_checked(cls):
    """The reverse: no field escapes its declaration, and ``check`` refuses a value past each declared range."""
    for f in dataclasses.fields(cls):
        kind = settings._shape(settings.types_of(cls)[f.name])[0]
        if dataclasses.is_dataclass(kind) or kind == "dict":
            continue
        assert settings.KEY in f.metadata, f"{cls.__name__}.{f.name} is not declared with setting()"
        assert settings.docs(cls).get(f.name), f"{cls.__name__}.{f.name} has no docstring (its help)"
        s = settings.spec(f)
        for bad in ([s["hi"] * 2 + 1] if s.get("hi") is not None else []) + \
                   ([s["lo"] - 1] if s.get("lo") is not None else []):
            value = (bad,) if kind == "tuple" else int(bad) if kind == "int" else bad
            with pytest.raises(ConfigError, match=f.name if not s.get("flag") else s["flag"]):
                settings.check_value(cls, f, value)
        if kind in ("int", "float") and not s.get("choices"):
            assert s.get("lo") is not None and s.get("hi") is not None, f"{cls.__name__}.{f.name} has no range"


def test_every_recipe_setting_is_reachable_by_set_and_refused_out_of_range():
    recipe = RECIPES["grid-3d"]
    keys = [f.name for f in dataclasses.fields(TrainConfig)] + \
        [f.name for f in dataclasses.fields(RenderConfig) if f.name != "occupancy"] + \
        [f"occupancy.{f.name}" for f in dataclasses.fields(OccupancyConfig)] + \
        [f.name for f in dataclasses.fields(FIELDS["grid"][0]) if f.name not in ("dim", "bound")]
    for key in keys:
        assert recipe.has(key), key
        cls, f = recipe.declared(key)
        hi = settings.spec(f).get("hi")
        if hi is not None and settings._shape(settings.types_of(cls)[f.name])[0] in ("int", "float"):
            with pytest.raises(ConfigError):
                recipe.override(**{key: hi * 2 + 1}).validate()
    assert recipe.declared("no_such_setting") is None


def test_set_and_flag_give_the_same_error(tmp_path, capsys):
    from mitnerf.cli import main

    rc1 = main(["fit", "--data", str(tmp_path), "--lr", "-1"])
    err1 = capsys.readouterr().err
    assert rc1 == 2 and "--lr: it must be > 0, got -1" in err1
    for argv, words in [(["--set", "lr=-1"], "--lr must be > 0, got -1"),
                        (["--set", "lr=\"fast\""], "--lr must be a number"),
                        (["--set", "occupancy.resolution=0"], "--set occupancy.resolution must be >= 2"),
                        (["--set", "nonsense=1"], "has no setting 'nonsense'")]:
        assert settings.parse_set(argv[1])
        from mitnerf.cli.args import recipe_from_args
        args = build_parser().parse_args(["fit", "--data", "x", *argv])
        with pytest.raises(ConfigError, match=words):
            recipe_from_args(args, SimpleNamespace(dim=3))           # refused before the data sizes the recipe
