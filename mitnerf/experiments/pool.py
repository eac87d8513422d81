"""Run independent jobs in worker processes or on a Dask cluster; yield results as they finish.

* ``local``: ``concurrent.futures.ProcessPoolExecutor`` on the ``spawn`` context, each
  worker initialised once (thread counts, imports) by ``init(*init_args)``;
* ``dask``: ``dask.distributed.Client(scheduler)`` (start a cluster with ``dask scheduler``
  and ``dask worker tcp://HOST:8786 --nthreads 1 --nworkers N`` where mitnerf is installed).

``fn(job)`` must not raise (it returns its own failure record); a worker that dies (out of
memory, a crash) is turned into ``on_error(job, exception)``.
"""

from __future__ import annotations

import os
from typing import Callable, Iterator

from ..errors import ConfigError, EnvironmentProblem


def run_jobs(fn: Callable, jobs: list, executor: str = "local", workers: int = 1, scheduler: str | None = None,
             init: Callable | None = None, init_args: tuple = (), on_error: Callable | None = None) -> Iterator:
    if executor == "local":
        yield from _local(fn, jobs, workers, init, init_args, on_error)
    elif executor == "dask":
        if not scheduler:
            raise ConfigError("the dask executor needs a scheduler; pass --scheduler tcp://HOST:8786")
        yield from _dask(fn, jobs, scheduler, on_error)
    else:
        raise ConfigError(f"unknown executor {executor!r}; choose local or dask")


def _local(fn, jobs, workers, init, init_args, on_error) -> Iterator:
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=max(1, workers), mp_context=mp.get_context("spawn"), initializer=init,
                             initargs=init_args) as pool:
        futures = {pool.submit(fn, j): j for j in jobs}
        try:
            for fut in as_completed(futures):
                exc = fut.exception()
                yield on_error(futures[fut], exc) if exc is not None else fut.result()
        finally:
            for fut in futures:       # interrupted: do not start what is still queued
                fut.cancel()


def _dask(fn, jobs, address, on_error) -> Iterator:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise EnvironmentProblem("the dask executor needs dask.distributed: pip install -e .[dask]") from None
    try:
        client = Client(address, timeout="20s")
    except OSError as exc:
        raise EnvironmentProblem(f"cannot reach the Dask scheduler at {address} ({exc}); start one with "
                                 "'dask scheduler' and pass its address, or use --executor local") from None
    try:
        futures = {client.submit(fn, j, key=f"mitnerf-{os.getpid()}-{i}", pure=False): j for i, j in enumerate(jobs)}
        by_key = {f.key: j for f, j in futures.items()}
        for fut in as_completed(list(futures)):
            try:
                yield fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker
                yield on_error(by_key[fut.key], exc)
    finally:
        client.close()
