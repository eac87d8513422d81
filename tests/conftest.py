"""Shared fixtures: small datasets rendered once per test session (llvm_ad_rgb)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MITNERF_CACHE", str(Path(__file__).resolve().parents[1] / ".cache" / "mitnerf"))

import drjit as dr  # noqa: E402

import mitnerf  # noqa: E402,F401

dr.set_thread_count(2)


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
