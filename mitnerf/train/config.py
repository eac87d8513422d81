"""Configurations of a model and of its training, and how to build a model from them."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..render.pipeline import RenderConfig


def lr_schedule(lr: float, lr_final: float, warmup: int, progress: float, step: int) -> float:
    """Exponential decay from ``lr`` to ``lr_final`` over ``progress`` in [0, 1], times a linear
    warm-up from ``lr / 10`` over the first ``warmup`` steps."""
    lr = lr * (lr_final / lr) ** min(max(progress, 0.0), 1.0)
    if step < warmup:
        lr *= 0.1 + 0.9 * step / warmup
    return lr


@dataclass
class ModelConfig:
    """Which field, with which arguments, rendered how."""

    field: str = "vanilla"
    """Field family (``mitnerf.fields.FIELDS``)."""
    field_args: dict = dataclasses.field(default_factory=dict)
    """Keyword arguments of the family's config (``dim`` and ``bound`` come from the data)."""
    render: RenderConfig = dataclasses.field(default_factory=RenderConfig)
    """Samples, fine pass, background, integral."""

    def to_dict(self) -> dict:
        return {"field": self.field, "field_args": dict(self.field_args), "render": dataclasses.asdict(self.render)}

    @classmethod
    def from_dict(cls, d: dict) -> "ModelConfig":
        return cls(d.get("field", "vanilla"), dict(d.get("field_args", {})), RenderConfig(**d.get("render", {})))


def model_fields(cfg: ModelConfig, dim: int, bound: float, make_field) -> dict:
    """The fields of a model (``coarse``, and ``fine`` with a separate fine pass), built by
    ``make_field(family, **args)`` of either backend."""
    args = {**cfg.field_args, "dim": dim, "bound": bound}
    fields = {"coarse": make_field(cfg.field, **args)}
    if cfg.render.n_fine > 0 and cfg.render.separate_fine:
        fields["fine"] = make_field(cfg.field, **args)
    return fields


@dataclass
class TrainConfig:
    """How long and how to optimise."""

    iters: int = 2000
    """Optimisation steps (an upper bound when ``time_budget`` is set)."""
    time_budget: float | None = None
    """Stop after this many seconds of training (the schedule then follows the clock)."""
    batch_rays: int = 1024
    """Rays per step, drawn at random from all training pixels."""
    lr: float = 5e-3
    """Peak learning rate (Adam)."""
    lr_final: float = 5e-4
    """Learning rate at the end (exponential decay from ``lr``)."""
    warmup: int = 50
    """Steps of linear warm-up from ``lr / 10`` (protects ReLU fields from dying early)."""
    beta1: float = 0.9
    """Adam's first-moment decay."""
    beta2: float = 0.99
    """Adam's second-moment decay."""
    eps: float = 1e-10
    """Adam's epsilon."""
    coarse_weight: float = 1.0
    """Weight of the coarse pass's photometric loss when there is a fine pass."""
    depth_weight: float = 0.0
    """Weight of the depth-supervision loss (``mitnerf.train.losses``); 0 disables it."""
    depth_sigma: float = 0.05
    """Standard deviation of the depth-supervision Gaussian (world units)."""
    val_every: int = 250
    """Validation PSNR every so many steps (0: only at the end)."""
    val_views: int = 4
    """Validation views rendered each time."""
    seed: int = 0
    """Seed of the initial weights, the ray batches and the sample jitter."""
    threads: int = 2
    """CPU threads (Dr.Jit and torch)."""
    freeze: bool = True
    """Record the Dr.Jit step once and replay it (``dr.freeze``); off only for debugging."""
    progress: bool = True
    """Show a progress bar."""

    def lr_at(self, progress: float, step: int) -> float:
        """Learning rate after ``progress`` in [0, 1] of the run (``step`` for the warm-up)."""
        return lr_schedule(self.lr, self.lr_final, self.warmup, progress, step)
