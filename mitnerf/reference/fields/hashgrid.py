"""Twin of :mod:`mitnerf.fields.hashgrid`: hash encoding and the two tiny networks in PyTorch."""

from __future__ import annotations

import torch
from torch import nn

from ...fields.hashgrid import HashGridConfig, HashGridField as _DrJitField
from .encoding import direction_encoding
from .hashenc import hash_encode
from .mlp import TwinField, density_activation


class HashGridField(TwinField):
    def __init__(self, cfg: HashGridConfig):
        super().__init__(cfg)
        twin = _DrJitField(cfg)                      # the layout and layer shapes
        self.traceable = twin.traceable
        self.layout = twin.layout
        self.table = nn.Parameter(torch.zeros(twin.n_table))
        shapes = {name: (i, o) for name, o, i in twin.shapes}        # nn.Linear(in, out)
        self.sigma_net = nn.ModuleList(nn.Linear(*shapes[f"sigma_net.{k}"]) for k in range(2))
        self.color_net = nn.ModuleList(nn.Linear(*shapes[f"color_net.{k}"]) for k in range(2))

    def _sigma_and_geo(self, x):
        b = self.cfg.bound
        inside = (x.abs() <= b).all(dim=1)
        feat = hash_encode(self.table, torch.clamp((x / b + 1.0) * 0.5, 0.0, 1.0), self.layout)
        out = self.sigma_net[1](torch.relu(self.sigma_net[0](feat)))
        sigma = torch.where(inside, density_activation(out[:, 0], self.cfg.density_activation),
                            torch.zeros_like(out[:, 0]))
        return sigma, out

    def density(self, x):
        return self._sigma_and_geo(x)[0]

    def query(self, x, d):
        sigma, out = self._sigma_and_geo(x)
        c = out[:, 1:]
        if self.cfg.view_dependent:
            c = torch.cat([c, direction_encoding(d, self.cfg.dir_L)], dim=1)
        return sigma, torch.sigmoid(self.color_net[1](torch.relu(self.color_net[0](c))))
