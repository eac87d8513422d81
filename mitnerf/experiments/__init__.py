"""Experiments, one module each: ``Config`` (a dataclass), ``quick(seed)`` (about a minute) and
``run(cfg, out) -> rows``, which also writes CSV files, figures and ``report.md`` into ``out``."""

from __future__ import annotations

from . import depth, pe, pixelnerf, stability, sweep, window_shop

EXPERIMENTS = {"pe": pe, "depth": depth, "pixelnerf": pixelnerf, "stability": stability,
               "window-shop": window_shop, "sweep": sweep}
