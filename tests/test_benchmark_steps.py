"""The step benchmarks' bookkeeping (``benchmarks/records.py``, ``benchmarks/scatter.py``): the order of their
measurements and what they record, with the measurements faked."""

import pytest

from mitnerf.results import load_results


def test_records_alternates_packets_and_floats_per_case_and_skips_without_the_data(results, tmp_path, monkeypatch,
                                                                                    capsys):
    """Each case's training steps alternate their order over the repeats; the medians, their ratio and the peaks
    are recorded under ``records/lego``, each case's settings passed with ``color_packets`` on and off."""
    from benchmarks import records

    assert records.main(["--data", str(tmp_path / "absent")]) == 0
    assert capsys.readouterr().out.startswith("records: no lego at ")
    assert load_results() == {}
    (tmp_path / "transforms_train.json").write_text("{}")
    rates = {True: iter([4.0, 4.4, 3.0, 3.2]), False: iter([3.6, 3.8, 2.0, 2.2])}
    calls = []

    def fake_measure(data, adam, settings):
        calls.append((adam, settings))
        return {"steps_per_s": next(rates[settings["color_packets"]]), "params": 54_000_000,
                "peak_gib": 2.5 if settings["color_packets"] else 2.4}

    monkeypatch.setattr(records, "measure", fake_measure)
    assert records.main(["--data", str(tmp_path), "--repeats", "2"]) == 0
    assert [s["color_packets"] for _, s in calls] == [True, False, False, True] * 2
    assert {a for a, _ in calls} == {"lean"} and calls[4][1] == {"sh_degree": 2, "color_packets": True}
    v = load_results()["records/lego"]["values"]
    assert v["degree 1"]["packets_steps_per_s"] == pytest.approx(4.2)
    assert v["degree 1"]["floats_steps_per_s"] == pytest.approx(3.7)
    assert v["degree 2"]["step_ratio"] == pytest.approx(3.1 / 2.1)
    assert "in packets 4.20 steps/s, peak 2.50 GiB; float by float 3.70 steps/s" in \
        load_results()["records/lego"]["summary"]


def test_scatter_alternates_copies_and_atomic_adds_and_skips_without_the_data(results, tmp_path, monkeypatch, capsys):
    """The two modes alternate their order over the repeats, each with Adam's launch and its ``EXPAND_BYTES`` (None:
    the engine's own; 0: Dr.Jit's threshold); the lattice's case runs ``--repeats`` rounds, the hash grid's twice as
    many; the medians, their ratio and the added peak go to ``scatter/lego`` and ``scatter/lego_hashgrid``."""
    from benchmarks import scatter

    assert scatter.main(["--data", str(tmp_path / "absent")]) == 0
    assert capsys.readouterr().out.startswith("scatter: no lego at ")
    assert load_results() == {}
    (tmp_path / "transforms_train.json").write_text("{}")
    rates = {(False, None): iter([4.6, 4.8]), (False, 0): iter([3.8, 3.6]),
             (True, None): iter([8.0, 9.0, 7.0, 8.2]), (True, 0): iter([8.4, 7.2, 8.6, 7.6])}
    calls = []

    def fake_measure(data, adam, settings, expand_bytes):
        calls.append((adam, settings, expand_bytes))
        hashgrid = settings.get("recipe") == "hashgrid-3d"
        return {"steps_per_s": next(rates[hashgrid, expand_bytes]), "params": 1_270_000 if hashgrid else 54_500_000,
                "peak_gib": (0.90 if hashgrid else 2.85) if expand_bytes is None else (0.88 if hashgrid else 2.75)}

    monkeypatch.setattr(scatter, "measure", fake_measure)
    assert scatter.main(["--data", str(tmp_path), "--repeats", "2"]) == 0
    hg = {"recipe": "hashgrid-3d", "timed": [100, 500]}
    two_rounds = [(None, 0), (0, None)]                # copies first, then atomic first
    assert calls == [("fused", s, e) for s, n in (({}, 1), (hg, 2)) for _ in range(n) for r in two_rounds for e in r]
    v = load_results()["scatter/lego"]["values"]
    assert v["copies_steps_per_s"] == pytest.approx(4.7) and v["atomic_steps_per_s"] == pytest.approx(3.7)
    assert v["step_ratio"] == pytest.approx(4.7 / 3.7) and v["peak_added_gib"] == pytest.approx(0.1)
    assert v["repeats"] == 2
    assert "whole lattice (54.5 M parameters), training steps: gradients in a copy per thread 4.70 steps/s, peak " \
        "2.85 GiB; atomic adds 3.70 steps/s" in load_results()["scatter/lego"]["summary"]
    h = load_results()["scatter/lego_hashgrid"]["values"]
    # medians of 4: copies (8.0 + 8.2) / 2 = 8.1, atomic (7.6 + 8.4) / 2 = 8.0
    assert h["copies_steps_per_s"] == pytest.approx(8.1) and h["atomic_steps_per_s"] == pytest.approx(8.0)
    assert h["repeats"] == 4 and h["peak_added_gib"] == pytest.approx(0.02) and h["params"] == 1_270_000
    assert "hashgrid-3d (1.3 M parameters)" in load_results()["scatter/lego_hashgrid"]["summary"]
