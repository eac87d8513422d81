"""The backend contract: what an engine (:mod:`.backend_drjit`, :mod:`.backend_torch`) must do (:class:`Backend`'s
abstract methods), and what they share: the loss, occupancy updates, chunked rendering, the checkpointed state."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from ..data.rays import RaySet
from ..errors import CheckpointError
from ..geometry.mesh import LEVEL
from ..rng import batch_indices, uniform_np
from .config import ModelConfig, TrainConfig
from .mining import ErrorMap, finite


def model_fields(cfg: ModelConfig, dim: int, bound: float, make_field) -> dict:
    """The model's fields (``coarse``, and ``fine`` with a separate fine pass), built by the engine's ``make_field``."""
    args = {**cfg.field_args, "dim": dim, "bound": bound}
    fields = {"coarse": make_field(cfg.field, **args)}
    if cfg.render.n_fine > 0 and cfg.render.separate_fine:
        fields["fine"] = make_field(cfg.field, **args)
    return fields


def training_loss(cfg: TrainConfig, n_final: int, ops, outs: dict, target, depth, hit, free, behind, regularizer,
                  weight=None):
    """The final pass's MSE, the fields' regularisers, and the coarse, depth, free-space, solid, distortion and
    opacity terms with their ``cfg`` weights; ``ops``: the engine's losses (:mod:`mitnerf.train.losses` or its
    twin); ``behind``: the density at :func:`behind_depth`'s points and which rays have a solid extent (None when
    the solid loss is off); ``weight``: the rays' photometric weights (mined batches, :mod:`.mining`; None: 1)."""
    final = outs["fine"] if outs.get("fine") is not None else outs["coarse"]
    loss = ops.mse(final.rgb, target, weight)
    if outs.get("fine") is not None and cfg.coarse_weight > 0:
        loss = loss + cfg.coarse_weight * ops.mse(outs["coarse"].rgb, target, weight)
    if regularizer is not None:
        loss = loss + regularizer
    t, delta = outs["samples"] if cfg.needs_weights else (None, None)
    if cfg.depth_weight > 0:
        loss = loss + cfg.depth_weight * ops.depth_kl(final.weights, t, delta, depth, hit, n_final, cfg.depth_sigma)
    if cfg.free_space_weight > 0:
        loss = loss + cfg.free_space_weight * ops.free_space(final.weights, t, delta, free, n_final,
                                                             cfg.free_space_margin)
    if cfg.solid_weight > 0:
        loss = loss + cfg.solid_weight * ops.solid_behind(*behind, LEVEL)
    if cfg.distortion_weight > 0:                # world distance, or the unit spacing where the scene is warped
        loss = loss + cfg.distortion_weight * ops.distortion(final.weights, *outs["spacing"], n_final)
    if cfg.opacity_weight > 0:
        loss = loss + cfg.opacity_weight * ops.opacity_entropy(final.opacity)
    return loss


def pixel_offsets(spp: int, square: bool) -> list[tuple[float, float]]:
    """Stratified positions in a pixel (``[-1/2, 1/2]``): ``spp`` along a 1D pixel, or a
    ``k x k`` grid (``k = round(sqrt(spp))``) in a 2D one."""
    if not square:
        return [((i + 0.5) / spp - 0.5, 0.0) for i in range(spp)]
    k = max(1, round(spp ** 0.5))
    return [((i + 0.5) / k - 0.5, (j + 0.5) / k - 0.5) for i in range(k) for j in range(k)]


def behind_depth(u, depth, extent, start: float):
    """Distances along pixel-centre rays behind their measured ``depth``: uniform (``u`` in [0, 1)) in
    ``[depth + start, depth + extent]``, each ray's solid extent, or at ``depth + extent`` where the extent is
    shorter than ``start``: the solid loss's points (Dr.Jit, torch or numpy alike)."""
    over = extent - start
    over = 0.5 * (over + abs(over))                  # max(extent - start, 0)
    return depth + (extent - over) + u * over        # extent - over = min(extent, start)


SOLID_SALT = 0x3C6EF372
"""Seed salt of the solid loss's random numbers (both engines)."""


def jitter_np(seed: int, directions: np.ndarray, footprint: np.ndarray) -> np.ndarray:
    """Training rays spread over their pixels (numpy twin of the Dr.Jit step's jitter)."""
    idx = np.arange(len(directions), dtype=np.uint32)
    a, b = (uniform_np(seed ^ 0x68E31DA4, idx, np.full_like(idx, k)) - 0.5 for k in (0, 1))
    d = directions + a[:, None] * footprint[:, 0] + b[:, None] * footprint[:, 1]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


class Backend(ABC):
    """One model being trained by one engine."""

    name: str
    chunk = 8192
    """Rays per render launch."""

    def __init__(self, model_cfg: ModelConfig, train_cfg: TrainConfig, dim: int, bound: float, near: float,
                 far: float):
        self.model_cfg, self.cfg = model_cfg, train_cfg
        self.dim, self.bound, self.near, self.far = dim, float(bound), float(near), float(far)
        self.occupancy, self.rays, self.n_pixels = None, None, 0
        self.errors: ErrorMap | None = None
        """The training pixels' last errors where batches are mined (``cfg.mining``, :mod:`.mining`)."""
        self.drawn: tuple = (None, None)
        """The last batch's flat pixel indices ``[B]`` and loss weights (``[B]``, or None where not mined)."""
        self._in_flight: list = []
        """``(pixel indices, per-ray error handle)`` of the mined steps not yet recorded in :attr:`errors`."""
        self.step_reached: int | None = None
        """The last training step begun (None: none yet, or unknown, as after loading a checkpoint): a field's
        step-dependent schedule renders as at this step (:meth:`~mitnerf.render.pipeline.Model.at_step`)."""

    def set_data(self, rays) -> None:
        """Hold the training rays (:class:`~mitnerf.data.rays.TrainingRays`, or a :class:`RaySet` of every one):
        :meth:`step` draws its batch from them (:meth:`batch`)."""
        self.rays, self.n_pixels = rays, len(rays)
        if self.cfg.mining > 0:
            shape = getattr(rays, "shape", (1, 1, len(rays)))
            self.errors = ErrorMap(shape, self.cfg.mining_tile, self.cfg.mining, self.cfg.mining_alpha)
            self._in_flight = []

    def batch(self, seed: int) -> RaySet:
        """The rays of the step with batch seed ``seed`` (:func:`mitnerf.rng.batch_indices`, or mined from the
        errors, :mod:`.mining`; :attr:`drawn`); with an occupancy grid, which gives each ray as many samples as it
        crosses occupied space, those known to be empty all along come first, so that rays marched side by side (a
        SIMD packet) mostly end their march together."""
        if self.errors is None:
            index, weight = batch_indices(seed, self.cfg.batch_rays, self.n_pixels), None
        else:
            while len(self._in_flight) > 1:         # every step but the last is done: the engine synced for it
                done, error = self._in_flight.pop(0)
                self.errors.record(done, self._errors_of(error))
            index, weight = self.errors.draw(seed, self.cfg.batch_rays)
        b = self.rays.batch(index, seed)
        if self.occupancy is not None:
            order = np.argsort(~np.isinf(b.free), kind="stable")
            b, index, weight = b.batch(order), index[order], None if weight is None else weight[order]
        self.drawn = (index, weight)
        return b

    def mined(self, error) -> None:
        """Note the per-ray error of the step just launched on :attr:`drawn` (a handle of the engine's; nothing
        where batches are not mined): a later :meth:`batch` records it, once the engine is past that step."""
        if self.errors is not None:
            self._in_flight.append((self.drawn[0], error))

    def _errors_of(self, error) -> np.ndarray:
        """The engine's per-ray error handle (or numpy, read from a checkpoint) -> numpy ``[B]``."""
        return np.asarray(error)

    def sampling_state(self) -> dict[str, np.ndarray]:
        """The error map and the errors of the steps not yet recorded in it (mined batches; else nothing), for a
        checkpoint: a resumed run draws the batches the run would have drawn. float32: the errors' own precision."""
        if self.errors is None:
            return {}
        out = {"error": self.errors.error.astype(np.float32)}
        for i, (index, error) in enumerate(self._in_flight):
            out[f"flight{i}.index"] = np.asarray(index, np.int64)
            out[f"flight{i}.error"] = finite(self._errors_of(error)).astype(np.float32)
        return out

    def load_sampling_state(self, arrays: dict[str, np.ndarray], where: str = "the checkpoint") -> None:
        """Restore what :meth:`sampling_state` returned (after :meth:`set_data`; nothing where batches are not
        mined or ``arrays`` is empty: the map then starts afresh)."""
        if self.errors is None or not arrays:
            return
        n = sum(k.endswith(".index") for k in arrays)
        ok = arrays.get("error") is not None and arrays["error"].shape == self.errors.error.shape and all(
            f"flight{i}.{k}" in arrays for i in range(n) for k in ("index", "error")) and len(arrays) == 1 + 2 * n
        if not ok:
            raise CheckpointError(f"{where}: its error map does not fit the training pixels of the data given "
                                  "(another dataset, or an edited checkpoint): resume with the run's own data")
        self.errors.error[:] = arrays["error"]
        self._in_flight = [(arrays[f"flight{i}.index"], arrays[f"flight{i}.error"]) for i in range(n)]

    @abstractmethod
    def step(self, index: int, seed: int, lr: float):
        """Optimisation step ``index`` with batch/jitter ``seed``; returns a handle for :meth:`read`."""

    def release(self) -> None:
        """Give back the memory the engine keeps cached for the training steps (their gradients and temporaries), so
        that what follows (evaluation, writing) does not stack its own on top: :func:`~.fit.fit` calls it when the
        training ends, and a later :meth:`step` allocates again."""

    @abstractmethod
    def read(self, handle) -> tuple[float, str | None]:
        """The loss of a step, and the name of a quantity that became NaN or infinite (or None)."""

    @abstractmethod
    def render_chunk(self, origins: np.ndarray, directions: np.ndarray) -> dict:
        """Rays ``[n, D]`` (no jitter) -> numpy ``rgb [n, 3]``, ``depth [n]``, ``opacity [n]``."""

    @abstractmethod
    def density(self, x: np.ndarray) -> np.ndarray:
        """Density of the final field at points ``[m, D]`` -> ``[m]``."""

    @abstractmethod
    def model_weights(self) -> dict[str, np.ndarray]:
        """The model's parameters, canonical names (``coarse.trunk.0.weight``, ...)."""

    @abstractmethod
    def load_model_weights(self, arrays: dict[str, np.ndarray]) -> None:
        """Replace the model's parameters (optimizer state is kept)."""

    @abstractmethod
    def optimizer_state(self) -> dict[str, np.ndarray]:
        """Adam's moments and step counts (engine-specific names; for resuming in the same engine), for a checkpoint
        to write at once: the moments may be views of the engine's own arrays, which the next step replaces."""

    @abstractmethod
    def load_optimizer_state(self, arrays: dict[str, np.ndarray]) -> None:
        """Restore what :meth:`optimizer_state` returned."""

    @abstractmethod
    def _density_fn(self):
        """``points -> density`` in the engine's array type, without gradients (occupancy updates)."""

    @property
    def n_final(self) -> int:
        """Samples per ray of the final pass."""
        r = self.model_cfg.render
        return r.n_coarse + max(r.n_fine, 0)

    def update_occupancy(self, index: int, seed: int) -> None:
        occ = self.occupancy
        if occ is not None and index % occ.cfg.update_every == 0:
            occ.update(self._density_fn(), index, seed)

    def render(self, origins: np.ndarray, directions: np.ndarray, chunk: int | None = None,
               footprint: np.ndarray | None = None, spp: int = 1) -> dict:
        """Render rays ``[P, D]`` in chunks -> numpy ``rgb [P, 3]``, ``depth [P]``, ``opacity [P]``;
        with a ``footprint [P, 2, D]``, the average of ``spp`` rays spread over each pixel."""
        chunk = chunk or self.chunk
        origins = np.asarray(origins, np.float32)
        dirs = [np.asarray(directions, np.float32)]
        if footprint is not None and spp > 1:
            dirs = [d / np.linalg.norm(d, axis=-1, keepdims=True)
                    for d in (directions + a * footprint[:, 0] + b * footprint[:, 1] for a, b in
                              pixel_offsets(spp, np.abs(footprint[:, 1]).max() > 0))]
        out = {"rgb": np.zeros((len(origins), 3), np.float32), "depth": np.zeros(len(origins), np.float32),
               "opacity": np.zeros(len(origins), np.float32)}
        for d in dirs:
            for s in range(0, len(origins), chunk):
                part = self.render_chunk(origins[s:s + chunk], d[s:s + chunk].astype(np.float32))
                for k, v in part.items():
                    out[k][s:s + chunk] += v / len(dirs)
        return out

    def get_weights(self) -> dict[str, np.ndarray]:
        """Model parameters and occupancy state (what a checkpoint stores), as copies: Dr.Jit reuses numpy views."""
        out = self.model_weights()
        if self.occupancy is not None:
            out.update({f"occupancy.{k}": v for k, v in self.occupancy.state().items()})
        return {k: np.array(v, copy=True) for k, v in out.items()}

    def set_weights(self, arrays: dict[str, np.ndarray]) -> None:
        arrays = dict(arrays)
        occ = {k.split(".", 1)[1]: arrays.pop(k) for k in list(arrays) if k.startswith("occupancy.")}
        if occ and self.occupancy is not None:
            self.occupancy.load(occ)
        self.load_model_weights(arrays)

    def n_params(self) -> int:
        return int(sum(v.size for v in self.model_weights().values()))
