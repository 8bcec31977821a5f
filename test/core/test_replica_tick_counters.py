"""The replica's cumulative counters (what /replica/limit_status and the run's totals report: ticks, limit-shaped
ticks, limit-violation ticks) are the number of commands and of commands whose own report says shaped or broken:
one a tick, whatever the tick's flags hold, over a run that goes in and out of a limit, and through the hold
(the same law and limits). The arm at rest in the nominal pose (nothing shaped, nothing broken), then with joint 4
0.01 rad beyond its upper limit (JOINT_POSITION, shaped), back inside while the command slews back (shaped only),
and held beyond the limit."""
from __future__ import annotations

import numpy as np
from test_limit_mutants import _replica

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.robot_model import RobotModel


def test_each_counter_is_the_number_of_commands_whose_report_says_so(robot: RobotModel) -> None:
    limits = PandaLimits.from_robot(robot)
    inside = np.array(NOMINAL_CONFIGURATION, dtype=float)
    beyond = inside.copy()
    beyond[3] = limits.upper_array[3] + 0.01
    replica = _replica(robot)
    robot.update(inside, np.zeros(7))
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    commands = []
    for q in [inside] * 3 + [beyond] * 3 + [inside] * 2:
        commands.append(replica.command(q, np.zeros(7), position, rotation, time=0.001 * len(commands)))
    commands.append(replica.hold(beyond, np.zeros(7), time=0.001 * len(commands)))
    violations = [bool(command.limit_violations) for command in commands]
    shaped = [bool(command.limit_shaping) for command in commands]
    assert violations == [False] * 3 + [True] * 3 + [False] * 2 + [True]
    assert all(command.limit_violations & LimitFlag.JOINT_POSITION for command in commands[3:6] + commands[8:])
    assert shaped[:3] == [False] * 3 and all(shaped[3:])
    assert replica.ticks == len(commands) == 9
    assert replica.violation_ticks == sum(violations)
    assert replica.shaped_ticks == sum(shaped)
