"""The documents made from the one results file: ``RESULTS.md`` and the README's table.

Every figure lives in ``results.json`` (written by the benchmarks and experiment runs
through :func:`mitnerf.results.record_result`, each with the command and the machine that
produced it). This script renders it:

* ``RESULTS.md``: every entry, grouped by area, with its command, machine and date, and the fit table's rows;
* the lego's rows beside the published figures (:func:`lego_table`);
* the README's results table, between ``<!-- results:begin -->`` and ``<!-- results:end -->``
  (the entries whose key is listed in ``README_KEYS``); in both, a table whose entries come from more than one
  kind of CPU is split into one per kind (:func:`tables`): speeds measured on two kinds do not compare;
* ``REPRODUCTION.md`` (:mod:`mitnerf.experiments.reproduction`: every claim of the two source
  reports beside our figure, from the ``experiment/...`` entries) and its figure
  ``docs/reproduction.png``;
* ``docs/glossy.png``: test PSNR against roughness (``glossy/2d``, ``glossy/3d``), the goals marked; in 2D a plain
  grid too (``glossy/preset``: no view dependence, no losses), beside the figure a user reported for it.

    python benchmarks/report.py
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from mitnerf.results import load_results, machine_line

ROOT = Path(__file__).resolve().parents[1]
README_KEYS = ("demo/bunny", "fit/bunny-cli", "step_time/w128", "step_time/w32", "step_time/equal_steps_psnr",
               "grid_step/2d", "hashgrid/psnr", "hashgrid/generalisation",
               "experiment/pe", "experiment/depth", "experiment/pixelnerf", "experiment/window-shop",
               "seeds/grid-2d", "check/nerfstudio")
BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"


def table(entries: dict) -> str:
    lines = ["| figure | value | command | machine, date |", "|---|---|---|---|"]
    for key, e in entries.items():
        lines.append(f"| `{key}` | {e['summary']} | `{e['command']}` | {machine_line(e['machine'])}, {e['date']} |")
    return "\n".join(lines) + "\n"


def cpu_kind(entry: dict) -> str:
    """The CPU and its vector width an entry was measured on."""
    return f"{entry['machine'].get('cpu', '?')} ({entry['machine'].get('simd', '?')})"


def tables(entries: dict) -> str:
    """:func:`table` of the entries, one per CPU kind (in order of first appearance), each headed by its kind when
    there is more than one."""
    kinds: dict[str, dict] = {}
    for key, e in entries.items():
        kinds.setdefault(cpu_kind(e), {})[key] = e
    if len(kinds) == 1:
        return table(entries)
    return "\n".join(f"On {kind}:\n\n{table(group)}" for kind, group in kinds.items())


def rows_table(key: str, entry: dict) -> str:
    """The rows of a ``fits/<scene>`` entry (one per fitted option set) as a table, headed by its machine."""
    rows, geo = entry["values"]["rows"], entry["values"]["geometry"]
    lines = [f"`{key}` ({machine_line(entry['machine'])}, {entry['date']}):\n",
             f"| run | PSNR | SSIM | {geo} | parameters | seconds | status |",
             "|---|---|---|---|---|---|---|"]
    f = lambda v, spec: "-" if v is None else format(v, spec)           # noqa: E731  (null: not measured)
    lines += [f"| {r['run']} | {f(r['psnr'], '.2f')} | {f(r['ssim'], '.3f')} | {f(r['geometry'], '.4f')} | "
              f"{r['params']} | {f(r['seconds'], '.1f')} | {r['status']} |" for r in rows]
    return "\n".join(lines) + "\n"


def lego_table(results: dict) -> str:
    """``lego/<budget>`` (and ``lego/nerfacto/<budget>``, ``benchmarks/nerfacto.py``) beside the published figures
    (``benchmarks/lego.py``)."""
    if __package__:                       # imported as benchmarks.report (the tests)
        from .lego import ANCHORS
    else:                                 # run as python benchmarks/report.py
        from lego import ANCHORS

    ours = {k: e for k, e in results.items() if k.startswith("lego/")}
    if not ours:
        return ""
    lines = ["Lego: ours at the size each row gives (trained and tested at it) on the machine named, the published "
             "figures at 800 x 800 on a GPU, on the 200 test views; all over white. The peer (nerfacto) renders "
             "slowly on a CPU and is scored on fewer views, with our 600 s fit on the same views beside it.\n",
             "| run | views | test views | test PSNR [dB] | SSIM | training | hardware |",
             "|---|---|---|---|---|---|---|"]
    for key, e in ours.items():
        v = e["values"]
        lines.append(f"| `{key}` ({v.get('recipe', '')}) | {v.get('size', '?')} | {v.get('views', 200)} | "
                     f"{v['psnr']:.2f} | {v['ssim']:.3f} | {v['train_s']:.0f} s, {v['steps']} steps | "
                     f"{machine_line(e['machine'])} |")
        if "ours" in v:
            o = v["ours"]
            lines.append(f"| `{o['run']}` on the same views | {v.get('size', '?')} | {v['views']} | {o['psnr']:.2f} | "
                         f"{o['ssim']:.3f} | | |")
    lines += [f"| {name} (published) | 800 x 800 | 200 | {db} | | {when} | {gpu} |" for name, db, when, gpu in ANCHORS]
    return "\n".join(lines) + "\n"


def captures_table(results: dict, name: str) -> str:
    """``<name>/fit`` beside the published figures of ``benchmarks/captures.py``'s :data:`ANCHORS`."""
    if __package__:
        from .captures import ANCHORS
    else:
        from captures import ANCHORS
    e = results.get(f"{name}/fit")
    if e is None or name not in ANCHORS:
        return ""
    v = e["values"]
    lines = ["| run | views | test PSNR [dB] | SSIM | training | hardware |", "|---|---|---|---|---|---|",
             f"| `{name}/fit` ({v['recipe']}) | {v.get('size', '?')} | {v['psnr']:.2f} | {v['ssim']:.3f} | "
             f"{v['train_s']:.0f} s, {v['steps']} steps | {machine_line(e['machine'])} |"]
    lines += [f"| {who} (published) | {size} | {db} | | {when} | {gpu} |" for who, db, when, gpu, size in ANCHORS[name]]
    return "\n".join(lines) + "\n"


REPORTED_PRESET = 27.8
"""The figure a user reported for the plain grid on a glossy 2D dataset, 10 s (dB)."""


def glossy_figure(results: dict, path: Path) -> Path | None:
    """Test PSNR against the material's roughness, 2D and 3D side by side; None when nothing is recorded."""
    from mitnerf.viz.panels import pyplot, save

    panels = [(k, goal) for k, goal in (("glossy/2d", 33.0), ("glossy/3d", 30.0)) if k in results]
    if not panels:
        return None
    plt = pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 3.6), squeeze=False)
    for ax, (key, goal) in zip(axes[0], panels):
        values = results[key]["values"]
        alphas = sorted(values, key=float)
        for name, style in (("grid", "o-"), ("hashlinear", "s-"), ("outline_harmonics", "k^--")):
            if all(name in values[a] for a in alphas):
                label = "appearance on the exact outline" if name == "outline_harmonics" else name
                ax.plot([float(a) for a in alphas], [values[a][name]["psnr"] for a in alphas], style, label=label)
        preset = results.get("glossy/preset", {}).get("values", {}) if key == "glossy/2d" else {}
        shown = [a for a in alphas if f"bunny_glossy_r{a}" in preset]
        if shown:           # the plain grid: where it meets the reported figure is a roughness like theirs
            ax.plot([float(a) for a in shown], [preset[f"bunny_glossy_r{a}"]["psnr"] for a in shown], "x:",
                    color="grey", label="plain grid")
            ax.axhline(REPORTED_PRESET, color="grey", lw=0.8, ls="--",
                       label=f"that preset on the report's data, {REPORTED_PRESET:g} dB")
        ax.axhline(goal, color="r", lw=0.8, ls=":", label=f"goal {goal:g} dB")
        ax.set(title=f"{key}: {'bunny, 10 s' if key.endswith('2d') else 'vase, 60 s'}", xlabel="roughness (GGX alpha)",
               ylabel="test PSNR [dB]", xscale="log")
        ax.set_xticks([float(a) for a in alphas], alphas, minor=False)
        ax.set_xticks([], minor=True)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save(fig, path)
    return path


def main() -> int:
    results = load_results()
    if not results:
        print("results.json is empty: run the benchmarks first (`make bench`)")
        return 1
    groups: dict[str, dict] = {}
    for key, e in results.items():
        groups.setdefault(key.split("/")[0], {})[key] = e
    text = ["# Measured results\n", "Generated by `python benchmarks/report.py` from `results.json`; every figure "
            "names the command that produced it and the machine it ran on. Do not edit by hand.\n"]
    for area, entries in groups.items():
        text += [f"## {area}\n", tables(entries)]
        text += [rows_table(k, e) for k, e in entries.items() if k.startswith("fits/") and "rows" in e["values"]]
        if area == "lego":
            text.append(lego_table(results))
        if area in ("fern", "fox"):
            text.append(captures_table(results, area))
    (ROOT / "RESULTS.md").write_text("\n".join(text))
    readme = ROOT / "README.md"
    chosen = {k: results[k] for k in README_KEYS if k in results}
    body = f"{BEGIN}\n{tables(chosen)}\nAll figures: [RESULTS.md](RESULTS.md).\n{END}"
    old = readme.read_text()
    if BEGIN in old:
        readme.write_text(re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda _: body, old, flags=re.S))
    from mitnerf.experiments.reproduction import document, figure

    (ROOT / "docs").mkdir(exist_ok=True)
    fig = figure(results, ROOT / "docs" / "reproduction.png")
    glossy_figure(results, ROOT / "docs" / "glossy.png")
    (ROOT / "REPRODUCTION.md").write_text(document(results, "docs/reproduction.png" if fig else None,
                                                   "python benchmarks/report.py"))
    print(f"wrote RESULTS.md ({len(results)} figures), REPRODUCTION.md and the README's table ({len(chosen)} rows)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
