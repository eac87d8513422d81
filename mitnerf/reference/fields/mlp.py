"""Twin of :mod:`mitnerf.fields.mlp`: the vanilla NeRF field as a ``torch.nn.Module``, its parameters
named as the canonical Dr.Jit names (``trunk.0.weight`` ...)."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from ...fields.mlp import NeRFConfig, init_weights, layer_shapes
from .encoding import direction_encoding, positional_encoding


def density_activation(raw: torch.Tensor, kind: str) -> torch.Tensor:
    if kind == "relu":
        return torch.relu(raw)
    if kind == "softplus":
        return torch.relu(raw) + torch.log(1.0 + torch.exp(-torch.abs(raw)))
    if kind == "trunc_exp":
        return torch.exp(torch.clamp(raw, max=15.0))
    raise ValueError(f"unknown density activation {kind!r}")


class TwinField(nn.Module):
    """The twins' contract: ``cfg``, ``dim``, weights as numpy arrays under the canonical names, ``density(x)``,
    ``query(x, d)``, and a training schedule and regulariser (none by default)."""

    traceable = True
    """Whether the Dr.Jit field of the same name runs inside the fused march (its ``traceable``): a sampler may then
    read its density while it places samples (:attr:`~mitnerf.render.occupancy.OccupancyConfig.early_stop`)."""

    def __init__(self, cfg):
        super().__init__()
        self.cfg, self.dim = cfg, cfg.dim

    def load_numpy(self, arrays) -> None:
        self.load_state_dict({k: torch.as_tensor(np.asarray(v, np.float32)) for k, v in arrays.items()})

    def to_numpy(self) -> dict:
        return {k: v.detach().numpy().copy() for k, v in self.state_dict().items()}

    def schedule(self, step: int) -> bool:          # applied in place; True if parameters were replaced
        return False

    def regularizer(self, seed: int):               # a loss term on the parameters, or None
        return None


class NeRFField(TwinField):
    def __init__(self, cfg: NeRFConfig):
        super().__init__(cfg)
        self.traceable = cfg.mode == "coopvec"
        shapes = {name: (i, o) for name, o, i in layer_shapes(cfg)}        # nn.Linear(in, out)
        self.trunk = nn.ModuleList(nn.Linear(*shapes[f"trunk.{k}"]) for k in range(cfg.depth))
        self.sigma = nn.Linear(*shapes["sigma"])
        self.color = nn.ModuleList(nn.Linear(*shapes[f"color.{k}"]) for k in range(2))
        self.step: int | None = None
        """The step ``pe_window``'s schedule renders at, set by the torch engine (its ``step_reached``); None: all
        frequencies open."""

    def init_params(self, seed: int = 0) -> None:
        self.load_numpy(init_weights(self.cfg, seed))

    def _trunk(self, x: torch.Tensor) -> torch.Tensor:
        cfg = self.cfg
        opened = None if self.step is None or not cfg.pe_window else self.step * (cfg.pos_L / cfg.pe_window)
        enc = positional_encoding(x / cfg.bound, cfg.pos_L, opened)
        h = enc
        for k, layer in enumerate(self.trunk):
            if k == self.cfg.skip and k > 0:
                h = torch.cat([h, enc], dim=-1)
            h = torch.relu(layer(h))
        return h

    def density(self, x: torch.Tensor) -> torch.Tensor:
        return density_activation(self.sigma(self._trunk(x))[..., 0], self.cfg.density_activation)

    def query(self, x: torch.Tensor, d: torch.Tensor):
        """``x, d [n, D]`` -> ``sigma [n]``, ``rgb [n, 3]``."""
        h = self._trunk(x)
        sigma = density_activation(self.sigma(h)[..., 0], self.cfg.density_activation)
        c = torch.cat([h, direction_encoding(d, self.cfg.dir_L)], -1) if self.cfg.view_dependent else h
        rgb = torch.sigmoid(self.color[1](torch.relu(self.color[0](c))))
        return sigma, rgb
