"""The torch engine (the reference twin): ``torch.optim.Adam``, the same initial weights, batches and jitter."""

from __future__ import annotations

import numpy as np
import torch

from ..reference.fields import make_field
from ..reference.render.occupancy import OccupancyGrid
from ..reference.render.pipeline import Model
from ..reference.train import losses
from ..rng import uniform_np
from .backend import SOLID_SALT, Backend, behind_depth, jitter_np, model_fields, training_loss
from .backend_drjit import build_model


def build_torch_model(cfg, dim: int, bound: float) -> Model:
    """The torch twin of :func:`mitnerf.train.backend_drjit.build_model` (its own initial weights)."""
    return Model(model_fields(cfg, dim, bound, make_field), cfg.render)


class TorchBackend(Backend):
    name = "torch"

    def __init__(self, model_cfg, train_cfg, dim, bound, near, far):
        super().__init__(model_cfg, train_cfg, dim, bound, near, far)
        torch.set_num_threads(train_cfg.threads)
        self.model = build_torch_model(model_cfg, dim, bound)
        # the same initial weights as the Dr.Jit engine (both start from the fields' numpy init)
        self.model.load_numpy(build_model(model_cfg, dim, bound).init_numpy(train_cfg.seed))
        self.opt = None
        self._rebuild_optimizer()
        occ = model_cfg.render.occupancy
        self.occupancy = OccupancyGrid(occ, dim, bound) if occ.enabled else None

    def _rebuild_optimizer(self) -> None:
        """A new Adam (after parameters were replaced) that keeps the state of the others."""
        c, old = self.cfg, self.opt
        self.opt = torch.optim.Adam(self.model.parameters(), lr=c.lr, betas=(c.beta1, c.beta2), eps=c.eps)
        if old is not None:
            self.opt.state.update({p: old.state[p] for p in self.model.parameters() if p in old.state})

    @property
    def step_reached(self) -> int | None:
        return self._step_reached

    @step_reached.setter
    def step_reached(self, step: int | None) -> None:
        """Also what the twins with a step-dependent schedule render at (their ``step``)."""
        self._step_reached = step
        model = getattr(self, "model", None)            # None while Backend.__init__ sets it
        for f in model.fields.values() if model is not None else ():
            if hasattr(f, "step"):
                f.step = step

    def step(self, index: int, seed: int, lr: float):
        if self.model.schedule(index):
            self._rebuild_optimizer()
        self.step_reached = index
        self.update_occupancy(index, seed)
        for group in self.opt.param_groups:
            group["lr"] = lr
        b = {k: torch.from_numpy(v) for k, v in vars(self.batch(seed)).items()}
        d = b["directions"]
        if self.model_cfg.render.pixel_jitter:
            d = torch.from_numpy(jitter_np(seed, d.numpy(), b["footprint"].numpy()).astype(np.float32))
        outs = self.model.render(b["origins"], d, self.near, self.far, seed, training=True,
                                 weights=self.cfg.needs_weights, occupancy=self.occupancy, background=b["background"])
        behind = None
        if self.cfg.solid_weight > 0:           # points within the solid extent behind pixel-centre depths
            n = len(b["depth"])
            u = uniform_np(seed ^ SOLID_SALT, np.arange(n, dtype=np.uint32), np.zeros(n, np.uint32))
            t = behind_depth(torch.from_numpy(u), b["depth"], b["solid"], self.cfg.solid_start)
            behind = (self.model.density(b["origins"] + t[:, None] * b["directions"]), (b["solid"] > 0).float())
        weight = self.drawn[1]
        loss = training_loss(self.cfg, self.n_final, losses, outs, b["target"], b["depth"], b["hit"], b["free"],
                             behind, self.model.regularizer(seed), None if weight is None else torch.from_numpy(weight))
        final = outs["fine"] if outs.get("fine") is not None else outs["coarse"]
        self.mined(losses.rms_error(final.rgb, b["target"]).numpy() if self.errors is not None else None)
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        bad = next((n for n, p in self.model.named_parameters()
                    if p.grad is not None and not torch.isfinite(p.grad).all()), None)
        self.opt.step()
        return loss.detach(), bad

    def read(self, handle) -> tuple[float, str | None]:
        loss, bad = handle
        value = float(loss.item())
        if bad is not None:
            return value, f"the gradient of {bad}"
        if np.isfinite(value):                      # a parameter can overflow with finite gradients
            bad = next((n for n, p in self.model.named_parameters() if not torch.isfinite(p).all()), None)
        return value, bad and f"parameter {bad}"

    def _density_fn(self):
        return torch.no_grad()(self.model.density)

    def render_chunk(self, origins: np.ndarray, directions: np.ndarray) -> dict:
        with torch.no_grad():
            outs = self.model.render(torch.from_numpy(origins), torch.from_numpy(directions), self.near, self.far, 0,
                                     training=False, occupancy=self.occupancy)
            out = outs["fine"] if outs["fine"] is not None else outs["coarse"]
            return {"rgb": out.rgb.numpy(), "depth": out.depth.numpy(), "opacity": out.opacity.numpy()}

    def density(self, x: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return self.model.density(torch.from_numpy(np.asarray(x, np.float32))).numpy()

    def model_weights(self) -> dict[str, np.ndarray]:
        return self.model.to_numpy()

    def load_model_weights(self, arrays: dict[str, np.ndarray]) -> None:
        self.model.load_numpy(arrays)
        self._rebuild_optimizer()

    def optimizer_state(self) -> dict[str, np.ndarray]:
        out = {}
        for name, p in self.model.named_parameters():
            st = self.opt.state.get(p)
            if st:
                out[f"{name}.t"] = np.array([int(st["step"])], np.uint32)
                out[f"{name}.m"], out[f"{name}.v"] = st["exp_avg"].numpy().copy(), st["exp_avg_sq"].numpy().copy()
        return out

    def load_optimizer_state(self, arrays: dict[str, np.ndarray]) -> None:
        for name, p in self.model.named_parameters():
            if f"{name}.m" in arrays:
                self.opt.state[p] = {"step": torch.tensor(float(arrays[f"{name}.t"][0])),
                                     "exp_avg": torch.from_numpy(np.array(arrays[f"{name}.m"])),
                                     "exp_avg_sq": torch.from_numpy(np.array(arrays[f"{name}.v"]))}
