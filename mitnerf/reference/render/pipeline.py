"""Twin of :mod:`mitnerf.render.pipeline`: fields plus coarse/fine rendering in PyTorch."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from ...render.pipeline import RenderConfig, join_params, split_params
from .occupancy import occupied_samples
from .samplers import Stratified, importance_sample
from .volume import RenderOutput, volume_render


class Model(nn.Module):
    def __init__(self, fields: dict, render_cfg: RenderConfig):
        super().__init__()
        self.fields = nn.ModuleDict(fields)
        self.render_cfg = render_cfg

    @property
    def dim(self) -> int:
        return self.fields["coarse"].dim

    def to_numpy(self) -> dict:
        return join_params(**{g: f.to_numpy() for g, f in self.fields.items()})

    def load_numpy(self, arrays: dict) -> None:
        for g, f in self.fields.items():
            f.load_numpy(split_params(arrays, g))

    def schedule(self, step: int) -> bool:
        """Apply the fields' training schedules (in place); True if parameters were replaced."""
        return any([f.schedule(step) for f in self.fields.values() if hasattr(f, "schedule")])

    def regularizer(self, seed: int):
        terms = [f.regularizer(seed) for f in self.fields.values() if hasattr(f, "regularizer")]
        terms = [t for t in terms if t is not None]
        return sum(terms[1:], terms[0]) if terms else None

    def final_field(self) -> str:
        return "fine" if "fine" in self.fields else "coarse"

    def density(self, x: torch.Tensor) -> torch.Tensor:
        return self.fields[self.final_field()].density(x)

    def render(self, origins, directions, near, far, seed: int, training: bool, weights: bool = False,
               occupancy=None) -> dict:
        cfg = self.render_cfg
        n = origins.shape[0]
        if occupancy is not None and cfg.occupancy.enabled:
            coarse = occupied_samples(occupancy, origins, directions, near, far, cfg.n_coarse,
                                      int(np.uint32(seed)), training)
        else:
            coarse = Stratified(cfg.n_coarse, int(np.uint32(seed)), jitter=training)
        out_c = volume_render(self.fields["coarse"], origins, directions, near, far, coarse, cfg.background,
                              weights=True)
        if cfg.n_fine <= 0:
            result = {"coarse": out_c if weights else RenderOutput(out_c.rgb, out_c.depth, out_c.opacity), "fine": None}
            if weights:
                result["samples"] = coarse.points(n, near, far)
            return result
        t, delta = coarse.points(n, near, far)
        fine = importance_sample(t, delta, out_c.weights, cfg.n_fine, int(np.uint32(seed)), training)
        g = "fine" if "fine" in self.fields else "coarse"
        out_f = volume_render(self.fields[g], origins, directions, near, far, fine, cfg.background, weights=weights)
        result = {"coarse": out_c, "fine": out_f}
        if weights:
            result["samples"] = fine.points(n, near, far)
        return result
