"""Shared helpers of the benchmarks: a small bunny dataset, backends, timing."""

from __future__ import annotations

import ctypes
import statistics
import time
from pathlib import Path

import drjit as dr
import numpy as np

import mitnerf
from mitnerf.data.cache import cached_dataset
from mitnerf.data.rig import RigConfig, noise_preset
from mitnerf.fields.native import compiled
from mitnerf.train.engines import make_backend
from mitnerf.train.config import TrainConfig

mitnerf.set_variant()


def bunny(n_train: int = 50):
    """The NeRF2D-protocol bunny (cached): ``n_train`` noisy views of 100 px, 4 val, 8 test."""
    return cached_dataset("bunny", RigConfig(dim=2, n_train=n_train, n_val=4, n_test=8, **noise_preset(1.0)))


def warm_kernels(ds, recipe) -> None:
    """Train ``recipe`` on ``ds`` untimed, past its last schedule change (a grid's upsampling, a level joining),
    so that every kernel its timed run needs is in Dr.Jit's disk cache: a time budget then buys steps, not
    compilation, for every contender alike (as on a user's second run)."""
    from mitnerf.train.fit import fit
    from mitnerf.train.loop import TrainingFailed

    last = recipe.model.field_config(ds.dim).schedule_end     # 0: no coarse-to-fine schedule
    try:                                  # trained, not evaluated: only the kernels are wanted
        fit(ds, recipe.at_steps(last + 2, progress=False, val_every=0), "drjit", progress=False)
    except TrainingFailed:                # the timed run meets and records the same failure
        pass


def backend(name, model_cfg, dataset, batch=1024, threads=2):
    """A backend of engine ``name`` holding ``dataset``'s training rays."""
    tc = TrainConfig(batch_rays=batch, threads=threads, progress=False)
    be = make_backend(name, model_cfg, tc, dataset.dim, dataset.bound, dataset.near, dataset.far)
    be.set_data(dataset["train"].rays(model_cfg.render.render_background(), **tc.ray_args()))
    return be


def time_step(be, k: int) -> float:
    """Seconds of one training step (synchronised)."""
    t0 = time.perf_counter()
    be.read(be.step(k, 1000 + k, 1e-3))
    if be.name == "drjit":
        dr.sync_thread()
    return time.perf_counter() - t0


def alternate(backends: dict, rounds: int, warmup: int = 3) -> dict:
    """Median step time of each backend, the runs interleaved (same machine state)."""
    for be in backends.values():
        for k in range(warmup):
            time_step(be, k)
    times = {name: [] for name in backends}
    for r in range(rounds):
        for name, be in backends.items():
            times[name].append(time_step(be, warmup + r))
    return {name: statistics.median(t) for name, t in times.items()}


def fma_peak(threads: int = 2, rounds: int = 5) -> float:
    """This CPU's fp32 arithmetic ceiling in GFLOP/s on ``threads`` threads: fused multiply-adds on registers only
    (``fma_peak.c``, built for this CPU by :func:`mitnerf.fields.native.compiled`), the best of ``rounds``. A GEMM
    library's peak can fall short of it (the 2048^3 GEMMs of ``step_time.py`` do on some AMD EPYCs); no kernel can
    beat it."""
    lib = compiled(Path(__file__).with_name("fma_peak.c"), "fma_peak", ("-ffp-contract=fast",))
    if lib is None:
        raise SystemExit("the FMA ceiling needs a C compiler (cc, gcc or $CC): install one")
    fma = lib.fma_gflops
    fma.argtypes, fma.restype = [ctypes.c_int, ctypes.c_long], ctypes.c_double
    return max(fma(threads, 20_000_000) for _ in range(rounds))
