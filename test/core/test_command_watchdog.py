"""The torque-command relay's watchdog (fic_core.command_watchdog): forwards unchanged, ramps to the rest command
within ramp_time once the replica is silent for timeout, monotonically and inside the torque rate, and hands back
at the replica's next command."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.command_watchdog import CommandWatchdog
from fic_core.errors import FicInputError
from fic_core.torque_semantics import TorqueSemantics

DT = 0.004  # the relay's 250 Hz check


def _silence(watchdog: CommandWatchdog, start: float, seconds: float, gravity=None) -> list[np.ndarray]:
    sent = []
    for k in range(int(round(seconds / DT))):
        command, _ = watchdog.check(start + (k + 1) * DT, gravity)
        if command is not None:
            sent.append(command)
    return sent


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-87.0, 87.0), min_size=7, max_size=7))
def test_a_silent_replica_ramps_to_zero_on_an_arm_that_compensates_gravity(last: list[float]) -> None:
    watchdog = CommandWatchdog(0.05, 0.5, TorqueSemantics(gravity_compensated_by_robot=True))
    forwarded, ended = watchdog.replica_command(last, 0.0)
    np.testing.assert_array_equal(forwarded, last)
    assert not ended
    assert watchdog.check(0.04, None) == (None, False)   # inside the timeout: nothing of its own
    sent = _silence(watchdog, 0.0, 1.0)
    assert sent, "no ramp"
    np.testing.assert_allclose(sent[-1], 0.0, atol=1e-12)
    steps = np.abs(np.diff(np.array([last] + sent), axis=0)).max()
    assert steps <= 2 * 87.0 / 0.5 * DT + 1e-9       # the ramp's rate bound, inside 1000 N m/s
    norms = [np.abs(c).max() for c in sent]
    assert all(b <= a + 1e-12 for a, b in zip(norms, norms[1:]))
    assert len(sent) >= int(0.5 / DT) - 1             # the ramp takes ramp_time, then holds zero


def test_without_gravity_compensation_it_ramps_to_gravity_and_holds_without_a_state() -> None:
    gravity = np.array([0.0, -20.0, 0.0, 15.0, 0.0, 1.0, 0.0])
    watchdog = CommandWatchdog(0.05, 0.2, TorqueSemantics(gravity_compensated_by_robot=False))
    watchdog.replica_command(np.ones(7), 0.0)
    np.testing.assert_allclose(_silence(watchdog, 0.0, 0.5, gravity)[-1], gravity)
    holding = CommandWatchdog(0.05, 0.2, TorqueSemantics(gravity_compensated_by_robot=False))
    holding.replica_command(np.ones(7), 0.0)
    np.testing.assert_allclose(_silence(holding, 0.0, 0.5, None)[-1], np.ones(7))  # no G(q): hold, never drop


def test_the_replica_coming_back_ends_the_ramp_and_is_forwarded() -> None:
    watchdog = CommandWatchdog(0.05, 0.5, TorqueSemantics(True))
    watchdog.replica_command(np.full(7, 10.0), 0.0)
    started = [watchdog.check(t, None)[1] for t in np.arange(0.004, 0.2, DT)]
    assert started.count(True) == 1                     # said once
    forwarded, ended = watchdog.replica_command(np.full(7, 3.0), 0.2)
    assert ended and np.all(forwarded == 3.0)
    assert watchdog.check(0.21, None) == (None, False)


def test_bad_commands_are_refused_and_the_last_good_one_stays() -> None:
    watchdog = CommandWatchdog(0.05, 0.5, TorqueSemantics(True))
    watchdog.replica_command(np.full(7, 2.0), 0.0)
    for bad in ([np.nan] * 7, [], [1.0] * 6):
        with pytest.raises(FicInputError):
            watchdog.replica_command(bad, 0.01)
    np.testing.assert_array_equal(watchdog.last_command, np.full(7, 2.0))
    assert watchdog.check(0.03, None)[0] is None        # the refused ones did not count as fresh, nor stale yet
    assert watchdog.check(0.06, None)[0] is not None
