"""``REPRODUCTION.md``: every claim of the two source reports beside our figure.

``mitnerf experiment all --out DIR`` runs the experiments of :data:`REPRODUCE` at full size (each
into ``DIR/<name>``), records their rows in the results file (key ``experiment/<name>``) and writes
``DIR/REPRODUCTION.md`` and ``DIR/reproduction.png``; ``benchmarks/report.py`` writes the same from
the results file.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from .._io import atomic_write_text
from ..results import machine_line, record_result
from ..viz.panels import pyplot, save
from .claims import CLAIMS, MISSING, SOURCES, _f, _ws
from .report import markdown_table, num, summarise
from .window_shop import COMBINATIONS

REPRODUCE = ("pe", "depth", "pixelnerf", "window-shop")
"""The experiments that test the reports' claims (``mitnerf experiment all``)."""

KEEP = ("psnr", "ssim", "iou", "depth_error", "chamfer", "train_time", "steps", "status", "reason")
BUDGETS = {
    "pe": lambda c: f"{c.steps} steps per run, {len(c.Ls)} L x {c.seeds} seeds",
    "depth": lambda c: (f"{c.steps} steps of {c.batch_rays} rays, {len(c.scenes)} scenes x {len(c.views)} view counts "
                        f"x 2 x {c.seeds} seeds"),
    "pixelnerf": lambda c: (f"pixelNeRF per encoder: the recipe's budget; NeRF: {c.nerf_iters} steps or "
                            f"{c.nerf_time_budget:g} s, {c.draws} draws per k"),
    "window-shop": lambda c: (f"{c.iters} steps or {c.time_budget:g} s per row of {c.batch_rays} rays, "
                              f"{c.architecture} MLP, {len(c.objects)} objects"),
}
"""Per experiment: its config -> its budget in words."""


def record(name: str, cfg, rows: list[dict], seconds: float, command: str, path: Path | None = None) -> dict:
    """Store an experiment's rows (labels and the metrics in ``KEEP``), config and budget in the results file."""
    verdicts = [f"{c.key}: {c.judge(rows)[1].split(':')[0]}" for c in CLAIMS if c.experiment == name and rows]
    budget = BUDGETS[name](cfg) if name in BUDGETS else ""
    slim = [{k: v for k, v in r.items() if (k in KEEP or not isinstance(v, float))
             and k not in ("recipe", "params", "render_time")} for r in rows]
    return record_result(f"experiment/{name}", {"rows": slim, "wall_s": round(seconds, 1)},
                         f"{len(rows)} runs in {seconds / 60:.0f} min; " + ("; ".join(verdicts) or "no claims"),
                         command, path=path, budget=budget, config=dataclasses.asdict(cfg))


def claims_table(results: dict, source: str) -> str:
    rows = []
    for c in [c for c in CLAIMS if c.source == source]:
        entry = results.get(f"experiment/{c.experiment}")
        ours, stands = "-", f"{MISSING} (`mitnerf experiment {c.experiment}`)"
        if entry and entry["values"].get("rows"):
            try:
                ours, stands = c.judge(entry["values"]["rows"])
            except (KeyError, ValueError, ZeroDivisionError) as e:
                ours, stands = "-", f"{MISSING}: the recorded rows lack {e}"
        rows.append({"claim": f"\"{c.quote}\" ({c.where})", "theirs": c.theirs, "ours": ours, "stands": stands,
                     "run": f"`{c.experiment}`", "deviations, judged as": c.deviations})
    return markdown_table(rows)


def runs_table(results: dict) -> str:
    """Per experiment: the command that made its figures, the budget, the time, the machine."""
    rows = []
    for n in REPRODUCE:
        e = results.get(f"experiment/{n}")
        rows.append({"run": f"`{n}`", "command": f"`{e['command']}`" if e else f"not run: `mitnerf experiment {n}`",
                     "budget": e.get("budget", "") if e else "", "wall time": f"{e['values']['wall_s'] / 60:.0f} min"
                     if e else "", "machine, date": f"{machine_line(e['machine'])}, {e['date']}" if e else ""})
    return markdown_table(rows)


def table2(results: dict) -> str:
    e = results.get("experiment/window-shop")
    objs = _ws(e["values"]["rows"]) if e else {}
    rows = []
    for i, (images, L, nc, vd, theirs) in COMBINATIONS.items():
        row = {"#": i, "images": images, "L": L, "N_c": nc, "view dep.": "on" if vd else "off",
               "Table 2 PSNR": f"{theirs:.1f}"}
        for obj, rs in objs.items():
            r = rs.get(str(i), {})
            row[f"{obj} PSNR / SSIM"] = f"{_f(r.get('psnr'), '.2f')} / {_f(r.get('ssim'), '.3f')}"
            steps, t = num(r.get("steps")), num(r.get("train_time"))
            row[f"{obj} steps, s"] = f"{int(steps) if math.isfinite(steps) else '-'}, {_f(t, '.0f')}"
        rows.append(row)
    add = [{"row": label, "object": obj, "images": r.get("images"), "PSNR": _f(r.get("psnr"), ".2f"),
            "SSIM": _f(r.get("ssim"), ".3f"), "steps": r.get("steps"), "train s": _f(r.get("train_time"), ".0f")}
           for obj, rs in objs.items() for label, r in rs.items() if not label.isdigit()]
    notes = []
    for obj, rs in objs.items():
        one, four = num(rs.get("7", {}).get("psnr")), num(rs.get("7, four direction frequencies", {}).get("psnr"))
        if math.isfinite(one) and math.isfinite(four):
            notes.append(f"* {obj}: combination 7 (5 photos) with NeRF's four direction frequencies {four:.2f} dB, "
                         f"with one {one:.2f} dB ({four - one:+.2f} dB): with few photos, a colour free to vary "
                         "with direction explains each photo by its direction instead of by geometry.")
    return (markdown_table(rows) + "\n" + "\n".join(notes) + ("\n" if notes else "") + "\nOur additions:\n\n"
            + markdown_table(add))


def figure(results: dict, path: Path) -> Path | None:
    """One figure of four panels from the recorded rows; None when nothing is recorded."""
    got = {n: results[f"experiment/{n}"]["values"]["rows"] for n in REPRODUCE if f"experiment/{n}" in results}
    if not got:
        return None
    plt = pyplot()
    fig, ax = plt.subplots(1, 4, figsize=(17, 3.6))
    if "pe" in got:
        s = sorted(summarise([{**r, "L": int(r["L"])} for r in got["pe"]], ["L"]), key=lambda r: r["L"])
        ax[0].errorbar([r["L"] for r in s], [r["psnr"] for r in s], yerr=[r["psnr_std"] for r in s], fmt="o-",
                       capsize=3)
        ax[0].set(title="NeRF2D: positional encoding (bunny)", xlabel="L", ylabel="test PSNR [dB]")
    if "depth" in got:
        s = summarise([{**r, "views": int(r["views"])} for r in got["depth"]], ["views", "method"])
        for method, style in (("NeRF", "o--"), ("DS-NeRF", "s-")):
            pts = sorted((r["views"], r["psnr"]) for r in s if r["method"] == method)
            ax[1].plot(*zip(*pts), style, label=method)
        ax[1].set(title="NeRF2D: depth supervision (4 scenes)", xlabel="training views", ylabel="mean test PSNR [dB]")
        ax[1].legend(fontsize=7)
    if "pixelnerf" in got:
        ev = [{**r, "k": int(r["k"])} for r in got["pixelnerf"] if r.get("group") == "eval"]
        for (scene, method), style in zip(sorted({(r["scene"], r["method"]) for r in ev}), ["o-", "s-", "^--"] * 4):
            pts = sorted((r["k"], r["psnr"]) for r in summarise([x for x in ev if x["scene"] == scene and
                                                                 x["method"] == method], ["k"]))
            ax[2].plot(*zip(*pts), style, label=f"{scene}, {method}")
        ax[2].set(title="NeRF2D: pixelNeRF vs NeRF", xlabel="input views", ylabel="test PSNR [dB]")
        ax[2].legend(fontsize=6)
    if "window-shop" in got:
        idx = list(COMBINATIONS)
        ax[3].plot(idx, [COMBINATIONS[i][4] for i in idx], "ks", mfc="none", label="Table 2 (Lego, GPU)")
        for obj, rs in _ws(got["window-shop"]).items():
            ax[3].plot(idx, [num(rs.get(str(i), {}).get("psnr")) for i in idx], "o", label=f"ours, {obj}")
        ax[3].set(title="Window shopping: Table 2 row for row", xlabel="combination", ylabel="test PSNR [dB]",
                  xticks=idx)
        ax[3].legend(fontsize=7)
    for a in ax:
        a.grid(alpha=0.3)
    save(fig, path)
    return path


def document(results: dict, figure_name: str | None, command: str) -> str:
    """The text of ``REPRODUCTION.md``."""
    parts = ["# Reproducing the two source reports\n",
             f"Generated by `{command}` from the results file; do not edit by hand. Every passage in quotation "
             "marks is quoted verbatim from the report named above its table (short quotes only; the reports "
             "themselves are not part of this project). *Stands* says whether our figure supports the claim, "
             "and where it does not, what we measured instead. Each experiment's command re-makes its figures; "
             "`make reproduce` re-makes all of them.\n"]
    if figure_name:
        parts.append(f"![the four experiments, ours against the reports]({figure_name})\n")
    parts += ["## Runs\n", runs_table(results)]
    for source, (title, shared) in SOURCES.items():
        parts += [f"## {title}\n", f"Deviations in every row: {shared}.\n", claims_table(results, source)]
        if source == "window-shop":
            parts += ["### Table 2, row for row\n", "Their Table 1 combinations at 2000 iterations with their "
                      "Table 2 PSNR, beside ours on each object (the same wall-clock budget per row, and the same "
                      "2000 steps where the budget affords them).\n", table2(results)]
    return "\n".join(parts)


def write(results: dict, out: Path, command: str) -> Path:
    """``out/REPRODUCTION.md`` and ``out/reproduction.png``."""
    fig = figure(results, out / "reproduction.png")
    return atomic_write_text(out / "REPRODUCTION.md", document(results, "reproduction.png" if fig else None, command))
