"""Experiments, one module each: ``Config`` (a dataclass; ``quick=True``: a smoke run that judges nothing),
``quick(seed)`` (about a minute) and ``run(cfg, out) -> rows``, which fits, writes the CSV, draws with
:mod:`mitnerf.viz` and writes ``report.md``, its verdicts from :mod:`.claims`; those ``REPRODUCTION.md`` charts also
give ``panels(rows)``."""

from __future__ import annotations

from . import depth, pe, pixelnerf, stability, sweep, window_shop

EXPERIMENTS = {"pe": pe, "depth": depth, "pixelnerf": pixelnerf, "stability": stability,
               "window-shop": window_shop, "sweep": sweep}
