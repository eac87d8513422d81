"""Shared fixtures: small datasets rendered once per test session (llvm_ad_rgb), small recipes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MITNERF_CACHE", str(Path(__file__).resolve().parents[1] / ".cache" / "mitnerf"))
os.environ.setdefault("MITNERF_RESULTS", str(Path(__file__).resolve().parents[1] / ".cache" / "results-tests.json"))

import drjit as dr  # noqa: E402

import mitnerf  # noqa: E402

mitnerf.set_variant()
dr.set_thread_count(2)
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def bunny_small():
    """A noisy 2D bunny dataset: 12 train, 4 val, 8 test views of 100 px."""
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig, noise_preset
    from mitnerf.scenes.registry import get_scene

    return make_dataset(get_scene("bunny"), RigConfig(dim=2, n_train=12, n_val=4, n_test=8, seed=3,
                                                      **noise_preset(1.0)), progress=False)


@pytest.fixture(scope="session")
def vase_small():
    """A 3D vase dataset: 6 train, 1 val, 4 test views of 24x24."""
    from mitnerf.data.generate import make_dataset
    from mitnerf.data.rig import RigConfig, noise_preset
    from mitnerf.scenes.registry import get_scene

    return make_dataset(get_scene("vase"), RigConfig(dim=3, n_train=6, n_val=1, n_test=4, resolution=24, seed=3,
                                                     **noise_preset(1.0)), progress=False)


@pytest.fixture
def results(tmp_path, monkeypatch):
    """A fresh ``results.json`` for a benchmark script's bookkeeping (``MITNERF_RESULTS``)."""
    path = tmp_path / "results.json"
    monkeypatch.setenv("MITNERF_RESULTS", str(path))
    return path


def small(name: str = "vanilla-2d", **overrides):
    """A recipe shrunk for tests: short, quiet, small."""
    from mitnerf.train.recipes import get_recipe

    sizes = {"vanilla": dict(width=16, depth=3, pos_L=6, dir_L=3), "grid": dict(resolution=33, initial_resolution=17,
                                                                               upsample_at=(10,)),
             "hashgrid": dict(n_levels=4, log2_hashmap_size=10, hidden=8, geo_features=3, base_resolution=4,
                              max_resolution=64),
             "hashlinear": dict(resolutions=(9, 17, 33), log2_hashmap_size=8, initial_levels=2, add_level_at=(10,))}
    r = get_recipe(name)
    args = dict(sizes[r.model.field], n_coarse=32, batch_rays=256, val_every=0, progress=False, iters=30)
    r = r.override(**{**args, **overrides})
    return r if "time_budget" in overrides else r.at_steps(r.train.iters)


# Hypothesis profiles (tests/fuzz/): HYPOTHESIS_PROFILE=ci (the default: derandomized, a fixed number of
# examples, the whole file well under a minute on 2 cores) or local (many more examples, random).
try:
    from hypothesis import HealthCheck, settings

    settings.register_profile("ci", derandomize=True, max_examples=60, deadline=None, print_blob=True,
                              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                                     HealthCheck.data_too_large])
    settings.register_profile("local", max_examples=1000, deadline=None, print_blob=True,
                              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                                     HealthCheck.data_too_large])
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
except ImportError:  # hypothesis is a test extra; only tests/fuzz/ needs it
    pass


def pytest_terminal_summary(terminalreporter, config):
    """Lines a test module left in ``config.mitnerf_summary`` (the fuzz suite's case counts)."""
    for line in getattr(config, "mitnerf_summary", []):
        terminalreporter.write_line(line)
