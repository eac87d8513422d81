"""Error-driven ray sampling (mitnerf.train.mining): tiles, chances and weights by hand, the draws' frequencies,
the importance weights' expectation, the weighted loss in both engines, and a mined fit in both engines alike."""

import drjit as dr
import numpy as np
import pytest
import torch
from conftest import small
from drjit.auto.ad import Float

from mitnerf.reference.train import losses as twin
from mitnerf.rng import step_seed
from mitnerf.train import losses
from mitnerf.train.engines import make_backend
from mitnerf.train.mining import UNSEEN, ErrorMap


def test_tiles_by_hand():
    # 2 views of 5 x 6 pixels, tiles of 4: 2 x 2 tiles a view, of 4 x 4, 4 x 2, 1 x 4 and 1 x 2 pixels
    m = ErrorMap((2, 5, 6), tile=4, share=0.5, alpha=1.0)
    assert len(m) == 8
    np.testing.assert_array_equal(m.height * m.width, [16, 8, 4, 2] * 2)
    # pixel (view 1, row 4, col 5) = (1 * 5 + 4) * 6 + 5 = 59 lies in view 1's last tile, 7;
    # pixel (view 0, row 3, col 4) = 22 in tile 1
    np.testing.assert_array_equal(m.tile_of(np.array([59, 22, 0])), [7, 1, 0])
    # rays held flat (a RaySet: one "view" of 1 x P pixels): tiles of 1 x 4, 1 x 4 and 1 x 2 pixels
    flat = ErrorMap((1, 1, 10), tile=4, share=0.5, alpha=1.0)
    np.testing.assert_array_equal(flat.height * flat.width, [4, 4, 2])


def test_chances_and_weights_by_hand():
    # 1 view of 4 x 4 pixels, tiles of 2 (four of 4 pixels), N = 16; errors (0.3, 0.1, 0, 0) over 4 pixels each:
    #   sum_j e_t(j) = 4 (0.3 + 0.1) = 1.6; with s = 0.5, p_i = 0.5 e / 1.6 + 0.5 / 16
    #   tile 0: p_i = 0.09375 + 0.03125 = 0.125, p_t = 0.5; tile 1: 0.0625, 0.25; tiles 2, 3: 0.03125, 0.125
    #   alpha = 1: w_i = 1 / (16 p_i) = 0.5, 1, 2, 2
    m = ErrorMap((1, 4, 4), tile=2, share=0.5, alpha=1.0)
    m.error[:] = [0.3, 0.1, 0.0, 0.0]
    np.testing.assert_allclose(m.probabilities(), [0.5, 0.25, 0.125, 0.125])
    index, weight = m.draw(seed=7, batch=4000)
    raw = {0: 0.5, 1: 1.0, 2: 2.0, 3: 2.0}
    expected = np.array([raw[t] for t in m.tile_of(index)])
    np.testing.assert_allclose(weight, expected / expected.mean(), rtol=1e-6)
    # the draws land as often as the chances say, and uniformly inside a tile
    share = np.bincount(m.tile_of(index), minlength=4) / len(index)
    np.testing.assert_allclose(share, [0.5, 0.25, 0.125, 0.125], atol=0.025)
    inside = np.bincount(index[m.tile_of(index) == 0], minlength=16)[[0, 1, 4, 5]]
    assert inside.min() > 0.8 * inside.mean()


def test_no_share_is_the_uniform_draw_with_unit_weights():
    # tiles of 4 on 5 x 6 views are unequal (16, 8, 4, 2 pixels): a pixel's chance is still 1 / N
    m = ErrorMap((2, 5, 6), tile=4, share=0.0, alpha=0.6)
    m.error[:] = np.arange(8)
    np.testing.assert_allclose(m.probabilities(), m.height * m.width / 60)
    index, weight = m.draw(seed=1, batch=60_000)
    np.testing.assert_allclose(weight, 1.0)
    counts = np.bincount(index, minlength=60)
    assert counts.min() > 0.85 * 1000 and counts.max() < 1.15 * 1000


def test_importance_weights_keep_the_mean_at_alpha_one():
    # alpha = 1: the weighted mean of any per-pixel quantity over the drawn pixels is its mean over all pixels
    rng = np.random.default_rng(3)
    m = ErrorMap((3, 8, 8), tile=2, share=0.9, alpha=1.0)
    m.error[:] = rng.random(len(m)) ** 4
    f = m.error[m.tile_of(np.arange(3 * 64))] + 0.1 * rng.random(3 * 64)      # larger where the errors are
    index, weight = m.draw(seed=11, batch=200_000)
    assert abs(np.mean(weight * f[index]) - f.mean()) < 0.01 * f.mean()
    assert f[index].mean() > 1.5 * f.mean()                            # the draws alone are skewed


def test_record_sets_the_tiles_and_all_zero_errors_draw_uniformly():
    m = ErrorMap((1, 4, 4), tile=2, share=0.8, alpha=0.6)
    np.testing.assert_array_equal(m.error, UNSEEN)
    m.record(np.array([0, 15, 10]), np.array([0.2, 0.0, np.nan]))   # tiles 0, 3, 3: the later ray wins
    np.testing.assert_allclose(m.error, [0.2, UNSEEN, UNSEEN, UNSEEN])
    m.error[:] = 0.0
    np.testing.assert_allclose(m.probabilities(), 0.25)


def test_the_weighted_loss_by_hand_in_both_engines():
    # rays rgb (0, 0, 0) and (1, 1, 1) against 0, weights (1, 3): (1 * 0 + 3 * 3) / 2 rays / 3 channels = 1.5;
    # the ray errors: RMS (0, 1)
    rgb, target = np.array([[0.0] * 3, [1.0] * 3], np.float32), np.zeros((2, 3), np.float32)
    cols = lambda a: [Float(c) for c in a.T]
    assert abs(losses.mse(cols(rgb), cols(target), Float(1.0, 3.0))[0] - 1.5) < 1e-6
    assert abs(losses.mse(cols(rgb), cols(target))[0] - 0.5) < 1e-6
    np.testing.assert_allclose(losses.rms_error(cols(rgb), cols(target)).numpy(), [0.0, 1.0])
    t = torch.from_numpy
    assert abs(float(twin.mse(t(rgb), t(target), torch.tensor([1.0, 3.0]))) - 1.5) < 1e-6
    np.testing.assert_allclose(twin.rms_error(t(rgb), t(target)).numpy(), [0.0, 1.0])


def test_a_mined_batch_is_weighted_and_its_errors_fill_the_map(bunny_small):
    """Both engines draw the same mined batches from their own errors, and their loss curves coincide."""
    recipe = small("grid-2d", mining=0.8, mining_tile=2)
    ds = bunny_small
    bes = [make_backend(b, recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far) for b in ("drjit", "torch")]
    curves = []
    for be in bes:
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
        curves.append([be.read(be.step(k, step_seed(0, k), 0.02))[0] for k in range(12)])
        dr.sync_thread()
    np.testing.assert_allclose(curves[0], curves[1], rtol=3e-3)
    for be in bes:
        index, weight = be.drawn
        assert weight is not None and abs(weight.mean() - 1.0) < 1e-5 and weight.std() > 0
        seen = be.errors.error < UNSEEN
        assert seen.sum() >= 0.5 * len(be.errors)            # 10 recorded batches of 256 rays
    np.testing.assert_array_equal(bes[0].drawn[0], bes[1].drawn[0])


def test_a_checkpoint_keeps_the_error_map_so_a_resumed_run_draws_alike(bunny_small, tmp_path):
    """A mined fit's checkpoint holds its map and the errors of the steps not yet recorded: loaded into a fresh
    engine, the next batch is the one the run itself draws; a map of other data is refused in one line."""
    from mitnerf.errors import CheckpointError
    from mitnerf.train.checkpoint import load_checkpoint, save_checkpoint
    from mitnerf.train.fit import fit

    recipe = small("grid-2d", mining=0.8, mining_tile=2, iters=12)
    run = fit(bunny_small, recipe, "drjit")
    save_checkpoint(run, tmp_path / "ckpt")
    loaded, resume = load_checkpoint(tmp_path / "ckpt")
    assert set(resume["mining"]) == {"error", "flight0.index", "flight0.error", "flight1.index", "flight1.error"}
    be = loaded.backend
    be.set_data(bunny_small["train"].rays((0, 0, 0), **recipe.train.ray_args()))
    be.load_sampling_state(resume["mining"])
    seed = step_seed(recipe.train.seed, 12)
    run.backend.batch(seed)
    be.batch(seed)
    np.testing.assert_array_equal(be.drawn[0], run.backend.drawn[0])
    np.testing.assert_array_equal(be.drawn[1], run.backend.drawn[1])
    np.testing.assert_array_equal(be.errors.error, run.backend.errors.error)
    with pytest.raises(CheckpointError, match=r"^ckpt: its error map does not fit .*run's own data$"):
        be.load_sampling_state({"error": np.zeros(3, np.float32)}, "ckpt")
