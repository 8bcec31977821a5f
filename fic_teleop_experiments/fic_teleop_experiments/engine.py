"""Where a sweep's runs execute (docs/CLUSTER.md): a concurrent.futures.Executor over this machine's cores or over a
cluster, behind one call, so that a sweep's code is the same everywhere.

- engine "pool" (the default): concurrent.futures.ProcessPoolExecutor, one process per worker on this machine;
- engine "dask": a Dask distributed Client on a LocalCluster of single-threaded worker processes on this machine;
- a cluster address (``--cluster tcp://host:8786``): a Dask Client to that running scheduler; its workers, wherever
  they run, execute the runs.

Both Dask cases hand the sweep ``Client.get_executor()``, which is a concurrent.futures.Executor: ``submit``,
``map`` and ``concurrent.futures.as_completed`` behave as with the process pool. A run is a Python call that holds
the GIL for its whole length (the simulation, the laws and the verdict are single-threaded numpy/MuJoCo/Pinocchio
code), so every Dask worker gets one thread and the parallelism comes from processes.
"""
from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field

ENGINES = ("pool", "dask")
#: How long a client waits for a cluster's scheduler before giving up [s].
CONNECT_TIMEOUT_S = 10.0


def local_cores() -> int:
    """The cores this process may run on (its CPU affinity, which a batch scheduler or taskset may have narrowed)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:          # not Linux
        return os.cpu_count() or 1


@dataclass
class Engine:
    """An open engine: the executor a sweep submits its runs to, and what to record about it beside the results."""
    executor: Executor
    name: str                        # "pool" or "dask"
    address: str | None              # the Dask scheduler's address (None for the process pool)
    workers: int                     # worker processes when the engine opened (a cluster may grow or shrink later)
    _close: list = field(default_factory=list, repr=False)

    def describe(self) -> dict:
        return {"engine": self.name, "address": self.address, "workers": self.workers}


class EngineError(RuntimeError):
    """The engine cannot be opened (bad worker count, unreachable scheduler); its message is one line for the user."""


@contextmanager
def open_engine(cluster: str | None = None, workers: int | None = None, engine: str | None = None) -> Iterator[Engine]:
    """The engine for (cluster, workers, engine); closed (pool shut down, client and local cluster closed) on exit.

    cluster None: this machine, ``workers`` processes (None: every core it may use) with ``engine`` "pool" (default)
    or "dask". cluster an address: a Dask client to that scheduler (``workers`` must then be None: the cluster's
    workers are started with the cluster, docs/CLUSTER.md)."""
    if engine not in (None, *ENGINES):
        raise EngineError(f"unknown engine {engine!r} (one of {', '.join(ENGINES)})")
    if workers is not None and workers < 1:
        raise EngineError(f"--workers must be at least 1, got {workers}")
    if cluster is not None:
        if engine == "pool":
            raise EngineError("--cluster needs the dask engine (the process pool runs on this machine only)")
        if workers is not None:
            raise EngineError("--workers applies to this machine only; a cluster's workers are started with the "
                              "cluster (docs/CLUSTER.md)")
        with _dask_client(cluster) as opened:
            yield opened
        return
    count = workers or local_cores()
    if (engine or "pool") == "pool":
        with ProcessPoolExecutor(max_workers=count) as pool:
            yield Engine(executor=pool, name="pool", address=None, workers=count)
        return
    from distributed import LocalCluster

    # One thread a worker (a run holds the GIL), no dashboard (no port to hold open, no bokeh needed), and a
    # worker may use the machine's memory as the process pool's would (a 30 s run keeps well under 1 GB).
    local = LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=None,
                         memory_limit=0)
    try:
        with _dask_client(local) as opened:
            yield opened
    finally:
        local.close()


@contextmanager
def _dask_client(target) -> Iterator[Engine]:
    from distributed import Client

    address = target if isinstance(target, str) else target.scheduler_address
    try:
        client = Client(target, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as error:
        raise EngineError(f"cannot reach the Dask scheduler at {address} within {CONNECT_TIMEOUT_S:g} s "
                          f"({type(error).__name__})") from None
    try:
        workers = len(client.scheduler_info(n_workers=-1)["workers"])   # -1: all of them, not the first few
        # pure=False: two equal submissions are two runs, as with the process pool (Dask would otherwise compute
        # a task of identical arguments once).
        yield Engine(executor=client.get_executor(pure=False), name="dask", address=address, workers=workers)
    finally:
        client.close()


@contextmanager
def make_executor(cluster: str | None = None, workers: int | None = None,
                  engine: str | None = None) -> Iterator[Executor]:
    """The executor alone (open_engine's): ``with make_executor(args.cluster, args.workers) as executor: ...``."""
    with open_engine(cluster, workers, engine) as opened:
        yield opened.executor


def add_engine_arguments(parser: argparse.ArgumentParser) -> None:
    """--engine, --cluster and (unless the parser has it already) --workers, for any sweep's command line."""
    group = parser.add_argument_group("where the runs execute (docs/CLUSTER.md)")
    group.add_argument("--engine", choices=ENGINES, default=None,
                       help="pool: a process pool on this machine (default); dask: a Dask LocalCluster on this "
                            "machine (the same engine a cluster runs)")
    group.add_argument("--cluster", metavar="ADDRESS", default=None,
                       help="run on the Dask cluster whose scheduler listens at ADDRESS (e.g. tcp://10.0.0.5:8786); "
                            "implies --engine dask")
    if "--workers" not in parser._option_string_actions:
        group.add_argument("--workers", type=int, default=None,
                           help=f"worker processes on this machine (default: every core, here {local_cores()})")


def engine_from_arguments(args: argparse.Namespace):
    """open_engine for the parsed --cluster, --workers and --engine (a context manager)."""
    return open_engine(getattr(args, "cluster", None), getattr(args, "workers", None), getattr(args, "engine", None))
