"""Each experiment's quick mode writes its CSV, figures and report."""

import pytest

from mitnerf.experiments import get_experiment

FILES = {
    "pe": ["pe.csv", "pe_psnr.png", "pe_density.png", "pe_views.png"],
    "depth": ["depth.csv", "depth_square_concave.png", "depth_summary.png"],
    "stability": ["stability.csv", "stability.png"],
}


@pytest.mark.parametrize("name", list(FILES))
def test_quick_mode_writes_its_files(name, tmp_path):
    report = get_experiment(name).run(tmp_path, quick=True)
    assert report == tmp_path / "report.md"
    text = report.read_text()
    for f in FILES[name]:
        path = tmp_path / f
        assert path.exists() and path.stat().st_size > 200, f
        if f.endswith(".png"):
            assert f"({f})" in text, f"{f} is not embedded in the report"
    assert "| " in text                      # a markdown table
    rows = (tmp_path / FILES[name][0]).read_text().splitlines()
    assert len(rows) >= 3 and "status" in rows[0]
