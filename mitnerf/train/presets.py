"""Tuned starting points per field family for 2D scenes (the bunny protocol: 50 views
of 100 px) and 3D objects. ``preset(field, dim)`` returns fresh copies."""

from __future__ import annotations

import copy

from ..render.pipeline import RenderConfig
from .config import ModelConfig, TrainConfig

_PRESETS = {
    # field: {dim: (model, train)}
    "vanilla": {
        2: (ModelConfig("vanilla", dict(width=64, depth=4, pos_L=8, dir_L=4), RenderConfig(n_coarse=64)),
            TrainConfig(iters=3000, lr=5e-3, lr_final=2e-4, batch_rays=1024)),
        3: (ModelConfig("vanilla", dict(width=64, depth=4, pos_L=10, dir_L=4), RenderConfig(n_coarse=64, n_fine=32)),
            TrainConfig(iters=3000, lr=5e-3, lr_final=2e-4, batch_rays=2048)),
    },
}


def preset_fields() -> list[str]:
    return list(_PRESETS)


def preset(field: str, dim: int) -> tuple[ModelConfig, TrainConfig]:
    from ..errors import MitnerfError

    if field not in _PRESETS:
        raise MitnerfError(f"no preset for field {field!r}; choose one of {', '.join(_PRESETS)}")
    return copy.deepcopy(_PRESETS[field][dim])
