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
from ..viz.charts import series_figure
from .claims import CLAIMS, SOURCES, _f, _ws, claims_table, verdict
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


def rows_of(results: dict, name: str) -> list[dict] | None:
    """The rows recorded for experiment ``name`` (None: not recorded)."""
    return results.get(f"experiment/{name}", {}).get("values", {}).get("rows")


def record(name: str, cfg, rows: list[dict], seconds: float, command: str, path: Path | None = None) -> dict:
    """Store an experiment's rows (labels and the metrics in ``KEEP``), config and budget in the results file."""
    verdicts = [f"{c.key}: {verdict(c, rows)[1].split(':')[0]}" for c in CLAIMS if c.experiment == name and rows]
    budget = BUDGETS[name](cfg) if name in BUDGETS else ""
    slim = [{k: v for k, v in r.items() if (k in KEEP or not isinstance(v, float))
             and k not in ("recipe", "params", "render_time")} for r in rows]
    return record_result(f"experiment/{name}", {"rows": slim, "wall_s": round(seconds, 1)},
                         f"{len(rows)} runs in {seconds / 60:.0f} min; " + ("; ".join(verdicts) or "no claims"),
                         command, path=path, budget=budget, config=dataclasses.asdict(cfg))


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
    """One chart per recorded experiment, ours against the reports; None when nothing is recorded."""
    got = {n: rows_of(results, n) for n in REPRODUCE if rows_of(results, n)}
    as_int = lambda rows, *keys: [{**r, **{k: int(r[k]) for k in keys}} for r in rows]
    panels = []
    if "pe" in got:
        panels.append(dict(title="NeRF2D: positional encoding (bunny)", xlabel="L", x="L",
                           rows=summarise(as_int(got["pe"], "L"), ["L"])))
    if "depth" in got:
        panels.append(dict(title="NeRF2D: depth supervision (4 scenes)", xlabel="training views", x="views",
                           by=("method",), styles={"NeRF": "o--", "DS-NeRF": "s-"}, err=False,
                           rows=summarise(as_int(got["depth"], "views"), ["views", "method"])))
    if "pixelnerf" in got:
        ev = as_int([r for r in got["pixelnerf"] if r.get("group") == "eval"], "k")
        panels.append(dict(title="NeRF2D: pixelNeRF vs NeRF", xlabel="input views", x="k", by=("scene", "method"),
                           err=False, rows=summarise(ev, ["scene", "method", "k"])))
    if "window-shop" in got:
        rows = [{"#": i, "psnr": c[4], "run": "Table 2 (Lego, GPU)"} for i, c in COMBINATIONS.items()]
        rows += [{"#": i, "psnr": rs.get(str(i), {}).get("psnr"), "run": f"ours, {obj}"}
                 for obj, rs in _ws(got["window-shop"]).items() for i in COMBINATIONS]
        panels.append(dict(title="Window shopping: Table 2 row for row", xlabel="combination", x="#", by=("run",),
                           err=False, styles={"Table 2 (Lego, GPU)": "ks", **{r["run"]: "o" for r in rows}},
                           xticks=list(COMBINATIONS), rows=rows))
    return series_figure(path, panels, cell=(4.25, 3.6)) if panels else None


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
        parts += [f"## {title}\n", f"Deviations in every row: {shared}.\n",
                  claims_table([c for c in CLAIMS if c.source == source], lambda name: rows_of(results, name))]
        if source == "window-shop":
            parts += ["### Table 2, row for row\n", "Their Table 1 combinations at 2000 iterations with their "
                      "Table 2 PSNR, beside ours on each object (the same wall-clock budget per row, and the same "
                      "2000 steps where the budget affords them).\n", table2(results)]
    return "\n".join(parts)


def write(results: dict, out: Path, command: str) -> Path:
    """``out/REPRODUCTION.md`` and ``out/reproduction.png``."""
    fig = figure(results, out / "reproduction.png")
    return atomic_write_text(out / "REPRODUCTION.md", document(results, "reproduction.png" if fig else None, command))
