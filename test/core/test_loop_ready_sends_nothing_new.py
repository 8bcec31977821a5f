"""ReplicaLoop.ready judges only a law torque about to go out (fic_core.loop_health, "ready"): a joint state that
arrived between control ticks, with nothing to send, starts no hold however late it is made ready (its state is
not acted on), and the hold's own torque goes out as it is, however old its state has grown."""
from __future__ import annotations

import numpy as np
from config_values import replica_loop_parameters

from fic_core.loop_health import HEALTHY, HOLDING
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

PERIOD = 2.0 ** -9   # [s] the control period (512 Hz)
Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)


def healthy_loop() -> tuple[ReplicaLoop, float]:
    replica = ReplicaLoop(replica_loop_parameters(control_rate=512.0, command_period=PERIOD,
                                                  loop_max_state_age=0.04, loop_max_tick_gap=0.04,
                                                  loop_resume_ticks=5, loop_resume_ramp=0.1))
    now = 0.0
    for _ in range(10):
        now += PERIOD
        step = replica.ready(replica.joint_state(now, now, Q0, np.zeros(7)), now, now)
        assert step.torque is not None and not step.held
    return replica, now


def test_a_state_between_ticks_made_ready_late_sends_nothing_and_starts_no_hold() -> None:
    replica, now = healthy_loop()
    between = now + 0.25 * PERIOD
    step = replica.joint_state(between, between, Q0, np.zeros(7))
    assert step.torque is None and not step.held              # not a control tick: nothing to send
    step = replica.ready(step, between, between + 0.5)          # half a second later
    assert step.torque is None and not step.held and step.notices == []
    assert (replica.health.state, replica.health.holds) == (HEALTHY, 0)


def test_the_holds_torque_goes_out_as_it_is_however_late() -> None:
    replica, now = healthy_loop()
    now += PERIOD
    step = replica.joint_state(now - 0.05, now, Q0, np.zeros(7))   # a state 50 ms old: the loop holds
    assert step.held and replica.health.state == HOLDING and step.torque is not None
    torque, notices = step.torque.copy(), list(step.notices)
    step = replica.ready(step, now - 0.05, now + 0.5)
    np.testing.assert_array_equal(step.torque, torque)
    assert step.held and step.notices == notices and replica.health.holds == 1
