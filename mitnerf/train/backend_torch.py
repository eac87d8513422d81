"""The PyTorch backend (the reference): the torch twin of the model, ``torch.optim.Adam``,
and the same batches and sample jitter as the Dr.Jit backend."""

from __future__ import annotations

import numpy as np

from .config import ModelConfig, TrainConfig, model_fields
from .rays import RaySet, batch_indices


def build_torch_model(cfg: ModelConfig, dim: int, bound: float):
    from ..reference.fields import make_field
    from ..reference.render.pipeline import Model

    return Model(model_fields(cfg, dim, bound, make_field), cfg.render)


class TorchBackend:
    name = "torch"

    def __init__(self, model_cfg: ModelConfig, dim: int, bound: float, near: float, far: float,
                 train_cfg: TrainConfig):
        import torch

        torch.set_num_threads(train_cfg.threads)
        self.torch = torch
        self.model = build_torch_model(model_cfg, dim, bound)
        from .backend_drjit import build_model

        twin = build_model(model_cfg, dim, bound)          # the same initial weights as the Dr.Jit backend
        self.model.load_numpy(twin.to_numpy(twin.init_params(train_cfg.seed)))
        self.near, self.far = float(near), float(far)
        self.cfg = train_cfg
        self.opt = torch.optim.Adam(self.model.parameters(), lr=train_cfg.lr, betas=(train_cfg.beta1, train_cfg.beta2),
                                    eps=train_cfg.eps)
        occ = model_cfg.render.occupancy
        if occ.enabled:
            from ..reference.render.occupancy import OccupancyGrid

            self.occupancy = OccupancyGrid(occ, dim, bound)
        else:
            self.occupancy = None

    def set_data(self, rays: RaySet) -> None:
        t = self.torch
        self.data = {k: t.from_numpy(np.ascontiguousarray(getattr(rays, k)))
                     for k in ("origins", "directions", "target", "depth", "hit")}
        self.n_pixels = len(rays)

    def _rebuild_optimizer(self) -> None:
        """After parameters were replaced: a new Adam that keeps the state of the others."""
        old = self.opt
        cfg = self.cfg
        self.opt = self.torch.optim.Adam(self.model.parameters(), lr=cfg.lr, betas=(cfg.beta1, cfg.beta2), eps=cfg.eps)
        for p in self.model.parameters():
            if p in old.state:
                self.opt.state[p] = old.state[p]

    def step(self, seed: int, lr: float, index: int = 0):
        from ..reference.train.losses import depth_kl, mse

        if self.model.schedule(index):
            self._rebuild_optimizer()
        if self.occupancy is not None and index % self.occupancy.cfg.update_every == 0:
            with self.torch.no_grad():
                self.occupancy.update(self.model.density, index, seed)
        cfg = self.cfg
        for group in self.opt.param_groups:
            group["lr"] = lr
        idx = self.torch.from_numpy(batch_indices(seed, cfg.batch_rays, self.n_pixels))
        b = {k: v[idx] for k, v in self.data.items()}
        use_depth = cfg.depth_weight > 0
        outs = self.model.render(b["origins"], b["directions"], self.near, self.far, seed, training=True,
                                 weights=use_depth, occupancy=self.occupancy)
        out = outs["fine"] if outs["fine"] is not None else outs["coarse"]
        loss = mse(out.rgb, b["target"])
        if outs["fine"] is not None and cfg.coarse_weight > 0:
            loss = loss + cfg.coarse_weight * mse(outs["coarse"].rgb, b["target"])
        reg = self.model.regularizer(seed)
        if reg is not None:
            loss = loss + reg
        if use_depth:
            t, delta = outs["samples"]
            loss = loss + cfg.depth_weight * depth_kl(out.weights, t, delta, b["depth"], b["hit"], cfg.depth_sigma)
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        self.opt.step()
        return loss.detach()

    @staticmethod
    def scalar(loss) -> float:
        return float(loss.item())

    def render(self, origins: np.ndarray, directions: np.ndarray, chunk: int = 8192) -> dict:
        t = self.torch
        parts = []
        with t.no_grad():
            for s in range(0, len(origins), chunk):
                o, d = t.from_numpy(origins[s:s + chunk]), t.from_numpy(directions[s:s + chunk])
                outs = self.model.render(o, d, self.near, self.far, 0, training=False, occupancy=self.occupancy)
                out = outs["fine"] if outs["fine"] is not None else outs["coarse"]
                parts.append((out.rgb.numpy(), out.depth.numpy(), out.opacity.numpy()))
        if not parts:
            return {"rgb": np.zeros((0, 3), np.float32), "depth": np.zeros(0, np.float32),
                    "opacity": np.zeros(0, np.float32)}
        return {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(("rgb", "depth", "opacity"))}

    def density(self, x: np.ndarray) -> np.ndarray:
        with self.torch.no_grad():
            return self.model.density(self.torch.from_numpy(x.astype(np.float32))).numpy()

    def get_weights(self) -> dict[str, np.ndarray]:
        out = self.model.to_numpy()
        if self.occupancy is not None:
            out.update({f"occupancy.{k}": v for k, v in self.occupancy.state().items()})
        return out

    def set_weights(self, arrays: dict[str, np.ndarray]) -> None:
        arrays = dict(arrays)
        occ = {k.split(".", 1)[1]: arrays.pop(k) for k in list(arrays) if k.startswith("occupancy.")}
        if occ and self.occupancy is not None:
            self.occupancy.load(occ)
        self.model.load_numpy(arrays)
