"""Tuned starting points per field family for 2D scenes (the bunny protocol: 50 views
of 100 px) and 3D objects (25 views of 100x100). ``preset(field, dim)`` returns fresh
copies. Measured on 2 cores (while other jobs ran, so these are lower bounds):

* 2D bunny, 10 s of training: grid 33.3 dB (450 steps), vanilla MLP ~20 dB,
  hash grid 23.2 dB (with occupancy).
* 3D vase, 60 s: grid + occupancy 31.8 dB (1085 steps), hash grid + occupancy 25.0 dB.
"""

from __future__ import annotations

import copy

from ..render.occupancy import OccupancyConfig
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
    "grid": {
        2: (ModelConfig("grid", dict(resolution=513, initial_resolution=129, upsample_at=(150, 400), tv_weight=1e-4),
                        RenderConfig(n_coarse=128)),
            TrainConfig(iters=1500, lr=0.05, lr_final=0.005, batch_rays=1024)),
        3: (ModelConfig("grid", dict(resolution=129, initial_resolution=33, upsample_at=(200, 600), tv_weight=1e-4),
                        RenderConfig(n_coarse=64, occupancy=OccupancyConfig(enabled=True, resolution=64,
                                                                            march_bins=256))),
            TrainConfig(iters=3000, lr=0.05, lr_final=0.005, batch_rays=2048)),
    },
    "hashgrid": {
        2: (ModelConfig("hashgrid", dict(n_levels=8, log2_hashmap_size=14, hidden=16, geo_features=7),
                        RenderConfig(n_coarse=48, occupancy=OccupancyConfig(enabled=True, resolution=128,
                                                                            warmup=32))),
            TrainConfig(iters=2000, lr=0.02, lr_final=0.002, batch_rays=1024)),
        3: (ModelConfig("hashgrid", dict(n_levels=12, log2_hashmap_size=16, base_resolution=16, max_resolution=512),
                        RenderConfig(n_coarse=48, occupancy=OccupancyConfig(enabled=True, resolution=64,
                                                                            march_bins=256))),
            TrainConfig(iters=3000, lr=0.01, lr_final=0.001, batch_rays=2048)),
    },
}


def preset_fields() -> list[str]:
    return list(_PRESETS)


def preset(field: str, dim: int) -> tuple[ModelConfig, TrainConfig]:
    from ..errors import MitnerfError

    if field not in _PRESETS:
        raise MitnerfError(f"no preset for field {field!r}; choose one of {', '.join(_PRESETS)}")
    return copy.deepcopy(_PRESETS[field][dim])
