"""The Pareto front of a sweep (:mod:`.sweep`) and what is written from it.

:func:`pareto_front`: of the successful runs of one scene, those that no run as fast or
faster beats on test PSNR (sorted by time, a run joins when its PSNR exceeds every
faster one's by more than 0.01 dB). :func:`reference_verdict`: does any run reach the
torch reference's test PSNR in at most 1/100 of the reference's wall time?
:func:`write_outputs` writes ``sweep.md`` and ``pareto.png`` from ``sweep.csv``.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

from .common import markdown_table

MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]
"""Marker shape per field family, in order of first appearance."""
COLOURS = {"drjit": "tab:blue", "torch": "tab:orange"}
"""Colour per backend (others: grey)."""
SPEEDUP = 100
"""The goal: the reference's PSNR in 1/SPEEDUP of its wall time."""


def _num(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _ok(r: dict, x: str, y: str) -> bool:
    return r.get("status", "ok") == "ok" and math.isfinite(_num(r.get(x))) and math.isfinite(_num(r.get(y)))


def pareto_front(rows: list[dict], x: str = "wall_time", y: str = "psnr", min_gain: float = 0.01) -> list[dict]:
    """The rows on the front (max ``y`` for less ``x``), by increasing ``x``: a row joins when
    its ``y`` exceeds every faster row's by more than ``min_gain`` (dB: noise is no gain).
    Rows with a missing or non-finite value, or ``status`` other than ``ok``, take no part."""
    pts = sorted((r for r in rows if _ok(r, x, y)), key=lambda r: (_num(r[x]), -_num(r[y])))
    front, best = [], -math.inf
    for r in pts:
        if _num(r[y]) > best + min_gain:
            front.append(r)
            best = _num(r[y])
    return front


def is_reference(r: dict) -> bool:
    return str(r.get("reference", "")).lower() in ("true", "1")


def reference_verdict(rows: list[dict]) -> dict | None:
    """Against the (successful) torch reference row: the fastest run reaching its PSNR, the
    best PSNR within 1/SPEEDUP of its wall time, and ``passed``. None without a reference."""
    refs = [r for r in rows if is_reference(r) and _ok(r, "wall_time", "psnr")]
    if not refs:
        return None
    ref = refs[0]
    others = [r for r in rows if r["scene"] == ref["scene"] and not is_reference(r) and _ok(r, "wall_time", "psnr")]
    limit = _num(ref["wall_time"]) / SPEEDUP
    reaching = sorted((r for r in others if _num(r["psnr"]) >= _num(ref["psnr"])), key=lambda r: _num(r["wall_time"]))
    within = sorted((r for r in others if _num(r["wall_time"]) <= limit), key=lambda r: -_num(r["psnr"]))
    fastest = reaching[0] if reaching else None
    return {"reference": ref, "limit": limit, "fastest_reaching": fastest, "best_within": within[0] if within else None,
            "speedup": _num(ref["wall_time"]) / _num(fastest["wall_time"]) if fastest else None,
            "passed": bool(fastest) and _num(fastest["wall_time"]) <= limit}


def _name(r: dict) -> str:
    return f"{r['family']} {r['size']} s{r['samples']} {r['backend']} {r['budget']}"


def verdict_text(v: dict | None) -> str:
    if v is None:
        return "No torch reference in this sweep (it runs on its scene, with the reference row enabled)."
    ref = v["reference"]
    lines = [f"Torch reference ({_name(ref)}, {ref['scene']}): test PSNR {_num(ref['psnr']):.2f} dB "
             f"in {_num(ref['wall_time']):.1f} s; the goal is the same PSNR in at most {v['limit']:.2f} s.\n"]
    f, b = v["fastest_reaching"], v["best_within"]
    lines.append(f"- fastest run reaching it: {_name(f)}, {_num(f['psnr']):.2f} dB in {_num(f['wall_time']):.2f} s "
                 f"({v['speedup']:.1f}x faster)" if f else "- no run reaches it")
    lines.append(f"- best run within {v['limit']:.2f} s: {_name(b)}, {_num(b['psnr']):.2f} dB" if b
                 else f"- no run finished within {v['limit']:.2f} s")
    lines.append(f"- **{'PASSED' if v['passed'] else 'NOT PASSED'}**: reference PSNR in <= 1/{SPEEDUP} of its time")
    return "\n".join(lines) + "\n"


def plot_pareto(rows: list[dict], path: Path) -> Path:
    """``pareto.png``: test PSNR against wall time, one subplot per scene."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    scenes = list(dict.fromkeys(r["scene"] for r in rows)) or ["(no runs)"]
    families = list(dict.fromkeys(r["family"] for r in rows))
    marker = {f: MARKERS[i % len(MARKERS)] for i, f in enumerate(families)}
    ncols = min(2, len(scenes))
    nrows = math.ceil(len(scenes) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.0 * ncols, 4.2 * nrows), squeeze=False)
    for ax, scene in zip(axes.flat, scenes):
        pts = [r for r in rows if r["scene"] == scene and _ok(r, "wall_time", "psnr")]
        for r in pts:
            ref = is_reference(r)
            ax.scatter(_num(r["wall_time"]), _num(r["psnr"]), marker=marker[r["family"]], s=90 if ref else 36,
                       color=COLOURS.get(r["backend"], "grey"), edgecolors="black" if ref else "none",
                       linewidths=1.2, alpha=0.85, zorder=3)
            if ref:
                ax.annotate("torch reference", (_num(r["wall_time"]), _num(r["psnr"])), fontsize=8,
                            xytext=(-6, 6), textcoords="offset points", ha="right")
        front = pareto_front(pts)
        if front:
            xs, ys = [_num(r["wall_time"]) for r in front], [_num(r["psnr"]) for r in front]
            x_end = max(_num(r["wall_time"]) for r in pts) * 1.2
            ax.step(xs + [x_end], ys + [ys[-1]], where="post", color="black", lw=1, ls="--", zorder=2)
            ax.scatter(xs, ys, s=140, facecolors="none", edgecolors="black", linewidths=1, zorder=4)
            ax.set_xscale("log")
            ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
            lo, hi = min(_num(r["psnr"]) for r in pts), max(_num(r["psnr"]) for r in pts)
            pad = max(0.5 - (hi - lo) / 2, 0.05 * (hi - lo))       # at least 1 dB tall: noise stays flat
            ax.set_ylim(lo - pad, hi + pad)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set(title=scene, xlabel="wall time of fit (s)", ylabel="test PSNR (dB)")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    handles = [Line2D([], [], ls="", marker=marker[f], color="grey", label=f) for f in families]
    handles += [Patch(color=c, label=b) for b, c in COLOURS.items()]
    handles += [Line2D([], [], ls="", marker="o", color="white", mec="black", label="torch reference"),
                Line2D([], [], ls="--", color="black", marker="o", mfc="none", label="Pareto front")]
    ncol = min(len(handles), 4)                  # wraps instead of running off a one-panel figure
    rows_of_legend = math.ceil(len(handles) / ncol)
    fig.legend(handles=handles, loc="lower center", ncol=ncol, frameon=False, fontsize=9)
    fig.tight_layout(rect=(0, 0.05 * rows_of_legend / nrows, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


TABLE = ["family", "size", "samples", "backend", "budget", "psnr", "ssim", "wall_time", "train_time", "steps",
         "front", "id"]
FMT = {"psnr": ".2f", "ssim": ".3f", "wall_time": ".2f", "train_time": ".2f"}


def report_text(rows: list[dict]) -> str:
    """``sweep.md``: the chart, the verdict, per scene its front and its table, the failures."""
    by_scene = defaultdict(list)
    for r in rows:
        by_scene[r["scene"]].append(r)
    text = ["# Speed against accuracy\n", "![test PSNR against wall time](pareto.png)\n",
            "## Torch reference\n", verdict_text(reference_verdict(rows))]
    for scene, rs in by_scene.items():
        front_ids = {r["id"] for r in pareto_front(rs)}
        table = [{**r, "front": "yes" if r["id"] in front_ids else "",
                  "budget": r["budget"] + (" (reference)" if is_reference(r) else "")}
                 for r in sorted(rs, key=lambda r: _num(r.get("wall_time")))]
        ok = [r for r in table if r["status"] == "ok"]
        front = "".join(f"- {_name(r)}: {_num(r['psnr']):.2f} dB in {_num(r['wall_time']):.2f} s\n"
                        for r in ok if r["front"])
        text += [f"## {scene}\n", "Pareto front (fastest first):\n", front or "- (no successful run)\n",
                 markdown_table(ok, TABLE, FMT)]
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        text += ["## Failed runs\n", markdown_table(failed, ["scene", "family", "size", "samples", "backend",
                                                             "budget", "error", "id"])]
    return "\n".join(text)


def write_outputs(csv_path: Path, out: Path) -> tuple[Path, Path]:
    """``sweep.md`` and ``pareto.png`` from the records in ``csv_path``."""
    from .sweep_exec import read_results

    rows = read_results(csv_path)
    chart = plot_pareto(rows, Path(out) / "pareto.png")
    report = Path(out) / "sweep.md"
    report.write_text(report_text(rows))
    return report, chart
