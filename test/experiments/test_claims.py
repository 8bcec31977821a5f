"""The claim cells (fic_teleop_experiments/claims.py, claims_sweep.py): what a claim run configures, the kept series
round trip, and a tiny sweep through an executor that resumes where it stopped."""
from __future__ import annotations

import dataclasses
import importlib.util
import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from fic_teleop_experiments import claims_sweep
from fic_teleop_experiments.claims import (
    ClaimRun,
    claim_cells,
    claim_runs,
    dense_cell,
    execute,
    load_series,
    save_series,
    tail_for,
    thinned,
)
from fic_teleop_experiments.claims import judge_series as claims_sweep_judge
from fic_teleop_experiments.in_process import run


def test_a_claim_run_holds_both_directions_at_the_rate_with_the_law_at_full_rate() -> None:
    config = ClaimRun(1.0, 10.0, "fic_paper_law", "reactive", 3, 30.0).config()
    assert (config.delay, config.rate_cap, config.control_rate) == (1.0, 10.0, 1000.0)
    assert config.controller == "fic" and config.replica_overrides == {"paper_law": True}
    assert (config.operator, config.hand, config.task_variation, config.scene) == (
        "closed_loop", "reactive", True, "superimposition")
    assert not config.dynamics_at_physics_rate


def test_the_sweep_runs_the_claim_first_and_covers_the_grid_and_the_delay_sweep() -> None:
    cells = claim_cells()
    # Tier 1: the cells the claim and the goals are about, 1 s first.
    assert cells[:6] == [(1, 1.0, 10.0), (1, 1.0, 0.0), (1, 0.2, 10.0), (1, 0.2, 0.0), (1, 0.0, 10.0), (1, 0.0, 0.0)]
    grid = {(d, r) for _, d, r in cells}
    assert {(d, r) for d in (0.0, 0.2, 1.0, 2.0) for r in (0.0, 10.0, 5.0)} <= grid
    assert {d for d, r in grid if r == 0.0} == {0.0, 0.2, 0.5, 1.0, 1.5, 2.0}
    runs = claim_runs()
    claims = [r for r in runs if r.force_feedback]
    dense = [c for c in cells if dense_cell(c[1], c[2])]
    assert {(d, r) for _, d, r in dense} == {(1.0, 10.0), (0.2, 10.0), (0.0, 10.0)}
    assert len(claims) == (len(cells) + len(dense)) * 5 * 2 * 20 and len(runs) == len({r.key for r in runs})
    # The dense cells' seeds 21-40 come right after tier 1's 20 seeds, before the 5 Hz tier.
    tier_1 = 6 * 5 * 2 * 20
    assert {r.seed for r in claims[tier_1:tier_1 + 3 * 5 * 2 * 20]} == set(range(21, 41))
    assert all(r.rate_hz != 5.0 for r in claims[:tier_1 + 3 * 5 * 2 * 20])
    # The open-loop controls come last: the 10 Hz claim cells, the reactive hand, every law and seed, K_H = 0.
    controls = runs[len(claims):]
    assert all(not r.force_feedback for r in controls) and len(controls) == 2 * 5 * 20
    assert {(r.cell, r.hand) for r in controls} == {("delay_1__rate_10__feedback_off", "reactive"),
                                                    ("delay_0.2__rate_10__feedback_off", "reactive")}
    assert controls[0].config().master_overrides == {"haptic_gain": 0.0} and claims[0].config().master_overrides == {}
    assert not any(r.force_feedback is False for r in claim_runs(quick=True))
    first = runs[:20]   # seed 1 of both claim cells: every law with both hands
    assert {(r.cell, r.controller, r.hand) for r in first} == {
        (c, law, hand) for c in ("delay_1__rate_10", "delay_1__rate_full")
        for law in ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa") for hand in ("passive",
                                                                                                    "reactive")}


def test_every_claim_run_ends_with_its_quiet_tail() -> None:
    """At least 4 round trips or 8 s of free response after one round trip and 1 s of flush, the task unchanged."""
    assert [tail_for(d) for d in (0.0, 0.2, 1.0, 2.0)] == pytest.approx([9.0, 9.4, 11.0, 21.0])
    runs = claim_runs()
    assert all(r.tail == tail_for(r.delay) and r.key.endswith(f"__tail_{r.tail:g}s") for r in runs)
    config = ClaimRun(1.0, 10.0, "fic", "reactive", 3, 30.0, tail=11.0).config()
    assert (config.duration, config.quiet_from) == (41.0, 30.0)
    assert ClaimRun(1.0, 10.0, "fic", "reactive", 3, 30.0).config().quiet_from is None
    assert not any(r.tail for r in claim_runs(tail=False))


def test_in_the_quiet_tail_the_planner_and_the_operator_stop_and_the_link_runs_on(tmp_path: Path) -> None:
    """The tail's start is kept with the series; the operator's target holds still from it, the planner's x_d'' comes
    to rest within 1 s (w_n = 8 rad/s), the hand keeps holding the handle; the task's figures end where it starts."""
    claim = ClaimRun(0.2, 10.0, "fic", "reactive", 1, 2.5, tail=1.5)
    row = execute(claim, tmp_path)
    kept = load_series(tmp_path / row["series"])
    assert kept.quiet_from == 2.5
    tail = kept.time >= 2.5
    assert np.ptp(kept.operator_target[tail], axis=0).max() == 0.0
    assert np.ptp(kept.operator_target[kept.time >= 0.5], axis=0).max() > 1e-4   # it moved before
    step = float(np.median(np.diff(kept.time)))
    speed = np.linalg.norm(np.diff(kept.planner, axis=0), axis=1) / step
    assert speed[kept.time[1:] >= 3.5].max() < 2e-3 < speed[kept.time[1:] < 2.5].max()
    assert np.any(np.linalg.norm(np.diff(kept.master[tail], axis=0), axis=1) > 0.0)   # the handle still answers
    before = execute(dataclasses.replace(claim, tail=0.0), tmp_path)
    assert row["figures"]["error_rms_m"] == pytest.approx(before["figures"]["error_rms_m"], rel=0.02)


def test_the_kept_series_is_the_run_at_50_hz(tmp_path: Path) -> None:
    claim = ClaimRun(0.2, 10.0, "fic", "reactive", 2, 2.0)
    result = run(claim.config())
    path = tmp_path / "run.npz"
    save_series(path, thinned(result))
    kept = load_series(path)
    assert np.median(np.diff(kept.time)) == pytest.approx(0.02)
    np.testing.assert_allclose(kept.tcp, result.tcp[::2], atol=1e-6)
    # Flags are pooled over each kept sample's pair: a touch on either sample is kept.
    np.testing.assert_array_equal(kept.obstacle_contact, result.obstacle_contact[::2]
                                  | np.append(result.obstacle_contact[1::2], False)[:kept.time.size])
    assert kept.limit_violations == result.limit_violations and kept.draws == json.loads(json.dumps(result.draws))
    assert set(kept.draws) == {"task", "hand"}


def test_a_touch_between_kept_samples_stays_in_the_kept_series() -> None:
    """One 100 Hz sample of contact with a force spike, on the sample a stride drops: the kept series has the flag
    and the spike at the kept sample before it, and the motions stay every second sample."""
    claim = ClaimRun(0.2, 10.0, "fic", "reactive", 2, 2.0)
    result = run(claim.config())
    n = result.time.size
    touch = 2 * (n // 4) + 1   # an odd sample: the stride keeps 0, 2, 4, ...
    contact = np.zeros(n, dtype=bool)
    contact[touch] = True
    force = np.zeros_like(result.force)
    force[touch] = (0.0, 71.6, 0.0)
    force[touch - 1] = (3.0, 0.0, 0.0)
    kept = thinned(dataclasses.replace(result, obstacle_contact=contact, force=force))
    assert kept.obstacle_contact.sum() == 1 and kept.obstacle_contact[touch // 2]
    np.testing.assert_array_equal(kept.force[touch // 2], (0.0, 71.6, 0.0))
    assert np.count_nonzero(np.linalg.norm(kept.force, axis=1)) == 1
    np.testing.assert_array_equal(kept.tcp, result.tcp[::2])
    np.testing.assert_array_equal(kept.time, result.time[::2])


def test_a_kept_series_is_judged_as_its_full_rate_run() -> None:
    """The claim sweep's run (1 s, 10 Hz, FIC, reactive hand, seed 21) whose one 10 ms touch of the fixed obstacle
    fell between the stride's samples: judged on the stride's series the channel's burst one delay later read as
    steady generation outside contact (116 mW); on the pooled series, as on the full-rate run, it is stable."""
    from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

    claim = next(c for c in claim_runs(controllers=["fic"], hands=["reactive"], seeds=21)
                 if c.key == "delay_1__rate_10__fic__reactive__21__30s__tail_11s")
    result = run(claim.config())
    full = judge(VerdictInput.from_run_result(result, one_way_delay=claim.delay))
    kept = judge(VerdictInput.from_run_result(thinned(result), one_way_delay=claim.delay))
    assert full.stable and kept.stable, (full.stable_reasons, kept.stable_reasons)
    assert kept.figures["contact_share"] > 0.0


def test_a_touch_late_in_the_quiet_tail_gets_a_free_response_after_it() -> None:
    """The claim sweep's run (1 s, 10 Hz, FIC, passive hand, seed 19) that touched the fixed obstacle 4.9 s into its
    11 s tail: its swing after the touch had not decayed when the fixed tail ended (judged unstable). The tail now
    goes on until it has run the verdict's tail since the last contact, and the verdict judges the response after
    it: the swing decays and the run is stable. The same run, task draws frozen, with a 31 s tail decayed to
    0.19 mm by 12-14 s into the tail."""
    from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

    claim = next(c for c in claim_runs(controllers=["fic"], hands=["passive"], seeds=19)
                 if c.key == "delay_1__rate_10__fic__passive__19__30s__tail_11s")
    result = run(claim.config())
    in_tail = result.time >= result.quiet_from
    last_touch = float(result.time[in_tail & result.obstacle_contact][-1]) - result.quiet_from
    assert 4.5 < last_touch < 5.5
    assert result.simulated_s == pytest.approx(claim.duration + last_touch + tail_for(claim.delay), abs=0.02)
    verdict = judge(VerdictInput.from_run_result(thinned(result), one_way_delay=claim.delay))
    assert verdict.stable, verdict.stable_reasons
    assert verdict.figures["tail_free_from_s"] == pytest.approx(result.quiet_from + last_touch, abs=0.02)


def test_a_sweep_through_an_executor_keeps_every_run_and_resumes(tmp_path: Path) -> None:
    runs = [ClaimRun(0.2, 10.0, "fic", hand, 1, 1.5) for hand in ("passive", "reactive")]
    directory, jsonl = tmp_path / "runs", tmp_path / "runs.jsonl"
    with ThreadPoolExecutor(max_workers=2) as executor:
        rows, new = claims_sweep.sweep(runs[:1], executor, directory, jsonl, {"commit": "x"}, progress=False)
        assert len(rows) == len(new) == 1 and (directory / rows[0]["series"]).exists()
        rows, new = claims_sweep.sweep(runs, executor, directory, jsonl, {"commit": "x"}, progress=False)
        assert [row["key"] for row in new] == [runs[1].key]          # the first one was not simulated again
    assert [row["key"] for row in rows] == [r.key for r in runs]
    lines = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert len(lines) == 2 and all(line["commit"] == "x" and line["wall_s"] > 0 for line in lines)
    assert {"error_rms_m", "peak_force_n", "limit_violations"} <= set(lines[0]["figures"])
    jsonl.write_text(jsonl.read_text() + '{"key": "cut sh')                 # a line cut short by a kill
    (directory / rows[1]["series"]).unlink()                              # a series lost: that run is not done
    assert list(claims_sweep.finished(jsonl, directory)) == [runs[0].key]
    # ... unless its verdict was kept (same row, same verdict code): judged already, it is not simulated again.
    judged = {rows[1]["key"]: {**rows[1], "verdict": {"stable": True}}}
    assert list(claims_sweep.finished(jsonl, directory, judged)) == [runs[0].key, runs[1].key]
    changed = {rows[1]["key"]: {**rows[1], "seed": 2, "verdict": {"stable": True}}}
    assert list(claims_sweep.finished(jsonl, directory, changed)) == [runs[0].key]


@pytest.mark.skipif(importlib.util.find_spec("fic_teleop_tools.verdict.run_verdict") is None,
                    reason="the run verdict is not in this tree")
def test_the_verdict_applies_to_a_kept_series(tmp_path: Path) -> None:
    from fic_teleop_experiments.claims import judge_series

    claim = ClaimRun(0.2, 0.0, "fic", "passive", 1, 3.0)
    path = tmp_path / "run.npz"
    save_series(path, thinned(run(claim.config())))
    verdict = judge_series(path, claim.delay)
    assert verdict["safe"] in (True, False) and verdict["stable"] in (True, False, None)


def test_judging_again_reuses_only_verdicts_of_the_same_verdict_code_and_row(tmp_path: Path) -> None:
    """--reuse-verdicts: a row judged before by the same verdict code keeps its verdict (nothing is submitted for
    it); a changed row, a new row, or a summary of another verdict code is judged again."""
    code = claims_sweep.verdict_code()
    assert len(code) == 16 and code == claims_sweep.verdict_code()
    rows = [dict(key=f"run{i}", series=f"run{i}.npz", delay=0.2, wall_s=1.0) for i in range(3)]
    summary = tmp_path / "claims.json"
    judged_rows = [{**rows[0], "verdict": {"stable": True}}, {**rows[1], "wall_s": 2.0, "verdict": {"stable": True}}]
    summary.write_text(json.dumps(dict(verdict_code=code, runs=judged_rows)))

    class Recording(ThreadPoolExecutor):
        submitted: list = []

        def submit(self, function, path, delay):   # no series on disk: record what would be judged
            self.submitted.append(Path(path).name)
            return super().submit(lambda: {"stable": False})

    saved: list[list[dict]] = []
    with Recording(max_workers=1) as executor:
        out = claims_sweep.judged(rows, tmp_path, executor, progress=False,
                                  earlier=claims_sweep.reusable(summary, code), checkpoint=saved.append, every=0.0)
    assert Recording.submitted == ["run1.npz", "run2.npz"]
    assert [row["verdict"]["stable"] for row in out] == [True, False, False]
    # A checkpoint after each judged run: every row, the ones not judged yet without a verdict.
    assert [[("verdict" in row) for row in rows_so_far] for rows_so_far in saved] == [[True, True, False],
                                                                                      [True, True, True]]
    assert claims_sweep.reusable(summary, "another code") == {} and claims_sweep.reusable(None, code) == {}


def test_the_command_reaches_the_replica_at_the_links_rate_and_is_interpolated_in_between() -> None:
    # x_d' in use at the replica's 100 Hz poses: the replica's link hold (fic_core.link_hold) moves it in a straight
    # line to each delivered command over the learned interval, so its velocity changes once a delivery: at 10 Hz at
    # most one change a 0.1 s slot, and x_d' keeps moving in between (a staircase would stand still there); at full
    # rate it changes at most every 10 ms.
    changes, shares = {}, {}
    for rate in (0.0, 10.0):
        result = run(ClaimRun(0.2, rate, "fic", "passive", 1, 2.0).config())
        after = result.time >= 1.1   # the operator's first move has reached the replica (about 1 s)
        velocity = np.diff(result.offset[after], axis=0)
        moving = np.linalg.norm(velocity, axis=1) > 1e-9
        kinks = np.linalg.norm(np.diff(velocity, axis=0), axis=1) > 1e-9
        changes[rate] = int(np.sum(kinks[1:] & ~kinks[:-1]) + kinks[0])   # one change spans two differences
        shares[rate] = float(kinks.mean())
        assert moving.mean() > 0.95
    span = 2.0 - 1.1
    assert 5 <= changes[10.0] <= 10 * span + 1 and shares[10.0] < 0.3
    assert shares[0.0] > 0.8   # at full rate a new command, and a change of velocity, at nearly every pose


def test_a_task_drawn_per_seed_needs_the_closed_loop_operator_and_a_known_hand() -> None:
    with pytest.raises(ValueError, match="closed-loop"):
        run(dataclasses.replace(ClaimRun(0.2, 0.0, "fic", "passive", 1, 1.0).config(), operator="scripted"))
    with pytest.raises(ValueError, match="hand"):
        run(dataclasses.replace(ClaimRun(0.2, 0.0, "fic", "passive", 1, 1.0).config(), hand="tense"))


def test_a_kept_claim_run_with_its_quiet_tail_is_assessed(tmp_path) -> None:
    """The kept series (thinned to 50 Hz) ends one sample before the run does, so its tail is a sample shorter than
    tail_for made it: the verdict still judges it (it said 'not assessed' for every run of the sweep)."""
    claim = ClaimRun(0.2, 10.0, "fic", "passive", 1, 30.0, tail=tail_for(0.2))   # a run of the sweep
    row = execute(claim, tmp_path)
    verdict = claims_sweep_judge(tmp_path / row["series"], claim.delay)
    assert verdict["stable"] is not None, verdict["stable_reasons"]
