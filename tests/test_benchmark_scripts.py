"""The benchmark scripts' bookkeeping (what they record, and what a rerun keeps), with the fits faked: the figures
themselves are measured by running the scripts, never here."""

from types import SimpleNamespace
from pathlib import Path

import numpy as np
import pytest

from mitnerf.results import load_results, record_result


def fake_row(ds, recipe, label, extra_time=0.0):
    """A row whose PSNR is 30 dB plus a hundredth of its budget, so a longer run scores higher."""
    budget = recipe.train.time_budget
    return {"run": label, "recipe": recipe.name, "psnr": 30 + budget / 100, "ssim": 0.9, "geometry": 0.95,
            "params": 1, "seconds": budget + extra_time, "status": "ok"}


@pytest.fixture
def fit_table(monkeypatch):
    """The fit table script with its datasets and fits faked."""
    from benchmarks import fit_table

    monkeypatch.setattr(fit_table, "dataset", lambda scene, dim: SimpleNamespace(dim=dim))
    monkeypatch.setattr(fit_table, "row", fake_row)
    return fit_table


def test_fit_table_records_every_row_and_the_longer_runs(results, fit_table):
    assert fit_table.main(["--scenes", "square", "tu", "--budget", "10", "--long", "300", "--long-scenes", "tu",
                           "--no-3d", "--no-auto"]) == 0
    recorded = load_results()
    rows = recorded["fits/square"]["values"]["rows"]
    assert {r["run"].split(",")[0] for r in rows} == set(fit_table.FAMILIES)
    assert sum("[recipe]" in r["run"] for r in rows) == len(fit_table.FAMILIES)     # each family's own set, once
    assert recorded["fits/longer"]["values"] == {"tu": {"short": 30.1, "long": 33.0}}
    # a rerun of the longer runs on another scene keeps tu's and names both commands
    assert fit_table.main(["--scenes", "square", "--budget", "10", "--long", "60", "--long-scenes", "square",
                           "--redo", "longer", "--no-3d", "--no-auto"]) == 0
    entry = load_results()["fits/longer"]
    assert entry["values"] == {"tu": {"short": 30.1, "long": 33.0}, "square": {"short": 30.1, "long": 30.6}}
    assert entry["command"].count(" && ") == 1


def test_fit_table_marks_each_3d_recipe_among_its_option_sets(results, fit_table):
    """The 3D "reg." set carries 3D's own weights, so the 3D recipes' rows are found and marked too."""
    assert fit_table.main(["--scenes", "--no-auto", "--budget-3d", "60"]) == 0
    rows = load_results()["fits/vase_glossy"]["values"]["rows"]
    marked = sorted(r["run"].split(",")[0] for r in rows if "[recipe]" in r["run"])
    assert marked == sorted(fit_table.FAMILIES)
    assert all(r["seconds"] == 60 for r in rows)


def test_glossy_sweep_keeps_the_rows_of_roughnesses_not_rerun(results):
    from benchmarks import glossy_sweep

    record_result("glossy/3d", {"0.12": {"grid": 1}, "0.3": {"grid": 2}}, "old", "python benchmarks/glossy_sweep.py")
    rows, command = glossy_sweep.merged("glossy/3d", {"0.25": {"grid": 3}, "0.3": {"grid": 4}},
                                        "python benchmarks/glossy_sweep.py --roughness-3d 0.25 0.3")
    assert rows == {"0.12": {"grid": 1}, "0.25": {"grid": 3}, "0.3": {"grid": 4}}       # in order of roughness
    assert list(rows) == ["0.12", "0.25", "0.3"]
    assert command == "python benchmarks/glossy_sweep.py && python benchmarks/glossy_sweep.py --roughness-3d 0.25 0.3"
    rows, command = glossy_sweep.merged("glossy/3d", {"0.12": {}, "0.3": {}}, "again")
    assert command == "again"                                                               # nothing kept


def test_poses_fit_pair_records_both_fits_and_a_collapsed_one(results, monkeypatch, tmp_path):
    from benchmarks import poses

    lines = {"ours": "test PSNR 18.38 dB, SSIM 0.5, train 60.0 s, recipe grid-3d (drjit)",
             "true": "test PSNR 4.78 dB, SSIM 0.001, train 60.0 s, recipe grid-3d [collapsed: constant: x] (drjit)"}
    monkeypatch.setattr(poses, "cli", lambda *args, ok: ("fit ...\n" + lines[Path(args[2]).name], 60.0))
    assert poses.fit_pair("fern", tmp_path / "ours", tmp_path / "true", 60) == "fit fern -13.60 dB"
    entry = load_results()["poses/fit/fern"]
    assert entry["values"]["status"] == {"ours": "ok", "true": "collapsed: constant: x"}
    assert "the fit on true poses collapsed" in entry["summary"]
def test_lego_records_each_budget_and_skips_without_the_data(results, tmp_path, monkeypatch, capsys):
    from benchmarks import lego

    assert lego.main(["--data", str(tmp_path / "absent")]) == 0
    assert capsys.readouterr().out.startswith("lego: skipped, no Blender lego at ")
    assert load_results() == {}
    (tmp_path / "transforms_train.json").write_text("{}")
    metrics = {"psnr": 30.5, "ssim": 0.95, "train_time": 600.2, "steps": 4000, "eval_time": 41.0, "peak_memory": 1.5,
               "render_time": 0.1, "views": 200, "background": "white", "recipe": "grid-3d"}
    monkeypatch.setattr(lego, "fit", lambda data, budget: {
        "metrics": dict(metrics, train_time=float(budget)), "size": "400 x 400", "wall": 700.0,
        "first": "recipe grid-3d: ...",
        "last": "test PSNR 30.50 dB", "command": f"python -m mitnerf fit --data D --time-budget {budget}"})
    assert lego.main(["--data", str(tmp_path), "--parts", "600"]) == 0
    entry = load_results()["lego/600"]
    assert entry["values"]["psnr"] == 30.5 and entry["values"]["eval_s"] == 41.0 and entry["values"]["views"] == 200
    assert entry["command"].endswith("--time-budget 600") and "3600" not in load_results()
    from benchmarks import report

    table = report.lego_table(load_results())
    assert "| `lego/600` (grid-3d) | 400 x 400 | 200 | 30.50 | 0.950 | 600 s, 4000 steps |" in table
    assert "| NeRF (published) | 800 x 800 | 200 | 32.54 |" in table
    assert "on 200 views of 400 x 400 over" in entry["summary"]
    assert "evaluation 41 s (rendering 20 s)" in entry["summary"]             # 0.1 s a view, 200 views


def test_lego_single_grey_and_uniform_run_a_budgets_command_with_one_setting(results, tmp_path, monkeypatch):
    """Part single: part 600's fit with ``--set density_refine=1``; part grey: part 3600's with ``--set
    view_color=grey``; parts uniform and uniform-hour: parts 600's and 3600's with ``--set mining=0``; parts random and
    random-hour: the same with ``--set background=random``; part
    samples128: part 3600's with ``--set n_coarse=128``; part fine: part 3600's with three settings, a ``--set``
    each; each in its own folder, recorded beside the default."""
    from benchmarks import lego

    (tmp_path / "transforms_train.json").write_text("{}")
    seen = []
    metrics = {"psnr": 31.0, "ssim": 0.97, "train_time": 600.1, "steps": 3000, "eval_time": 45.0,
               "peak_memory": 3.9, "render_time": 0.2, "views": 200, "background": "white", "recipe": "grid-3d+"}

    def fake_fit(data, budget, part=None, *flags):
        seen.append((budget, part, flags))
        return {"metrics": metrics, "size": "400 x 400", "wall": 700.0, "first": "recipe grid-3d+: ...",
                "last": "test PSNR 31.00 dB", "command": "python -m mitnerf fit --set density_refine=1"}

    monkeypatch.setattr(lego, "fit", fake_fit)
    assert lego.main(["--data", str(tmp_path), "--parts", "single", "grey", "uniform",
                      "uniform-hour", "random", "random-hour", "samples128", "fine"]) == 0
    assert seen == [("600", "single-600", ("--set", "density_refine=1")),
                    ("3600", "grey-3600", ("--set", "view_color=grey")), ("600", "uniform-600", ("--set", "mining=0")),
                    ("3600", "uniform-3600", ("--set", "mining=0")),
                    ("600", "random-600", ("--set", "background=random")),
                    ("3600", "random-3600", ("--set", "background=random")),
                    ("3600", "samples128-3600", ("--set", "n_coarse=128")),
                    ("3600", "fine-3600", ("--set", "resolution=213", "--set", "density_refine=2", "--set",
                                           "render_oversample=4"))]
    assert {"lego/grey/3600", "lego/uniform/600", "lego/uniform/3600", "lego/random/600", "lego/random/3600",
            "lego/samples128/3600",
            "lego/fine/3600"} <= set(load_results())
    entry = load_results()["lego/single/600"]
    assert entry["values"]["psnr"] == 31.0 and "density_refine=1" in entry["command"]
    from benchmarks import report

    assert "| `lego/single/600` (grid-3d+) | 400 x 400 | 200 | 31.00 | 0.970 |" in report.lego_table(load_results())


def test_lego_auto_records_the_search_and_the_whole_wall_time(results, tmp_path, monkeypatch):
    """Part auto: ``fit --auto`` with probes of 120 s; the record keeps the probes' lines and counts the sizes."""
    from benchmarks import lego

    (tmp_path / "transforms_train.json").write_text("{}")
    seen = []
    metrics = {"psnr": 27.0, "ssim": 0.9, "train_time": 120.0, "steps": 700, "eval_time": 25.0, "peak_memory": 3.0,
               "render_time": 0.1, "views": 200, "background": "white", "recipe": "auto:grid-3d"}
    search = ["grid (...), 64 samples: 53246700 parameters, validation 27.00 dB in 120.0 s [size]",
              "vanilla (...), 64 samples: 21796 parameters, validation 20.70 dB in 120.0 s [size]",
              "grid with 53246700 parameters (27.00 dB) is the best of 2 probes"]

    def fake_fit(data, budget, part=None, *flags):
        seen.append((budget, part, flags))
        return {"metrics": metrics, "size": "400 x 400", "wall": 540.0, "first": "recipe auto:grid-3d: ...",
                "last": "test PSNR 27.00 dB", "auto": search, "command": "python -m mitnerf fit --auto"}

    monkeypatch.setattr(lego, "fit", fake_fit)
    assert lego.main(["--data", str(tmp_path), "--parts", "auto"]) == 0
    assert seen == [("120", "auto", ("--auto",))]
    entry = load_results()["lego/auto/120"]
    assert entry["values"]["search"] == search and entry["values"]["recipe"] == "auto:grid-3d"
    assert "2 sizes probed, 9.0 min in all" in entry["summary"]


def hour_fit(lego, part: str, tmp_path, monkeypatch, capsys) -> Path:
    """Checks that ``part`` of ``benchmarks/lego.py`` says one line and records nothing without part 3600's fit, then
    gives it a fit's folder (written by grid-3d+) in its place."""
    (tmp_path / "transforms_train.json").write_text("{}")
    monkeypatch.setattr(lego, "RUN_3600", tmp_path / "absent")
    assert lego.main(["--data", str(tmp_path), "--parts", part]) == 0
    assert f"lego_{part}: skipped, no fit at " in capsys.readouterr().out and load_results() == {}
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text("{}")
    (run / "metrics.json").write_text('{"recipe": "grid-3d+"}')
    monkeypatch.setattr(lego, "RUN_3600", run)
    return run


def test_lego_resolution_scores_the_3600_fit_twice_smaller_and_skips_without_it(results, tmp_path, monkeypatch,
                                                                                  capsys):
    from benchmarks import lego

    hour_fit(lego, "resolution", tmp_path, monkeypatch, capsys)
    monkeypatch.setattr(lego, "scored_at_sizes", lambda r, data: {1: (30.46, 0.965, "400 x 400"),
                                                                   2: (32.16, 0.982, "200 x 200"),
                                                                   "train": (34.50, 0.980, "400 x 400")})
    assert lego.main(["--data", str(tmp_path), "--parts", "resolution"]) == 0
    entry = load_results()["lego_resolution/3600"]
    assert abs(entry["values"]["gain_db"] - 1.70) < 1e-9 and entry["recipe"] == "grid-3d+"
    assert abs(entry["values"]["gap_db"] - 4.04) < 1e-9        # 34.50 on the training views - 30.46 on the test views
    assert "32.16 dB, SSIM 0.982 box-filtered to 200 x 200 (+1.70 dB)" in entry["summary"]
    assert "on its own training views 34.50 dB, SSIM 0.980 (+4.04 dB over the test views" in entry["summary"]


def test_lego_quadrature_renders_the_3600_fit_with_each_oversample_and_skips_without_it(results, tmp_path,
                                                                                         monkeypatch, capsys):
    """Part quadrature: one checkpoint and one dataset loaded, the test views rendered once per oversample with that
    oversample set at the time of the render; a record per oversample, and one line without the hour's fit."""
    import mitnerf.data.formats as formats
    import mitnerf.train.checkpoint as checkpoint
    import mitnerf.train.evaluate as evaluate
    from benchmarks import lego

    run = hour_fit(lego, "quadrature", tmp_path, monkeypatch, capsys)
    backend = SimpleNamespace(model_cfg=SimpleNamespace(render=SimpleNamespace(render_oversample=2)))
    loads, seen = [], []
    monkeypatch.setattr(checkpoint, "load_checkpoint", lambda r: loads.append(r) or (SimpleNamespace(backend=backend),
                                                                                    None))
    monkeypatch.setattr(formats, "load_dataset", lambda d: loads.append(d) or "dataset")

    def fake_evaluate(b, ds, split, geometry_metrics):
        k = b.model_cfg.render.render_oversample
        seen.append((k, ds, split, geometry_metrics))
        return SimpleNamespace(psnr=31.0 + 0.5 * min(k, 4) ** 0.5, ssim=0.97, render_time=0.1 * k, views=200)

    monkeypatch.setattr(evaluate, "evaluate", fake_evaluate)
    assert lego.main(["--data", str(tmp_path), "--parts", "quadrature"]) == 0
    assert loads == [run, tmp_path] and seen == [(k, "dataset", "test", False) for k in (1, 2, 4, 8)]
    entry = load_results()["lego_quadrature/3600"]
    assert entry["recipe"] == "grid-3d+" and entry["values"]["x4"] == {"psnr": 32.0, "ssim": 0.97, "render_s": 80.0}
    assert "1x its training samples: 31.500 dB in 20.0 s; 2x" in entry["summary"]      # 31 + 0.5 * 1, 200 * 0.1
    assert entry["summary"].endswith("8x its training samples: 32.000 dB in 160.0 s")


def test_lego_800_fits_the_views_upsampled_and_records_memory_and_time(results, tmp_path, monkeypatch):
    """Part 800: every view twice as large, each pixel a 2 x 2 block, its transforms files beside them; the record
    names memory and evaluation time, and its command no temporary folder."""
    import imageio.v3 as iio

    from benchmarks import lego

    (tmp_path / "train").mkdir()
    (tmp_path / "transforms_train.json").write_text('{"camera_angle_x": 0.7, "frames": []}')
    view = np.arange(2 * 3 * 4, dtype=np.uint8).reshape(2, 3, 4)
    iio.imwrite(tmp_path / "train" / "r_0.png", view)
    (tmp_path / "big").mkdir()
    big = lego.upsampled(tmp_path, tmp_path / "big")
    out = iio.imread(big / "train" / "r_0.png")
    assert out.shape == (4, 6, 4) and (out[1, 3] == view[0, 1]).all() and (out[3, 5] == view[1, 2]).all()
    assert (big / "transforms_train.json").read_text() == '{"camera_angle_x": 0.7, "frames": []}'
    seen = []

    def fake_fit(data, budget, part=None, *flags):
        seen.append((data, budget, part, sorted(p.name for p in data.iterdir()), flags))
        return {"metrics": {"psnr": 20.0, "ssim": 0.9, "train_time": 150.1, "steps": 900, "eval_time": 110.0,
                            "render_time": 0.45, "peak_memory": 3.5, "views": 200, "background": "white",
                            "recipe": "grid-3d"},
                "size": "800 x 800", "wall": 400.0, "first": "recipe grid-3d: ...", "last": "",
                "command": " ".join(["python -m mitnerf fit --data", str(data.relative_to(lego.ROOT)), *flags,
                                     "--time-budget", budget])}

    monkeypatch.setattr(lego, "fit", fake_fit)
    assert lego.main(["--data", str(tmp_path), "--parts", "800", "800-samples128"]) == 0
    assert seen[0][1:] == ("150", "800", ["train", "transforms_train.json"], ())
    assert seen[1][1:] == ("150", "800-samples128", ["train", "transforms_train.json"], ("--set", "n_coarse=128"))
    assert not seen[0][0].exists()                                   # the temporary folder is gone
    entry = load_results()["lego800/upsampled"]
    assert "peak memory 3.50 GiB, evaluation of 200 test views 110 s (rendering 90 s)" in entry["summary"]
    assert "<lego_400 upsampled>" in entry["command"] and "tmp" not in entry["command"]
    command = load_results()["lego800/samples128"]["command"]
    assert command.startswith("python benchmarks/lego.py --parts 800-samples128") and "n_coarse=128" in command
    from benchmarks import report

    assert "lego800" not in report.lego_table(load_results())           # no PSNR row of blocky views


def test_nerfacto_scores_its_renders_with_mitnerfs_metrics_and_records_them(results, monkeypatch, tmp_path):
    """The nerfacto process faked: grey renders (0.5) of 2 of 5 white test views, so the MSE is 0.25 and the PSNR
    -10 log10(0.25) = 6.02 dB, and the SSIM is its luminance term alone, (2 * 0.5 * 1 + C1) / (0.5^2 + 1 + C1) = 0.80
    (both images flat: the contrast and structure terms are C2 / C2 = 1); the views are the ends of the split
    (test_views(5, 2) = [0, 4])."""
    import json

    import numpy as np

    import mitnerf.data.formats
    from benchmarks import nerfacto

    (tmp_path / "transforms_test.json").write_text(json.dumps({"frames": [{}] * 5}))
    split = SimpleNamespace(target=lambda bg, views: np.ones((len(views), 4, 6, 3), np.float32) * np.float32(bg))
    monkeypatch.setattr(mitnerf.data.formats, "load_dataset", lambda path: {"test": split})
    monkeypatch.setattr(nerfacto, "missing", lambda python, data: None)
    monkeypatch.setattr(nerfacto, "ROOT", tmp_path)
    asked = {}

    def fake_run(cmd):
        asked["views"] = cmd[cmd.index("--views") + 1]
        out = Path(cmd[cmd.index("--out") + 1])
        out.mkdir(parents=True)
        np.save(out / "renders.npy", np.full((2, 4, 6, 3), 0.5, np.float32))
        (out / "run.json").write_text(json.dumps({"steps": 7, "train_s": 60.5, "render_s": 3.0, "torch": "t",
                                                  "nerfstudio": "n"}))
        return [], 70.0

    monkeypatch.setattr(nerfacto, "run", fake_run)
    assert nerfacto.main(["--time-budget", "60", "--test-views", "2", "--data", str(tmp_path)]) == 0
    entry = load_results()["lego/nerfacto/60"]
    v = entry["values"]
    assert asked["views"] == "0,4"
    assert (round(v["psnr"], 2), round(v["ssim"], 2)) == (6.02, 0.80)
    assert (v["steps"], v["views"], v["size"], entry["machine"]["threads"]) == (7, 2, "6 x 4", 2)
    assert "implementation torch" in entry["settings"] and entry["command"].startswith("python benchmarks/nerfacto")
    assert "ours" not in v                                  # no mitnerf lego run under ROOT/out/lego/600
    monkeypatch.setattr(nerfacto, "ours", lambda data, views: {"psnr": 25.0, "ssim": 0.9, "run": "out/lego/600"})
    import shutil

    shutil.rmtree(tmp_path / "out" / "lego" / "nerfacto-60")
    assert nerfacto.main(["--time-budget", "60", "--test-views", "2", "--data", str(tmp_path)]) == 0
    from benchmarks import report

    table = report.lego_table(load_results())
    assert "| `lego/nerfacto/60` (nerfacto) | 6 x 4 | 2 | 6.02 | 0.800 | 60 s, 7 steps |" in table
    assert "| `out/lego/600` on the same views | 6 x 4 | 2 | 25.00 | 0.900 | | |" in table
    # --rescore trains nothing: the same renders, our newer fit
    monkeypatch.setattr(nerfacto, "run", lambda cmd: pytest.fail("--rescore trained nerfacto"))
    monkeypatch.setattr(nerfacto, "ours", lambda data, views: {"psnr": 26.0, "ssim": 0.9, "run": "out/lego/600"})
    assert nerfacto.main(["--time-budget", "60", "--test-views", "2", "--data", str(tmp_path), "--rescore"]) == 0
    entry = load_results()["lego/nerfacto/60"]
    assert round(entry["values"]["psnr"], 2) == 6.02 and entry["values"]["ours"]["psnr"] == 26.0
    assert "rescored" in entry["summary"] and entry["command"].endswith("--rescore")
    shutil.rmtree(tmp_path / "out" / "lego" / "nerfacto-60")             # nothing to rescore: one line, exit 2
    assert nerfacto.main(["--time-budget", "60", "--data", str(tmp_path), "--rescore"]) == 2


def test_nerfacto_skips_with_one_line_without_its_interpreter(results, tmp_path, capsys):
    from benchmarks import nerfacto

    (tmp_path / "transforms_test.json").write_text("{}")
    assert nerfacto.main(["--python", str(tmp_path / "none"), "--data", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("\n") == 1 and not results.exists()


def test_render_records_both_modes_per_size_and_skips_without_the_data(results, tmp_path, monkeypatch, capsys):
    """Each size's renders alternate their order over the repeats; the median seconds of each mode, their ratio, both
    PSNRs and peaks are recorded under ``render/lego``."""
    from benchmarks import render

    assert render.main(["--data", str(tmp_path / "absent")]) == 0
    assert capsys.readouterr().out.startswith("render: skipped, no Blender lego at ")
    assert load_results() == {}
    (tmp_path / "transforms_train.json").write_text("{}")
    seconds = {"fused": iter([40.0, 44.0]), "deferred": iter([31.0, 29.0])}
    order = []

    def fake_measure(run, data, mode):
        order.append(mode)
        return {"render_s": next(seconds[mode]), "psnr": 31.5, "views": 200, "peak_gib": 2.0}

    monkeypatch.setattr(render, "measure", fake_measure)
    monkeypatch.setattr(render, "field", lambda data, budget: (tmp_path, "a field"))
    assert render.main(["--data", str(tmp_path), "--sizes", "400", "--repeats", "2"]) == 0
    assert order == ["fused", "deferred", "deferred", "fused"]
    v = load_results()["render/lego"]["values"]["400"]
    assert v["fused_render_s"] == 42.0 and v["deferred_render_s"] == 30.0 and v["ratio"] == pytest.approx(1.4)
    assert "rendered in 30.0 s deferred, 42.0 s fused (1.40x)" in load_results()["render/lego"]["summary"]
