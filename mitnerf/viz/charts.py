"""Charts of result tables (rows as dicts): series against a setting, seeds and failures, the speed-against-accuracy
plane."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .panels import pyplot, save

MARKERS = ("o", "s", "^", "D", "v", "P", "X")
COLOURS = {"drjit": "tab:blue", "torch": "tab:orange"}


def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def plot_pareto(rows: list[dict], path: Path, front_of, is_reference) -> Path:
    """Test PSNR against wall time (log), one panel per scene, one marker per field family, one
    colour per backend; ``front_of(rows)`` is drawn as a step line."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    ok = [r for r in rows if r.get("status") == "ok" and math.isfinite(_num(r.get("psnr")))
          and math.isfinite(_num(r.get("wall_time")))]
    scenes = list(dict.fromkeys(r["scene"] for r in rows)) or ["(no runs)"]
    families = list(dict.fromkeys(r["family"] for r in rows))
    marker = {f: MARKERS[i % len(MARKERS)] for i, f in enumerate(families)}
    ncols = min(2, len(scenes))
    nrows = math.ceil(len(scenes) / ncols)
    fig, axes = pyplot().subplots(nrows, ncols, figsize=(6.0 * ncols, 4.2 * nrows), squeeze=False)
    for ax, scene in zip(axes.flat, scenes):
        pts = [r for r in ok if r["scene"] == scene]
        for r in pts:
            ref, xy = is_reference(r), (_num(r["wall_time"]), _num(r["psnr"]))
            ax.scatter(*xy, marker=marker[r["family"]], s=90 if ref else 36, color=COLOURS.get(r["backend"], "grey"),
                       edgecolors="black" if ref else "none", alpha=0.85)
            if ref:
                ax.annotate("torch reference", xy, fontsize=8, xytext=(-6, 6), textcoords="offset points", ha="right")
        if front := front_of(pts):
            xs, ys = [_num(r["wall_time"]) for r in front], [_num(r["psnr"]) for r in front]
            ax.step(xs + [max(_num(r["wall_time"]) for r in pts) * 1.2], ys + [ys[-1]], where="post", color="black",
                    lw=1, ls="--")
            ax.set_xscale("log")
        ax.set(title=scene, xlabel="wall time of fit (s)", ylabel="test PSNR (dB)")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    handles = [Line2D([], [], ls="", marker=marker[f], color="grey", label=f) for f in families]
    handles += [Patch(color=c, label=b) for b, c in COLOURS.items()]
    handles += [Line2D([], [], ls="--", color="black", label="Pareto front")]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 4), frameon=False, fontsize=9)
    return save(fig, path, rect=(0, 0.08 * math.ceil(len(handles) / 4) / nrows, 1, 1))


def series(ax, rows: list[dict], x: str, y: str = "psnr", by: tuple = (), styles: dict | None = None,
           err: bool = True) -> None:
    """One line per value of the ``by`` columns: ``y`` against ``x`` (error bars: the ``<y>_std`` column of a
    summary), a row's ``label`` written beside its point; ``styles`` maps the last ``by`` value to a format."""
    groups: dict = {}
    for r in rows:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    for key, rs in groups.items():
        rs = sorted(rs, key=lambda r: _num(r[x]))
        xs, ys = [_num(r[x]) for r in rs], [_num(r[y]) for r in rs]
        ax.errorbar(xs, ys, yerr=[_num(r.get(f"{y}_std")) for r in rs] if err else None, capsize=2,
                    fmt=(styles or {}).get(key[-1] if key else None, "o-"), label=", ".join(map(str, key)) or None)
        for r, xy in zip(rs, zip(xs, ys)):
            if "label" in r:
                ax.annotate(r["label"], xy, fontsize=7, xytext=(3, 2), textcoords="offset points")


def series_figure(path: Path, panels: list[dict], title: str = "", cell=(4.5, 3.4)) -> Path:
    """Charts side by side, each ``dict(title=, xlabel=, ylabel= (test PSNR), xscale=, yscale=, xticks=, **``
    :func:`series` ``arguments)``."""
    fig, axes = pyplot().subplots(1, len(panels), figsize=(cell[0] * len(panels), cell[1]), squeeze=False)
    for ax, p in zip(axes[0], panels):
        p = {"ylabel": "test PSNR [dB]", **p}
        ax.set(**{k: p.pop(k) for k in ("title", "xlabel", "ylabel", "xscale", "yscale", "xticks") if k in p})
        series(ax, **p)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=7)
    fig.suptitle(title)
    return save(fig, path)


def plot_seeds(rows: list[dict], methods: list[str], path: Path, title: str = "") -> Path:
    """Every run's test PSNR per method (a red x at 5 dB: failed, ``status`` not ok) and each method's failure rate."""
    fig, axes = pyplot().subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [3, 1]})
    rates = []
    for i, m in enumerate(methods):
        rs = [r for r in rows if r["method"] == m]
        x = i + np.random.default_rng(i).uniform(-0.15, 0.15, len(rs))
        ok = np.array([r["status"] == "ok" for r in rs], bool)
        axes[0].plot(x[ok], [_num(r["psnr"]) for r, k in zip(rs, ok) if k], "o", ms=4, alpha=0.7)
        axes[0].plot(x[~ok], [5.0] * int((~ok).sum()), "x", color="red", ms=6)
        rates.append(float((~ok).mean()) if rs else 0.0)
    axes[0].set_xticks(range(len(methods)), [m.replace(", ", ",\n") for m in methods], fontsize=7)
    axes[0].set_ylabel("test PSNR [dB] (x: failed)")
    axes[0].grid(alpha=0.3, axis="y")
    axes[1].barh(range(len(methods)), rates, color="tab:red")
    axes[1].set_yticks(range(len(methods)), methods, fontsize=6)
    axes[1].set(xlabel="failure rate", xlim=(0, 1))
    fig.suptitle(title)
    return save(fig, path)
