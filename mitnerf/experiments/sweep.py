"""Speed against accuracy: which model is enough for a scene, and what it costs.

``mitnerf sweep --out DIR`` trains the grid ``scenes x families x sizes x SAMPLES x backends x
BUDGETS`` (the sizes: :data:`~mitnerf.train.recipes.SWEEP_SIZES`; ``torch`` runs those in ``TORCH_SIZES``) plus the torch ``REFERENCE``, and writes into
``DIR``: ``sweep.csv``, one line per run (``COLUMNS``; ``wall_time`` is the clock around ``fit``:
set-up, compilation, training), appended as runs finish, so a rerun skips the rows already there;
``sweep.md``, per scene its Pareto front and its table, and whether some run reaches the reference's
PSNR in 1/:data:`~mitnerf.experiments.claims.SPEEDUP` of its time (not in a quick sweep: a smoke test);
``pareto.png``, PSNR against wall time.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import json
import multiprocessing as mp
import os
import socket
import time
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import drjit as dr
from tqdm.auto import tqdm

from .._io import digest
from .._variant import set_variant
from ..data.cache import cached_dataset
from ..data.rig import RigConfig, noise_preset
from ..errors import ConfigError, EnvironmentProblem
from ..scenes.objects3d import OBJECTS_3D
from ..scenes.registry import SCENES_2D
from ..train.fit import fit_and_evaluate
from ..train.recipes import SWEEP_SIZES as SIZES, Recipe, recipe_for
from ..viz.panels import series_figure
from ..settings import setting
from .claims import judged
from .report import is_reference, markdown_table, num, pareto_front, write_report

SAMPLES = (32, 64, 128)
"""Coarse samples per ray (a fine pass gets half as many)."""
BUDGETS = ("3s", "10s", "30s")
TORCH_SIZES = ("recipe",)
REFERENCE = dict(scene="bunny", family="vanilla", backend="torch", budget="600s")
QUICK = dict(sizes={"vanilla": {"w16": dict(width=16, depth=2, pos_L=4, dir_L=2)},
                    "grid": {"r17": dict(resolution=17, initial_resolution=17, upsample_at=())},
                    "hashgrid": {"T10": dict(n_levels=4, log2_hashmap_size=10, hidden=8, geo_features=3)}},
             samples=(16,), budgets=("15it",), reference="30it", train=dict(batch_rays=256, warmup=5))
SCENES = ("bunny", "square", "tu", "vase")
COLUMNS = ["id", "scene", "family", "size", "samples", "backend", "budget", "reference", "status", "reason", "psnr",
           "ssim", "iou", "chamfer", "wall_time", "train_time", "steps", "render_time", "params", "host", "config"]


@dataclass
class Config:
    """What to sweep and where to run it."""

    scenes: tuple = setting(SCENES, flag="--scenes")
    """Scene names (2D and 3D)."""
    budgets: tuple | None = setting(None, flag="--budgets", metavar="20s|500it", shown=" ".join(BUDGETS))
    """Training budgets: seconds (20s) or steps (500it)."""
    reference: bool = setting(True, flag="--reference")
    """Add the torch reference row (when its scene is swept)."""
    workers: int = setting(1, lo=1, hi=256, flag="--workers")
    """Parallel runs (local processes)."""
    threads: int = setting(2, lo=1, hi=256, flag="--threads")
    """CPU threads of each run."""
    executor: str = setting("local", choices=("local", "dask"), flag="--executor")
    """``local`` or ``dask``."""
    scheduler: str | None = setting(None, flag="--scheduler", metavar="ADDRESS", shown="none; --executor dask "
                                    "needs one")
    """The Dask scheduler's address, e.g. tcp://10.0.0.5:8786."""
    quick: bool = setting(False, flag="--quick")
    """Tiny rigs and models, a few steps: a smoke test."""
    retry_failed: bool = setting(False, flag="--retry-failed")
    """Rerun rows recorded as failed."""
    seed: int = setting(0, lo=0, hi=2 ** 31, flag="--seed")
    """Seed of the rigs and the runs."""
    families: tuple = setting(factory=lambda: tuple(SIZES), choices=tuple(SIZES), flag="--families")
    """Field families to sweep."""


def quick(seed: int = 0) -> Config:
    return Config(scenes=("square",), quick=True, seed=seed)


def parse_budget(text: str) -> dict:
    """``"20s"`` -> 20 s of training; ``"500it"`` -> 500 steps."""
    t = str(text).strip().lower()
    with contextlib.suppress(ValueError):
        if t.endswith("it") and int(t[:-2]) > 0:
            return {"iters": int(t[:-2])}
        if t.endswith("s") and 0 < float(t[:-1]) < 1e7:
            return {"time_budget": float(t[:-1])}
    raise ConfigError(f"cannot read the budget {text!r}; write seconds as '20s' or steps as '500it'")


def scene_rig(scene: str, quick: bool, seed: int) -> RigConfig:
    if scene in SCENES_2D:
        return RigConfig(dim=2, n_train=8 if quick else 50, n_val=2 if quick else 4, n_test=4 if quick else 20,
                         resolution=32 if quick else 100, seed=seed, **noise_preset(1.0))
    if scene in OBJECTS_3D:
        return RigConfig(dim=3, n_train=6 if quick else 25, n_val=1 if quick else 2, n_test=2 if quick else 8,
                         resolution=16 if quick else 100, seed=seed, **noise_preset(1.0))
    raise ConfigError(f"the sweep knows no scene {scene!r}; choose from {', '.join(SCENES_2D + OBJECTS_3D)}")


def make_row(scene: str, rig: RigConfig, family: str, size: str, args: dict, samples: int | None, backend: str,
             budget: str, cfg: Config, reference: bool = False) -> dict:
    r = recipe_for(family, rig.dim)
    if args and all(isinstance(k, int) for k in args):
        args = args.get(rig.dim, {})
    overrides = dict(args, val_every=0, seed=cfg.seed, threads=cfg.threads, progress=False, **parse_budget(budget))
    if samples is not None:
        overrides.update(n_coarse=samples, n_fine=samples // 2 if r.model.render.n_fine else None)
    r = r.override(**overrides, **(QUICK["train"] if cfg.quick else {}))
    if "iters" in parse_budget(budget):
        r = r.at_steps(r.train.iters)
    row = {"scene": scene, "rig": dataclasses.asdict(rig), "backend": backend, "recipe": r.to_dict(),
           "reference": reference}
    row["id"] = digest(json.dumps(row, sort_keys=True, default=list))
    return {**row, "family": family, "size": size, "samples": r.model.render.n_coarse, "budget": budget}


def build_rows(cfg: Config) -> list[dict]:
    """Every row of the sweep, the reference first (the longest run)."""
    sizes = QUICK["sizes"] if cfg.quick else SIZES
    samples = QUICK["samples"] if cfg.quick else SAMPLES
    budgets = cfg.budgets or (QUICK["budgets"] if cfg.quick else BUDGETS)
    rigs = {s: scene_rig(s, cfg.quick, cfg.seed) for s in cfg.scenes}
    rows = []
    if cfg.reference and REFERENCE["scene"] in rigs:
        rows.append(make_row(REFERENCE["scene"], rigs[REFERENCE["scene"]], "vanilla", "recipe", {}, None, "torch",
                             QUICK["reference"] if cfg.quick else REFERENCE["budget"], cfg, reference=True))
    for scene, rig in rigs.items():
        for family in cfg.families:
            for size, args in sizes.get(family, {}).items():
                backends = ["drjit"] + (["torch"] if cfg.quick or size in TORCH_SIZES else [])
                rows += [make_row(scene, rig, family, size, args, n, b, budget, cfg)
                         for n in samples for b in backends for budget in budgets]
    return list({r["id"]: r for r in rows}.values())


def prepare_worker(threads: int) -> None:
    """The variant and Dr.Jit's thread count of a worker process (the torch engine sets its own)."""
    set_variant()
    dr.set_thread_count(int(threads))


def _record(row: dict, **values) -> dict:
    rec = {k: row.get(k, "") for k in ("id", "scene", "family", "size", "samples", "backend", "budget", "reference")}
    rec.update(host=socket.gethostname(), reason="",
               config=json.dumps({k: row[k] for k in ("scene", "rig", "backend", "recipe")}, sort_keys=True))
    return {**rec, **values}


def run_row(row: dict) -> dict:
    """Fit and evaluate one row; returns its record (never raises)."""
    try:
        prepare_worker(row["recipe"]["train"]["threads"])
        ds = cached_dataset(row["scene"], RigConfig(**row["rig"]))
        t0 = time.perf_counter()
        _, rec = fit_and_evaluate(ds, Recipe.from_dict(row["recipe"]), row["backend"])
        return _record(row, **{k: v for k, v in rec.row().items() if k in COLUMNS},
                       wall_time=time.perf_counter() - t0)
    except Exception as exc:  # noqa: BLE001 - a failed row is a result, not the end of the sweep
        return _record(row, status="failed", reason=f"{type(exc).__name__}: {exc}"[:500])


def append_result(path: Path, record: dict) -> None:
    """Append one record (header first for a new file); a torn last line is cut off first."""
    data = path.read_bytes() if path.exists() else b""
    if data and not data.endswith(b"\n"):
        with open(path, "r+b") as f:
            f.truncate(data.rfind(b"\n") + 1)
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        if b"\n" not in data:
            w.writeheader()
        w.writerow(record)
        f.flush()
        os.fsync(f.fileno())


def read_results(path: Path) -> list[dict]:
    """The complete records of the CSV, the last one of each id."""
    if not path.exists():
        return []
    text = path.read_text()
    text = text[:text.rfind("\n") + 1]
    recs = {}
    for r in csv.DictReader(io.StringIO(text, newline="")):
        with contextlib.suppress(ValueError):
            if isinstance(json.loads(r.get("config") or ""), dict) and r.get("status"):
                recs[r["id"]] = r
    return list(recs.values())


@contextlib.contextmanager
def executor(cfg: Config) -> Iterator[Executor]:
    """``cfg.workers`` local processes, or the Dask cluster at ``cfg.scheduler`` (``dask scheduler``; ``dask worker
    tcp://HOST:8786 --nthreads 1 --nworkers N`` where mitnerf is installed)."""
    if cfg.executor == "local":
        with ProcessPoolExecutor(max_workers=max(1, cfg.workers), mp_context=mp.get_context("spawn"),
                                 initializer=prepare_worker, initargs=(cfg.threads,)) as pool:
            yield pool
        return
    if cfg.executor != "dask":
        raise ConfigError(f"unknown executor {cfg.executor!r}; choose local or dask")
    if not cfg.scheduler:
        raise ConfigError("the dask executor needs a scheduler; pass --scheduler tcp://HOST:8786")
    try:
        from distributed import Client
    except ImportError:
        raise EnvironmentProblem("the dask executor needs dask.distributed: pip install -e .[dask]") from None
    try:
        client = Client(cfg.scheduler, timeout="20s")
    except OSError as exc:
        raise EnvironmentProblem(f"cannot reach the Dask scheduler at {cfg.scheduler} ({exc}); start one with "
                                 "'dask scheduler' and pass its address, or use --executor local") from None
    try:
        yield client.get_executor(pure=False)
    finally:
        client.close()


def run_jobs(fn: Callable, jobs: list, cfg: Config) -> Iterator[dict]:
    """``fn(job)`` of every job, yielded as they finish, on the :func:`executor` of ``cfg``. ``fn`` must not raise;
    a worker that dies (or a Dask ``KilledWorker``) gives a failed record."""
    with executor(cfg) as pool:
        futures = {pool.submit(fn, j): j for j in jobs}
        try:
            for fut in as_completed(futures):
                exc = fut.exception()
                yield fut.result() if exc is None else _record(
                    futures[fut], status="failed", reason=f"worker died: {type(exc).__name__}: {exc}"[:500])
        finally:
            for fut in futures:       # interrupted: do not start what is still queued
                fut.cancel()


def run(cfg: Config, out: Path, progress: bool = True) -> list[dict]:
    """Run the rows not yet in ``out/sweep.csv``, then write ``sweep.md`` and ``pareto.png``."""
    csv_path = out / "sweep.csv"
    rows = build_rows(cfg)
    done = {r["id"] for r in read_results(csv_path) if not (cfg.retry_failed and r["status"] != "ok")}
    todo = [r for r in rows if r["id"] not in done]
    for key in sorted({json.dumps([r["scene"], r["rig"]], sort_keys=True) for r in todo}):
        scene, rig = json.loads(key)
        cached_dataset(scene, RigConfig(**rig))          # rendered here once; workers only read the cache
    with tqdm(total=len(todo), desc="sweep", unit="run", disable=not progress) as bar:
        for rec in run_jobs(run_row, todo, cfg):
            append_result(csv_path, rec)
            bar.update(1)
    rows = read_results(csv_path)
    scenes = {s: [r for r in rows if r["scene"] == s] for s in dict.fromkeys(r["scene"] for r in rows)}
    front = {s: pareto_front(rs) for s, rs in scenes.items()}
    series_figure(out / "pareto.png", [dict(  # each family and backend, the reference labelled, the front dashed
        title=s, x="wall_time", by=("run",), err=False, xscale="log", xlabel="wall time of fit (s)", rows=[
            {**r, "run": f"{r['family']}, {r['backend']}", **({"label": "torch reference"} if is_reference(r) else {})}
            for r in rs] + [{**r, "run": "Pareto front"} for r in front[s]],
        styles={**{f"{r['family']}, {r['backend']}": "o" for r in rs}, "Pareto front": "k--"})
        for s, rs in scenes.items()], cell=(6.0, 4.2))
    cols = ["family", "size", "samples", "backend", "budget", "psnr", "ssim", "wall_time", "steps", "front", "id"]
    sections = [("Test PSNR against wall time", "![test PSNR against wall time](pareto.png)")]
    for scene, rs in scenes.items():
        ids = {r["id"] for r in front[scene]}
        table = [{**r, "front": "yes" if r["id"] in ids else ""} for r in sorted(rs, key=lambda r: num(r["wall_time"]))]
        sections.append((scene, markdown_table([r for r in table if r["status"] == "ok"], cols,
                                               {"psnr": ".2f", "ssim": ".3f", "wall_time": ".2f"})))
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        sections.append(("Failed runs", markdown_table(failed, ["scene", "family", "size", "backend", "budget",
                                                                "status", "reason"])))
    write_report(out, "Speed against accuracy", sections, cfg.quick, lambda: judged("sweep", rows), name="sweep.md")
    return rows
