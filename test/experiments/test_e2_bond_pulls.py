"""The E2 bond-pull reader (fic_teleop_experiments.e2.bond_pulls): the lock-and-pull windows from the operator's
phases, what the recorder takes from the simulation and the replica at a step, and that recording leaves the
runner's classes as they were and records every physics step of a run."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from fic_teleop_experiments import in_process
from fic_teleop_experiments.e2 import bond_pulls as e2_bond_pulls
from fic_teleop_experiments.e2.command_line import main


def test_a_window_runs_from_the_lock_to_the_first_phase_after_the_pull() -> None:
    phases = [("cuboid:insert", 20.0), ("cuboid:lock", 22.0), ("cuboid:pull", 23.0), ("cuboid:pulled", 26.0),
              ("cuboid:carry", 28.0), ("cuboid:lock", 40.0), ("cuboid:pull", 41.0), ("cuboid:pulled", 44.0),
              ("cuboid:done", 47.5), ("star_prism:lock", 90.0), ("star_prism:pull", 91.0)]
    assert e2_bond_pulls.windows(phases, 100.0) == [("cuboid", 22.0, 28.0), ("cuboid", 40.0, 47.5),
                                                    ("star_prism", 90.0, 100.0)]


def _command(force: list[float], error: list[float], feedforward: list[float] | None) -> SimpleNamespace:
    return SimpleNamespace(wrench=np.array([*force, 0.0, 0.0, 0.0]), tracking_error_values=error,
                           feedforward_wrench=None if feedforward is None else np.array([*feedforward, 0.0, 0.0, 0.0]))


def test_the_recorder_takes_the_bond_force_while_bonded_and_at_its_break_and_counts_saturated_axes() -> None:
    recorder = e2_bond_pulls._Recorder()
    bonded = SimpleNamespace(steps=1500, bond_state=SimpleNamespace(bonded_piece="piece_cuboid", bond_force=13.5,
                                                                    break_threshold=18.1, breaks=0,
                                                                    last_break_force=0.0))
    recorder.station = SimpleNamespace(loop=SimpleNamespace(last_command=_command([6.0, 0.0, 8.0], [0.06, 0.0, -0.07],
                                                                                  [3.0, 4.0, 0.0])))
    recorder.record(bonded)
    broken = SimpleNamespace(steps=1501, bond_state=SimpleNamespace(bonded_piece=None, bond_force=0.0,
                                                                    break_threshold=18.1, breaks=1,
                                                                    last_break_force=18.3))
    recorder.station.loop.last_command = _command([0.0, 0.0, 2.0], [0.0, 0.0, 0.01], None)
    recorder.record(broken)
    recorder.record(SimpleNamespace(steps=1502, bond_state=broken.bond_state))
    assert recorder.rows == [(pytest.approx(1.5), 13.5, 18.1, pytest.approx(10.0), pytest.approx(5.0), 2),
                             (pytest.approx(1.501), 18.3, 18.1, pytest.approx(2.0), 0.0, 0),
                             (pytest.approx(1.502), 0.0, 0.0, pytest.approx(2.0), 0.0, 0)]


def test_recording_records_every_physics_step_and_restores_the_runner() -> None:
    simulation, station = in_process.PandaSimulation, in_process.ReplicaStation
    with e2_bond_pulls.recording() as recorder:
        result = in_process.run(in_process.RunConfig(scene="shape_sorting", trajectory="fixed", duration=0.2,
                                                     delay=0.0, seed=3, operator="scripted"))
    assert in_process.PandaSimulation is simulation and in_process.ReplicaStation is station
    assert len(recorder.rows) == round(result.simulated_s / e2_bond_pulls.STEP_S)
    assert recorder.station is not None
    times = np.array([row[0] for row in recorder.rows])
    assert np.all(np.diff(times) > 0)
    with pytest.raises(RuntimeError):
        with e2_bond_pulls.recording():
            raise RuntimeError("a failed run")
    assert in_process.PandaSimulation is simulation and in_process.ReplicaStation is station


@pytest.mark.filterwarnings("ignore::RuntimeWarning")   # the run verdict on 1 s: empty judged spans, not ours
def test_a_short_trial_gives_its_row_and_the_100_hz_series_with_its_tail_without_pulls() -> None:
    result = e2_bond_pulls.in_process_pulls(3, "fic", 0.2, False, 1.0)
    assert result["pulls"] == [] and result["felt_pulls_n"] == [] and result["seed"] == 3
    series = result["series"]
    # The task's 1 s and the quiet tail after it (the trial ends as a claim run does, e2.trial.trial).
    from fic_teleop_tools.verdict.run_verdict import VerdictCriterion
    samples = round((1.0 + VerdictCriterion().tail_needed(0.2)) * 100)
    assert len(series["time"]) == len(series["bond_n"]) == len(series["law_n"]) == samples
    assert np.allclose(np.diff(series["time"]), 0.01)
    assert max(series["bond_n"]) == 0.0   # nothing is grasped in the first second


def test_the_plot_draws_one_panel_a_result(tmp_path) -> None:
    series = {"time": [0.0, 0.01, 0.02], "bond_n": [0.0, 12.0, 18.2], "threshold_n": [0.0, 18.1, 18.1],
              "law_n": [1.0, 14.1, 14.1], "feedforward_n": [0.0, 10.0, 3.0], "ft_time": [0.0, 0.25], "ft_n": [0.0, 9.0]}
    result = {"law": "fic", "delay_s": 0.2, "seed": 3, "jitter": True, "pieces_inside": [], "series": series,
              "pulls": [{"start_s": 0.0, "end_s": 0.02, "broke": True}]}
    path = tmp_path / "bond.json"
    path.write_text(json.dumps(result))
    assert main(["bond-pulls", "--plot", str(tmp_path / "bond.png"), "--results", str(path), str(path)]) == 0
    assert (tmp_path / "bond.png").stat().st_size > 10_000
    with pytest.raises(SystemExit):
        main(["bond-pulls", "--plot", str(tmp_path / "none.png")])


def test_a_result_s_row_names_the_pull_that_broke_the_bond_and_the_forces_there(tmp_path, capsys) -> None:
    pulls = [{"piece": "cuboid", "bond_peak_n": 14.4, "broke": False, "law_at_bond_peak_n": 11.1,
              "feedforward_at_bond_peak_n": 1.5},
             {"piece": "cuboid", "bond_peak_n": 18.2, "broke": True, "law_at_bond_peak_n": 12.9,
              "feedforward_at_bond_peak_n": 9.0},
             {"piece": "star_prism", "bond_peak_n": 13.3, "broke": True, "law_at_bond_peak_n": 13.1,
              "feedforward_at_bond_peak_n": 0.0}]
    result = {"law": "fic", "jitter": False, "pulls": pulls}
    assert e2_bond_pulls.pulls_row(result) == \
        "| fic, the graph's twin | 2 | 14.4, 18.2 | at pull 2 | 11.1-12.9 | 1.5-9.0 |"
    path = tmp_path / "fic.json"
    path.write_text(json.dumps(dict(result, jitter=True, pulls=pulls[:1])))
    assert main(["bond-pulls", "--table", "--results", str(path)]) == 0
    assert capsys.readouterr().out == "| fic, the sweep's draws | 1 | 14.4 | no | 11.1-11.1 | 1.5-1.5 |\n"
