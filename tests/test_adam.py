"""LeanAdam (mitnerf.train.adam): drjit.opt.Adam's values to the bit, with fewer arrays alive during a step."""

from __future__ import annotations

import subprocess
import sys

import drjit as dr
import numpy as np
import pytest
from conftest import small
from drjit.auto.ad import Float, TensorXf, UInt32
from drjit.opt import Adam

from mitnerf.rng import step_seed
from mitnerf.train.adam import LeanAdam
from mitnerf.train.engines import make_backend


def _params(n: int) -> dict:
    """A tensor and a flat array, as the fields hold them."""
    return {"grid": TensorXf(dr.linspace(Float, -1, 1, 2 * n), (2, n)), "bias": dr.linspace(Float, 0, 1, n)}


def _fit(opt, steps: int) -> dict:
    """``steps`` steps of a loss with a different gradient each step (sin of the values, shifted by the step)."""
    for k in range(steps):
        for key in opt.keys():
            x = opt[key]
            flat = x.array if dr.is_tensor_v(x) else x
            dr.backward_from(dr.sum(dr.sin(flat * (1.0 + k) + Float(dr.arange(UInt32, dr.width(flat))) * 1e-2)))
        opt.step()
    return {k: np.asarray(opt[k].array if dr.is_tensor_v(opt[k]) else opt[k]) for k in opt.keys()}


def test_lean_step_gives_adams_values_to_the_bit():
    kw = dict(lr=0.05, beta_1=0.9, beta_2=0.99, epsilon=1e-15)
    ours, theirs = _fit(LeanAdam(params=_params(1000), **kw), 5), _fit(Adam(params=_params(1000), **kw), 5)
    for k in theirs:
        assert np.array_equal(ours[k], theirs[k]), k
        assert not np.array_equal(theirs[k], np.asarray(_params(1000)[k].array if k == "grid" else _params(1000)[k]))


def test_lean_step_keeps_shapes_types_gradients_and_state():
    opt = LeanAdam(lr=0.1, params=_params(10))
    _fit(opt, 2)
    assert opt["grid"].shape == (2, 10) and isinstance(opt["grid"], TensorXf) and isinstance(opt["bias"], Float)
    assert dr.grad_enabled(opt["grid"]) and dr.grad_enabled(opt["bias"])
    t, m, v, _ = opt.state["bias"][3]
    assert int(np.asarray(t)[0]) == 2 and dr.width(m) == dr.width(v) == 10


def test_small_parameters_take_adams_own_step(monkeypatch):
    calls = []
    monkeypatch.setattr(Adam, "step", lambda self, **kw: calls.append(kw))
    LeanAdam(lr=0.1, params=_params(10), lean_above=20).step()          # 30 parameters: lean
    LeanAdam(lr=0.1, params=_params(10), lean_above=30).step()          # 30: Adam's one launch
    assert len(calls) == 1


PEAK = """
import sys, drjit as dr
from drjit.auto.ad import Float, UInt32
from drjit.opt import Adam
from mitnerf.train.adam import LeanAdam
from mitnerf.train.evaluate import peak_memory
dr.set_thread_count(2)

def fit(n):
    opt = (LeanAdam if sys.argv[1] == "lean" else Adam)(lr=0.01, params={"x": dr.zeros(Float, n)})
    for k in range(3):
        dr.backward_from(dr.sum(dr.sin(opt["x"] + Float(dr.arange(UInt32, n)) * 1e-3)))
        opt.step()
    dr.sync_thread()

fit(1 << 10)                        # the kernels compiled (their memory) before anything large lives
before = peak_memory()
n = 1 << 25
fit(n)
print((peak_memory() - before) * 2 ** 30 / (4 * n))
"""


def test_lean_step_holds_two_arrays_fewer_at_its_peak():
    """Peak memory above the peak before (:func:`~mitnerf.train.evaluate.peak_memory`), in copies of the parameters
    (a fresh process each, its kernels compiled first on a small array): the lean step holds two arrays the size of
    the parameters fewer than Adam's (whose step holds ``x, m, v``, the gradient and the three new ones at once)."""
    peak = {k: float(subprocess.run([sys.executable, "-c", PEAK, k], capture_output=True, text=True,
                                    check=True).stdout) for k in ("adam", "lean")}
    assert peak["adam"] - peak["lean"] > 1.5, peak


@pytest.mark.parametrize("replayed", [False, True])
def test_the_engine_trains_alike_with_the_lean_step(bunny_small, monkeypatch, replayed):
    """Past ``LEAN_ADAM_ABOVE`` parameters the engine's Adam step is lean, traced or replayed (``dr.freeze``); the
    weights after five steps are those of Adam's own step, to the bit (one thread: the sums are deterministic)."""
    from mitnerf.train import backend_drjit

    recipe = small("grid-2d", threads=1)
    ds = bunny_small
    monkeypatch.setattr(backend_drjit, "FREEZE_MAX_PARAMS", 1 << 30 if replayed else 0)
    weights = []
    for lean_above in (1 << 62, 0):
        monkeypatch.setattr(backend_drjit, "LEAN_ADAM_ABOVE", lean_above)
        be = make_backend("drjit", recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far)
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
        assert be.replayed == replayed and be.opt.lean_above == lean_above
        for k in range(5):
            be.read(be.step(k, step_seed(0, k), 0.02))
        weights.append(be.get_weights())
    for k in weights[0]:
        assert np.array_equal(weights[0][k], weights[1][k]), k
