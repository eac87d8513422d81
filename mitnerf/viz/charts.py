"""Charts of result tables (rows as dicts): series against a setting, side by side."""

from __future__ import annotations

import math
from pathlib import Path

from .panels import pyplot, save


def num(v) -> float:
    """``v`` as a float; NaN where it is none (an empty CSV cell, text)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def series(ax, rows: list[dict], x: str, y: str = "psnr", by: tuple = (), styles: dict | None = None,
           err: bool = True) -> None:
    """One line per value of the ``by`` columns: ``y`` against ``x`` (error bars: the ``<y>_std`` column of a
    summary), a row's ``label`` written beside its point; ``styles`` maps the last ``by`` value to a format."""
    groups: dict = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    for key, rs in groups.items():
        rs = sorted(rs, key=lambda r: num(r[x]))
        xs, ys = [num(r[x]) for r in rs], [num(r[y]) for r in rs]
        ax.errorbar(xs, ys, yerr=[num(r.get(f"{y}_std")) for r in rs] if err else None, capsize=2,
                    fmt=(styles or {}).get(key[-1] if key else None, "o-"), label=", ".join(map(str, key)) or None)
        for r, xy in zip(rs, zip(xs, ys)):
            if "label" in r:
                ax.annotate(r["label"], xy, fontsize=7, xytext=(3, 2), textcoords="offset points")


def series_figure(path: Path, panels: list[dict], title: str = "", cell=(4.5, 3.4), columns: int = 0) -> Path:
    """Charts side by side (``columns`` to a row; 0: all), each ``dict(title=, xlabel=, ylabel= (test PSNR), xscale=,
    yscale=, xticks=, xticklabels=, **`` :func:`series` ``arguments)``."""
    m = columns or len(panels)
    n = math.ceil(len(panels) / m)
    fig, axes = pyplot().subplots(n, m, figsize=(cell[0] * m, cell[1] * n), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    for ax, p in zip(axes.flat, panels):
        p = {"ylabel": "test PSNR [dB]", **p}
        ax.set(**{k: p.pop(k) for k in ("title", "xlabel", "ylabel", "xscale", "yscale", "xticks", "xticklabels")
                  if k in p})
        series(ax, **p)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=7)
    fig.suptitle(title)
    return save(fig, path)
