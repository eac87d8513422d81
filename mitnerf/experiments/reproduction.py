"""``REPRODUCTION.md``: every claim of the two source reports beside our figure.

``mitnerf experiment all --out DIR`` runs the experiments of :data:`REPRODUCE` at full size (each
into ``DIR/<name>``), records their rows in the results file (key ``experiment/<name>``) and writes
``DIR/REPRODUCTION.md`` and ``DIR/reproduction.png``; ``benchmarks/report.py`` writes the same from
the results file.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .._io import atomic_write_text
from ..results import machine_line, record_result
from ..settings import spec
from ..viz.panels import series_figure
from . import EXPERIMENTS
from .claims import CLAIMS, SOURCES, claims_table, verdict
from .report import markdown_table
from .window_shop import PICKED, lr_words, tables

REPRODUCE = ("pe", "depth", "pixelnerf", "window-shop")
"""The experiments that test the reports' claims (``mitnerf experiment all``)."""

KEEP = ("psnr", "ssim", "iou", "depth_error", "chamfer", "train_time", "steps", "status", "reason", "psnr_ours",
        "ssim_ours", "psnr_pool", "ssim_pool")
BUDGETS = {
    "pe": lambda c: f"{c.steps} steps per run, {len(c.Ls)} L x {c.seeds} seeds",
    "depth": lambda c: (f"{c.steps} steps of {c.batch_rays} rays, {len(c.scenes)} scenes x {len(c.views)} view counts "
                        f"x 2 x {c.seeds} seeds"),
    "pixelnerf": lambda c: (f"pixelNeRF per encoder: the recipe's budget; NeRF: {c.nerf_iters} steps or "
                            f"{c.nerf_time_budget:g} s, {c.draws} draws per k"),
    "window-shop": lambda c: (f"{c.iters} steps or {c.time_budget:g} s per row of {c.batch_rays} rays, "
                              f"{c.architecture} MLP, "
                              + (f"{Path(c.data).name}" if c.data else f"{len(c.objects)} objects")
                              + (f", rows of at most {c.few_views} images with FreeNeRF's frequency window over "
                                 f"{c.pe_window} steps" if c.few_views else "")),
}
"""Per experiment: its config -> its budget in words."""


def rows_of(results: dict, name: str) -> list[dict] | None:
    """The rows recorded for experiment ``name`` (None: not recorded)."""
    return results.get(f"experiment/{name}", {}).get("values", {}).get("rows")


def partial(cfg) -> list[str]:
    """The settings of ``cfg`` that choose its runs (``setting(selects=True)``) and differ from their defaults: a run
    of part of the experiment (empty: the whole of it)."""
    whole = type(cfg)()
    return [f.name for f in dataclasses.fields(cfg) if spec(f).get("selects")
            and getattr(cfg, f.name) != getattr(whole, f.name)]


def record(name: str, cfg, rows: list[dict], seconds: float, command: str, path: Path | None = None) -> dict | None:
    """Store an experiment's rows (labels and the metrics in ``KEEP``), config and budget in the results file; a run
    of part of it (:func:`partial`) stores nothing, so the record of the whole stays (None)."""
    if partial(cfg):
        return None
    verdicts = [f"{c.key}: {verdict(c, rows)[1].split(':')[0]}" for c in CLAIMS if c.experiment == name and rows]
    budget = BUDGETS[name](cfg) if name in BUDGETS else ""
    slim = [{k: v for k, v in r.items() if (k in KEEP or not isinstance(v, float))
             and k not in ("recipe", "params", "render_time")} for r in rows]
    return record_result(f"experiment/{name}" + record_suffix(cfg),
                         {"rows": slim, "wall_s": round(seconds, 1)},
                         f"{len(rows)} runs in {seconds / 60:.0f} min; " + ("; ".join(verdicts) or "no claims"),
                         command, path=path, budget=budget, config=dataclasses.asdict(cfg))


def record_suffix(cfg) -> str:
    """The record of an experiment on a user's file (``data``), or on views picked otherwise than the first N
    (``pick``), has its own key, ``experiment/<name>/<file>[-<pick>]``, beside the record of the whole on our data."""
    data, pick = getattr(cfg, "data", None), getattr(cfg, "pick", "first")
    parts = ([Path(data).stem] if data else []) + ([pick] if pick != "first" else [])
    return "/" + "-".join(parts) if parts else ""


def runs_table(results: dict) -> str:
    """Per experiment: the command that made its figures, the budget, the time, the machine."""
    rows = []
    for n in REPRODUCE:
        e = results.get(f"experiment/{n}")
        rows.append({"run": f"`{n}`", "command": f"`{e['command']}`" if e else f"not run: `mitnerf experiment {n}`",
                     "budget": e.get("budget", "") if e else "", "wall time": f"{e['values']['wall_s'] / 60:.0f} min"
                     if e else "", "machine, date": f"{machine_line(e['machine'])}, {e['date']}" if e else ""})
    return markdown_table(rows)


def figure(results: dict, path: Path) -> Path | None:
    """The recorded experiments' charts (each experiment's ``panels``), ours against the reports; None when nothing
    is recorded."""
    panels = [p for n in REPRODUCE if rows_of(results, n) for p in EXPERIMENTS[n].panels(rows_of(results, n))]
    return series_figure(path, panels, cell=(4.25, 3.6), columns=3) if panels else None


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
            ours = results.get("experiment/window-shop", {}).get("config", {})
            parts += ["### Table 2, row for row\n", "Their Table 1 combinations at 2000 iterations with their "
                      "Table 2 PSNR, beside ours on each object (the same wall-clock budget per row, and the same "
                      f"2000 steps where the budget affords them; {lr_words(ours)}).\n",
                      *tables(rows_of(results, "window-shop") or [])]
            for key in sorted(k for k in results if k.startswith("experiment/window-shop/")):
                e, rows = results[key], results[key]["values"]["rows"]
                table, additions = tables(rows)
                config = e.get("config", {})
                pick, own = config.get("pick", "first"), bool(config.get("data"))
                where = f"the file's views ({PICKED[pick]})" if own else f"{PICKED[pick]} views of each object's pool"
                scored = ("scored by the report's protocol (view 101) and on the held-out views" if own
                          else "scored on each object's test orbit")
                title = "the report's own data" if own else "our objects"
                parts += [f"### Table 2 on {title}: {key.rsplit('/', 1)[1]}\n",
                          f"`{e['command']}` ({e.get('budget', '')}; {machine_line(e['machine'])}, {e['date']}). "
                          f"Trained on {where}, {scored}; {lr_words(config)}.\n", table]
                if any(not r["row"].isdigit() for r in rows):
                    parts += ["\n" + additions + ("\n\n(PSNR and SSIM on view 101.)" if own else "")]
    return "\n".join(parts)


def write(results: dict, out: Path, command: str) -> Path:
    """``out/REPRODUCTION.md`` and ``out/reproduction.png``."""
    fig = figure(results, out / "reproduction.png")
    return atomic_write_text(out / "REPRODUCTION.md", document(results, "reproduction.png" if fig else None, command))
