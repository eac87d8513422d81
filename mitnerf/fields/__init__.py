"""Fields: functions from positions (and view directions) to density and colour.

``FIELDS`` maps a family name to ``(config class, Dr.Jit field class)``; the PyTorch
twins are registered in ``mitnerf.reference.fields``. Every field follows the
protocol in :mod:`mitnerf.fields.base`.
"""

from __future__ import annotations

from .grid import GridConfig, GridField
from .hashgrid import HashGridConfig, HashGridField
from .mlp import NeRFConfig, NeRFField

FIELDS: dict[str, tuple[type, type]] = {
    "vanilla": (NeRFConfig, NeRFField),
    "grid": (GridConfig, GridField),
    "hashgrid": (HashGridConfig, HashGridField),
}


def field_config(kind: str, **kwargs):
    if kind not in FIELDS:
        from ..errors import MitnerfError

        raise MitnerfError(f"unknown field {kind!r}; choose one of {', '.join(FIELDS)}")
    return FIELDS[kind][0](**kwargs)


def make_field(kind: str, **kwargs):
    """A Dr.Jit field of family ``kind`` built from its config's keyword arguments."""
    return FIELDS[kind][1](field_config(kind, **kwargs))
