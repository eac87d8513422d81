"""What users bring, fitted: scene x field family x options -> PSNR, geometry, seconds.

Every 2D scene (the NeRF2D protocol: 50 noisy views of 100 px, 4 validation, 8 test views)
is fitted by each family's recipe (``grid-2d``, ``hashlinear-2d``, ``hashgrid-2d``, ``vanilla-2d``) for
``--budget`` seconds with each option set of :func:`options` (view dependence on or off, the
regularisers on or off; the recipe's own set is marked), then by ``mitnerf fit --auto``'s
choice (marked ``auto``; its probes train as long as the rows, the search stops after 150 s,
and its time is counted). The 3D rows fit a glossy vase (25 views of 100 x 100) for
``--budget-3d`` seconds (plain, view dependence, with the losses, with the depth losses too). The default
recipe is also run for ``--long`` seconds on the ``--long-scenes``: test PSNR must not fall
with more training (the best validation checkpoint is kept). Every row: test PSNR, SSIM,
IoU (2D) or Chamfer distance (3D), parameters, training seconds. Before its timed run, every row trains untimed
past its schedule's last change (``_common.warm_kernels``), so its budget buys steps, not kernel compilation.
Prints the table and records it in ``results.json`` (``fits/<scene>``, ``fits/longer``);
``--redo`` reruns the named families' rows (or ``auto``, or the ``longer`` runs) and keeps the other rows as recorded.

    python benchmarks/fit_table.py [--scenes bunny bunny_glossy square_concave tu] [--budget 10]
                                   [--budget-3d 60] [--long 300] [--long-scenes bunny ...]
                                   [--no-auto] [--no-3d] [--redo grid hashlinear hashgrid vanilla auto longer]
"""

from __future__ import annotations

import argparse
import sys
import time

from mitnerf.data.cache import cached_dataset
from mitnerf.data.rig import RigConfig, noise_preset
from mitnerf.results import load_results, record_result
from mitnerf.train.auto import AutoConfig, choose_recipe, regulariser_weights
from mitnerf.train.fit import fit_and_evaluate
from mitnerf.train.recipes import recipe_for

if __package__:                        # imported as benchmarks.fit_table (the tests)
    from ._common import warm_kernels
else:                                  # run as python benchmarks/fit_table.py
    from _common import warm_kernels   # (importing _common chooses the Mitsuba variant)

DEPTH_LOSSES = ("free_space_weight", "solid_weight")


def options(dim: int) -> dict[str, dict]:
    """Option sets, each stating every option, applied on top of each family's recipe (the colour total variation
    only where the family has it: a set that then repeats an earlier one is skipped); the row whose set is the
    recipe's own is marked ``[recipe]``. "reg." is the colour total variation, the distortion and the opacity loss
    at the weights ``fit --auto`` switches them on with in ``dim`` (:func:`regulariser_weights`); "free space" and
    "solid" the losses on the dataset's depth maps (our scenes carry them), at the weights of the same recipe."""
    reg = dict(regulariser_weights(AutoConfig(), dim))
    depth = {k: recipe_for(None, dim).get(k) for k in DEPTH_LOSSES}
    off = {"view_dependent": False, **{k: 0.0 for k in (*reg, *depth)}}
    return {
        "plain": off,
        "view dependence": {**off, "view_dependent": True},
        "regularised": {**off, **reg},
        "view dep. + dist. + opacity": {**off, **reg, "view_dependent": True, "tv_color_weight": 0.0},
        "view dep. + reg.": {**off, "view_dependent": True, **reg},
        "view dep. + reg. + free space": {**off, "view_dependent": True, **reg,
                                          "free_space_weight": depth["free_space_weight"]},
        "view dep. + reg. + free space + solid": {**off, "view_dependent": True, **reg, **depth},
    }


OPTIONS_3D = ("plain", "view dependence", "view dep. + reg.", "view dep. + reg. + free space + solid")
"""The option sets of the 3D rows (a minute each)."""
FAMILIES = ("grid", "hashlinear", "hashgrid", "vanilla")


def dataset(scene: str, dim: int):
    if dim == 2:
        return cached_dataset(scene, RigConfig(dim=2, n_train=50, n_val=4, n_test=8, seed=0, **noise_preset(1.0)))
    return cached_dataset(scene, RigConfig(dim=3, n_train=25, n_val=2, n_test=8, resolution=100, seed=0,
                                           **noise_preset(1.0)))


def row(ds, recipe, label: str, extra_time: float = 0.0) -> dict:
    warm_kernels(ds, recipe)
    _, rec = fit_and_evaluate(ds, recipe)
    geo = rec.iou if ds.dim == 2 else rec.chamfer
    return {"run": label, "recipe": recipe.name, "psnr": rec.psnr, "ssim": rec.ssim, "geometry": geo,
            "params": rec.params, "seconds": rec.train_time + extra_time, "status": rec.status}


def longer(ds, recipe, budget: float, long: float, short: dict | None = None) -> tuple[dict, dict]:
    """The rows of ``recipe`` trained ``budget`` and ``long`` seconds (``short``: the first, already measured)."""
    short = short or row(ds, recipe.override(time_budget=budget, progress=False), f"{recipe.name}, {budget:g} s")
    long_row = row(ds, recipe.override(time_budget=long, iters=10 ** 6, progress=False), f"{recipe.name}, {long:g} s")
    return short, long_row


def show(scene: str, rows: list[dict], dim: int) -> None:
    geo = "IoU" if dim == 2 else "Chamfer"
    print(f"\n{scene}\n{'run':<54} {'PSNR':>6} {'SSIM':>6} {geo:>8} {'params':>9} {'s':>6}  status")
    for r in rows:
        print(f"{r['run']:<54} {r['psnr']:6.2f} {r['ssim']:6.3f} {r['geometry']:8.4f} {r['params']:9d} "
              f"{r['seconds']:6.1f}  {r['status']}", flush=True)


def table(ds, budget: float, auto: bool, names=None, families=FAMILIES) -> list[dict]:
    sets = options(ds.dim)
    rows = []
    for family in families:
        base = recipe_for(family, ds.dim).override(time_budget=budget, iters=10 ** 6, progress=False)
        done = []
        for name in names or sets:
            # only the options that differ: one set on the recipe stays fixed against the data (Sizing.fixed)
            r = base.override(**{k: v for k, v in sets[name].items() if base.has(k) and base.get(k) != v})
            if r.essence() in done:
                continue
            done.append(r.essence())
            rows.append(row(ds, r, f"{family}, {name}" + (" [recipe]" if r.essence() == base.essence() else "")))
    if auto:
        t0 = time.perf_counter()
        chosen, reasons = choose_recipe(ds, AutoConfig(time_budget=150), {"time_budget": budget, "progress": False})
        search = time.perf_counter() - t0
        rows.append({**row(ds, chosen, "auto", search), "why": "; ".join(r for r in reasons if "[" not in r)})
    return rows


def joined(old: str, new: str) -> str:
    """The commands that made an entry: the recorded ones, then ``new`` (once)."""
    parts = old.split(" && ")
    return " && ".join([p for p in parts if p != new] + [new])


def rows_for(key: str, ds, budget: float, args, auto: bool, names=None) -> tuple[list[dict], str]:
    """The table of one scene and the command that made it: every row, or with ``--redo`` the named families'
    (and ``auto``) rows anew and the others as recorded."""
    command = args.command
    if not args.redo:
        return table(ds, budget, auto, names), command
    old = load_results().get(key)
    if old is None:
        raise SystemExit(f"fit_table: no {key} in results.json; run without --redo first")
    new = table(ds, budget, auto and "auto" in args.redo, names, [f for f in FAMILIES if f in args.redo])
    kept = [r for r in old["values"]["rows"] if r["run"].split(",")[0] not in args.redo]
    order = {f: i for i, f in enumerate((*FAMILIES, "auto"))}
    rows = sorted(kept + new, key=lambda r: order[r["run"].split(",")[0]])          # stable: options keep their order
    if not new:                         # nothing of this table redone (--redo longer): its command stays
        return rows, old["command"]
    return rows, (joined(old["command"], command) if kept else command)


def record_longer(runs: dict, old: dict | None, args) -> None:
    """Record ``fits/longer`` (``{scene: {"short", "long"}}``) after each scene, so a long run is not lost
    to a later failure; ``old``: the recorded entry whose other scenes a ``--redo`` keeps."""
    command = args.command
    if old and set(old["values"]) - set(args.scenes):
        command = joined(old["command"], command)
    worst = min(v["long"] - v["short"] for v in runs.values())
    record_result("fits/longer", runs,
                  f"default 2D recipe, {args.budget:g} s -> {args.long:g} s: test PSNR change "
                  + ", ".join(f"{s} {v['long'] - v['short']:+.2f} dB" for s, v in runs.items())
                  + (" (never lower)" if worst >= 0 else " (lower on some scene)"), command)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="*", default=["bunny", "bunny_glossy", "square_concave", "tu"])
    p.add_argument("--budget", type=float, default=10.0)
    p.add_argument("--budget-3d", type=float, default=60.0)
    p.add_argument("--long", type=float, default=300.0)
    p.add_argument("--long-scenes", nargs="*", default=["bunny", "bunny_glossy", "square_concave", "tu"])
    p.add_argument("--no-auto", action="store_true")
    p.add_argument("--no-3d", action="store_true")
    p.add_argument("--redo", nargs="+", choices=(*FAMILIES, "auto", "longer"), help="rerun only these families' "
                   "rows (and the auto rows, the longer runs) after a change to them, keeping the others as recorded")
    args = p.parse_args(argv)
    args.command = " ".join(["python benchmarks/fit_table.py", *(argv if argv is not None else sys.argv[1:])])
    old_longer = load_results().get("fits/longer") if args.redo else None
    long_runs = dict(old_longer["values"]) if old_longer else {}
    for scene in args.scenes:
        ds = dataset(scene, 2)
        rows, command = rows_for(f"fits/{scene}", ds, args.budget, args, not args.no_auto)
        show(scene, rows, 2)
        best = max((r for r in rows if r["status"] == "ok"), key=lambda r: r["psnr"])
        auto = next((r for r in rows if r["run"] == "auto"), None)
        record_result(f"fits/{scene}", {"rows": rows, "geometry": "IoU"},
                      f"best {best['run']} {best['psnr']:.2f} dB, IoU {best['geometry']:.3f} in {args.budget:g} s"
                      + (f"; auto {auto['psnr']:.2f} dB, IoU {auto['geometry']:.3f} ({auto['recipe']})" if auto else ""),
                      command)
        if args.long and scene in args.long_scenes and (not args.redo or "longer" in args.redo):
            short, long = longer(ds, recipe_for(None, 2), args.budget, args.long)
            print(f"  longer training: {short['psnr']:.2f} dB at {args.budget:g} s -> {long['psnr']:.2f} dB at "
                  f"{args.long:g} s", flush=True)
            long_runs[scene] = {"short": short["psnr"], "long": long["psnr"]}
            record_longer(long_runs, old_longer, args)
    if not args.no_3d and set(args.redo or FAMILIES) & set(FAMILIES):
        ds = dataset("vase_glossy", 3)
        rows, command = rows_for("fits/vase_glossy", ds, args.budget_3d, args, False, OPTIONS_3D)
        show("vase_glossy (3D, 25 views)", rows, 3)
        best = max((r for r in rows if r["status"] == "ok"), key=lambda r: r["psnr"])
        record_result("fits/vase_glossy", {"rows": rows, "geometry": "Chamfer"},
                      f"best {best['run']} {best['psnr']:.2f} dB, Chamfer {best['geometry']:.4f} in {args.budget_3d:g} s",
                      command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
