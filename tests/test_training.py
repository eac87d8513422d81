"""Training: both backends learn, agree step by step, checkpoints reload, failures are caught."""

import sys
from pathlib import Path

import numpy as np
import pytest

from mitnerf.render.pipeline import RenderConfig
from mitnerf.train.checkpoint import load_checkpoint, save_checkpoint
from mitnerf.train.config import ModelConfig, TrainConfig
from mitnerf.train.rays import rays_of, step_seed
from mitnerf.train.trainer import TrainingFailed, _check_collapse, fit, make_backend, scene_bound

SMALL = ModelConfig("vanilla", dict(width=16, depth=3, pos_L=6, dir_L=3), RenderConfig(n_coarse=32))


def quick(iters, **kw):
    return TrainConfig(iters=iters, val_every=0, progress=False, batch_rays=512, **kw)


@pytest.mark.parametrize("backend", ["drjit", "torch"])
def test_a_short_run_lowers_the_loss_threefold(bunny_small, backend):
    run = fit(bunny_small, SMALL, quick(150, lr=1e-2, lr_final=2e-3), backend)
    loss = np.array(run.history["loss"])
    assert loss[-3:].mean() < loss[:3].mean() / 3, loss[[0, -1]]
    assert run.history["val_psnr"][-1] > 16.0


def test_backends_agree_step_by_step(bunny_small):
    """Same weights, batches and jitter: the loss curves coincide (this caught Dr.Jit 1.5.0's
    Adam scaling an array learning rate in place)."""
    mc = ModelConfig("vanilla", dict(width=16, depth=3, pos_L=6, dir_L=3), RenderConfig(n_coarse=32, n_fine=16))
    bes = [make_backend(b, mc, 2, scene_bound(bunny_small), bunny_small.near, bunny_small.far, quick(30))
           for b in ("drjit", "torch")]
    for be in bes:
        be.set_data(rays_of(bunny_small["train"], (0, 0, 0)))
    curves = [[be.scalar(be.step(step_seed(0, k), 5e-3)) for k in range(30)] for be in bes]
    np.testing.assert_allclose(curves[0], curves[1], rtol=2e-3)
    assert curves[0][-1] < 0.8 * curves[0][0]


def test_checkpoints_reload_to_identical_renders(bunny_small, tmp_path):
    run = fit(bunny_small, SMALL, quick(20), "drjit")
    save_checkpoint(run, tmp_path / "ckpt")
    o, d = bunny_small["test"].cameras.rays()
    o, d = o.reshape(-1, 2).astype(np.float32), d.reshape(-1, 2).astype(np.float32)
    a = run.backend.render(o, d)
    b = load_checkpoint(tmp_path / "ckpt").backend.render(o, d)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    t = load_checkpoint(tmp_path / "ckpt", backend="torch").backend.render(o, d)   # and into torch
    np.testing.assert_allclose(t["rgb"], a["rgb"], atol=1e-5)


def test_nan_loss_stops_with_advice(bunny_small):
    import copy

    ds = copy.deepcopy(bunny_small)
    ds["train"].color[:] = np.nan
    with pytest.raises(TrainingFailed, match="loss became nan.*lower --lr"):
        fit(ds, SMALL, quick(20), "drjit")


def test_a_dead_field_is_reported_as_collapsed(bunny_small):
    dead = ModelConfig("vanilla", dict(width=16, depth=3, pos_L=6, dir_L=3, density_activation="relu",
                                       density_bias=-100.0), RenderConfig(n_coarse=32))
    with pytest.raises(TrainingFailed, match="collapsed"):
        fit(bunny_small, dead, TrainConfig(iters=60, val_every=60, warmup=10, progress=False, batch_rays=256), "drjit")
    _check_collapse(np.random.rand(4, 10, 1, 3), np.random.rand(4, 10, 1, 3), 100, quick(1))   # varied: fine


def test_fit_cli_last_line(bunny_small, tmp_path, capsys):
    from mitnerf.cli import main
    from mitnerf.data.formats import save_dataset

    save_dataset(bunny_small, tmp_path / "ds")
    assert main(["fit", "--data", str(tmp_path / "ds"), "--iters", "20", "--width", "16", "--depth", "2",
                 "--samples", "16", "--out", str(tmp_path / "run")]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("test PSNR ") and last.endswith("drjit vanilla") and " dB, train " in last
    assert {"weights.npz", "config.json", "test_views.png", "density.png", "curves.png"} <= \
        {p.name for p in (tmp_path / "run").iterdir()}


def test_check_backends_script_passes():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
    import check_backends

    assert check_backends.main(["--rays", "24", "--samples", "16", "--fine", "8", "--width", "8"]) == 0
    assert check_backends.main(["--dim", "3", "--rays", "16", "--samples", "12", "--fine", "0", "--width", "8"]) == 0
