"""PyTorch twins of the fields, by family name (as ``mitnerf.fields.FIELDS``)."""

from __future__ import annotations

from ...errors import MitnerfError
from ...fields import field_config
from .grid import GridField
from .hashgrid import HashGridField
from .hashlinear import HashLinearField
from .mlp import NeRFField

TORCH_FIELDS = {"vanilla": NeRFField, "grid": GridField, "hashgrid": HashGridField, "hashlinear": HashLinearField}


def make_field(kind: str, **kwargs):
    if kind not in TORCH_FIELDS:
        raise MitnerfError(f"field {kind!r} has no PyTorch twin; use --backend drjit")
    return TORCH_FIELDS[kind](field_config(kind, **kwargs))
