"""Gradients summed in a copy per thread (``mitnerf.train.backend_drjit.EXPAND_BYTES``): the rule, its scope (the
training step alone), and training that ends where atomic adds end."""

import drjit as dr
import numpy as np
from conftest import small

from mitnerf.rng import step_seed
from mitnerf.train import backend_drjit
from mitnerf.train.engines import make_backend


def test_the_threshold_counts_a_copy_per_thread_and_one_more_and_never_falls_under_drjits():
    assert backend_drjit.expand_threshold(2) == (1 << 30) // 12          # 3 copies of 4-byte floats in 1 GiB
    assert backend_drjit.expand_threshold(1) == (1 << 30) // 8
    assert backend_drjit.expand_threshold(4096) == 1 << 20               # Dr.Jit's own, the least


def _train(recipe, ds, monkeypatch, bytes_: int):
    """Five steps of ``recipe`` with ``EXPAND_BYTES = bytes_``: (losses, weights, the fifth step's kernels)."""
    monkeypatch.setattr(backend_drjit, "EXPAND_BYTES", bytes_)
    be = make_backend("drjit", recipe.model, recipe.train, 3, ds.bound, ds.near, ds.far)
    be.set_data(ds["train"].rays((1, 1, 1), **recipe.train.ray_args()))
    losses = [be.read(be.step(k, step_seed(0, k), 0.02))[0] for k in range(4)]     # the last steps are replays
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()
        losses.append(be.read(be.step(4, step_seed(0, 4), 0.02))[0])
        dr.sync_thread()
        kernels = dr.kernel_history()
    return losses, {k: np.asarray(v) for k, v in be.params.items()}, kernels


def test_a_lattice_under_the_threshold_sums_its_gradient_in_copies_only_in_the_step_and_trains_alike(
        vase_small, monkeypatch):
    """A 65^3 colour lattice (3.3 M floats, over Dr.Jit's own threshold): with the engine's threshold its gradient is
    copied into its expansion every step, with ``EXPAND_BYTES = 0`` it is added atomically and never copied; the
    threshold outside the step is the one before it; both end on the same losses, and on the same weights but for a
    few whose first Adam step took the sign of a gradient that the order of the sums flips (two threads)."""
    recipe = small("grid-3d", resolution=65, initial_resolution=65, upsample_at=(), solid_weight=0.0,
                   free_space_weight=0.0, threads=2)
    before = dr.expand_threshold()
    copies, atomic = (_train(recipe, vase_small, monkeypatch, b) for b in (1 << 30, 0))
    assert dr.expand_threshold() == before
    colour = 4 * copies[1]["coarse.color"].size

    def copied(kernels):
        return [k for k in kernels if k["type"] == dr.KernelType.Memcpy and k["size"] == colour]
    assert copied(copies[2]) and not copied(atomic[2])
    np.testing.assert_allclose(copies[0], atomic[0], rtol=1e-4)
    for name, w in copies[1].items():
        off = np.abs(w - atomic[1][name]) > 1e-3 * max(1.0, np.abs(w).max())
        assert off.mean() < 1e-3, (name, off.mean())
