"""What the window-shopping ablation (:mod:`.window_shop`) writes: ``results.csv``,
``table.md``, ``psnr_vs_time.png``, ``psnr_vs_views.png``, ``thumbnails.png`` and
``report.md``, whose verdicts on the original report's two claims are computed from the
rows (:func:`trend_views`, :func:`trend_collapse`), not written by hand.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .common import markdown_table, write_csv, write_report

REPORT_RANGE = (23.0, 25.0)
"""The original report: "PSNR stays around 23-25 dB even at 5 views"."""
FLAT_DB = 2.0
"""A series counts as "staying around" its level when it loses at most this many dB."""
REPORT_COLLAPSE = (15.0, 16.0)
"""The original report: "N_c = 128 with 5 views collapsed to 15-16 dB"."""
TABLE = ["object", "budget", "design", "config", "views", "status", "psnr", "ssim", "train_time", "steps",
         "ms_per_step", "render_time", "opacity_fg", "density_max"]
FMT = {"psnr": ".2f", "ssim": ".3f", "train_time": ".1f", "ms_per_step": ".0f", "render_time": ".3f",
       "opacity_fg": ".2f", "density_max": ".3g"}
FACTOR_COLOURS = {"pos_L": "tab:orange", "n_coarse": "tab:green", "view_dependent": "tab:purple",
                  "hierarchical": "tab:brown"}
BUDGET_MARKERS = {"iters": "o", "time": "s"}


def num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def is_base(r: dict) -> bool:
    """A NeRF row at the base configuration (whatever its design label)."""
    from .window_shop import BASE

    return (r["field"] == "vanilla" and r.get("activation", "softplus") == "softplus"
            and all(str(r[k]) == str(v) for k, v in BASE.items()))


def changed_factor(r: dict) -> str | None:
    """The one factor in which a NeRF row differs from the base (None: base or several)."""
    from .window_shop import BASE

    diff = [k for k, v in BASE.items() if str(r[k]) != str(v)]
    return diff[0] if len(diff) == 1 else None


def series(rows, pick, budget) -> tuple[list, list]:
    pts = sorted((int(r["views"]), num(r["psnr"])) for r in rows if pick(r) and r["budget"] == budget)
    return [p[0] for p in pts], [p[1] for p in pts]


# ----------------------------------------------------------------------------- figures
def plot_psnr_vs_time(rows: list[dict], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    objects = list(dict.fromkeys(r["object"] for r in rows))
    views = sorted({int(r["views"]) for r in rows})
    blues = {v: plt.cm.Blues(0.35 + 0.65 * i / max(len(views) - 1, 1)) for i, v in enumerate(views)}
    fig, axes = plt.subplots(1, len(objects), figsize=(max(6.2 * len(objects), 10.0), 4.8), squeeze=False)
    for ax, obj in zip(axes[0], objects):
        for r in (r for r in rows if r["object"] == obj):
            x, y = num(r.get("train_time")), num(r.get("psnr"))
            if not (math.isfinite(x) and math.isfinite(y)):
                continue
            f = changed_factor(r) if r["field"] == "vanilla" else None
            colour = ("black" if r["field"] != "vanilla" else "tab:red" if r["activation"] != "softplus"
                      else blues[int(r["views"])] if is_base(r) else FACTOR_COLOURS.get(f, "grey"))
            ax.scatter(x, y, marker=BUDGET_MARKERS[r["budget"]], color=colour, s=42, zorder=3,
                       edgecolors="red" if r["status"] != "ok" else "none", linewidths=1.5)
            if r["status"] != "ok":
                ax.annotate("collapsed", (x, y), fontsize=7, color="red", xytext=(4, -10), textcoords="offset points")
        for pick, colour in ((is_base, "tab:blue"), (lambda r: r["field"] == "grid", "black")):
            for budget, ls in (("iters", "-"), ("time", "--")):
                xs = sorted(((int(r["views"]), num(r["train_time"]), num(r["psnr"])) for r in rows
                             if r["object"] == obj and pick(r) and r["budget"] == budget and
                             math.isfinite(num(r.get("psnr")))))
                if xs:
                    ax.plot([p[1] for p in xs], [p[2] for p in xs], ls=ls, color=colour, lw=0.8, alpha=0.6)
                    for v, t, p in xs:
                        ax.annotate(f"{v}v", (t, p), fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.axhspan(*REPORT_RANGE, color="gold", alpha=0.15, lw=0)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.FuncFormatter(
            lambda v, _: f"{v:g}" if f"{v:g}"[0] in "25" else ""))
        ax.set(title=obj, xlabel="train time (s, log)", ylabel="test PSNR (dB)")
        ax.grid(True, which="both", alpha=0.3)
    handles = [Line2D([], [], ls="", marker=m, color="grey", label=f"fixed {b}") for b, m in BUDGET_MARKERS.items()]
    handles += [Line2D([], [], ls="-", marker="o", color="tab:blue", label="NeRF base, by views"),
                Line2D([], [], ls="-", marker="o", color="black", label="grid (preset)")]
    handles += [Line2D([], [], ls="", marker="o", color=c, label=f"{k} changed") for k, c in FACTOR_COLOURS.items()]
    handles += [Line2D([], [], ls="", marker="o", color="tab:red", label="ReLU density probe"),
                Line2D([], [], ls="", marker="o", color="white", mec="red", label="collapsed"),
                matplotlib.patches.Patch(color="gold", alpha=0.3, label="report: 23-25 dB")]
    fig.legend(handles=handles, loc="lower center", ncol=4, frameon=False, fontsize=8)
    fig.tight_layout(rect=(0, 0.2, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_psnr_vs_views(rows: list[dict], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objects = list(dict.fromkeys(r["object"] for r in rows))
    fig, axes = plt.subplots(1, len(objects), figsize=(5.2 * len(objects), 4.0), squeeze=False)
    for ax, obj in zip(axes[0], objects):
        mine = [r for r in rows if r["object"] == obj]
        for label, pick, colour in (("NeRF base", is_base, "tab:blue"), ("grid", lambda r: r["field"] == "grid",
                                                                         "black")):
            for budget, ls in (("iters", "-"), ("time", "--")):
                v, p = series(mine, pick, budget)
                if v:
                    ax.plot(v, p, ls=ls, marker=BUDGET_MARKERS[budget], color=colour, label=f"{label}, fixed {budget}")
        ax.axhspan(*REPORT_RANGE, color="gold", alpha=0.2, lw=0, label="report: 23-25 dB")
        empty = num(mine[0]["psnr_empty"]) if mine else math.nan
        if math.isfinite(empty):
            ax.axhline(empty, color="grey", ls=":", label=f"empty render ({empty:.1f} dB)")
        ax.set_xscale("log")
        ax.set_xticks(sorted({int(r["views"]) for r in mine}))
        ax.get_xaxis().set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.set(title=obj, xlabel="training photos", ylabel="test PSNR (dB)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_thumbnails(thumbs: dict, views: int, path: Path) -> Path | None:
    """First test view of every fixed-iteration run at ``views`` photos: ground truth, renders,
    and each run's opacity below it (evidence for collapse: an empty field is black there)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objects = list(dict.fromkeys(s.object for s in thumbs))
    per = {o: [(s, t) for s, t in thumbs.items() if s.object == o and s.views == views and s.budget == "iters"]
           for o in objects}
    n = max((len(v) for v in per.values()), default=0)
    if n == 0:
        return None
    fig, axes = plt.subplots(2 * len(objects), n + 1, figsize=(1.6 * (n + 1), 3.4 * len(objects)), squeeze=False)
    for i, o in enumerate(objects):
        for ax in axes[2 * i:2 * i + 2].flat:
            ax.axis("off")
        if per[o]:
            axes[2 * i, 0].imshow(np.clip(per[o][0][1]["target"], 0, 1))
            axes[2 * i, 0].set_title(f"{o}: truth", fontsize=7)
        for j, (s, t) in enumerate(per[o], start=1):
            axes[2 * i, j].imshow(np.clip(t["rgb"], 0, 1))
            axes[2 * i, j].set_title(s.name.replace(" ", "\n", 1), fontsize=6)
            axes[2 * i + 1, j].imshow(t["opacity"], cmap="gray", vmin=0, vmax=1)
        axes[2 * i + 1, 0].text(0.5, 0.5, "opacity\n(black: empty)", ha="center", va="center", fontsize=7)
    fig.suptitle(f"first test view, {views} training photos, fixed iterations", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ----------------------------------------------------------------------------- verdicts
def pivot_views(rows: list[dict]) -> str:
    """Test PSNR by number of views: one row per object, model, budget."""
    views = sorted({int(r["views"]) for r in rows})
    out = []
    for obj in dict.fromkeys(r["object"] for r in rows):
        for label, pick in (("NeRF base", is_base), ("grid", lambda r: r["field"] == "grid")):
            for budget in ("iters", "time"):
                v, p = series([r for r in rows if r["object"] == obj], pick, budget)
                if v:
                    cells = dict(zip(v, p))
                    out.append({"object": obj, "model": label, "budget": budget,
                                **{f"{k} views": cells.get(k, "") for k in views}})
    return markdown_table(out, None, {f"{k} views": ".2f" for k in views})


def pivot_factors(rows: list[dict], views: int) -> str:
    """Test PSNR of each one-factor change at ``views`` photos, beside the base."""
    from .window_shop import BASE, LEVELS

    out = []
    for obj in dict.fromkeys(r["object"] for r in rows):
        for budget in ("iters", "time"):
            here = [r for r in rows if r["object"] == obj and r["budget"] == budget and int(r["views"]) == views
                    and r["field"] == "vanilla" and r["activation"] == "softplus"]
            base = [r for r in here if is_base(r)]
            if not base:
                continue
            b = num(base[0]["psnr"])
            line = {"object": obj, "budget": budget, "base": f"{b:.2f}"}
            for k in BASE:
                alt = [r for r in here if changed_factor(r) == k]
                other = [lv for lv in LEVELS[k] if lv != BASE[k]][0]
                name = {"pos_L": f"L={other}", "n_coarse": f"N_c={other}", "view_dependent": "no view dep.",
                        "hierarchical": "no hierarchical"}[k]
                if alt:
                    a = alt[0]
                    mark = " (collapsed)" if a["status"] != "ok" else ""
                    line[name] = f"{num(a['psnr']):.2f} ({num(a['psnr']) - b:+.2f}){mark}"
            out.append(line)
    return markdown_table(out) if out else "(no one-factor runs at this number of views)\n"


def factor_effects(rows: list[dict], views: int) -> str:
    """Mean PSNR change of each one-factor change at ``views`` photos, per budget, over objects."""
    from .window_shop import BASE

    lines, helped = [], set()
    for budget in ("iters", "time"):
        here = [r for r in rows if r["budget"] == budget and int(r["views"]) == views and r["field"] == "vanilla"
                and r["activation"] == "softplus"]
        base = {r["object"]: num(r["psnr"]) for r in here if is_base(r)}
        effects = {}
        for k in BASE:
            d = [num(r["psnr"]) - base[r["object"]] for r in here if changed_factor(r) == k and r["object"] in base]
            d = [x for x in d if math.isfinite(x)]
            if d:
                effects[k] = float(np.mean(d))
        if effects:
            ranked = sorted(effects.items(), key=lambda kv: -kv[1])
            lines.append(f"- fixed {budget}: " + ", ".join(f"{CHANGE[k]} {v:+.2f} dB" for k, v in ranked)
                         + f" (mean over {len(base)} object{'s' if len(base) > 1 else ''}).")
            helped |= {k for k, v in effects.items() if v > 1.0}
    if "view_dependent" in helped:
        lines.append(f"\nView dependence off helps at {views} views: each surface point is seen from few "
                     "directions, so a view-dependent colour can fit every photo on its own instead of agreeing "
                     "on one colour, and the novel test views pay for it.")
    if "pos_L" in helped:
        lines.append(f"\nFewer encoding frequencies (L = 6) help at {views} views: the field cannot fit "
                     "high-frequency detail that only one photo constrains (few-view NeRFs regularise the "
                     "frequencies for the same reason).")
    return "\n".join(lines) + "\n" if lines else ""


CHANGE = {"pos_L": "L 10 -> 6", "n_coarse": "N_c 64 -> 128", "view_dependent": "view dependence off",
          "hierarchical": "hierarchical off"}
"""How each one-factor change reads in the text."""


def trend_views(rows: list[dict]) -> str:
    """Claim 1: "PSNR stays around 23-25 dB even at 5 views"."""
    lines, flats, learned = [], [], []
    for obj in dict.fromkeys(r["object"] for r in rows):
        for label, pick in (("NeRF", is_base), ("grid", lambda r: r["field"] == "grid")):
            for budget in ("iters", "time"):
                v, p = series([r for r in rows if r["object"] == obj], pick, budget)
                if len(v) < 2:
                    continue
                lo, hi = REPORT_RANGE
                inside = "inside" if lo - 1 <= p[0] <= hi + 1 else "below" if p[0] < lo - 1 else "above"
                flat = p[-1] - p[0] <= FLAT_DB
                flats.append(flat)
                if flat:
                    empty = num(next(r for r in rows if r["object"] == obj)["psnr_empty"])
                    learned.append(p[-1] - empty)
                lines.append(f"- {obj}, {label}, fixed {budget}: {p[0]:.2f} dB at {v[0]} views, {p[-1]:.2f} dB at "
                             f"{v[-1]} ({p[-1] - p[0]:+.2f} dB from {v[0]} to {v[-1]} views): "
                             f"{'flat' if flat else 'not flat'}; {v[0]} views {inside} 23-25 dB (+-1 dB).")
    if not lines:
        return "(fewer than two view counts: no trend)\n"
    lines.append(f"\nPSNR flat (within {FLAT_DB:g} dB) from the most to the fewest views in {sum(flats)} of "
                 f"{len(flats)} series.")
    if learned:
        lines[-1] += (f" The flat series end {min(learned):.1f}-{max(learned):.1f} dB above an empty render: "
                      "flat because they learned little from any number of photos, not because few photos suffice.")
    return "\n".join(lines) + "\n"


def trend_collapse(rows: list[dict]) -> str:
    """Claim 2: "N_c = 128 with 5 views collapsed to 15-16 dB"."""
    lines = []
    fewest = min((int(r["views"]) for r in rows), default=0)
    for obj in dict.fromkeys(r["object"] for r in rows):
        mine = [r for r in rows if r["object"] == obj and r["field"] == "vanilla" and int(r["views"]) == fewest]
        empty = num(mine[0]["psnr_empty"]) if mine else math.nan
        lines.append(f"- {obj}: an empty render (background only) scores {empty:.2f} dB on the test views.")
        for r in mine:
            if is_base(r) or str(r["n_coarse"]) == "128" or r["activation"] != "softplus" or r["status"] != "ok":
                lines.append(f"  - {r['config']}, fixed {r['budget']}: **{r['status']}**, {num(r['psnr']):.2f} dB, "
                             f"opacity on the object {num(r.get('opacity_fg')):.2f}, max density "
                             f"{num(r.get('density_max')):.3g}" + (f" ({r['reason']})" if r.get("reason") else ""))
    healthy = [num(r["psnr"]) for r in rows if r["field"] == "vanilla" and int(r["views"]) == fewest
               and r["status"] == "ok" and r["activation"] == "softplus"]
    lo, hi = REPORT_COLLAPSE
    near = [p for p in healthy if lo - 1 <= p <= hi + 1]
    if near:
        lines.append(f"\n{len(near)} of {len(healthy)} healthy NeRF runs at {fewest} views (opacity on the object "
                     f"well above 0) also score {min(near):.2f}-{max(near):.2f} dB, within 1 dB of the report's "
                     f"{lo:g}-{hi:g}: such a PSNR alone does not tell a collapsed run from an unconverged one; "
                     f"the opacity and density columns do.")
    return "\n".join(lines) + "\n"


def collapse_summary(rows: list[dict]) -> tuple[int, int, int]:
    """(collapsed N_c = 128 softplus runs at the fewest views, of how many; collapsed ReLU probes)."""
    fewest = min((int(r["views"]) for r in rows), default=0)
    nc = [r for r in rows if r["field"] == "vanilla" and str(r["n_coarse"]) == "128" and int(r["views"]) == fewest
          and r["activation"] == "softplus"]
    relu = [r for r in rows if r["field"] == "vanilla" and r["activation"] != "softplus"]
    return (sum(r["status"] != "ok" for r in nc), len(nc), sum(r["status"] != "ok" for r in relu))


def write_outputs(out: Path, rows: list[dict], thumbs: dict, cfg, wall: float,
                  load: tuple | None = None) -> Path:
    """Every file of the experiment; returns the path of ``report.md``. ``load``: the lowest and
    highest 1-minute load average seen between runs."""
    from .window_shop_text import report_sections

    write_csv(out / "results.csv", rows)
    table = markdown_table(sorted(rows, key=lambda r: (r["object"], r["budget"], r["field"], int(r["views"]))),
                           TABLE, FMT)
    (out / "table.md").write_text(table)
    plot_psnr_vs_time(rows, out / "psnr_vs_time.png")
    plot_psnr_vs_views(rows, out / "psnr_vs_views.png")
    fewest = min(int(r["views"]) for r in rows) if rows else 0
    thumbs_png = plot_thumbnails(thumbs, fewest, out / "thumbnails.png")
    sections = report_sections(rows, cfg, wall, table, thumbs_png is not None, fewest, load)
    return write_report(out, "Window shopping in 3D: how few photos, which hyperparameters", sections)
