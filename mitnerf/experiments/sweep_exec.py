"""Running the rows of a sweep (:mod:`.sweep`): one row, a pool of them, the CSV.

:func:`run_row` is the unit of work: it loads the row's dataset (``cached_dataset``),
fits, evaluates on the test split and returns one CSV record (``COLUMNS``). It never
raises: an exception, :class:`~mitnerf.train.trainer.TrainingFailed` included, comes
back as ``status='failed'`` with the error. It sets the thread counts of Dr.Jit and torch
itself (:func:`prepare_worker`), so it behaves the same in a local worker and on a Dask
worker. ``wall_time`` is the clock around ``fit``: model set-up, kernel compilation (Dr.Jit
reuses its kernel cache, ``~/.drjit``), training and the final validation; the process's
one-time imports are done before it.

:func:`execute` yields records as runs finish, from

* ``local``: ``concurrent.futures.ProcessPoolExecutor`` on the ``spawn`` context
  (``workers`` processes, each initialised to ``threads`` threads);
* ``dask``: ``dask.distributed.Client(scheduler)``; the same function is submitted and
  results are gathered as they complete (``distributed.as_completed``). Start a cluster
  with ``dask scheduler`` and ``dask worker tcp://HOST:8786 --nthreads 1 --nworkers N``
  on machines where ``mitnerf`` is installed (each renders or caches its own datasets).

A worker that dies (out of memory, a crash) fails its row with the reason.
"""

from __future__ import annotations

import csv
import gc
import io
import json
import os
import socket
import time
from pathlib import Path
from typing import Iterator

COLUMNS = ["id", "scene", "family", "size", "samples", "backend", "budget", "reference", "status",
           "psnr", "ssim", "wall_time", "train_time", "steps", "depth_error", "eval_time",
           "render_time_per_view", "final_val_psnr", "threads", "host", "error", "config"]
"""Columns of ``sweep.csv``; ``config`` is the row's JSON (scene, rig, backend, model, train)."""


def prepare_worker(threads: int) -> None:
    """Thread counts of Dr.Jit and torch in this process, and the one-time imports done here
    (torch imports ``torch._dynamo`` on its first optimiser: ~3 s that are no run's cost)."""
    import drjit as dr

    import mitnerf  # noqa: F401  (selects the variant, checks LLVM)
    from ..train import backend_drjit, trainer  # noqa: F401

    dr.set_thread_count(int(threads))
    try:
        import torch
    except ImportError:  # torch is an extra: drjit rows still run
        return
    from ..train import backend_torch  # noqa: F401

    torch.set_num_threads(int(threads))
    torch.optim.Adam([torch.zeros(1, requires_grad=True)])


def _record(row: dict, **values) -> dict:
    rec = {k: row.get(k, "") for k in ("id", "scene", "family", "size", "samples", "backend", "budget", "reference")}
    rec.update(threads=row["train"]["threads"], host=socket.gethostname(), error="",
               config=json.dumps({k: row[k] for k in ("scene", "rig", "backend", "model", "train")}, sort_keys=True))
    rec.update(values)
    return rec


def run_row(row: dict) -> dict:
    """Fit and evaluate one row; returns its record (never raises)."""
    try:
        prepare_worker(row["train"]["threads"])
        from ..data.rig import RigConfig
        from ..train.config import ModelConfig, TrainConfig
        from ..train.trainer import evaluate, fit
        from .common import cached_dataset

        dataset = cached_dataset(row["scene"], RigConfig(**row["rig"]))
        mc, tc = ModelConfig.from_dict(row["model"]), TrainConfig(**row["train"])
        t0 = time.perf_counter()
        run = fit(dataset, mc, tc, row["backend"])       # same path as fit_and_report, timed alone
        wall = time.perf_counter() - t0
        t1 = time.perf_counter()
        ev = evaluate(run, dataset, "test")
        eval_time = time.perf_counter() - t1
        val = run.history["val_psnr"]
        return _record(row, status="ok", psnr=float(ev["psnr"]), ssim=float(ev["ssim"]), wall_time=wall,
                       train_time=run.train_time, steps=run.steps, depth_error=float(ev.get("depth_error", "nan")),
                       eval_time=eval_time, render_time_per_view=float(ev["render_time_per_view"]),
                       final_val_psnr=float(val[-1]) if val else "")
    except Exception as exc:  # noqa: BLE001 - a failed row is a result, not the end of the sweep
        return _record(row, status="failed", error=f"{type(exc).__name__}: {exc}"[:500])
    finally:
        gc.collect()


def _failed(row: dict, exc: BaseException) -> dict:
    return _record(row, status="failed", error=f"worker died: {type(exc).__name__}: {exc}"[:500])


def execute(rows: list[dict], cfg) -> Iterator[dict]:
    """Run ``rows`` on ``cfg.executor``; yield records in order of completion (with a bar)."""
    from tqdm.auto import tqdm

    from ..errors import MitnerfError

    if cfg.executor == "local":
        gen = _local(rows, cfg.workers)
    elif cfg.executor == "dask":
        if not cfg.scheduler:
            raise MitnerfError("the dask executor needs a scheduler; pass --scheduler tcp://HOST:8786")
        gen = _dask(rows, cfg.scheduler)
    else:
        raise MitnerfError(f"unknown executor {cfg.executor!r}; choose local or dask")
    with tqdm(total=len(rows), desc="sweep", unit="run", disable=not cfg.progress) as bar:
        for rec in gen:
            bar.update(1)
            bar.set_postfix_str(f"{rec['scene']} {rec['family']} {rec['size']} {rec['backend']} {rec['status']}")
            yield rec


def _local(rows: list[dict], workers: int) -> Iterator[dict]:
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    threads = rows[0]["train"]["threads"]
    with ProcessPoolExecutor(max_workers=max(1, workers), mp_context=mp.get_context("spawn"),
                             initializer=prepare_worker, initargs=(threads,)) as pool:
        futures = {pool.submit(run_row, r): r for r in rows}
        try:
            for fut in as_completed(futures):
                exc = fut.exception()
                yield _failed(futures[fut], exc) if exc is not None else fut.result()
        finally:
            for fut in futures:       # interrupted: do not start what is still queued
                fut.cancel()


def _dask(rows: list[dict], address: str) -> Iterator[dict]:
    from ..errors import MitnerfError

    try:
        from distributed import Client, as_completed
    except ImportError:
        raise MitnerfError("the dask executor needs dask.distributed; pip install -e .[dask]") from None
    try:
        client = Client(address, timeout="20s")
    except OSError as exc:
        raise MitnerfError(f"cannot reach the Dask scheduler at {address} ({exc}); start one with "
                           "'dask scheduler' and pass its address, or use --executor local") from None
    try:
        futures = {client.submit(run_row, r, key=f"mitnerf-sweep-{r['id']}-{os.getpid()}", pure=False): r
                   for r in rows}
        by_key = {f.key: r for f, r in futures.items()}
        for fut in as_completed(list(futures)):
            try:
                yield fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker
                yield _failed(by_key[fut.key], exc)
    finally:
        client.close()


# ----------------------------------------------------------------------------- data and the CSV
def prepare_datasets(rows: list[dict], progress: bool = True) -> None:
    """Render each row's dataset once, here, so that parallel workers only read the cache."""
    from tqdm.auto import tqdm

    from ..data.rig import RigConfig
    from .common import cached_dataset

    keys = {json.dumps([r["scene"], r["rig"]], sort_keys=True) for r in rows}
    for key in tqdm(sorted(keys), desc="datasets", disable=not progress, leave=False):
        scene, rig = json.loads(key)
        cached_dataset(scene, RigConfig(**rig))


def append_result(path: Path, record: dict) -> None:
    """Append one record to the CSV (header first when the file is new), flushed at once.
    A torn last line (a write killed midway) is cut off first."""
    path = Path(path)
    if path.exists() and path.stat().st_size:
        data = path.read_bytes()
        if not data.endswith(b"\n"):
            with open(path, "r+b") as f:
                f.truncate(data.rfind(b"\n") + 1)
    new = not path.exists() or path.stat().st_size == 0
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        if new:
            w.writeheader()
        w.writerow(record)
        f.flush()
        os.fsync(f.fileno())


def read_results(path: Path) -> list[dict]:
    """The complete records of the CSV, the last one of each id (a retried row replaces its failure)."""
    if not Path(path).exists():
        return []
    text = Path(path).read_text()
    text = text[:text.rfind("\n") + 1]            # without a torn last line
    recs = [r for r in csv.DictReader(io.StringIO(text, newline=""))
            if r.get("status") in ("ok", "failed") and _complete(r)]
    return list({r["id"]: r for r in recs}.values())


def _complete(record: dict) -> bool:
    try:
        return isinstance(json.loads(record.get("config") or ""), dict)
    except ValueError:
        return False


def finished_ids(path: Path, retry_failed: bool = False) -> set[str]:
    return {r["id"] for r in read_results(path) if not (retry_failed and r["status"] != "ok")}
