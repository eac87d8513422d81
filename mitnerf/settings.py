"""One declaration per setting.

A config is a dataclass. Each field made with :func:`setting` declares, once, its range or choices, its unit and
its command-line flag (if it has one); its type is its annotation and its help is the string written under it.
Everything else is generated from that declaration: :func:`check` (what every config's ``validate()`` runs),
:func:`parse_set` (a ``--set KEY=VALUE``), :func:`add_flags` (the command line) and the help text. Rules that tie
settings together (a degree capped by the dimension) stay in the config, after :func:`check`.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import inspect
import json
import math
import re
import textwrap
import types
import typing

from .errors import ConfigError

KEY = "mitnerf"
METAVARS = {"int": "N", "float": "X", "tuple": "A,B,..."}
"""A flag's placeholder by the kind of its value (others: ``TEXT``)."""


def setting(default=dataclasses.MISSING, *, lo=None, hi=None, above: bool = False, choices=None, flag=None,
            unit: str = "", parse=None, factory=dataclasses.MISSING, metavar=None, shown=None, selects: bool = False):
    """A dataclass field and its checks: a number (or each number of a tuple) in ``[lo, hi]`` (``(lo, hi]`` with
    ``above``), or one of ``choices``; ``flag``: its command-line flag; ``unit``: shown in the help; ``parse``:
    how the flag's text becomes the value (default: by the type); ``shown``: the default as the help names it
    (default: the value); ``selects``: it chooses which of an experiment's runs take place, so a value other than
    the default runs part of the experiment (:func:`~mitnerf.experiments.reproduction.partial`)."""
    meta = {KEY: dict(lo=lo, hi=hi, above=above, choices=tuple(choices) if choices else None, flag=flag, unit=unit,
                      parse=parse, metavar=metavar, shown=shown, selects=selects)}
    if factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def spec(f: dataclasses.Field) -> dict:
    return f.metadata.get(KEY, {})


@functools.cache
def types_of(cls) -> dict:
    return typing.get_type_hints(cls)


@functools.cache
def docs(cls) -> dict[str, str]:
    """The string written under each field of ``cls`` and its bases: the fields' help."""
    out = {}
    for klass in reversed(cls.__mro__):
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError, SyntaxError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for a, b in zip(body, body[1:]):
            if isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr) \
                    and isinstance(b.value, ast.Constant) and isinstance(b.value.value, str):
                out[a.target.id] = " ".join(b.value.value.split())
    return out


def _shape(tp, value=None) -> tuple[str, bool, tuple | None]:
    """``(kind, may be None, literal choices)`` of an annotation (of a union, the member ``value`` is: a list is
    a tuple): kind is bool, int, float, str, tuple, dict or a dataclass."""
    optional, choices = False, None
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        optional = len(args) < len(typing.get_args(tp))
        member = tuple if isinstance(value, list) else type(value)
        tp = member if member in args else args[0]
    if typing.get_origin(tp) is typing.Literal:
        choices = typing.get_args(tp)
        tp = type(choices[0])
    tp = typing.get_origin(tp) or tp
    kind = tp if dataclasses.is_dataclass(tp) else getattr(tp, "__name__", str(tp))
    return kind, optional, choices


def name_of(f: dataclasses.Field, prefix: str = "") -> str:
    """How an error names a setting: its flag, else ``--set <key>``."""
    return spec(f).get("flag") or f"--set {prefix}{f.name}"


def check_value(cls, f: dataclasses.Field, value, prefix: str = ""):
    """``value`` for the field ``f`` of ``cls``, checked against its declaration (a list becomes a tuple); raises
    :class:`ConfigError` naming the setting as the user writes it."""
    kind, optional, choices = _shape(types_of(cls)[f.name], value)
    s, what = spec(f), name_of(f, prefix)
    choices = s.get("choices") or choices
    if value is None:
        if optional:
            return None
        raise ConfigError(f"{what} cannot be null; give a value (default: {_show(f)})")
    if dataclasses.is_dataclass(kind):
        if isinstance(value, dict):
            value = kind(**value)
        if not isinstance(value, kind):
            raise ConfigError(f"{what} must be a group of settings, got {_got(value)}")
        check(value, f"{prefix}{f.name}.")
        return value
    if kind == "tuple":
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{what} must be a list, got {_got(value)}; e.g. {json.dumps(list(default_of(f) or ()))}")
        if choices is not None:
            bad = [v for v in value if v not in choices]
            if bad:
                raise ConfigError(f"{what}: {bad[0]!r} is not one of {', '.join(map(str, choices))}")
            return tuple(value)
        if _of_text(f):
            if not all(isinstance(v, str) for v in value):
                raise ConfigError(f"{what} must be a list of names, got {_got(value)}")
            return tuple(value)
        return tuple(_number(what, v, s, integer=False) for v in value)
    if choices is not None:
        value = int(value) if kind == "int" and isinstance(value, float) and value.is_integer() else value
        if value not in choices:
            raise ConfigError(f"{what} must be one of {', '.join(map(str, choices))}, got {_got(value)}")
        return value
    if kind in _TYPES and not isinstance(value, _TYPES[kind][0]):
        raise ConfigError(f"{what} must be {_TYPES[kind][1]}, got {_got(value)}")
    return _number(what, value, s, integer=kind == "int") if kind in ("int", "float") else value


_TYPES = {"dict": (dict, "a group of settings"), "bool": (bool, "true or false"), "str": (str, "a string")}
"""The kinds of setting checked by type alone: the type, and what an error says the value must be."""


def _got(value) -> str:
    """A bad value as an error quotes it (JSON, cut to 40 characters)."""
    return json.dumps(value, default=str)[:40]


def _of_text(f: dataclasses.Field) -> bool:
    """Whether a tuple setting holds names (its default's elements are strings), not numbers."""
    d = default_of(f)
    return isinstance(d, tuple) and bool(d) and isinstance(d[0], str) or spec(f).get("lo") is None and \
        spec(f).get("hi") is None and not d


def _number(what: str, value, s: dict, integer: bool):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not float(value).is_integer()):
        raise ConfigError(f"{what} must be {'a whole' if integer else 'a'} number, got {_got(value)}")
    if not math.isfinite(value):
        raise ConfigError(f"{what} must be a finite number, got {value}")
    lo, hi, above = s.get("lo"), s.get("hi"), s.get("above")
    if lo is not None and (value <= lo if above else value < lo):
        raise ConfigError(f"{what} must be {'>' if above else '>='} {lo:g}, got {value:g}")
    if hi is not None and value > hi:
        raise ConfigError(f"{what} must be <= {hi:g}, got {value:g}")
    return int(value) if integer else value


def check(cfg, prefix: str = "") -> None:
    """Check every declared field of the dataclass ``cfg`` (types, ranges, choices; nested configs too), and
    store the normalised values (a list read from JSON becomes a tuple)."""
    cls = type(cfg)
    for f in dataclasses.fields(cfg):
        if KEY in f.metadata or dataclasses.is_dataclass(_shape(types_of(cls)[f.name])[0]):
            object.__setattr__(cfg, f.name, check_value(cls, f, getattr(cfg, f.name), prefix))


def field_named(cls, key: str) -> dataclasses.Field | None:
    return next((f for f in dataclasses.fields(cls) if f.name == key), None)


def parse_set(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` (an argparse type); the value is a JSON literal when it parses, else the text."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected key=value, got {text!r}")
    key, value = text.split("=", 1)
    try:
        return key.strip(), json.loads(value)
    except json.JSONDecodeError:
        return key.strip(), value


def show_value(v) -> str:
    """A setting's value as the help shows it."""
    if v is dataclasses.MISSING:
        return "required"
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, tuple):
        return ",".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v) or "none"
    return "none" if v is None else f"{v:g}" if isinstance(v, float) else str(v)


def _show(f: dataclasses.Field) -> str:
    return show_value(default_of(f))


def flag_type(cls, f: dataclasses.Field):
    """The argparse ``type`` of a field's flag: the text parsed as the declaration says, and checked."""
    s = spec(f)

    def parse(text: str):
        try:
            value = s["parse"](text) if s.get("parse") else _from_text(cls, f, text)
            return check_value(cls, f, value)
        except (ConfigError, ValueError) as exc:
            raise argparse.ArgumentTypeError(str(exc).replace(f"{name_of(f)} ", "it ", 1)) from None
    kind = _shape(types_of(cls)[f.name])[0]
    parse.__name__ = kind if isinstance(kind, str) else "value"
    return parse


def _from_text(cls, f, text: str):
    kind = _shape(types_of(cls)[f.name])[0]
    if kind in ("int", "float"):                # a whole number checked as one by check_value
        return float(text)
    if kind == "tuple":
        return tuple(float(x) for x in text.split(","))
    return text


def add_flags(group, cls, *, prefix: str = "", dest: str = "", overrides: bool = False, shown=None,
              seen: set | None = None) -> dict[str, str]:
    """Add the flag of every field of ``cls`` that declares one to the argparse ``group`` (skipping flags in
    ``seen``); the value lands in ``<dest><prefix><name>``. With ``overrides`` an unset flag holds None (the value
    then comes from elsewhere, a recipe) and ``shown(key)`` gives the default the help names. Returns
    ``{flag: key}``."""
    out = {}
    for f in sorted(dataclasses.fields(cls), key=lambda f: f.name not in vars(cls).get("__annotations__", {})):
        s, key = spec(f), f"{prefix}{f.name}"                   # a class's own fields first, then its bases'
        if not s.get("flag") or (seen is not None and s["flag"] in seen):
            continue
        kind, optional, choices = _shape(types_of(cls)[f.name])
        unit = f" [{s['unit']}]" if s.get("unit") else ""
        default = None if overrides else default_of(f)
        told = s.get("shown") or (shown(key) if shown else _show(f))
        text = f"{summary(docs(cls).get(f.name, ''))}{unit} " + \
            ("(required)" if default is dataclasses.MISSING else f"(default: {told})")
        if not s["flag"].startswith("-"):                   # a positional argument (a list: any number of words)
            group.add_argument(s["flag"], help=text, **({"nargs": "*", "metavar": s.get("metavar")} if kind == "tuple"
                                                        else {"type": flag_type(cls, f)}),
                               **({"choices": s["choices"]} if s.get("choices") and kind != "tuple" else {}))
        elif kind == "tuple" and not s.get("parse"):        # a list: one value per word
            group.add_argument(s["flag"], dest=dest + key, default=default, help=text, nargs="+",
                               type=str if _of_text(f) else float, metavar=s.get("metavar") or
                               ("NAME" if _of_text(f) else "X"))
        elif kind == "bool":
            group.add_argument(s["flag"], dest=dest + key, default=default, help=text,
                               action=argparse.BooleanOptionalAction)
        else:
            choices = s.get("choices") or choices
            group.add_argument(s["flag"], dest=dest + key, default=default, help=text, type=flag_type(cls, f),
                               required=default is dataclasses.MISSING and not overrides,
                               metavar=s.get("metavar") or ("|".join(map(str, choices)) if choices else
                                                            METAVARS.get(kind, "TEXT")))
        out[s["flag"]] = key
        if seen is not None:
            seen.add(s["flag"])
    return out


def default_of(f: dataclasses.Field):
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def parse_color(text: str, names: tuple = ()) -> str | tuple:
    """One of ``names``, else ``r,g,b`` -> an RGB tuple."""
    if text in names:
        return text
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3:
        raise ConfigError(f"expected {', '.join(names) + ' or ' if names else ''}r,g,b with values in [0, 1], "
                          f"got {text!r}")
    return values


def summary(text: str) -> str:
    """A field's help from its docstring: the first sentence, without reST markup or references to modules."""
    text = re.sub(r"\s*\((?::\w+:)?``?~?mitnerf[\w.]*``?\)", "", text)
    text = re.sub(r":\w+:`~?([\w.]+)`", lambda m: m.group(1).rsplit(".", 1)[-1], text).replace("``", "")
    cut = text.find(". ")
    return text if cut < 0 else text[:cut + 1]
