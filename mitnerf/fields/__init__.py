"""Fields: functions from positions (and view directions) to density and colour.

``FIELDS`` maps a family name to ``(config class, Dr.Jit field class)``; the PyTorch
twins are registered in ``mitnerf.reference.fields``. Every field follows the
contract :class:`mitnerf.fields.base.Field`.
"""

from __future__ import annotations

import dataclasses

from ..errors import ConfigError
from .grid import GridConfig, GridField
from .hashgrid import HashGridConfig, HashGridField
from .hashlinear import HashLinearConfig, HashLinearField
from .mlp import NeRFConfig, NeRFField
from .pixelnerf import PixelNeRFConfig, PixelNeRFField

FIELDS: dict[str, tuple[type, type]] = {
    "vanilla": (NeRFConfig, NeRFField),
    "grid": (GridConfig, GridField),
    "hashgrid": (HashGridConfig, HashGridField),
    "hashlinear": (HashLinearConfig, HashLinearField),
    "pixelnerf": (PixelNeRFConfig, PixelNeRFField),
}
CONDITIONED = ("pixelnerf",)
"""Families that render from input views (a context), trained across scenes, not fitted to one."""


def field_config(kind: str, **kwargs):
    """The config of family ``kind``; unknown families or arguments are refused with the valid ones."""
    if kind not in FIELDS:
        raise ConfigError(f"unknown field {kind!r}; choose one of {', '.join(FIELDS)}")
    cls = FIELDS[kind][0]
    unknown = sorted(set(kwargs) - {f.name for f in dataclasses.fields(cls)})
    if unknown:
        raise ConfigError(f"the {kind} field has no setting {', '.join(map(repr, unknown))}; its settings are "
                          f"{', '.join(f.name for f in dataclasses.fields(cls) if f.name not in ('dim', 'bound'))}")
    return cls(**kwargs)


def make_field(kind: str, **kwargs):
    """A Dr.Jit field of family ``kind`` built from its config's keyword arguments."""
    return FIELDS[kind][1](field_config(kind, **kwargs))
