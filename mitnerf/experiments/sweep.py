"""Speed against accuracy: which model is enough for a scene, and what it costs.

``python -m mitnerf sweep --out DIR`` (or ``benchmarks/pareto.py``, or
:func:`run_sweep`) trains a grid of configurations on a few scenes and writes, into
``DIR``:

* ``sweep.csv``: one line per run (``COLUMNS`` in :mod:`.sweep_exec`): scene, field
  family, size, samples, backend, budget, test PSNR and SSIM, ``wall_time`` (seconds of
  ``fit``: training, kernel compilation and the final validation), ``train_time`` (the
  trainer's clock: training steps only), steps, and the error of a run that failed;
* ``sweep.md``: the table per scene, the Pareto front of each scene (the runs that no
  faster run beats on test PSNR), and, when the torch reference ran, whether some
  configuration reaches its PSNR in at most 1/100 of its time;
* ``pareto.png``: test PSNR against wall time (log scale), one subplot per scene, one
  marker shape per field family, one colour per backend, the front as a step line.

The grid
--------
A row is (scene, backend, field family, field arguments, render arguments, train
arguments); its ``id`` is a hash of that row's canonical JSON. The default grid is
``scenes x families x SIZES x SAMPLES x backends x BUDGETS``:

* families: every family of ``mitnerf.fields.FIELDS`` with a preset
  (``mitnerf.train.presets.preset_fields()``); each size and sample count edits the
  family's preset for the scene's dimension;
* backends: ``drjit``, plus ``torch`` where the family has a PyTorch twin
  (``mitnerf.reference.fields.TORCH_FIELDS``);
* one special row, the *torch reference*: the vanilla preset on torch for 600 s on bunny.

To add a field family (say ``hashgrid``): register it in ``FIELDS`` and give it a preset;
it joins the grid at its preset size. For several sizes add a line to ``SIZES`` (and to
``QUICK_SIZES`` for a small one in quick mode), e.g.
``"hashgrid": {"T14": dict(log2_hashmap_size=14), "T18": dict(log2_hashmap_size=18)}``.

Budgets are ``"20s"`` (seconds of training; the learning-rate schedule follows the
clock) or ``"500it"`` (steps). Scenes: 2D ones use 50 noisy train views of 100 px
(seeded), 3D ones 25 views of 100 x 100 (3D runs cost ~100x more per view).
``--quick`` shrinks everything (tiny rigs, one tiny model, a few steps) to a smoke test.

Runs go to worker processes (``workers`` x ``threads`` should not exceed the cores) or,
with ``executor='dask'`` and a scheduler address, to a Dask distributed cluster. Each
result is appended to ``sweep.csv`` as it arrives; running the same command again skips
the rows already there (``retry_failed`` also reruns those that failed). The report and
the chart cover every record in ``sweep.csv``: give a quick sweep its own folder.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

from .._io import digest

# ----------------------------------------------------------------------------- the grid
SIZES: dict[str, dict[str, dict]] = {
    # family: {size label: field_args overrides on the family's preset, or {dim: overrides}}
    "vanilla": {"w32": dict(width=32), "preset": {}},
    "grid": {"small": {2: dict(resolution=129, initial_resolution=33, upsample_at=(100,)),
                       3: dict(resolution=65, initial_resolution=33, upsample_at=(200,))},
             "preset": {}},
    "hashgrid": {"T12": dict(log2_hashmap_size=12), "preset": {}},
}
SAMPLES = (32, 64, 128)
"""Coarse samples per ray; a preset with a fine pass gets ``n_fine = samples // 2``."""
BUDGETS = ("3s", "10s", "30s")
"""Training budget of every grid row."""
TORCH_SIZES = ("preset",)
"""Sizes that also run on the torch backend (the reference twin of every family)."""
REFERENCE = dict(scene="bunny", family="vanilla", backend="torch", budget="600s")
"""The torch reference (the family's preset, unchanged): the yardstick of ``sweep.md``."""

QUICK_SIZES: dict[str, dict[str, dict]] = {
    "vanilla": {"w16": dict(width=16, depth=2, pos_L=4, dir_L=2)},
    "grid": {"r17": dict(resolution=17, initial_resolution=17, upsample_at=())},
    "hashgrid": {"T10": dict(n_levels=4, log2_hashmap_size=10, hidden=8, geo_features=3)},
}
QUICK_SAMPLES = (16,)
QUICK_BUDGETS = ("15it",)
QUICK_REFERENCE_BUDGET = "30it"
QUICK_TRAIN = dict(batch_rays=256, warmup=5)
"""Train-argument overrides in quick mode."""

SCENES = ("bunny", "square", "tu", "vase")
"""Default scenes: three 2D outlines and one 3D object."""
SWEEP_TRAIN = dict(val_every=0, val_views=2, progress=False)
"""Train-argument overrides of every run (validation once, at the end; no bars in workers)."""


@dataclass(frozen=True)
class Spec:
    """One configuration of the grid, before a scene and a budget are chosen."""

    family: str
    """Field family (``mitnerf.fields.FIELDS``)."""
    size: str
    """Label of the size (a key of ``SIZES[family]``, or ``preset``)."""
    field_args: dict = field(default_factory=dict, hash=False)
    """Overrides of the preset's field arguments."""
    samples: int | None = None
    """Coarse samples per ray (None: the preset's)."""
    backend: str = "drjit"
    """``drjit`` or ``torch``."""


@dataclass
class SweepConfig:
    """What to sweep, where to run it, where to write it."""

    out: Path = Path("out/sweep")
    """Folder of ``sweep.csv``, ``sweep.md`` and ``pareto.png``."""
    scenes: list[str] = field(default_factory=lambda: list(SCENES))
    """Scene names (``mitnerf.scenes.registry.scene_names()``)."""
    configs: list[Spec] | None = None
    """Configurations; None: the default grid (:func:`default_specs`)."""
    budgets: list[str] | None = None
    """Budgets such as ``"20s"`` or ``"500it"``; None: ``BUDGETS`` (quick: ``QUICK_BUDGETS``)."""
    reference: bool = True
    """Add the torch reference row (when its scene is swept)."""
    workers: int = 1
    """Parallel runs (local processes)."""
    threads: int = 2
    """CPU threads of each run (Dr.Jit and torch)."""
    executor: str = "local"
    """``local`` (a pool of spawned processes) or ``dask`` (a distributed cluster)."""
    scheduler: str | None = None
    """Address of the Dask scheduler (``tcp://host:8786``); required with ``executor='dask'``."""
    quick: bool = False
    """Tiny rigs, one tiny model, a few steps: a smoke test of the whole pipeline."""
    seed: int = 0
    """Seed of the rigs, the initial weights and the batches."""
    retry_failed: bool = False
    """Also rerun rows recorded as failed."""
    progress: bool = True
    """Progress bar over the runs."""


def parse_budget(text: str) -> dict:
    """``"20s"`` -> ``{time_budget: 20, iters: 10**7}``; ``"500it"`` -> ``{iters: 500, time_budget: None}``."""
    from ..errors import MitnerfError

    t = str(text).strip().lower()
    try:
        if t.endswith("it"):
            return {"iters": int(t[:-2]), "time_budget": None}
        if t.endswith("s"):
            return {"iters": 10 ** 7, "time_budget": float(t[:-1])}
    except ValueError:
        pass
    raise MitnerfError(f"cannot read the budget {text!r}; write seconds as '20s' or steps as '500it'")


def default_specs(quick: bool = False) -> list[Spec]:
    """The default grid: families with presets x sizes x samples x backends."""
    from ..fields import FIELDS
    from ..reference.fields import TORCH_FIELDS
    from ..train.presets import preset_fields

    sizes, samples = (QUICK_SIZES, QUICK_SAMPLES) if quick else (SIZES, SAMPLES)
    specs = []
    for family in preset_fields():
        if family not in FIELDS:
            continue
        for size, args in sizes.get(family, {"preset": {}}).items():
            backends = ["drjit"] + (["torch"] if family in TORCH_FIELDS and (quick or size in TORCH_SIZES) else [])
            for n in samples:
                specs += [Spec(family, size, dict(args), n, b) for b in backends]
    return specs


def args_for_dim(args: dict, dim: int) -> dict:
    """Size overrides given per dimension (``{2: {...}, 3: {...}}``) or for both."""
    if args and all(isinstance(k, int) for k in args):
        return dict(args.get(dim, {}))
    return dict(args)


def scene_rig(scene: str, quick: bool, seed: int):
    """The rig of a scene: the NeRF2D protocol in 2D, 25 views of 100 x 100 in 3D."""
    from ..data.rig import RigConfig, noise_preset
    from ..errors import MitnerfError
    from ..scenes.registry import OBJECTS_3D, SCENES_2D

    if scene in SCENES_2D:
        if quick:
            return RigConfig(dim=2, n_train=8, n_val=2, n_test=4, resolution=32, seed=seed, **noise_preset(1.0))
        return RigConfig(dim=2, n_train=50, n_val=4, n_test=20, resolution=100, seed=seed, **noise_preset(1.0))
    if scene in OBJECTS_3D:
        if quick:
            return RigConfig(dim=3, n_train=6, n_val=1, n_test=2, resolution=16, seed=seed, **noise_preset(1.0))
        return RigConfig(dim=3, n_train=25, n_val=2, n_test=8, resolution=100, seed=seed, **noise_preset(1.0))
    raise MitnerfError(f"the sweep knows no scene {scene!r}; choose from {', '.join(SCENES_2D + OBJECTS_3D)}")


def make_row(scene: str, rig, spec: Spec, budget: str, quick: bool, seed: int, threads: int,
             reference: bool = False) -> dict:
    """A JSON-ready row: labels, the rig, the model and train configs, and its id."""
    from ..train.presets import preset

    mc, tc = preset(spec.family, rig.dim)
    mc.field_args.update(args_for_dim(spec.field_args, rig.dim))
    if spec.samples is not None:
        if mc.render.n_fine > 0:
            mc.render.n_fine = spec.samples // 2
        mc.render.n_coarse = spec.samples
    if rig.dim == 3:
        mc.render.background = (1.0, 1.0, 1.0)     # 3D datasets are composited over white
    train = {**dataclasses.asdict(tc), **SWEEP_TRAIN, **(QUICK_TRAIN if quick else {}), **parse_budget(budget),
             "seed": seed, "threads": threads}
    row = {"scene": scene, "rig": dataclasses.asdict(rig), "backend": spec.backend, "model": mc.to_dict(),
           "train": train, "reference": reference}
    row["id"] = digest(json.dumps(row, sort_keys=True, default=list))
    row.update(family=spec.family, size=spec.size, samples=mc.render.n_coarse, budget=budget)
    return row


def build_rows(cfg: SweepConfig) -> list[dict]:
    """Every row of the sweep, the reference first (the longest run)."""
    specs = cfg.configs if cfg.configs is not None else default_specs(cfg.quick)
    budgets = cfg.budgets or list(QUICK_BUDGETS if cfg.quick else BUDGETS)
    rigs = {s: scene_rig(s, cfg.quick, cfg.seed) for s in cfg.scenes}
    rows = []
    if cfg.reference and REFERENCE["scene"] in rigs:
        ref = Spec(REFERENCE["family"], "preset", {}, None, REFERENCE["backend"])
        budget = QUICK_REFERENCE_BUDGET if cfg.quick else REFERENCE["budget"]
        rows.append(make_row(REFERENCE["scene"], rigs[REFERENCE["scene"]], ref, budget, cfg.quick, cfg.seed,
                             cfg.threads, reference=True))
    for scene, rig in rigs.items():
        for spec in specs:
            rows += [make_row(scene, rig, spec, b, cfg.quick, cfg.seed, cfg.threads) for b in budgets]
    return list({r["id"]: r for r in rows}.values())       # a spec listed twice runs once


@dataclass
class SweepResult:
    """What :func:`run_sweep` did."""

    csv: Path
    """``sweep.csv``."""
    report: Path
    """``sweep.md``."""
    chart: Path
    """``pareto.png``."""
    ran: int
    """Rows run now."""
    skipped: int
    """Rows already in the CSV."""
    failed: int
    """Rows run now that failed."""


def run_sweep(cfg: SweepConfig) -> SweepResult:
    """Run the rows not yet in ``sweep.csv``, then write the report and the chart."""
    from . import sweep_exec
    from .pareto import write_outputs

    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "sweep.csv"
    rows = build_rows(cfg)
    done = sweep_exec.finished_ids(csv_path, retry_failed=cfg.retry_failed)
    todo = [r for r in rows if r["id"] not in done]
    failed = 0
    if todo:
        sweep_exec.prepare_datasets(todo, cfg.progress)
        for result in sweep_exec.execute(todo, cfg):
            sweep_exec.append_result(csv_path, result)
            failed += result["status"] != "ok"
    report, chart = write_outputs(csv_path, out)
    return SweepResult(csv_path, report, chart, len(todo), len(rows) - len(todo), failed)


def run(out: Path, quick: bool = False, seed: int = 0) -> Path:
    """The experiment interface (``mitnerf experiment sweep``): the default sweep, one run at a time."""
    return run_sweep(SweepConfig(out=Path(out), quick=quick, seed=seed)).report
