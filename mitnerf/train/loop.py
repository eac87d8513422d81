"""The one training loop: clock, learning-rate schedule, NaN guard, validation, Ctrl-C. The learning rate
follows the steps, or the clock under a time budget, whichever is further along; validation time is not
training time. A NaN or infinite loss, gradient or parameter raises :class:`TrainingFailed`; SIGINT or
SIGTERM lets the step in flight finish, then raises :class:`Interrupted`."""

from __future__ import annotations

import signal
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from tqdm.auto import tqdm

from .._fs import deferred_signals
from ..rng import step_seed
from .config import TrainConfig


class TrainingFailed(RuntimeError):
    """The run diverged (``status='nan'``) or collapsed; the message says what to change."""

    def __init__(self, message: str, status: str = "nan", step: int | None = None):
        super().__init__(message)
        self.status, self.step = status, step


class Interrupted(Exception):
    """SIGINT or SIGTERM arrived; the loop stopped after a whole step."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def new_history() -> dict:
    return {"step": [], "time": [], "loss": [], "val_step": [], "val_time": [], "val_psnr": []}


@dataclass
class LoopState:
    """How far a run has come (everything a resumed run needs besides the weights)."""

    step: int = 0
    """Steps taken."""
    train_time: float = 0.0
    """Seconds of training so far (validation excluded)."""
    history: dict = field(default_factory=new_history)
    """Loss per read-back step and validation PSNR, with their times."""


def run_loop(step_fn: Callable, read_fn: Callable, cfg: TrainConfig, state: LoopState,
             validate: Callable[[int], None] | None = None, desc: str = "fit", read_every: int = 10) -> LoopState:
    """Step ``step_fn(index, seed, lr) -> handle`` from ``state.step`` to ``cfg.iters`` or ``cfg.time_budget``;
    ``read_fn(handle) -> (loss, name of a non-finite quantity or None)``; ``validate(step)`` every ``val_every``."""
    budget, h = cfg.time_budget, state.history
    pending: list = []

    def due(state: LoopState) -> bool:
        """Whether a validation is due: every ``val_every`` steps, or each ``1 / val_points`` of the budget."""
        if cfg.val_every is not None:
            return bool(cfg.val_every) and state.step % cfg.val_every == 0
        share = state.train_time / budget if budget is not None else state.step / cfg.iters
        return len(h["val_step"]) + 1 <= share * cfg.val_points and share < 1
    bar = tqdm(total=budget if budget is not None else cfg.iters, desc=desc, leave=False,
               unit="s" if budget is not None else "step", disable=not cfg.progress, mininterval=0.5,
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s{postfix}" if budget is not None else None)
    t_last = time.perf_counter()

    def drain():
        nonlocal pending, t_last
        for k, handle in pending:
            value, bad = read_fn(handle)
            if bad is not None or not np.isfinite(value):
                what = bad or f"the loss ({value})"
                raise TrainingFailed(f"{what} became NaN or infinite at step {k}; lower the learning rate "
                                     f"(--lr, now {cfg.lr:g}) or use a softplus density "
                                     "(--set density_activation=softplus)", "nan", k)
            for key, v in (("step", k), ("loss", value), ("time", state.train_time)):
                h[key].append(v)
        pending = []
        now = time.perf_counter()
        state.train_time += now - t_last
        t_last = now
        bar.update((min(state.train_time, budget) if budget is not None else state.step) - bar.n)
        if h["loss"]:
            bar.set_postfix(step=state.step, loss=f"{h['loss'][-1]:.2e}", refresh=False)

    try:
        with deferred_signals() as signals:
            while state.step < cfg.iters and (budget is None or state.train_time < budget):
                k = state.step
                progress = k / cfg.iters if budget is None else max(k / cfg.iters, state.train_time / budget)
                pending.append((k + 1, step_fn(k, step_seed(cfg.seed, k), cfg.lr_at(progress, k))))
                state.step = k + 1
                slow = state.step > 1 and state.train_time / max(state.step - len(pending), 1) > 0.05
                if state.step % read_every == 0 or state.step == cfg.iters or signals or (budget is not None and slow):
                    drain()                                  # syncs, so the clock below is honest
                if signals:
                    raise Interrupted(signals[0])
                if validate is not None and due(state):
                    drain()
                    validate(state.step)
                    t_last = time.perf_counter()              # validation is not training time
            drain()
    finally:
        bar.close()
    return state
