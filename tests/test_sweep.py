"""The speed/accuracy sweep: quick mode writes its files, resumes, runs on Dask; the front."""

from __future__ import annotations

import math

import pytest

from mitnerf.experiments import sweep_exec
from mitnerf.experiments.pareto import pareto_front, reference_verdict
from mitnerf.experiments.sweep import SweepConfig, build_rows, default_specs, parse_budget, run_sweep


def quick_cfg(out, **kw):
    """2 rows: the tiny vanilla on square (8 views of 32 px), 15 steps, drjit and torch, 1 thread."""
    vanilla = [s for s in default_specs(quick=True) if s.family == "vanilla"]
    return SweepConfig(out=out, quick=True, scenes=["square"], workers=1, threads=1, progress=False,
                       configs=vanilla, **kw)


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    return run_sweep(quick_cfg(out))


def test_quick_sweep_writes_csv_report_and_chart(local_sweep):
    rows = sweep_exec.read_results(local_sweep.csv)
    assert (local_sweep.ran, local_sweep.skipped, local_sweep.failed) == (2, 0, 0)
    assert sorted(r["backend"] for r in rows) == ["drjit", "torch"]
    for r in rows:
        assert r["status"] == "ok" and r["steps"] == "15" and r["scene"] == "square"
        assert 5 < float(r["psnr"]) < 40 and float(r["wall_time"]) >= float(r["train_time"]) > 0
    # same weights, batches and jitter, one thread: the two backends land on the same PSNR
    assert abs(float(rows[0]["psnr"]) - float(rows[1]["psnr"])) < 0.05
    png = local_sweep.chart.read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    md = local_sweep.report.read_text()
    assert "![test PSNR against wall time](pareto.png)" in md and "## square" in md
    assert md.count("| vanilla | w16 | 16 |") == 2 and "Pareto front" in md


def test_a_second_call_skips_every_finished_row(local_sweep, monkeypatch):
    before = local_sweep.csv.read_bytes()

    def no_fits(*a, **k):
        raise AssertionError("a finished row was run again")

    monkeypatch.setattr(sweep_exec, "execute", no_fits)
    again = run_sweep(quick_cfg(local_sweep.csv.parent))
    assert (again.ran, again.skipped) == (0, 2)
    assert local_sweep.csv.read_bytes() == before


def test_dask_executor_on_a_local_cluster_gives_the_same_rows(local_sweep, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        res = run_sweep(quick_cfg(tmp_path, executor="dask", scheduler=cluster.scheduler_address))
    assert (res.ran, res.failed) == (2, 0)
    local = {r["id"]: r for r in sweep_exec.read_results(local_sweep.csv)}
    remote = {r["id"]: r for r in sweep_exec.read_results(res.csv)}
    assert remote.keys() == local.keys()
    for k, r in remote.items():
        assert r["steps"] == local[k]["steps"] and r["config"] == local[k]["config"]
        assert float(r["psnr"]) == pytest.approx(float(local[k]["psnr"]), abs=1e-3)   # 1 thread: deterministic


def test_a_failing_row_is_recorded_not_raised():
    row = build_rows(quick_cfg("unused"))[0]
    row["backend"] = "nope"
    rec = sweep_exec.run_row(row)
    assert rec["status"] == "failed" and "unknown backend" in rec["error"]


def test_a_torn_last_line_is_ignored_and_closed(tmp_path):
    path = tmp_path / "sweep.csv"
    good = {"id": "a", "status": "ok", "config": "{}", "psnr": 20}
    sweep_exec.append_result(path, good)
    with open(path, "a") as f:
        f.write('b,square,vanilla,w16,16,drjit,15it,False,ok,21,0.5,1,1,15,,,,,1,h,,"{""sc')   # killed mid-write
    assert [r["id"] for r in sweep_exec.read_results(path)] == ["a"]
    sweep_exec.append_result(path, {**good, "id": "c"})
    assert [r["id"] for r in sweep_exec.read_results(path)] == ["a", "c"]


def test_pareto_front_of_a_hand_made_table():
    t = lambda name, time, psnr, status="ok": dict(id=name, wall_time=time, psnr=psnr, status=status)
    rows = [t("B", 2, 19), t("A", 1, 20), t("D", 3, 24), t("C", 3, 25), t("E", 10, 25.005), t("F", 20, "30"),
            t("G", 0.5, 40, "failed"), t("H", 0.1, math.nan)]
    # by time: A (1 s, 20 dB) joins; B (19) is worse; at 3 s C (25) beats D (24) and joins;
    # E gains 0.005 dB < 0.01 (noise); F (30) joins. G failed and H has no PSNR: out.
    assert [r["id"] for r in pareto_front(rows)] == ["A", "C", "F"]
    assert [r["id"] for r in pareto_front(rows, min_gain=0)] == ["A", "C", "E", "F"]


def test_reference_verdict_and_budgets():
    base = dict(scene="bunny", family="vanilla", size="w32", samples=32, backend="drjit", status="ok")
    ref = dict(base, id="R", reference="True", backend="torch", budget="600s", wall_time=600.0, psnr=30.0)
    fast = dict(base, id="a", reference="False", budget="2s", wall_time=5.0, psnr=30.5)   # 120x faster
    slow = dict(base, id="b", reference="False", budget="20s", wall_time=25.0, psnr=31.0)
    v = reference_verdict([ref, slow, fast])
    assert v["passed"] and v["fastest_reaching"]["id"] == "a" and v["speedup"] == pytest.approx(120)
    v = reference_verdict([ref, dict(fast, wall_time=7.0)])      # 7 s > 600 s / 100
    assert not v["passed"] and v["best_within"] is None
    assert reference_verdict([fast]) is None
    assert parse_budget("20s") == {"iters": 10 ** 7, "time_budget": 20.0}
    assert parse_budget("500it") == {"iters": 500, "time_budget": None}
    with pytest.raises(ValueError, match="'20s'"):
        parse_budget("twenty")


def test_command_line_options_become_a_config(tmp_path):
    import argparse

    from mitnerf.cli import sweep_cmd
    from mitnerf.errors import MitnerfError

    parser = argparse.ArgumentParser()
    sweep_cmd.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sweep", "--out", str(tmp_path), "--quick", "--workers", "2", "--threads", "1",
                              "--scenes", "square", "tu", "--budgets", "5s", "100it"])
    cfg = sweep_cmd.config_from_args(args)
    assert (cfg.workers, cfg.threads, cfg.scenes, cfg.budgets, cfg.quick) == (2, 1, ["square", "tu"],
                                                                              ["5s", "100it"], True)
    # 2 scenes x 3 families (1 size, 1 sample count each) x 2 backends x 2 budgets; no bunny, so no
    # reference row
    assert len(build_rows(cfg)) == 24
    for bad, match in ((["--executor", "dask"], "--scheduler"), (["--budgets", "5min"], "'20s'"),
                       (["--workers", "0"], "at least 1")):
        with pytest.raises(MitnerfError, match=match):
            sweep_cmd.config_from_args(parser.parse_args(["sweep", "--out", str(tmp_path)] + bad))
