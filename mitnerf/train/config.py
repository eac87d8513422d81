"""A training run's model (field + rendering) and optimisation; values are written only in :mod:`.recipes`.
``validate()`` refuses values that cannot work, with the fix, before any kernel is built."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..errors import ConfigError
from ..fields import field_config
from ..render.pipeline import RenderConfig
from ..settings import check, setting


@dataclass
class ModelConfig:
    """Which field, with which arguments, rendered how."""

    field: str = "grid"
    """Field family (``mitnerf.fields.FIELDS``)."""
    field_args: dict = dataclasses.field(default_factory=dict)
    """Keyword arguments of the family's config (``dim`` and ``bound`` come from the data)."""
    render: RenderConfig = dataclasses.field(default_factory=RenderConfig)
    """Samples, fine pass, background, integral, occupancy grid."""

    def to_dict(self) -> dict:
        return {"field": self.field, "field_args": dict(self.field_args), "render": dataclasses.asdict(self.render)}

    @classmethod
    def from_dict(cls, d: dict) -> "ModelConfig":
        return cls(d.get("field", "grid"), dict(d.get("field_args", {})), RenderConfig(**d.get("render", {})))

    def field_config(self, dim: int):
        """The field's config: these field settings over the family's defaults (refused with the valid ones)."""
        return field_config(self.field, **{**self.field_args, "dim": dim})

    def validate(self, dim: int) -> None:
        self.render.validate()
        self.field_config(dim)


@dataclass
class TrainConfig:
    """How long and how to optimise."""

    iters: int = setting(2000, lo=1, hi=10 ** 9, flag="--iters", unit="steps")
    """Optimisation steps (an upper bound when ``time_budget`` is set)."""
    time_budget: float | None = setting(None, lo=0, above=True, hi=10 ** 7, flag="--time-budget", unit="seconds")
    """Stop after this many seconds of training (the schedule then follows the clock)."""
    batch_rays: int = setting(1024, lo=1, hi=1 << 22, flag="--batch", unit="rays")
    """Rays per step, drawn at random from all training pixels (uniformly, or partly by their errors: ``mining``)."""
    mining: float = setting(0.0, lo=0, hi=0.99)
    """Share of a batch's draw given to the pixels' last errors (soft mining, :mod:`mitnerf.train.mining`); the
    rest draws uniformly. 0: every pixel alike."""
    mining_alpha: float = setting(0.6, lo=0, hi=1)
    """Exponent of a mined ray's loss weight ``(uniform chance / its chance)^alpha``: 1 keeps the uniform loss's
    expectation (importance sampling), 0 takes the drawn rays as they come (hard mining)."""
    mining_tile: int = setting(4, lo=1, hi=4096, unit="pixels")
    """Side of the square of a view's pixels that shares one remembered error (the map holds one a tile)."""
    lr: float = setting(5e-3, lo=0, above=True, hi=10, flag="--lr")
    """Peak learning rate (Adam)."""
    lr_final: float = setting(5e-4, lo=0, above=True, hi=10, flag="--lr-final")
    """Learning rate at the end (exponential decay from ``lr``)."""
    warmup: int = setting(50, lo=0, hi=10 ** 9, unit="steps")
    """Steps of linear warm-up from ``lr / 10`` (protects ReLU fields from dying early)."""
    beta1: float = setting(0.9, lo=0, hi=0.999999)
    """Adam's first-moment decay."""
    beta2: float = setting(0.99, lo=0, hi=0.999999)
    """Adam's second-moment decay."""
    eps: float = setting(1e-10, lo=0, hi=1)
    """Adam's epsilon."""
    coarse_weight: float = setting(1.0, lo=0, hi=1e6)
    """Weight of the coarse pass's photometric loss when there is a fine pass."""
    depth_weight: float = setting(0.0, lo=0, hi=1e6, flag="--depth-weight")
    """Weight of DS-NeRF's depth loss on the dataset's depth (``mitnerf.train.losses``); 0: off."""
    depth_sigma: float = setting(0.05, lo=0, above=True, hi=1e6, flag="--depth-sigma", unit="world units")
    """Standard deviation of the depth-supervision Gaussian (world units)."""
    free_space_weight: float = setting(0.0, lo=0, hi=1e6, flag="--free-space-weight")
    """Weight of the free-space loss: no density before the depth the dataset measured, nor anywhere on a ray
    whose pixel and neighbours miss (``mitnerf.train.losses``); 0: off, and nothing where the data has no
    depth or alpha. On in the dense-grid recipes only: ``benchmarks/fit_table.py`` measures it on every family,
    and it empties the MLP's density and costs the hash grid PSNR there."""
    free_space_margin: float = setting(0.01, lo=0, hi=1e6, unit="world units")
    """Distance before the measured depth within which the free-space loss leaves density alone (world units)."""
    solid_weight: float = setting(0.0, lo=0, hi=1e6, flag="--solid-weight")
    """Weight of the solid-behind-the-surface loss: matter for ``solid_thickness`` behind the dataset's depth
    (``mitnerf.train.losses``), so the density encloses a solid; 0: off, and nothing without depth."""
    solid_thickness: float = setting(0.05, lo=0, above=True, hi=1e6, unit="world units")
    """How far behind the measured depth the solid loss draws its points at most (world units): each ray's
    reach ends where a training view's depth map shows empty space (:mod:`mitnerf.data.carve`)."""
    solid_start: float = setting(0.005, lo=0, hi=1e6, unit="world units")
    """How far behind the measured depth the solid loss's nearest points lie (world units): less than a cell
    of the grids, so matter begins at the surface."""
    distortion_weight: float = setting(0.0, lo=0, hi=1e6, flag="--distortion-weight")
    """Weight of mip-NeRF 360's distortion loss (floaters, fill-in), taken along world distance in an object scene
    and along the unit spacing coordinate in a forward or unbounded one (``Space.spacing``); 0: off."""
    opacity_weight: float = setting(0.0, lo=0, hi=1e6, flag="--opacity-weight")
    """Weight of the rays' opacity entropy (haze); 0: off."""
    val_every: int | None = setting(None, lo=0, hi=10 ** 9, flag="--val-every", unit="steps",
                                    shown="10 validations spread over the run")
    """Validate every so many steps (0: only at the end); the best validation is kept."""
    val_points: int = setting(10, lo=1, hi=10 ** 4)
    """Validations spread evenly over the run's budget (seconds or steps) when ``val_every`` is unset: the
    learning curve's points."""
    val_views: int = setting(4, lo=1, hi=10 ** 6)
    """Validation views rendered each time."""
    test_views: int = setting(0, lo=0, hi=10 ** 6, flag="--test-views", shown="all")
    """Test views the run is evaluated on, evenly spaced (a quick check, said wherever its figure is); 0: all, the
    protocol (:func:`~mitnerf.train.evaluate.test_views`)."""
    keep_best: bool = setting(True)
    """End with the weights of the best validation, not the last step (and say so), when it beats the last
    validation by ``keep_best_margin``."""
    keep_best_margin: float = setting(0.3, lo=0, hi=100, unit="dB")
    """dB of validation PSNR by which the best validation must beat the last for its weights to be kept. Late in a
    run, validations on a few views swing by tenths of a dB with the batches' noise: within that, the last
    weights (trained longest, at the smallest rate) win, so a long run does not end on a lucky earlier draw
    (``benchmarks/fit_table.py``'s ``longer`` runs)."""
    seed: int = setting(0, lo=0, hi=2 ** 32 - 1, flag="--seed")
    """Seed of the initial weights, the ray batches and the sample jitter."""
    threads: int = setting(2, lo=1, hi=1024, flag="--threads")
    """CPU threads (Dr.Jit and torch)."""
    freeze: bool = setting(True)
    """Record the Dr.Jit step once and replay it (``dr.freeze``) while the model has at most
    :data:`~mitnerf.train.backend_drjit.FREEZE_MAX_PARAMS` parameters (past that, a replay costs more than tracing);
    off only for debugging."""
    progress: bool = setting(True, flag="--progress")
    """Show a progress bar."""

    def lr_at(self, progress: float, step: int) -> float:
        """Learning rate after ``progress`` in [0, 1] of the run: exponential decay from ``lr`` to
        ``lr_final``, times a linear warm-up from ``lr / 10`` over the first ``warmup`` steps."""
        lr = self.lr * (self.lr_final / self.lr) ** min(max(progress, 0.0), 1.0)
        return lr * (0.1 + 0.9 * step / self.warmup) if step < self.warmup else lr

    def ray_args(self) -> dict:
        """What the training rays need computed for these losses (:meth:`~mitnerf.data.dataset.Split.rays`)."""
        return {"solid_reach": self.solid_thickness if self.solid_weight > 0 else 0.0, "margin": self.free_space_margin}

    @property
    def needs_weights(self) -> bool:
        """Whether the loss needs the final pass's per-sample weights."""
        return self.depth_weight > 0 or self.distortion_weight > 0 or self.free_space_weight > 0

    def validate(self) -> None:
        check(self)
        if self.solid_start > self.solid_thickness:
            raise ConfigError(f"--set solid_start={self.solid_start:g} lies beyond solid_thickness "
                              f"({self.solid_thickness:g}); the solid loss's nearest points come first")
