"""The Dr.Jit backend: the model, Adam (``drjit.opt``), and one frozen training step."""

from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32
from drjit.opt import Adam

from ..fields import make_field
from ..render.occupancy import OccupancyGrid
from ..render.pipeline import Model, final
from ..render.samplers import hash_u32
from .config import ModelConfig, TrainConfig, model_fields
from .losses import depth_kl, mse
from .rays import RaySet


@dataclass
class DeviceRays:
    """A :class:`RaySet` as Dr.Jit arrays (a PyTree, so frozen steps see it as input)."""

    origins: list
    directions: list
    target: list
    depth: Float
    hit: Float


def to_device(rays: RaySet) -> DeviceRays:
    cols = lambda a: [Float(np.ascontiguousarray(c)) for c in a.T]
    return DeviceRays(cols(rays.origins), cols(rays.directions), cols(rays.target),
                      Float(rays.depth), Float(rays.hit))


def build_model(cfg: ModelConfig, dim: int, bound: float) -> Model:
    return Model(model_fields(cfg, dim, bound, make_field), cfg.render)


class DrJitBackend:
    name = "drjit"

    def __init__(self, model_cfg: ModelConfig, dim: int, bound: float, near: float, far: float,
                 train_cfg: TrainConfig):
        dr.set_thread_count(train_cfg.threads)
        self.model = build_model(model_cfg, dim, bound)
        self.near, self.far = float(near), float(far)
        self.cfg = train_cfg
        self.opt = Adam(lr=train_cfg.lr, beta_1=train_cfg.beta1, beta_2=train_cfg.beta2,
                        epsilon=train_cfg.eps, params=self.model.init_params(train_cfg.seed))
        self.data = None
        occ = model_cfg.render.occupancy
        self.occupancy = OccupancyGrid(occ, dim, bound) if occ.enabled else None
        # auto_opaque=False: every input is opaque from the first recording on, so a changing
        # value never bakes into a kernel (two recordings: before and after Adam has state).
        self._freeze = train_cfg.freeze
        self._frozen = self._new_step()

    # ------------------------------------------------------------------ training
    def set_data(self, rays: RaySet) -> None:
        self.data = to_device(rays)
        self.n_pixels = len(rays)

    def _new_step(self):
        return dr.freeze(self._make_step(), auto_opaque=False) if self._freeze else self._make_step()

    def _make_step(self):
        model, cfg = self.model, self.cfg
        near, far = self.near, self.far
        B = cfg.batch_rays
        use_depth = cfg.depth_weight > 0

        def step(opt, data, n_pixels, seed, lr, occupied):
            # Dr.Jit 1.5.0's Adam multiplies an array-valued learning rate *in place* by each
            # parameter's bias correction (opt._LRCache.product: `scale_o *= arg`), so one
            # shared array compounds across parameters and flips signs. Each parameter gets
            # its own copy, every step.
            opt.set_learning_rate({k: Float(lr) for k in opt.keys()})
            idx = hash_u32(hash_u32(seed) ^ dr.arange(UInt32, B)) % n_pixels
            g = lambda cols: [dr.gather(Float, c, idx) for c in cols]
            o, d, target = g(data.origins), g(data.directions), g(data.target)
            params = {k: opt[k] for k in opt.keys()}
            outs = model.render(params, o, d, near, far, seed, training=True, weights=use_depth, occupied=occupied)
            out = final(outs)
            loss = mse(out.rgb, target)
            if outs["fine"] is not None and cfg.coarse_weight > 0:
                loss = loss + cfg.coarse_weight * mse(outs["coarse"].rgb, target)
            reg = model.regularizer(params, seed)
            if reg is not None:
                loss = loss + reg
            if use_depth:
                t, delta = outs["samples"]
                loss = loss + cfg.depth_weight * depth_kl(out.weights, t, delta, dr.gather(Float, data.depth, idx),
                                                          dr.gather(Float, data.hit, idx), model.n_final(), cfg.depth_sigma)
            dr.backward(loss)
            opt.step()
            return loss

        return step

    def step(self, seed: int, lr: float, index: int = 0) -> Float:
        """Optimisation step number ``index``; returns the loss (not yet read back)."""
        new = self.model.schedule(index, self.params)
        if new:                     # a resized parameter also resets its Adam state
            for k, v in new.items():
                self.opt[k] = v
            # a fresh recording: replaying a frozen step after its inputs changed shape twice
            # crashes Dr.Jit 1.5.0 (segmentation fault), so old recordings are dropped
            self._frozen = self._new_step()
        occ = self.occupancy
        if occ is not None and index % occ.cfg.update_every == 0:
            params = {k: dr.detach(v) for k, v in self.params.items()}
            occ.update(lambda x: self.model.density(params, x), index, seed)
        return self._frozen(self.opt, self.data, dr.opaque(UInt32, self.n_pixels),
                            dr.opaque(UInt32, seed), dr.opaque(Float, lr),
                            occ.occupied if occ is not None else None)

    @staticmethod
    def scalar(loss) -> float:
        return float(loss[0])

    # ------------------------------------------------------------------ inference
    @property
    def params(self) -> dict:
        return {k: self.opt[k] for k in self.opt.keys()}

    def render(self, origins: np.ndarray, directions: np.ndarray, chunk: int | None = None) -> dict:
        """Render rays ``[P, D]`` (no jitter) -> numpy ``rgb [P, 3]``, ``depth``, ``opacity``."""
        chunk = chunk or (65536 if self.model.fields["coarse"].traceable else 8192)
        parts = []
        params = {k: dr.detach(v) for k, v in self.params.items()}
        with dr.suspend_grad():
            for s in range(0, len(origins), chunk):
                o = [Float(np.ascontiguousarray(c)) for c in origins[s:s + chunk].T]
                d = [Float(np.ascontiguousarray(c)) for c in directions[s:s + chunk].T]
                occupied = self.occupancy.occupied if self.occupancy is not None else None
                out = final(self.model.render(params, o, d, self.near, self.far, UInt32(0), training=False,
                                              occupied=occupied))
                dr.eval(out.rgb, out.depth, out.opacity)
                parts.append((np.stack([np.asarray(c) for c in out.rgb], 1), np.asarray(out.depth),
                              np.asarray(out.opacity)))
        if not parts:
            return {"rgb": np.zeros((0, 3), np.float32), "depth": np.zeros(0, np.float32),
                    "opacity": np.zeros(0, np.float32)}
        return {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(("rgb", "depth", "opacity"))}

    def density(self, x: np.ndarray) -> np.ndarray:
        """Density of the final field at points ``[m, D]``."""
        with dr.suspend_grad():
            p = {k: dr.detach(v) for k, v in self.params.items()}
            s = self.model.density(p, [Float(np.ascontiguousarray(c)) for c in x.T.astype(np.float32)])
            return np.asarray(s)

    def get_weights(self) -> dict[str, np.ndarray]:
        out = self.model.to_numpy(self.params)
        if self.occupancy is not None:
            out.update({f"occupancy.{k}": v for k, v in self.occupancy.state().items()})
        return out

    def set_weights(self, arrays: dict[str, np.ndarray]) -> None:
        arrays = dict(arrays)
        occ = {k.split(".", 1)[1]: arrays.pop(k) for k in list(arrays) if k.startswith("occupancy.")}
        if occ and self.occupancy is not None:
            self.occupancy.load(occ)
        for k, v in self.model.from_numpy(arrays).items():
            self.opt[k] = v
