"""Training a 2D pixelNeRF across scenes, and rendering it from a few input views.

One step (:func:`train`): pick a scene, a number of input views ``k`` in
``k_range``, ``k`` random views of that scene as the context, and ``batch_rays`` target
rays from its *other* views; render them through
:func:`mitnerf.render.volume.volume_render` (stratified, jittered samples; the field is
evaluated on all samples, then integrated by the replayed custom operation) and take an
Adam step on the photometric MSE. With a frozen encoder the features of every view are
computed once before training. Shapes change with ``k``, so steps are traced, not frozen
(Dr.Jit's kernel cache makes the repeats cheap); every value that changes between steps
(seed, near/far, learning rate) enters as an opaque array.

:func:`render_rays` renders any rays of a scene from a given context, in chunks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import drjit as dr
import numpy as np
from drjit.auto.ad import Float, UInt32
from drjit.opt import Adam
from tqdm.auto import tqdm

from ..fields.pixelnerf import Context, PixelNeRFConfig, PixelNeRFField, make_context
from ..render.samplers import Stratified
from ..render.volume import volume_render
from ..train.losses import mse
from .pixelnerf_data import SceneViews


@dataclass
class PixelTrainConfig:
    """How a pixelNeRF is trained across scenes."""

    iters: int = 3000
    """Optimisation steps (an upper bound when ``time_budget`` is set)."""
    time_budget: float | None = None
    """Stop after this many seconds of training (the learning-rate schedule follows the clock)."""
    batch_rays: int = 32
    """Target rays per step (all from one scene). Small batches, many steps: in 60 s runs
    (2 cores) 32 rays beat 64, 128 and 256 by 1.1, 5.7 and 6.5 dB (mean test PSNR, 9 views)."""
    n_samples: int = 32
    """Stratified samples per ray (training and rendering; rendering with 64 changed test
    PSNR by <= 0.01 dB)."""
    k_range: tuple = (1, 9)
    """Input views per step, drawn uniformly from this inclusive range."""
    lr: float = 2e-3
    """Peak learning rate (Adam)."""
    lr_final: float = 2e-4
    """Final learning rate (exponential decay)."""
    warmup: int = 50
    """Steps of linear warm-up from ``lr / 10``."""
    seed: int = 0
    """Seed of the initial weights, the scene/view/ray choices and the jitter."""
    threads: int = 2
    """CPU threads of Dr.Jit."""
    progress: bool = True
    """Show a progress bar."""

    def lr_at(self, progress: float, step: int) -> float:
        """Learning rate after ``progress`` in [0, 1] of the run (``step`` for the warm-up)."""
        from ..train.config import lr_schedule

        return lr_schedule(self.lr, self.lr_final, self.warmup, progress, step)


@dataclass
class PixelRun:
    """A trained pixelNeRF and how it got there."""

    field: PixelNeRFField
    params: dict
    train_cfg: PixelTrainConfig
    history: dict = field(default_factory=lambda: {"step": [], "time": [], "loss": []})
    train_time: float = 0.0
    steps: int = 0


def context_of(fld: PixelNeRFField, scene: SceneViews, views) -> Context:
    """The context made of some views of ``scene`` (frozen features taken from the scene)."""
    views = np.asarray(views)
    cached = fld.frozen is not None and scene.features_key == fld.cfg.encoder_key
    feats = scene.feature_columns(views) if cached else None
    return make_context(scene.images[views], scene.poses[views], scene.focal, feats)


def precompute_features(fld: PixelNeRFField, scenes: list[SceneViews]) -> None:
    """Frozen encoder: the features of every view of every scene, once."""
    if fld.frozen is None:
        return
    for s in scenes:
        if s.features_key != fld.cfg.encoder_key:
            s.features, s.features_key = fld.features_numpy(s.images), fld.cfg.encoder_key


def train(field_cfg: PixelNeRFConfig, scenes: list[SceneViews], cfg: PixelTrainConfig) -> PixelRun:
    """Train one field across ``scenes`` (each needs more than ``k_range[1]`` views)."""
    from ..errors import MitnerfError

    k_lo, k_hi = cfg.k_range
    short = [s.name for s in scenes if s.n_views <= k_hi]
    if short:
        raise MitnerfError(f"scenes {short} have at most {k_hi} views; give each more views than "
                           f"k_range's maximum ({k_hi}) or lower it")
    dr.set_thread_count(cfg.threads)
    fld = PixelNeRFField(field_cfg)
    precompute_features(fld, scenes)
    opt = Adam(lr=cfg.lr, params=fld.init_params(cfg.seed))
    run = PixelRun(fld, {}, cfg)
    rng = np.random.default_rng(cfg.seed)
    B, H = cfg.batch_rays, scenes[0].height
    pending, t_last, step = [], time.perf_counter(), 0
    bar = tqdm(total=cfg.iters, desc=f"pixelNeRF ({field_cfg.encoder})", unit="step", disable=not cfg.progress,
               leave=False)

    def drain():
        nonlocal pending, t_last
        values = [(k, float(loss[0])) for k, loss in pending]      # reading back syncs
        now = time.perf_counter()
        run.train_time += now - t_last
        t_last = now
        for k, value in values:
            if not np.isfinite(value):
                raise MitnerfError(f"the pixelNeRF loss became {value} at step {k}; lower lr (now {cfg.lr:g})")
            run.history["step"].append(k)
            run.history["loss"].append(value)
            run.history["time"].append(run.train_time)
        pending = []

    try:
        while step < cfg.iters and (cfg.time_budget is None or run.train_time < cfg.time_budget):
            progress = step / cfg.iters if cfg.time_budget is None else max(step / cfg.iters,
                                                                           run.train_time / cfg.time_budget)
            lr = cfg.lr_at(progress, step)
            sc = scenes[rng.integers(len(scenes))]
            k = int(rng.integers(k_lo, k_hi + 1))
            perm = rng.permutation(sc.n_views)
            view = rng.choice(perm[k:], B)
            pix = rng.integers(0, H, B)
            ctx = context_of(fld, sc, perm[:k])
            o, d, target = sc.origins[view, pix], sc.directions[view, pix], sc.images[view, pix]
            opt.set_learning_rate({name: dr.opaque(Float, lr) for name in opt.keys()})   # one copy each (Dr.Jit 1.5.0)
            params = {name: opt[name] for name in opt.keys()}
            sampler = Stratified(cfg.n_samples, dr.opaque(UInt32, int(rng.integers(2**31))), jitter=True)
            out = volume_render(fld.with_context(ctx), params, cols(o), cols(d), dr.opaque(Float, sc.near),
                                dr.opaque(Float, sc.far), sampler, (0.0, 0.0, 0.0))
            loss = mse(out.rgb, cols(target))
            dr.eval(loss)
            dr.backward(loss)
            opt.step()
            step += 1
            pending.append((step, loss))
            if step % 10 == 0:
                drain()
                bar.update(10)
                bar.set_postfix(loss=f"{run.history['loss'][-1]:.2e}")
        drain()
    finally:
        bar.close()
    run.steps = step
    run.params = {name: dr.detach(opt[name]) for name in opt.keys()}
    return run


def cols(a: np.ndarray) -> list:
    """``[P, C]`` numpy -> C Dr.Jit arrays ``[P]``."""
    return [Float(np.ascontiguousarray(c, dtype=np.float32)) for c in np.asarray(a).T]


def render_rays(run: PixelRun, context: Context, origins: np.ndarray, directions: np.ndarray, near: float,
                far: float, n_samples: int | None = None, chunk: int = 512) -> dict:
    """Rays ``[P, 2]`` seen through ``context`` -> numpy ``rgb [P, 3]``, ``depth``, ``opacity``
    (sample centres, no jitter)."""
    n_samples = n_samples or run.train_cfg.n_samples
    fld = run.field.with_context(context)
    parts = []
    with dr.suspend_grad():
        if context.features is None:    # encode the context once, not per chunk
            fld.context = Context(context.images, context.cams, context.n_views, context.height, context.focal,
                                  fld.features(run.params, context))
        for s in range(0, len(origins), chunk):
            out = volume_render(fld, run.params, cols(origins[s:s + chunk]), cols(directions[s:s + chunk]),
                                dr.opaque(Float, near), dr.opaque(Float, far),
                                Stratified(n_samples, UInt32(0), jitter=False), (0.0, 0.0, 0.0))
            dr.eval(out.rgb, out.depth, out.opacity)
            parts.append((np.stack([np.asarray(c) for c in out.rgb], 1), np.asarray(out.depth),
                          np.asarray(out.opacity)))
    return {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(("rgb", "depth", "opacity"))}


def density_grid(run: PixelRun, context: Context, bound: float, res: int = 128) -> np.ndarray:
    """Density on a ``res x res`` grid over ``[-bound, bound]^2`` (row 0 is +y)."""
    from ..viz.training import density_grid as grid_of

    fld = run.field.with_context(context)

    class Densities:                     # what viz.training.density_grid asks of a backend
        @staticmethod
        def density(pts: np.ndarray) -> np.ndarray:
            with dr.suspend_grad():
                return np.concatenate([np.asarray(fld.density(run.params, cols(pts[s:s + 4096])))
                                       for s in range(0, len(pts), 4096)])

    return grid_of(Densities, bound, 2, res)
