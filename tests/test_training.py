"""Training: both engines learn and agree step by step (every field family, with depth
supervision, a fine pass or the occupancy grid), checkpoints reload exactly, and what
stops a run says why."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, small

from mitnerf.rng import step_seed
from mitnerf.train.engines import make_backend
from mitnerf.train.checkpoint import load_checkpoint, save_checkpoint
from mitnerf.train.evaluate import classify
from mitnerf.train.fit import fit, fit_and_evaluate, keeps_best
from mitnerf.train.loop import LoopState, TrainingFailed


@pytest.mark.parametrize("backend", ["drjit", "torch"])
def test_a_short_run_lowers_the_loss_threefold(bunny_small, backend):
    run = fit(bunny_small, small(iters=150, lr=1e-2, lr_final=2e-3, batch_rays=512), backend)
    loss = np.array(run.state.history["loss"])
    assert loss[-3:].mean() < loss[:3].mean() / 3, loss[[0, -1]]
    assert run.state.history["val_psnr"][-1] > 16.0


OPTIONS = {"plain": {}, "depth": dict(depth_weight=0.05), "free space": dict(free_space_weight=0.5),
           "solid": dict(solid_weight=0.5),
           "fine": dict(n_fine=16),
           "occupancy": {"occupancy.enabled": True, "occupancy.warmup": 4, "occupancy.update_every": 4,
                         "occupancy.resolution": 32},
           "early stop": {"occupancy.enabled": True, "occupancy.warmup": 4, "occupancy.update_every": 4,
                          "occupancy.resolution": 32, "occupancy.early_stop": 0.05},
           "regularisers": dict(distortion_weight=0.01, opacity_weight=0.01, view_dependent=True),
           "pixel jitter": dict(pixel_jitter=True)}


@pytest.mark.parametrize("option", OPTIONS)
@pytest.mark.parametrize("family", ["vanilla", "grid", "hashgrid", "hashlinear"])
def test_engines_agree_step_by_step(bunny_small, family, option):
    """Same weights, batches and jitter: the loss curves coincide, for every field family with
    depth supervision, the free-space and solid losses, a fine pass or the occupancy grid (this caught Dr.Jit 1.5.0's Adam
    scaling an array learning rate in place, and a torch engine without depth samples)."""
    recipe = small(f"{family}-2d", **OPTIONS[option])
    if family == "grid":
        recipe.model.field_args.update(upsample_at=(8,))       # the coarse-to-fine resize inside the compared steps
        if option == "regularisers":
            recipe.model.field_args["sh_degree"] = 3          # past degree 2, the 2D harmonics' recurrence
    if family == "hashlinear":
        recipe.model.field_args.update(add_level_at=(8,))     # a level joins inside the compared steps
    ds = bunny_small
    bes = [make_backend(b, recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far) for b in ("drjit", "torch")]
    for be in bes:
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
    lr = {"vanilla": 5e-3, "grid": 0.02, "hashgrid": 0.01, "hashlinear": 0.02}[family]
    curves = [[be.read(be.step(k, step_seed(0, k), lr))[0] for k in range(16)] for be in bes]
    np.testing.assert_allclose(curves[0], curves[1], rtol=3e-3)
    assert curves[0][-1] < curves[0][0]


def test_engines_agree_while_the_frequency_window_opens(bunny_small):
    """FreeNeRF's window (``pe_window``) opens over the compared steps in both engines: the loss curves coincide,
    and each engine then renders at the step it reached."""
    recipe = small("vanilla-2d", pe_window=12)
    ds = bunny_small
    bes = [make_backend(b, recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far) for b in ("drjit", "torch")]
    for be in bes:
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
    curves = [[be.read(be.step(k, step_seed(0, k), 5e-3))[0] for k in range(8)] for be in bes]
    np.testing.assert_allclose(curves[0], curves[1], rtol=3e-3)
    o, d = (a.reshape(-1, 2)[:64].astype(np.float32) for a in ds["test"].cameras.rays())
    drjit_rgb, torch_rgb = (be.render(o, d)["rgb"] for be in bes)
    np.testing.assert_allclose(drjit_rgb, torch_rgb, atol=1e-4)


def warped_engine(engine: str, recipe, dataset, scene: str):
    """An engine for ``recipe`` trained on ``dataset`` (3D, white) as a ``scene`` (forward or unbounded)."""
    from mitnerf.train.fit import settle_scene

    recipe.model.render.scene = scene
    be = make_backend(engine, recipe.model, recipe.train, 3, *settle_scene(recipe, dataset))
    be.set_data(dataset["train"].rays((1, 1, 1), **recipe.train.ray_args()))
    return be


@pytest.mark.parametrize("scene", ["forward", "unbounded"])
def test_engines_agree_step_by_step_in_a_warped_scene(vase_small, scene):
    """NDC and the contraction with the distortion loss, which both engines take along the unit spacing coordinate
    (``Space.spacing``): the loss curves coincide."""
    recipe = small("grid-3d", distortion_weight=0.05, opacity_weight=0.01, free_space_weight=0.0, solid_weight=0.0,
                   **{"occupancy.enabled": False})
    bes = [warped_engine(b, recipe, vase_small, scene) for b in ("drjit", "torch")]
    curves = [[be.read(be.step(k, step_seed(0, k), 0.02))[0] for k in range(8)] for be in bes]
    np.testing.assert_allclose(curves[0], curves[1], rtol=3e-3)


def test_a_grid_step_with_total_variation_never_copies_the_colour_gradient(vase_small, monkeypatch):
    """The Dr.Jit step records the terms that read parameters at scattered points (total variation) before the
    render, so the integral's gradient is added to theirs (backend_drjit): no kernel of a step copies an array the
    size of the colour grid, the largest one (recorded the other way round, one copied it every step). With atomic
    adds: a gradient summed in a copy per thread (``EXPAND_BYTES``) is copied in its expansion, a cost that
    ``benchmarks/scatter.py`` measures with the rest of the step."""
    import drjit as dr

    from mitnerf.train import backend_drjit

    monkeypatch.setattr(backend_drjit, "EXPAND_BYTES", 0)
    recipe = small("grid-3d", resolution=65, initial_resolution=65, upsample_at=(), solid_weight=0.0,
                   free_space_weight=0.0)
    assert recipe.model.field_args["tv_color_weight"] > 0
    be = warped_engine("drjit", recipe, vase_small, "forward")
    for k in range(3):                                      # the recordings of the frozen step
        be.read(be.step(k, step_seed(0, k), 0.02))
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()
        be.read(be.step(3, step_seed(0, 3), 0.02))
        dr.sync_thread()
        kernels = dr.kernel_history()
    colour = 4 * dr.width(be.params["coarse.color"])             # bytes
    assert any(k["type"] == dr.KernelType.JIT for k in kernels)
    assert not [k for k in kernels if k["type"] == dr.KernelType.Memcpy and k["size"] == colour]


def test_a_model_past_the_freeze_limit_is_traced_each_step_and_trains_alike(bunny_small, monkeypatch):
    """Past ``FREEZE_MAX_PARAMS`` parameters a step is traced anew each time, not replayed; the losses are the same
    (one thread: the sums are deterministic)."""
    from mitnerf.train import backend_drjit

    recipe = small("grid-2d", threads=1)
    ds = bunny_small
    curves = []
    for limit in (1 << 30, 0):
        monkeypatch.setattr(backend_drjit, "FREEZE_MAX_PARAMS", limit)
        be = make_backend("drjit", recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far)
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
        assert be.replayed == (limit > 0)
        curves.append([be.read(be.step(k, step_seed(0, k), 0.02))[0] for k in range(5)])
    np.testing.assert_allclose(curves[0], curves[1], rtol=1e-6)


def test_a_traced_step_compiles_nothing_after_its_first(bunny_small, monkeypatch):
    """A step traced anew each time (past ``FREEZE_MAX_PARAMS``) finds every kernel in Dr.Jit's cache from the
    third step on: what changes between steps (seed, learning rate, step, Adam's step count) enters as opaque
    arrays, not as numbers baked into the kernels."""
    import drjit as dr

    from mitnerf.train import backend_drjit

    monkeypatch.setattr(backend_drjit, "FREEZE_MAX_PARAMS", 0)
    recipe = small("grid-2d")
    ds = bunny_small
    be = make_backend("drjit", recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far)
    be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
    assert not be.replayed
    for k in (0, 1):                    # the first steps differ (Adam's moments start as zeros)
        be.read(be.step(k, step_seed(0, k), 0.02))
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()
        for k in (2, 3, 4):
            be.read(be.step(k, step_seed(0, k), 0.02 / k))
        dr.sync_thread()
        kernels = [h for h in dr.kernel_history() if h["type"] == dr.KernelType.JIT]
    assert kernels and all(h["cache_hit"] for h in kernels), [h["hash"] for h in kernels if not h["cache_hit"]]


def test_training_goes_on_as_before_after_the_engine_gives_back_its_memory(bunny_small):
    """``release()`` between steps (fit calls it when training ends; a step after it allocates again) changes no
    loss: one thread, so the sums are deterministic."""
    recipe = small("grid-2d", threads=1)
    ds = bunny_small
    curves = []
    for release in (False, True):
        be = make_backend("drjit", recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far)
        be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
        curve = []
        for k in range(6):
            curve.append(be.read(be.step(k, step_seed(0, k), 0.02))[0])
            if release and k % 2:
                be.release()
        curves.append(curve)
    np.testing.assert_array_equal(curves[0], curves[1])


def test_torch_trains_with_depth_supervision(bunny_small):
    _, rec = fit_and_evaluate(bunny_small, small(depth_weight=0.02, iters=40), "torch")
    assert rec.status == "ok" and rec.psnr > 10 and np.isfinite(rec.depth_error)


@pytest.mark.parametrize("recipe, args", [("vanilla-2d", {}), ("hashlinear-2d", {}),   # saved after a level joined
                                          ("vanilla-2d", dict(pe_window=40))])        # saved with its window half open
def test_checkpoints_reload_to_identical_renders(bunny_small, tmp_path, recipe, args):
    run = fit(bunny_small, small(recipe, iters=20, **args), "drjit")
    save_checkpoint(run, tmp_path / "ckpt")
    o, d = bunny_small["test"].cameras.rays()
    o, d = o.reshape(-1, 2), d.reshape(-1, 2)
    a = run.backend.render(o, d)
    b = load_checkpoint(tmp_path / "ckpt")[0].backend.render(o, d)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    t = load_checkpoint(tmp_path / "ckpt", backend="torch")[0].backend.render(o, d)   # and into torch
    np.testing.assert_allclose(t["rgb"], a["rgb"], atol=1e-5)


def test_a_nan_stops_the_run_naming_step_quantity_and_fix(bunny_small):
    import copy

    ds = copy.deepcopy(bunny_small)
    ds["train"].color[:] = np.nan
    with pytest.raises(TrainingFailed, match=r"became NaN or infinite at step \d+; lower the learning rate"):
        fit(ds, small(iters=20), "drjit")


def test_the_last_good_weights_survive_a_nan(bunny_small):
    """A run that goes NaN after a good validation ends with that validation's weights."""
    import copy

    run = fit(bunny_small, small(iters=40, val_every=20), "drjit")
    good = run.backend.get_weights()
    poisoned = copy.deepcopy(bunny_small)
    poisoned["train"].color[:] = np.nan
    with pytest.raises(TrainingFailed) as info:
        fit(poisoned, small(iters=40, val_every=20), "drjit", resume={
            "weights": good, "optimizer": {}, "state": LoopState(), "best": run.best, "best_weights": good})
    assert f"kept the weights of step {run.best['step']}" in str(info.value)
    kept = info.value.run.backend.get_weights()
    for k in good:
        np.testing.assert_array_equal(kept[k], good[k])


def test_the_best_checkpoint_must_beat_the_last_by_the_margin(bunny_small):
    import copy

    assert not keeps_best(40.5, 40.3, 0.3)          # 0.2 dB: within the noise, the last weights stay
    assert keeps_best(40.7, 40.3, 0.3)              # 0.4 dB: the best checkpoint is kept
    assert not keeps_best(40.3, 40.3, 0.0)          # a tie goes to the last weights
    run = fit(bunny_small, small(iters=20, val_every=0), "drjit")
    start = run.backend.get_weights()               # a "best" checkpoint at 90 dB: far ahead of the last
    for margin, kept in ((0.3, True), (100.0, False)):
        again = fit(bunny_small, small(iters=40, val_every=0, keep_best_margin=margin), "drjit", resume={
            "weights": start, "optimizer": {}, "state": copy.deepcopy(run.state),
            "best": {"step": 20, "val_psnr": 90.0}, "best_weights": start})
        assert any("kept the checkpoint of step 20" in n for n in again.notes) == kept
        end = again.backend.get_weights()
        assert all(np.array_equal(end[k], start[k]) for k in start) == kept


@pytest.mark.parametrize("val_every", [60, 0], ids=["found by the loop's validation", "found by the last one"])
def test_a_dead_field_is_reported_as_collapsed(bunny_small, val_every):
    dead = small(density_activation="relu", density_bias=-100.0, iters=60, val_every=val_every, warmup=10)
    _, rec = fit_and_evaluate(bunny_small, dead, "drjit")
    assert rec.status == "collapsed" and "empty" in rec.reason
    s = bunny_small["test"]
    assert classify(np.random.rand(*s.color.shape), np.ones(s.alpha.shape), s, (0, 0, 0)) == ("ok", "")


def test_fit_cli_prints_the_recipe_and_ends_with_the_record(bunny_small, tmp_path, capsys):
    from mitnerf.cli import main
    from mitnerf.data.formats import save_dataset

    save_dataset(bunny_small, tmp_path / "ds")
    assert main(["fit", "--data", str(tmp_path / "ds"), "--iters", "20", "--field", "vanilla", "--mlp-width", "16",
                 "--mlp-depth", "2", "--samples", "16", "--out", str(tmp_path / "run")]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("recipe vanilla-2d+: vanilla (width=16, depth=2")
    assert lines[-1].startswith("test PSNR ") and " dB, SSIM " in lines[-1] and "recipe vanilla-2d+" in lines[-1]
    assert {"weights.npz", "manifest.json", "test_views.png", "density.png", "curves.png"} <= \
        {p.name for p in (tmp_path / "run").iterdir()}


def test_sigint_then_resume_lands_where_an_uninterrupted_run_does(bunny_small, tmp_path):
    """Ctrl-C writes the checkpoint and says how to resume; the resumed run ends within
    0.1 dB of the same run left alone (same seed, same steps). One thread: with two, Dr.Jit's
    parallel sums round differently from run to run, and the runs drift apart anyway."""
    from mitnerf.data.formats import save_dataset

    save_dataset(bunny_small, tmp_path / "ds")
    cmd = [sys.executable, "-m", "mitnerf", "fit", "--data", str(tmp_path / "ds"), "--field", "vanilla",
           "--iters", "1500", "--mlp-width", "16", "--mlp-depth", "3", "--samples", "32", "--batch", "256",
           "--set", "time_budget=null", "--val-every", "0", "--threads", "1", "--no-figures"]
    whole = subprocess.run(cmd + ["--out", str(tmp_path / "whole")], capture_output=True, text=True, cwd=ROOT)
    assert whole.returncode == 0, whole.stderr
    p = subprocess.Popen(cmd + ["--out", str(tmp_path / "cut")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, cwd=ROOT)
    for line in p.stderr:                       # the progress bar: wait until training runs
        if "step=" in line:
            break
    p.send_signal(2)
    out, _ = p.communicate(timeout=300)
    assert p.returncode == 130 and "resume with `mitnerf fit --resume" in out, out
    step = int(out.split("at step ")[1].split(";")[0])
    assert 0 < step < 1500
    again = subprocess.run([sys.executable, "-m", "mitnerf", "fit", "--resume", str(tmp_path / "cut")],
                           capture_output=True, text=True, cwd=ROOT)
    assert again.returncode == 0, again.stderr
    psnr = lambda text: float(text.strip().splitlines()[-1].split("test PSNR ")[1].split(" dB")[0])
    assert abs(psnr(again.stdout) - psnr(whole.stdout)) <= 0.1, (again.stdout, whole.stdout)


def test_parity_holds_within_each_tolerance_and_fails_past_it():
    from mitnerf.reference.parity import Parity

    # values 1e-5 abs (depths 5e-5), gradients 5e-3 relative, finite differences 2e-2
    ok = Parity(["custom op", "torch"], {"coarse colour": [9e-6, 0.0], "coarse depth": [4e-5, 0.0]},
                {"sigma": [4e-3, 0.0]}, 1e-2)
    assert ok.ok
    for bad in (dict(values={"coarse colour": [2e-5, 0.0]}), dict(grads={"sigma": [0.0, 6e-3]}), dict(fd=3e-2)):
        assert not dataclasses.replace(ok, **bad).ok, bad


def test_the_mlp_paths_agree_with_the_torch_twin():
    from mitnerf.reference.parity import check_parity

    assert check_parity(rays=24, samples=16, fine=8, width=8).ok
    assert check_parity(dim=3, rays=16, samples=12, fine=0, width=8).ok


def first_loss(ds, **overrides) -> float:
    """The loss of the first training step of a small ``grid-2d`` with ``overrides`` on ``ds``."""
    recipe = small("grid-2d", **overrides)
    be = make_backend("drjit", recipe.model, recipe.train, 2, ds.bound, ds.near, ds.far)
    be.set_data(ds["train"].rays((0, 0, 0), **recipe.train.ray_args()))
    return be.read(be.step(0, step_seed(0, 0), 0.0))[0]


def test_the_free_space_loss_sees_the_initial_fog(bunny_small):
    """The initial density is a thin fog everywhere: in front of the measured depth it is what the
    free-space loss penalises, so the first step's loss is larger with it on than off."""
    losses = [first_loss(bunny_small, free_space_weight=w, solid_weight=0.0) for w in (0.0, 0.5)]
    assert losses[1] > losses[0] + 0.01, losses


def test_the_solid_loss_sees_the_empty_inside(bunny_small):
    """The initial density (0.31) is below the level of matter: behind the measured depth the solid loss
    penalises it, so the first step's loss is larger with it on than off."""
    losses = [first_loss(bunny_small, solid_weight=w, free_space_weight=0.0) for w in (0.0, 0.5)]
    assert losses[1] > losses[0] + 0.1, losses


def test_a_setting_written_at_its_value_is_the_same_recipe():
    """Overriding a setting with the value it has (the recipe's, or the field's default) changes nothing,
    so the recipe keeps its name; a real change gets the ``+``."""
    from mitnerf.train.recipes import get_recipe

    base = get_recipe("grid-3d")
    assert "tv_samples" not in base.model.field_args
    same = base.override(**{k: base.get(k) for k in ("view_dependent", "free_space_weight", "tv_samples")})
    assert same.name == "grid-3d" and same.essence() == base.essence()
    changed = base.override(view_dependent=not base.get("view_dependent"))
    assert changed.name == "grid-3d+" and changed.essence() != base.essence()


def test_a_recipe_at_fixed_steps_has_no_clock():
    """``at_steps``: exactly the steps asked, no time budget, other settings as ``override``, and the ``+``;
    pixelnerf-2d (8000 steps within 150 s) at its own 8000 steps still differs: its clock is gone."""
    from mitnerf.train.recipes import get_recipe

    r = get_recipe("grid-2d").at_steps(300, seed=3)
    assert (r.train.iters, r.train.time_budget, r.train.seed, r.name) == (300, None, 3, "grid-2d+")
    same_steps = get_recipe("pixelnerf-2d").at_steps(8000)
    assert same_steps.train.time_budget is None and same_steps.name == "pixelnerf-2d+"
    assert r.at_steps(300).name == "grid-2d+"                                 # marked once, not "grid-2d++"
