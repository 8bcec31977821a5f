"""A ReplicaCommand has no equality by value (its fields are arrays; replica.py's docstring): two commands are equal
only if they are the same object, so a command can key a dict or sit in a set, and a command built from the same
fields is a different command."""
from __future__ import annotations

import dataclasses

import numpy as np

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaCommand, ReplicaController
from fic_core.robot_model import RobotModel


def test_a_command_is_equal_to_itself_only_and_can_key_a_dict(robot: RobotModel) -> None:
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)))
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.01, 0.0, 0.0], rotation)
    same_fields = ReplicaCommand(**{item.name: getattr(command, item.name)
                                    for item in dataclasses.fields(ReplicaCommand) if item.init})
    assert command == command and not (command != command)
    assert command != same_fields and not (command == same_fields)
    keyed = {command: "first", same_fields: "second"}
    assert keyed[command] == "first" and keyed[same_fields] == "second" and len({command, same_fields}) == 2
