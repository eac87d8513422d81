"""Charts of result tables (rows as dicts): the speed-against-accuracy plane."""

from __future__ import annotations

import math
from pathlib import Path

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
