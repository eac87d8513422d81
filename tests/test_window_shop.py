"""Window shopping: the ablation's design, its outputs (collapsed runs recorded, not fatal),
and the end-to-end example (videos with the right number of frames, a mesh)."""

import csv
import importlib.util
import json
from pathlib import Path

import pytest

from mitnerf.experiments import window_shop_runs
from mitnerf.experiments.window_shop import WindowShopConfig, design, execute, quick_config
from mitnerf.train.trainer import TrainingFailed

ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"


def test_default_design_is_one_factor_at_a_time_and_full_is_the_factorial():
    specs = design(WindowShopConfig())
    nerf = [s for s in specs if s.field == "vanilla" and s.design != "probe"]
    # per object and budget: base at 4 view counts + 4 factors changed at 5 views = 8; x 2 budgets x 2 objects
    assert len(nerf) == 32
    assert {s.views for s in nerf if s.design == "ofat"} == {5}
    assert all(sum([s.pos_L != 10, s.n_coarse != 64, not s.view_dependent, not s.hierarchical]) == 1
               for s in nerf if s.design == "ofat")
    assert sum(s.field == "grid" for s in specs) == 16                   # 4 views x 2 budgets x 2 objects
    assert sum(s.design == "probe" for s in specs) == 4                  # N_c 64/128 x 2 objects, fixed steps
    assert len(specs) == 52 and len({s.key() for s in specs}) == 52      # no training twice
    full = design(WindowShopConfig(full=True))
    # 4 views x 2 L x 2 N_c x 2 view dependence x 2 hierarchical = 64, x 2 budgets x 2 objects = 256
    assert sum(s.design == "factorial" for s in full) == 256
    assert len(design(quick_config())) == 13       # (2 views + 2 factors) x 2 budgets + 4 grid + 1 probe


def tiny_config() -> WindowShopConfig:
    """Smaller than quick mode (which takes ~1 min): the vase at 16x16, 3 and 6 views."""
    return WindowShopConfig(objects=("vase",), resolution=16, pool_views=6, test_views=2, views=(3, 6),
                            factors=("hierarchical",), iters=8, time_budget=1.0, warmup=2, probe_n_coarse=(64,),
                            compile_first=False, progress=False)


def test_the_ablation_writes_its_files_and_records_collapse(tmp_path, monkeypatch):
    real_fit = window_shop_runs.fit

    def fit(dataset, mc, tc, backend="drjit"):      # the no-hierarchical runs "diverge"
        if mc.field == "vanilla" and mc.render.n_fine == 0:
            raise TrainingFailed("the loss became nan at step 3")
        return real_fit(dataset, mc, tc, backend)

    monkeypatch.setattr(window_shop_runs, "fit", fit)
    cfg = tiny_config()
    report = execute(tmp_path, cfg)
    assert report == tmp_path / "report.md"
    for name in ("psnr_vs_time.png", "psnr_vs_views.png", "thumbnails.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG, name
    with open(tmp_path / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(design(cfg)) == 11     # (2 views + 1 factor) x 2 budgets + 4 grid + 1 probe
    failed = [r for r in rows if r["hierarchical"] == "False" and r["field"] == "vanilla"]
    assert len(failed) == 2 and all(r["status"] == "collapsed" and r["reason"].startswith("TrainingFailed")
                                    for r in failed)
    ok = [r for r in rows if r not in failed]
    assert all(r["psnr"] and float(r["train_time"]) > 0 and int(r["steps"]) > 0 for r in ok)
    assert all(int(r["steps"]) == 8 for r in ok if r["budget"] == "iters")
    text = report.read_text()
    assert "| object | budget | design | config | views | status | psnr | ssim | train_time |" in text
    assert "render_time" in text and "![test PSNR against train time](psnr_vs_time.png)" in text
    assert "23-25 dB" in text and "15-16 dB" in text


def load_example():
    spec = importlib.util.spec_from_file_location("window_shopping", ROOT / "examples" / "window_shopping.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_example_writes_videos_with_every_frame_and_a_mesh(tmp_path, capsys):
    from mitnerf.viz.video import read_video

    example = load_example()
    out = tmp_path / "shop"
    rc = example.main(["--scene", "vase", "--views", "4", "--resolution", "16", "--iters", "12", "--time-budget",
                       "30", "--frames", "7", "--video-resolution", "12", "--mesh-resolution", "24",
                       "--chamfer-points", "2000", "--level", "auto", "--no-progress", "--out", str(out)])
    assert rc == 0
    for name in ("color", "depth"):
        for ext in ("gif", "mp4"):
            frames = read_video(out / f"{name}.{ext}")
            assert frames.shape == (7, 12, 12, 3), (name, ext, frames.shape)
    assert (out / "mesh.ply").stat().st_size > 0 and (out / "mesh.png").read_bytes()[:8] == PNG
    s = json.loads((out / "summary.json").read_text())
    assert s["views"] == 4 and s["steps"] == 12 and s["video_frames"] == 7
    assert s["mesh"]["chamfer"] > 0
    printed = capsys.readouterr().out
    assert "test PSNR" in printed and "video 7 frames 12x12" in printed and "Chamfer distance" in printed


def test_the_example_refuses_zero_views():
    with pytest.raises(SystemExit):
        load_example().parse_args(["--views", "0"])
