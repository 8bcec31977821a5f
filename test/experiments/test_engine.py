"""The sweeps' engines run the same jobs with the same answers: the process pool, a real 2-worker Dask LocalCluster
and a client to a running scheduler's address; bad settings are refused in one line."""
from __future__ import annotations

import argparse
import math
import socket
from concurrent.futures import as_completed

import pytest

from fic_teleop_experiments.engine import (
    EngineError,
    add_engine_arguments,
    engine_from_arguments,
    make_executor,
    open_engine,
)


def _worker_pid_and_square(value: int) -> tuple[int, int]:
    import os
    return os.getpid(), value * value


def _short_run(seed: int) -> dict:
    """One very short in-process run (1 simulated second of the E1 scene, the FIC), as a sweep's job would be."""
    from fic_teleop_experiments.in_process import RunConfig, run
    result = run(RunConfig(duration=1.0, seed=seed, delay=0.2))
    return dict(seed=seed, simulated_s=result.simulated_s, samples=len(result.time),
                limit_violations=result.limit_violations, error_max_m=float(result.tracking_error.max()))


def _check_cheap_jobs(executor) -> set[int]:
    mapped = list(executor.map(_worker_pid_and_square, range(12)))
    assert [square for _, square in mapped] == [value * value for value in range(12)]   # map keeps the order
    futures = {executor.submit(math.factorial, n): n for n in (5, 10, 20)}
    assert {futures[f]: f.result() for f in as_completed(futures, timeout=60)} == {5: 120, 10: 3628800,
                                                                                  20: 2432902008176640000}
    return {pid for pid, _ in mapped}


def test_process_pool_runs_the_jobs():
    with open_engine(workers=2) as engine:
        assert engine.describe() == {"engine": "pool", "address": None, "workers": 2}
        assert _check_cheap_jobs(engine.executor)


def test_dask_local_cluster_runs_cheap_jobs_and_a_short_simulation():
    with open_engine(workers=2, engine="dask") as engine:
        assert engine.name == "dask" and engine.workers == 2 and engine.address.startswith("tcp://127.0.0.1:")
        import os
        pids = _check_cheap_jobs(engine.executor)
        assert os.getpid() not in pids                   # the jobs ran in the workers, not here
        row = engine.executor.submit(_short_run, 3).result(timeout=120)
    assert row["seed"] == 3 and row["simulated_s"] == pytest.approx(1.0)
    assert row["samples"] > 50 and row["limit_violations"] == 0 and row["error_max_m"] < 0.2


def test_client_to_a_running_scheduler_address():
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        with make_executor(cluster.scheduler_address) as executor:
            assert len(_check_cheap_jobs(executor)) == 1   # processes=False: the workers are threads of this process
        with open_engine(cluster.scheduler_address) as engine:
            assert engine.describe() == {"engine": "dask", "address": cluster.scheduler_address, "workers": 2}


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_scheduler_is_one_clear_error(monkeypatch):
    import fic_teleop_experiments.engine as engine_module
    monkeypatch.setattr(engine_module, "CONNECT_TIMEOUT_S", 1.0)
    address = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(EngineError, match=f"cannot reach the Dask scheduler at {address}"):
        with open_engine(address):
            pass


@pytest.mark.parametrize("cluster, workers, engine, message", [
    (None, 0, None, "at least 1"),
    ("tcp://127.0.0.1:8786", None, "pool", "needs the dask engine"),
    ("tcp://127.0.0.1:8786", 4, None, "this machine only"),
    (None, None, "ray", "unknown engine"),
])
def test_bad_settings_are_refused(cluster, workers, engine, message):
    with pytest.raises(EngineError, match=message):
        with open_engine(cluster, workers, engine):
            pass


def test_the_command_line_flags():
    parser = argparse.ArgumentParser()
    add_engine_arguments(parser)
    args = parser.parse_args(["--cluster", "tcp://10.0.0.5:8786"])
    assert (args.cluster, args.workers, args.engine) == ("tcp://10.0.0.5:8786", None, None)
    with engine_from_arguments(parser.parse_args(["--workers", "1"])) as engine:
        assert engine.describe() == {"engine": "pool", "address": None, "workers": 1}
    with pytest.raises(SystemExit):
        parser.parse_args(["--engine", "ray"])
    # A sweep that has its own --workers keeps it.
    own = argparse.ArgumentParser()
    own.add_argument("--workers", type=int, default=2)
    add_engine_arguments(own)
    assert own.parse_args([]).workers == 2


def test_the_engine_bench_runs_the_same_jobs_on_both_engines():
    """A tiny bench (2 judged runs of 3 s, one worker): both engines run every job and report their throughput."""
    from fic_teleop_experiments.engine_bench import alternating_rounds, jobs
    job_set = jobs(2, 3.0)
    assert [(job.controller, job.seed) for job in job_set] == [("fic", 1), ("fic_paper_law", 1)]
    reported = []
    rounds, summary = alternating_rounds(["pool", "dask"], 1, job_set, 1, reported.append)
    assert [r["engine"] for r in rounds] == ["pool", "dask"] and reported == rounds
    for row in rounds:
        assert row["runs"] == 2 and row["simulated_s"] == pytest.approx(6.0)
        assert row["runs_per_hour"] == pytest.approx(3600.0 * 2 / row["wall_s"])
    assert summary["dask"]["runs_per_hour"] == [rounds[1]["runs_per_hour"]]
