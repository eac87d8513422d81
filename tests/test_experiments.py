"""Each experiment's quick mode writes its CSV, figures and report; the CLI refuses bad settings."""

import pytest

from mitnerf.cli import main
from mitnerf.experiments import EXPERIMENTS
from mitnerf.experiments.report import SMOKE, read_csv, summarise

JUDGED = ("reproduced", "partly", "passed", "claim", "rise", "failure modes", "finding")
"""Words of the judged sections (the claims' verdicts, the stability findings, the sweep's goal)."""

FILES = {
    "pe": ["pe.csv", "pe_psnr.png", "pe_density.png", "pe_views.png"],
    "depth": ["depth.csv", "depth_square_concave.png", "depth_summary.png"],
    "stability": ["stability.csv", "stability.png"],
    "window-shop": ["results.csv", "psnr_vs_views.png", "thumbnails.png"],
}


@pytest.mark.parametrize("name", list(FILES))
def test_quick_mode_writes_its_files(name, tmp_path):
    assert main(["experiment", name, "--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "report.md").read_text()
    for f in FILES[name]:
        path = tmp_path / f
        assert path.exists() and path.stat().st_size > 200, f
        if f.endswith(".png"):
            assert f"({f})" in text, f"{f} is not embedded in the report"
    assert "| " in text                      # a markdown table
    # a smoke run says so on top and judges nothing: no claim, verdict or finding
    assert text.index(SMOKE) < text.index("| ")
    assert not [w for w in JUDGED if w in text.lower()], text
    rows = read_csv(tmp_path / FILES[name][0])
    assert len(rows) >= 2 and all(r["status"] in ("ok", "collapsed", "nan") for r in rows)


def test_bad_experiment_settings_are_one_line(tmp_path, capsys):
    assert main(["experiment", "pe", "--quick", "--set", "nope=1", "--out", str(tmp_path / "x")]) == 2
    assert "has no setting 'nope'" in capsys.readouterr().err and not (tmp_path / "x").exists()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    assert main(["experiment", "pe", "--quick", "--out", str(tmp_path / "mine")]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (tmp_path / "mine" / "notes.txt").read_text() == "mine"


def test_every_experiment_has_a_config_a_quick_version_and_run():
    for module in EXPERIMENTS.values():
        assert module.quick(3).seed == 3 and hasattr(module.Config(), "seed") and callable(module.run)


def test_summarise_gives_mean_and_spread_over_seeds():
    rows = [dict(L=0, status="ok", psnr=20.0), dict(L=0, status="ok", psnr=22.0), dict(L=0, status="nan", psnr=9),
            dict(L=2, status="ok", psnr=30.0)]
    s = {r["L"]: r for r in summarise(rows, ["L"], ("psnr",))}
    assert (s[0]["runs"], s[0]["failed"], s[0]["psnr"], s[0]["psnr_std"]) == (3, 1, 21.0, 1.0)
    assert (s[2]["psnr"], s[2]["psnr_std"], s[2]["psnr_min"]) == (30.0, 0.0, 30.0)


def test_window_shop_on_the_reports_own_data(tmp_path):
    """``--set data=FILE.npz``: a tiny-NeRF file's first 100 views are the pool; each row is scored on view 101
    (the report's protocol) and on every held-out view (ours); a file without that layout is refused."""
    import numpy as np

    from mitnerf.data.formats import save_dataset
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.errors import DataError
    from mitnerf.experiments import window_shop
    from mitnerf.scenes.registry import get_scene
    from mitnerf.train.recipes import get_recipe

    ds = make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=100, n_val=2, n_test=4, resolution=8), progress=False)
    npz = save_dataset(ds, tmp_path / "lego.npz", "tiny_nerf")
    cfg = window_shop.quick()
    cfg.data, cfg.additions, cfg.few_views, cfg.pe_window = str(npz), False, 5, 20
    args = [window_shop.nerf_recipe(cfg, n, 6, 64, True, steps=k).model.field_args for n, k in ((5, 2), (25, 1))]
    assert args[0]["pe_window"] == 40 and "pe_window" not in args[1]       # the few-view rows' window, per step
    flat, decays = (window_shop.nerf_recipe(cfg, 5, 6, 64, True, lr_decay=d).train for d in (False, True))
    assert flat.lr_final == flat.lr == decays.lr                             # constant: the report's schedule
    assert decays.lr_final == get_recipe("vanilla-3d").train.lr_final < flat.lr
    rows = window_shop.run(cfg, tmp_path / "out")
    assert [r["row"] for r in rows] == ["7", "8"]
    assert all(np.isfinite(r["psnr_ours"]) and np.isfinite(r["psnr_pool"]) for r in rows)    # the validation too
    report = (tmp_path / "out" / "report.md").read_text()
    assert "view 101" in report and "frequencies over the first 20 steps" in report
    few = type(ds)({"train": ds["train"].subset(slice(0, 20)), "val": ds["val"], "test": ds["test"]}, ds.near, ds.far)
    small = save_dataset(few, tmp_path / "small.npz", "tiny_nerf")
    cfg.data = str(small)
    with pytest.raises(DataError, match="needs 100 training views"):
        window_shop.run(cfg, tmp_path / "out2")


def test_window_shop_additions_count_the_views_a_file_has(tmp_path, monkeypatch):
    """A file's pool is its first 100 views: the additions' "200 images" rows train on 100 and say so, and every
    5-image row of the report's table but not the 25-image fine pass gets the frequency window (few_views 5)."""
    from types import SimpleNamespace

    from mitnerf.data.formats import save_dataset
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.experiments import window_shop
    from mitnerf.scenes.registry import get_scene

    ds = make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=100, n_val=2, n_test=4, resolution=4), progress=False)
    seen, cameras, flat, scored = [], {}, {}, {}

    def fake_row(data, recipe, labels, **_):             # no training: what each row would train on
        seen.append((labels["row"], len(data["train"]), recipe.model.field_args.get("pe_window", 0)))
        cameras[labels["row"]] = data["train"].cameras.origins
        if recipe.name.startswith("vanilla-3d"):          # the report's NeRF (the grid rows keep their recipes')
            flat[labels["row"]] = recipe.train.lr_final == recipe.train.lr
        assert labels["images"] == len(data["train"]) and isinstance(labels["images"], int)
        rec = SimpleNamespace(psnr=20.0, ssim=0.5, renders=None)

        def record(test, **_):
            scored.setdefault(labels["row"], []).append(test["test"].cameras.origins)
            return rec
        return {**labels, "psnr": 20.0}, SimpleNamespace(record=record), rec

    monkeypatch.setattr(window_shop, "train_row", fake_row)
    monkeypatch.setattr(window_shop, "_draw", lambda *a: None)
    cfg = window_shop.quick()
    cfg.data, cfg.combinations, cfg.addition_views, cfg.few_views = str(save_dataset(
        ds, tmp_path / "lego.npz", "tiny_nerf")), (7, 4), (5, 200), 5
    window_shop.run(cfg, tmp_path / "out")
    rows = {label: (n, window) for label, n, window in seen}
    assert rows["grid-3d recipe, 100 images"][0] == 100 and not any("200" in label for label in rows)
    assert rows["7"][1] == cfg.pe_window and rows["4"][1] == 0 and rows["fine pass, 25 images"][1] == 0
    assert rows["7, no frequency window"][1] == 0 and rows["fine pass, 5 images"][1] == cfg.pe_window
    assert rows[window_shop.NEAREST] == (5, cfg.pe_window)            # row 7 on the 5 photos nearest view 101
    (_, (pool, tests)), = window_shop.sources(cfg).items()
    near = window_shop.nearest_views(pool["train"].cameras.origins, tests["report"].cameras.origins[0], 5)
    assert cameras[window_shop.NEAREST].tolist() == pool["train"].cameras.origins[near].tolist()
    assert cameras[window_shop.NEAREST].tolist() != cameras["7"].tolist()            # not the first 5
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| held-out PSNR |" in report and "trains on the 5 seen from closest to view 101" in report
    # a constant rate in every NeRF row but the additions' one that decays; the validation on 12 unused photos
    assert [label for label, f in flat.items() if not f] == ["6, decaying learning rate"]
    assert "| unused pool PSNR |" in report and "a constant learning rate" in report
    unused = window_shop.unused_views(100, range(5), 12)                     # row 7 trains on the first 5
    assert scored["7"][-1].tolist() == pool["train"].cameras.origins[unused].tolist()
    assert len(scored["grid-3d recipe, 100 images"]) == 1              # held-out views only: no photo is unused


def test_unused_views_spread_evenly_over_the_photos_a_row_leaves():
    """By hand: of 10 photos, a row trains on 0, 1, 2; the rest are 3..9."""
    from mitnerf.experiments import window_shop

    assert window_shop.unused_views(10, [0, 1, 2], 3).tolist() == [3, 6, 9]          # first, middle, last of 3..9
    assert window_shop.unused_views(10, [0, 5], 20).tolist() == [1, 2, 3, 4, 6, 7, 8, 9]    # fewer left: all
    assert window_shop.unused_views(4, range(4), 3).tolist() == [] and window_shop.unused_views(9, [], 0).size == 0


def test_nearest_views_are_the_cameras_closest_in_direction_to_the_target():
    """By hand: the pool's directions at 0, 90, 6.3 and 180 deg in the plane; the target at 11.3 deg."""
    from mitnerf.experiments import window_shop

    pool = [[1, 0, 0], [0, 1, 0], [0.9, 0.1, 0], [-1, 0, 0]]
    # 6.3 deg camera 5.0 deg away, then 0 deg (11.3), 90 deg (78.7), 180 deg (168.7); the distance does not count
    assert window_shop.nearest_views(pool, [1, 0.2, 0], 4).tolist() == [2, 0, 1, 3]
    assert window_shop.nearest_views(pool, [10, 2, 0], 2).tolist() == [2, 0]
    assert window_shop.nearest_views(pool, [0, 0, 1], 4).tolist() == [0, 1, 2, 3]      # all at 90 deg: ties in order
    assert window_shop.nearest_views(pool, [1, 0, 0], 0).tolist() == []


def test_spread_views_takes_the_first_camera_then_the_farthest_from_those_taken():
    """Farthest-point sampling of camera directions, worked by hand; ``pick=spread`` trains on those views and keeps
    its own record in the results file."""
    import numpy as np

    from mitnerf.experiments import window_shop
    from mitnerf.experiments.reproduction import record_suffix

    # the docstring's: [1,0,0] first; [-1,0,0] opposite it (180 deg); then [0,1,0] (90 deg to both) over
    # [0.9,0.1,0] (6 deg from the first)
    assert window_shop.spread_views([[1, 0, 0], [0.9, 0.1, 0], [-1, 0, 0], [0, 1, 0]], 3).tolist() == [0, 2, 3]
    a = np.radians(45 * np.arange(8))                     # a ring, 45 deg apart, at 3 units
    ring = 3 * np.c_[np.cos(a), np.sin(a), np.zeros(8)]
    # 0; 4 (180 deg); 2 and 6 are 90 deg from both, 2 the lower index; then 6 (90 deg), the rest are 45 deg away
    assert window_shop.spread_views(ring, 4).tolist() == [0, 4, 2, 6]
    assert window_shop.spread_views(ring, 20).tolist()[:2] == [0, 4] and len(window_shop.spread_views(ring, 20)) == 8
    assert window_shop.spread_views(ring, 0).tolist() == [] and window_shop.spread_views(ring, 1).tolist() == [0]
    cfg = window_shop.quick()
    assert record_suffix(cfg) == ""
    cfg.pick, cfg.data = "spread", "../shared/data/tiny_nerf/tiny_lego_100.npz"
    assert record_suffix(cfg) == "/tiny_lego_100-spread"
    cfg.data = None
    assert record_suffix(cfg) == "/spread"


def test_window_shop_trains_on_the_views_it_picks(tmp_path, monkeypatch):
    """``pick=first`` trains a 5-image row on the pool's first 5 photos; ``pick=spread`` on the 5 of
    :func:`spread_views`, and its report says which."""
    from types import SimpleNamespace

    import numpy as np

    from mitnerf.data.formats import save_dataset
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig
    from mitnerf.experiments import window_shop
    from mitnerf.scenes.registry import get_scene

    ds = make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=100, n_val=2, n_test=4, resolution=4), progress=False)
    seen = []

    def fake_row(data, recipe, labels, **_):             # no training: the cameras each row would train on
        seen.append(data["train"].cameras.origins)
        rec = SimpleNamespace(psnr=20.0, ssim=0.5, renders=None)
        return {**labels, "psnr": 20.0}, SimpleNamespace(record=lambda *a, **k: rec), rec

    monkeypatch.setattr(window_shop, "train_row", fake_row)
    monkeypatch.setattr(window_shop, "_draw", lambda *a: None)
    cfg = window_shop.quick()
    cfg.data, cfg.combinations, cfg.additions = str(save_dataset(ds, tmp_path / "lego.npz", "tiny_nerf")), (7,), False
    pool = window_shop.load_dataset(cfg.data)["train"].cameras.origins
    for pick, expected in (("first", np.arange(5)), ("spread", window_shop.spread_views(pool[:100], 5))):
        cfg.pick = pick
        window_shop.run(cfg, tmp_path / pick)
        np.testing.assert_array_equal(seen[-1], pool[expected])
        assert window_shop.PICKED[pick] in (tmp_path / pick / "report.md").read_text()
    assert not np.array_equal(seen[0], seen[1])
