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
