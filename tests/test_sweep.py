"""The speed/accuracy sweep: quick mode writes its files, resumes, runs on Dask; the front."""

from __future__ import annotations

import math

import pytest

from mitnerf.errors import MitnerfError
from mitnerf.experiments import sweep
from mitnerf.experiments.report import SMOKE


def quick_cfg(**kw):
    """2 rows: the tiny vanilla on square (8 views of 32 px), 15 steps, drjit and torch, 1 thread."""
    return sweep.Config(scenes=("square",), quick=True, threads=1, families=("vanilla",), **kw)


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    return out, sweep.run(quick_cfg(), out, progress=False)


def test_quick_sweep_writes_csv_report_and_chart(local_sweep):
    out, rows = local_sweep
    assert sorted(r["backend"] for r in rows) == ["drjit", "torch"]
    for r in rows:
        assert r["status"] == "ok" and r["steps"] == "15" and r["scene"] == "square"
        assert 5 < float(r["psnr"]) < 40 and float(r["wall_time"]) >= float(r["train_time"]) > 0
    # same weights, batches and jitter, one thread: the two engines land on the same PSNR
    assert abs(float(rows[0]["psnr"]) - float(rows[1]["psnr"])) < 0.05
    png = (out / "pareto.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    md = (out / "sweep.md").read_text()
    assert "![test PSNR against wall time](pareto.png)" in md and "## square" in md
    # a smoke run: it says so on top and judges nothing (not even that there is no reference to judge)
    assert md.index(SMOKE) < md.index("## square") and "Torch reference" not in md and "PASSED" not in md
    assert md.count("| vanilla | w16 | 16 |") == 2


def test_a_second_call_skips_every_finished_row(local_sweep, monkeypatch):
    out, _ = local_sweep
    before = (out / "sweep.csv").read_bytes()
    monkeypatch.setattr(sweep, "run_jobs", lambda *a, **k: iter(()) if not a[1] else (_ for _ in ()).throw(
        AssertionError("a finished row was run again")))
    assert len(sweep.run(quick_cfg(), out, progress=False)) == 2
    assert (out / "sweep.csv").read_bytes() == before


def test_dask_executor_on_a_local_cluster_gives_the_same_rows(local_sweep, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote = sweep.run(quick_cfg(executor="dask", scheduler=cluster.scheduler_address), tmp_path, progress=False)
    local = {r["id"]: r for r in local_sweep[1]}
    assert {r["id"] for r in remote} == local.keys()
    for r in remote:
        assert r["steps"] == local[r["id"]]["steps"] and r["config"] == local[r["id"]]["config"]
        assert float(r["psnr"]) == pytest.approx(float(local[r["id"]]["psnr"]), abs=1e-3)   # 1 thread


def test_a_failing_row_is_recorded_not_raised():
    row = sweep.build_rows(quick_cfg())[0]
    row["backend"] = "nope"
    rec = sweep.run_row(row)
    assert rec["status"] == "failed" and "unknown backend" in rec["reason"]


def test_a_torn_last_line_is_ignored_and_closed(tmp_path):
    path = tmp_path / "sweep.csv"
    good = {"id": "a", "status": "ok", "config": "{}", "psnr": 20}
    sweep.append_result(path, good)
    with open(path, "a") as f:
        f.write('b,square,vanilla,w16,16,drjit,15it,False,ok,,21,0.5,1,1,15,,,,,1,h,"{""sc')   # killed mid-write
    assert [r["id"] for r in sweep.read_results(path)] == ["a"]
    sweep.append_result(path, {**good, "id": "c"})
    assert [r["id"] for r in sweep.read_results(path)] == ["a", "c"]


def test_pareto_front_of_a_hand_made_table():
    t = lambda name, time, psnr, status="ok": dict(id=name, wall_time=time, psnr=psnr, status=status)
    rows = [t("B", 2, 19), t("A", 1, 20), t("D", 3, 24), t("C", 3, 25), t("E", 10, 25.005), t("F", 20, "30"),
            t("G", 0.5, 40, "failed"), t("H", 0.1, math.nan)]
    # by time: A (1 s, 20 dB) joins; B (19) is worse; at 3 s C (25) beats D (24) and joins;
    # E gains 0.005 dB < 0.01 (noise); F (30) joins. G failed and H has no PSNR: out.
    assert [r["id"] for r in sweep.pareto_front(rows)] == ["A", "C", "F"]
    assert [r["id"] for r in sweep.pareto_front(rows, min_gain=0)] == ["A", "C", "E", "F"]


def test_budgets():
    assert sweep.parse_budget("20s") == {"time_budget": 20.0} and sweep.parse_budget("500it") == {"iters": 500}
    for bad in ("twenty", "0s", "-5it"):
        with pytest.raises(MitnerfError, match="'20s'"):
            sweep.parse_budget(bad)


def test_the_default_grid_and_the_command_line(tmp_path, capsys):
    from mitnerf.cli import main

    cfg = sweep.Config(scenes=("square", "tu"), budgets=("5s", "100it"), quick=True)
    # 2 scenes x 3 families (1 size, 1 sample count each) x 2 engines x 2 budgets; no bunny: no reference
    assert len(sweep.build_rows(cfg)) == 24
    for bad, match in ((["--executor", "dask"], "--scheduler"), (["--budgets", "5min"], "'20s'"),
                       (["--workers", "0"], "must be >= 1")):
        assert main(["sweep", "--out", str(tmp_path / "s"), "--quick"] + bad) == 2
        assert match in capsys.readouterr().err
    assert not (tmp_path / "s").exists()
