"""The in-process runner's results, bit for bit, against a stored reference: a change that only makes the runner
faster must leave every series of a run as it was (docs/EXPERIMENTS.md, "In-process runner": the claim sweep moves
to a faster commit only on bit-identical runs).

Two short runs cover the paths the sweeps take: a claim run (0.2 s each way at 10 Hz both ways, the closed-loop
operator with the force-reactive hand, the task drawn from the seed, channel jitter) and an E2 shape-sorting trial
(the shape-sorting operator, its adhesive bond). Each per-sample series and each scalar of the RunResult is reduced
to a SHA-256 of its float64 bytes and compared with test/data/in_process_reference.json.

The reference is this machine kind's with scripts/constraints.txt's MuJoCo, Pinocchio and numpy: other builds of
them may round differently. A change that is meant to change results (a law, a parameter, the scene) rewrites it,
said in its commit: ``python test/experiments/test_in_process_reference.py --write``.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from fic_teleop_experiments.claims import ClaimRun
from fic_teleop_experiments.in_process import RunConfig, RunResult, run
from fic_teleop_experiments.seed_jitter import CHANNEL_JITTER_S, HAND_IMPEDANCE_JITTER, OPERATOR_TIMING_JITTER_S

REFERENCE = Path(__file__).resolve().parents[1] / "data" / "in_process_reference.json"
DURATION_S = 2.5


def configs() -> dict[str, RunConfig]:
    claim = ClaimRun(0.2, 10.0, "fic", "reactive", 2, DURATION_S).config()
    e2 = RunConfig(scene="shape_sorting", trajectory="fixed", duration=DURATION_S, delay=0.2, seed=1,
                   controller="fic", operator="shape_sorting", hand="reactive", jitter=CHANNEL_JITTER_S,
                   operator_timing_jitter=OPERATOR_TIMING_JITTER_S, hand_impedance_jitter=HAND_IMPEDANCE_JITTER)
    return {"claim_0.2s_10Hz_fic_reactive": claim, "e2_shape_sorting_fic": e2}


def digests(result: RunResult) -> dict[str, str]:
    """A SHA-256 per array and per number of the result (its wall time aside), and the objects' final poses."""
    out = {}
    for field in dataclasses.fields(result):
        value = getattr(result, field.name)
        if field.name == "wall_s":
            continue
        if isinstance(value, np.ndarray):
            data = value.astype(np.float64 if value.dtype != bool else bool, copy=False)
            out[field.name] = hashlib.sha256(np.ascontiguousarray(data).tobytes()).hexdigest()
        elif isinstance(value, (bool, int, float, np.integer, np.floating)):
            out[field.name] = repr(float(value)) if not isinstance(value, bool) else repr(value)
    poses = np.concatenate([np.concatenate(pose) for _, pose in sorted(result.objects.items())]) \
        if result.objects else np.zeros(0)
    out["objects"] = hashlib.sha256(poses.astype(np.float64).tobytes()).hexdigest()
    out["operator_moves"] = hashlib.sha256(repr(result.operator_moves).encode()).hexdigest()
    return out


@pytest.mark.parametrize("name", sorted(configs()))
def test_a_short_run_is_bit_identical_to_the_reference(name: str) -> None:
    expected = json.loads(REFERENCE.read_text())[name]
    found = digests(run(configs()[name]))
    differ = sorted(key for key in expected.keys() | found.keys() if expected.get(key) != found.get(key))
    assert not differ, f"{name}: these results changed: {differ} (meant to? rewrite the reference, module docstring)"


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python test/experiments/test_in_process_reference.py --write")
    REFERENCE.parent.mkdir(parents=True, exist_ok=True)
    REFERENCE.write_text(json.dumps({name: digests(run(config)) for name, config in configs().items()}, indent=1,
                                    sort_keys=True) + "\n")
    print(f"wrote {REFERENCE}")
