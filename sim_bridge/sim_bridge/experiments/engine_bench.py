"""Runs per hour of the sweep engines (sim_bridge.experiments.engine) on one machine: the same job set through the
process pool and through a Dask LocalCluster, in alternating rounds so that both see the same machine load
(docs/CLUSTER.md; the command line is scripts/engine_bench.py).

The jobs are in-process runs of the E1 scene at 1 s one-way delay, each law in turn, each judged as the evidence
sweep judges it (sim_bridge.experiments.evidence_run.judge): a sweep's unit of work, returning a small row.
"""
from __future__ import annotations

import os
import time

from sim_bridge.experiments.engine import open_engine
from sim_bridge.experiments.evidence_run import CONTROLLERS, judge


def jobs(runs: int, duration: float) -> list[tuple]:
    """``runs`` jobs: the laws in turn, seeds 1, 2, ... (the evidence sweep's job tuple)."""
    cell = dict(id="delay_1", options=dict(delay=1.0))
    return [(cell, CONTROLLERS[i % len(CONTROLLERS)], 1 + i // len(CONTROLLERS), duration) for i in range(runs)]


def one_round(engine: str, workers: int, job_set: list[tuple]) -> dict:
    """One engine opened, the job set run through it, closed: wall time with the engine's start, runs per hour,
    and the runs' own simulation wall time summed (what the engine's overhead is not)."""
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    with open_engine(workers=workers, engine=engine) as opened:
        opened_s = time.perf_counter() - start
        rows = list(opened.executor.map(judge, job_set))
    wall = time.perf_counter() - start
    return dict(engine=engine, workers=workers, runs=len(rows), wall_s=wall, engine_start_s=opened_s,
                runs_per_hour=3600.0 * len(rows) / wall, simulated_s=sum(r["simulated_s"] for r in rows),
                runs_wall_s_sum=sum(r["wall_s"] for r in rows), load_1min_before=load_before,
                load_1min_after=os.getloadavg()[0], stable=sum(1 for r in rows if r["stable"]))


def alternating_rounds(engines: list[str], workers: int, job_set: list[tuple], rounds: int,
                       report=None) -> tuple[list[dict], dict]:
    """``rounds`` rounds of every engine in turn; (every round, per engine its runs per hour over all rounds)."""
    done = []
    for index in range(rounds):
        for engine in engines:
            row = {"round": index + 1, **one_round(engine, workers, job_set)}
            done.append(row)
            if report is not None:
                report(row)
    summary = {engine: dict(runs_per_hour=[r["runs_per_hour"] for r in done if r["engine"] == engine],
                            total_runs_per_hour=3600.0 * sum(r["runs"] for r in done if r["engine"] == engine)
                            / sum(r["wall_s"] for r in done if r["engine"] == engine))
               for engine in engines}
    return done, summary
