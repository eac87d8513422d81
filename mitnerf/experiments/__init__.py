"""Experiments: each module exposes ``run(out, quick=False, seed=0) -> Path`` that writes
CSV files, PNG figures and a markdown report (``report.md``) embedding them into
``out``, and returns the report's path. ``--quick`` runs must finish in ~2 minutes.

``EXPERIMENTS`` maps the command-line name to the module path (imported lazily).
"""

from __future__ import annotations

import importlib

EXPERIMENTS = {
    "pe": "mitnerf.experiments.positional_encoding",
    "depth": "mitnerf.experiments.depth_supervision",
    "pixelnerf": "mitnerf.experiments.pixelnerf",
    "stability": "mitnerf.experiments.stability",
    "window-shop": "mitnerf.experiments.window_shop",
}


def get_experiment(name: str):
    from ..errors import MitnerfError

    if name not in EXPERIMENTS:
        raise MitnerfError(f"unknown experiment {name!r}; choose one of {', '.join(EXPERIMENTS)}")
    return importlib.import_module(EXPERIMENTS[name])
