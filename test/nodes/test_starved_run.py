"""One throttled run in the suite: the whole graph but the recorder under a cgroup CPU quota of 40 % of one CPU
(the starvation harness, fic_teleop_experiments/tools/stress.py; the recorder spared so that the bag holds the run:
starved with the rest, it wrote no bag at all in an 8 s run) must be flagged by the launcher as starved (its
timing.json, and exit code 6 unless a safety figure broke first), and the arm must not run away. Needs root and the
cgroup cpu controller."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from conftest import isolated_env, reserved_domain

from fic_teleop_bringup.launch_supervision import EXIT_NODE_FAILED, EXIT_OK, EXIT_REFUSED, EXIT_STARVED

pytestmark = [pytest.mark.nodes, pytest.mark.slow]
LEVEL_PERCENT = 40.0


def _quota_available() -> bool:
    from fic_teleop_experiments.tools.stress import StressError, _cpu_hierarchy
    try:
        _cpu_hierarchy()
    except StressError:
        return False
    return True


@pytest.mark.skipif(os.geteuid() != 0 or not _quota_available(), reason="a CPU quota needs root and cgroup cpu")
def test_a_graph_at_40_percent_of_one_cpu_is_flagged_as_starved(tmp_path: Path) -> None:
    from fic_teleop_experiments.tools.stress import run_figures, stressed_run

    out = tmp_path / "run"
    with reserved_domain() as domain:
        result = stressed_run(["--duration", "8", "--no-video"], out, LEVEL_PERCENT, spare="recorder",
                              log=tmp_path / "run.log", env=isolated_env(tmp_path / "ros_log", domain))
    log = (tmp_path / "run.log").read_text()
    assert result["throttling"]["nr_throttled"] > 0, "the quota never throttled the graph"
    assert result["exit_code"] not in (EXIT_OK, EXIT_REFUSED, EXIT_NODE_FAILED), log[-3000:]
    timing = json.loads((out / "timing.json").read_text())
    assert timing["judged"] and timing["starved"], log[-3000:]
    assert "[run] timing: STARVED: the machine did not keep real time" in log
    if result["exit_code"] != EXIT_STARVED:   # a safety figure broke first: it must be a safety code
        assert result["exit_code"] in (3, 4, 5), log[-3000:]
    figures = run_figures(out, result["exit_code"])
    assert figures["runaway"] is False, figures["reasons"]
