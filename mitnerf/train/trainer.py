"""One training loop for both backends, evaluation, and what stops a run early.

``fit(dataset, model_cfg, train_cfg, backend='drjit')`` trains on the train split,
validates every ``val_every`` steps, and returns a :class:`Run` (the backend with
its weights, the history, timings). ``evaluate`` renders a split and measures it.
A NaN loss or a field that collapsed to constant renders raises
:class:`TrainingFailed` with what to change.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from ..data.dataset import Dataset
from .config import ModelConfig, TrainConfig
from .metrics import depth_error, psnr, ssim
from .rays import rays_of, step_seed


class TrainingFailed(RuntimeError):
    """The run diverged or collapsed; the message says what to change."""


def make_backend(name: str, model_cfg: ModelConfig, dim: int, bound: float, near: float, far: float,
                 train_cfg: TrainConfig):
    if name == "drjit":
        from .backend_drjit import DrJitBackend

        return DrJitBackend(model_cfg, dim, bound, near, far, train_cfg)
    if name == "torch":
        from .backend_torch import TorchBackend

        return TorchBackend(model_cfg, dim, bound, near, far, train_cfg)
    from ..errors import MitnerfError

    raise MitnerfError(f"unknown backend {name!r}; choose drjit or torch")


def scene_bound(dataset: Dataset) -> float:
    """Half-extent that normalises positions: the object's radius plus 10 %.

    From the outline (2D datasets rendered here), the unit sphere (3D objects here), or
    for foreign data the median camera distance minus the near plane.
    """
    meta = dataset.meta
    if "polygon" in meta:
        r = float(np.linalg.norm(np.asarray(meta["polygon"]), axis=1).max())
    elif meta.get("kind") == "3d":
        r = 1.0
    else:
        cams = np.concatenate([np.linalg.norm(s.cameras.origins, axis=1) for s in dataset.splits.values()])
        r = max(float(np.median(cams)) - dataset.near, 0.5)
    return 1.1 * r


@dataclass
class Run:
    """A trained model and how it got there."""

    backend: object
    model_cfg: ModelConfig
    train_cfg: TrainConfig
    dataset_meta: dict
    bound: float
    history: dict = field(default_factory=lambda: {"step": [], "time": [], "loss": [], "val_step": [],
                                                   "val_time": [], "val_psnr": []})
    train_time: float = 0.0
    steps: int = 0


def render_split(backend, split, background) -> dict:
    o, d = split.cameras.rays()
    D = o.shape[-1]
    t0 = time.perf_counter()
    out = backend.render(o.reshape(-1, D).astype(np.float32), d.reshape(-1, D).astype(np.float32))
    elapsed = time.perf_counter() - t0
    shape = o.shape[:-1]
    return {"rgb": out["rgb"].reshape(*shape, 3), "depth": out["depth"].reshape(shape),
            "opacity": out["opacity"].reshape(shape), "time": elapsed}


def evaluate(run: Run, dataset: Dataset, split: str = "test") -> dict:
    """PSNR, SSIM, depth error on hit pixels, render time per view, and the renders."""
    s = dataset[split]
    bg = tuple(run.model_cfg.render.background)
    r = render_split(run.backend, s, bg)
    target = s.target(bg)
    res = {"psnr": psnr(r["rgb"], target), "ssim": ssim(r["rgb"], target),
           "render_time_per_view": r["time"] / max(len(s), 1), "renders": r}
    if s.depth is not None:
        mask = s.mask if s.mask is not None else np.isfinite(s.depth)
        res["depth_error"] = depth_error(r["depth"], r["opacity"], s.depth, mask)
    return res


def fit(dataset: Dataset, model_cfg: ModelConfig, train_cfg: TrainConfig, backend: str = "drjit") -> Run:
    """Train a model on ``dataset['train']``; see the module docstring."""
    model_cfg.render.background = tuple(model_cfg.render.background)
    bound = scene_bound(dataset)
    be = make_backend(backend, model_cfg, dataset.dim, bound, dataset.near, dataset.far, train_cfg)
    be.set_data(rays_of(dataset["train"], model_cfg.render.background))
    run = Run(be, model_cfg, train_cfg, dict(dataset.meta), bound)
    val = dataset.splits.get("val")
    if val is not None and len(val):
        val = val.subset(np.linspace(0, len(val) - 1, min(train_cfg.val_views, len(val))).astype(int))
    _train(run, val, dataset)
    return run


def _check_collapse(pred, target, step, cfg) -> None:
    if step < 2 * cfg.warmup or float(np.std(target)) < 1e-2:
        return
    if float(np.std(pred)) < 1e-3:
        raise TrainingFailed(
            f"the field collapsed to a constant colour by step {step} (every render is the same); "
            "use --density-activation softplus, lower --lr, or lengthen the warm-up")


def _train(run: Run, val, dataset: Dataset) -> None:
    cfg, be, h = run.train_cfg, run.backend, run.history
    budget = cfg.time_budget
    bg = tuple(run.model_cfg.render.background)
    pending = []          # losses not yet read back (reading forces a sync)
    # under a time budget the bar follows the clock, otherwise the steps
    bar = tqdm(total=budget if budget is not None else cfg.iters, desc=f"fit {be.name}", leave=False,
               unit="s" if budget is not None else "step", disable=not cfg.progress, mininterval=0.5,
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s{postfix}" if budget is not None else None)
    train_time, step = 0.0, 0
    t_last = time.perf_counter()

    def drain(now_step):
        nonlocal pending
        for k, loss in pending:
            value = be.scalar(loss)
            if not np.isfinite(value):
                raise TrainingFailed(
                    f"the loss became {value} at step {k}; lower --lr (now {cfg.lr:g}) or use "
                    "--density-activation softplus")
            h["step"].append(k)
            h["loss"].append(value)
            h["time"].append(train_time)
        pending = []

    try:
        while step < cfg.iters and (budget is None or train_time < budget):
            progress = step / cfg.iters if budget is None else max(step / cfg.iters, train_time / budget)
            lr = cfg.lr_at(progress, step)
            loss = be.step(step_seed(cfg.seed, step), lr, step)
            step += 1
            pending.append((step, loss))
            slow = step > 1 and train_time / max(step - len(pending), 1) > 0.05
            if step % 10 == 0 or step == cfg.iters or (budget is not None and slow):
                drain(step)                        # syncs, so the clock below is honest
                now = time.perf_counter()
                train_time += now - t_last
                t_last = now
                bar.update(min(train_time, budget) - bar.n if budget is not None else step - bar.n)
                bar.set_postfix(step=step, loss=f"{h['loss'][-1]:.2e}",
                                rays_s=f"{cfg.batch_rays * step / max(train_time, 1e-9):.3g}", refresh=False)
            if val is not None and cfg.val_every and step % cfg.val_every == 0:
                _validate(run, val, bg, step, train_time)
                t_last = time.perf_counter()          # validation is not training time
        if pending:
            drain(step)
            now = time.perf_counter()
            train_time += now - t_last
    finally:
        bar.close()
    run.train_time, run.steps = train_time, step
    if val is not None:
        _validate(run, val, bg, step, train_time)


def _validate(run: Run, val, bg, step, train_time) -> None:
    r = render_split(run.backend, val, bg)
    target = val.target(bg)
    _check_collapse(r["rgb"], target, step, run.train_cfg)
    run.history["val_step"].append(step)
    run.history["val_time"].append(train_time)
    run.history["val_psnr"].append(psnr(r["rgb"], target))
