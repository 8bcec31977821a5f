"""The torque the replica sends between and across its law's ticks: the slew toward the law's output at a joint
state between two ticks (``held_torque``), the last torque again (``repeat_torque``), a torque stated from outside
(``reset``, ``state_sent``) and a controller swap (``continue_from``). Each keeps |tau_k - tau_(k-1)| <=
torque_rate * dt_k over the whole sequence sent (torque_slew.py; docs/CONTROL_LAWS.md, "The limits")."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.baseline import LinearImpedance
from fic_core.errors import FicInputError
from fic_core.limits import LimitFlag
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

RATE = 1000.0            # [N m/s] the Panda's torque-rate limit
CONTROL_PERIOD = 0.004   # [s] a 250 Hz law
COMMAND_PERIOD = 0.001   # [s] answering 1 kHz joint states
STEP = RATE * COMMAND_PERIOD  # [N m] the most a command may move from the one before it, a joint-state period later
ROUND_OFF = 1e-9         # [N m]


def paper_fic() -> PoseAttractor:
    """The paper's replica FIC (Sec. III): K0 = 200 N/m, x_b = 0.05 m; rotation 20 N m/rad, x_b = 0.5 rad."""
    return PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), ForceProfile(20.0, 0.5, 0.5, 10.0))


def rest(robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(TCP position, TCP rotation, gravity torque) at the nominal configuration, at rest."""
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    return robot.tcp_position.copy(), robot.tcp_rotation.copy(), robot.nonlinear_effects.copy()


def slow_law(robot: RobotModel) -> ReplicaController:
    return ReplicaController(robot, paper_fic(), control_period=CONTROL_PERIOD, command_period=COMMAND_PERIOD)


def test_between_ticks_the_torque_approaches_the_laws_output_at_the_rate_limit_and_stops_there(
        robot: RobotModel) -> None:
    """A 250 Hz law answering 1 kHz joint states: its output may move 4 N m from the last torque sent, the torque
    sent 1 N m a millisecond; ``held_torque`` at the joint states between two ticks takes the rest, 1 N m each,
    reaches the law's output and holds it (no overshoot, no step larger than the rate allows)."""
    replica = slow_law(robot)
    assert replica.held_torque(0.0) is None and replica.repeat_torque() is None   # nothing sent yet
    position, rotation, gravity = rest(robot)
    replica.reset(previous_torque=gravity)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.1, 0.0, 0.0], rotation, time=0.0)
    target = command.law_torque
    gap = np.abs(target - gravity)
    assert gap.max() == pytest.approx(RATE * CONTROL_PERIOD)          # the law moved a whole 4 ms rate step
    assert np.abs(command.torque - gravity).max() == pytest.approx(STEP)   # the torque sent only 1 ms's
    assert LimitFlag.TORQUE_RATE in command.limit_shaping
    sent = [command.torque]
    for k in range(1, 7):
        sent.append(replica.held_torque(k * COMMAND_PERIOD))
    for before, after in zip(sent, sent[1:]):
        assert np.abs(after - before).max() <= STEP + ROUND_OFF
        # Each joint moves toward the law's output and never past it.
        assert np.all(np.abs(target - after) <= np.abs(target - before) + ROUND_OFF)
    # Each millisecond takes a whole step off every joint's gap until it is closed: four milliseconds after the
    # tick the torque is the law's output, and it stays there.
    for k, torque in enumerate(sent):
        np.testing.assert_allclose(np.abs(target - torque), np.maximum(gap - (k + 1) * STEP, 0.0), rtol=0.0,
                                   atol=ROUND_OFF)
    np.testing.assert_array_equal(sent[-1], target)
    np.testing.assert_array_equal(replica.repeat_torque(), sent[-1])
    np.testing.assert_array_equal(replica.previous_torque, sent[-1])


def test_the_last_torque_repeated_is_a_copy_and_moves_nothing(robot: RobotModel) -> None:
    """``repeat_torque`` (a joint state that could not be used) is the last torque sent, as often as asked, and
    changing the array it returns changes nothing the replica sends next."""
    replica = ReplicaController(robot, paper_fic())
    position, rotation, gravity = rest(robot)
    replica.reset(previous_torque=gravity)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    first = replica.repeat_torque()
    np.testing.assert_array_equal(first, command.torque)
    first += 50.0
    np.testing.assert_array_equal(replica.repeat_torque(), command.torque)
    np.testing.assert_array_equal(replica.previous_torque, command.torque)


def test_a_torque_stated_as_sent_is_where_the_next_command_is_rate_bounded_from(robot: RobotModel) -> None:
    """``state_sent``: the loop sent another torque (its blend from a hold) in place of the last command's; the
    next command moves at most one rate step from that torque, reports it as its previous torque, and is
    checked against it (no torque-rate violation)."""
    replica = ReplicaController(robot, paper_fic())
    position, rotation, gravity = rest(robot)
    replica.reset(previous_torque=gravity)
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=0.0)
    stated = gravity + np.array([3.0, -3.0, 2.0, -2.0, 0.5, -0.5, 0.25])
    replica.state_sent(stated, 0.001)
    np.testing.assert_array_equal(replica.previous_torque, stated)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=0.002)
    np.testing.assert_array_equal(command.previous_torque, stated)
    assert np.abs(command.torque - stated).max() <= RATE * 0.001 + ROUND_OFF
    # The law holds the arm at rest near gravity's torque, 3 N m from the stated one: pulled back a full step.
    assert np.abs(command.torque - stated).max() == pytest.approx(RATE * 0.001)
    assert LimitFlag.TORQUE_RATE not in command.limit_violations
    with pytest.raises(FicInputError, match="torque sent"):
        replica.state_sent([np.nan] * 7, 0.003)
    np.testing.assert_array_equal(replica.previous_torque, command.torque)   # a refused statement changes nothing


def test_a_replacement_controller_continues_the_torque_the_counters_and_the_target(robot: RobotModel) -> None:
    """``continue_from`` (a parameter change at run time): the new controller's first command moves at most one
    rate step from the old one's last torque, the cumulative counters carry on from the old one's, and between
    its ticks it keeps approaching the old law's output."""
    old = slow_law(robot)
    position, rotation, gravity = rest(robot)
    old.reset(previous_torque=gravity)
    command = old.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.1, 0.0, 0.0], rotation, time=0.0)
    old.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.3, 0.0, 0.0], rotation, time=0.001)
    assert (old.ticks, old.shaped_ticks) == (2, 2)
    new = ReplicaController(robot, LinearImpedance(200.0, 20.0, 20.0, 2.0), control_period=CONTROL_PERIOD,
                            command_period=COMMAND_PERIOD)
    new.continue_from(old)
    assert (new.ticks, new.shaped_ticks, new.violation_ticks) == (old.ticks, old.shaped_ticks, old.violation_ticks)
    np.testing.assert_array_equal(new.previous_torque, old.previous_torque)
    held = new.held_torque(0.002)   # toward the old law's last output, one more millisecond's step
    assert np.abs(held - old.previous_torque).max() == pytest.approx(STEP)
    first = new.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=0.003)
    assert np.abs(first.torque - held).max() <= STEP + ROUND_OFF
    assert first.previous_torque is not None
    assert new.ticks == old.ticks + 1
    assert np.abs(command.law_torque - gravity).max() == pytest.approx(RATE * CONTROL_PERIOD)


def test_reset_states_the_applied_torque_or_forgets_it_and_refuses_a_non_finite_one(robot: RobotModel) -> None:
    """``reset(previous_torque)``: the first command after it is rate-bounded from that torque; ``reset()``
    without one lets the first command take the law's output whole; a NaN torque is refused by name, and the
    replica keeps what it had."""
    replica = ReplicaController(robot, paper_fic())
    position, rotation, gravity = rest(robot)
    far = position + [0.1, 0.0, 0.0]
    replica.reset()
    unbounded = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), far, rotation)
    assert unbounded.previous_torque is None
    replica.reset(previous_torque=gravity)
    bounded = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), far, rotation)
    np.testing.assert_array_equal(bounded.previous_torque, gravity)
    assert np.abs(bounded.torque - gravity).max() <= RATE * 0.001 + ROUND_OFF
    assert np.abs(unbounded.torque - gravity).max() > 2.0 * RATE * 0.001   # without it, the law's whole output
    with pytest.raises(FicInputError, match="previous_torque"):
        replica.reset(previous_torque=[np.nan] * 7)
    np.testing.assert_array_equal(replica.previous_torque, bounded.torque)
