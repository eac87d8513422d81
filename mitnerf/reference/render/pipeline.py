"""Twin of :mod:`mitnerf.render.pipeline`: fields plus coarse/fine rendering in PyTorch."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from torch import nn

from ...render.pipeline import FieldSet, RenderConfig, join_params, split_params, sum_terms
from .occupancy import occupied_samples
from .samplers import Stratified, importance_sample
from .volume import volume_render


class Model(nn.Module, FieldSet):
    def __init__(self, fields: dict, render_cfg: RenderConfig):
        super().__init__()
        self.fields = nn.ModuleDict(fields)
        self.render_cfg = render_cfg

    def to_numpy(self) -> dict:
        return join_params(**{g: f.to_numpy() for g, f in self.fields.items()})

    def load_numpy(self, arrays: dict) -> None:
        for g, f in self.fields.items():
            f.load_numpy(split_params(arrays, g))

    def schedule(self, step: int) -> bool:
        """Apply the fields' training schedules (in place); True if parameters were replaced."""
        return any([f.schedule(step) for f in self.fields.values()])

    def regularizer(self, seed: int):
        return sum_terms(f.regularizer(seed) for f in self.fields.values())

    def density(self, x: torch.Tensor) -> torch.Tensor:
        return self.fields[self.final_field()].density(x)

    def render(self, origins, directions, near, far, seed: int, training: bool, weights: bool = False,
               occupancy=None, background=None) -> dict:
        cfg, seed, space = self.render_cfg, int(np.uint32(seed)), self.render_cfg.space
        bg = cfg.render_background() if background is None else background
        n = origins.shape[0]
        f = 1 if training else cfg.render_oversample             # render_oversample: as the Dr.Jit pipeline's
        if occupancy is not None and cfg.occupancy.enabled:
            coarse = self.fields["coarse"]
            sampler = occupied_samples(occupancy, origins, directions, near, far, cfg.n_coarse * f, seed, training,
                                       space, density=coarse.density,
                                       early_stop=cfg.occupancy.early_stop if training and coarse.traceable else 0.0)
        else:
            sampler = Stratified(cfg.n_coarse * f, seed, jitter=training, knee=space.knee)
        kw = dict(w_min=cfg.min_color_weight, space=space)
        result = {"coarse": volume_render(self.fields["coarse"], origins, directions, near, far, sampler,
                                          bg, weights=True, **kw), "fine": None}
        if cfg.n_fine > 0:
            t, delta = sampler.points(n, near, far)
            sampler = importance_sample(t, delta, result["coarse"].weights, cfg.n_fine, seed, training)
            result["fine"] = volume_render(self.fields[self.final_field()], origins, directions, near, far, sampler,
                                           bg, weights=weights, **kw)
        elif not weights:
            result["coarse"] = replace(result["coarse"], weights=None)
        if weights:
            result["samples"] = sampler.points(n, near, far)
            t = result["samples"][0]
            result["spacing"] = space.spacing(*result["samples"], torch.as_tensor(near, dtype=t.dtype),
                                              torch.as_tensor(far, dtype=t.dtype), torch.where)
        return result
