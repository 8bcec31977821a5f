"""The robot and its torque controller in one process, joined without DDS, as a ros2_control hardware interface and
its controller share the controller manager's real-time loop.

When the simulated robot (sim_bridge's robot_node, ``controller_in_process``) and the replica
(``robot_in_process``) run in one process (a node group), the robot's physics thread hands each joint state and F/T
reading straight to the replica's control step, and the replica's torque straight back to the robot's command input:
no serialisation, no wake-up of another process, no transport delay. Every message still goes out on DDS as well
(the joint states, the wrench and the torque command: to the recorder in batches, record_batch.py, and on the topics
themselves while they have readers), so the recorder, the report and ``ros2 topic echo`` see the same graph; only
the robot's DDS command subscription and the replica's DDS state subscriptions are not made.

Why: on 2 cores most of the replica's CPU was the graph's cost per control tick (the joint state's reception, the
torque's publication and the robot's reception of it, the wake-ups between the two processes), not the law
(docs/RESULTS.md, "Graph levers"). A real arm's driver (franka_ros2) is another process, where the replica keeps
speaking DDS.

The simulated haptic device and the master in one process (``master_in_process``, ``device_in_process``) are joined
the same way by ``HANDLE_LINK``: the device's tick hands the handle's pose and velocity to the master, the master's
force tick its force command to the device, both on the process's one executor thread. Why: those were 750 messages
a second between two nodes of one process, each a DDS delivery and a wake-up (docs/RESULTS.md, "Benches"). The pose
and the force command still reach the recorder (record_batch.py) and any other reader; /haptic/twist, which only the
master read, is published only while something else reads it. A real device's driver (forcedimension_ros2) is
another process, where the master keeps reading DDS.

The link is the process's one ``LINK``; each side registers the callable that takes the other's messages. A side
that registers finds the other's reader whenever it has one: the robot may step before the replica is built (its
states then reach no controller, and its watchdog holds the arm, as before the first DDS command).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

Reader = Callable[[Any], None]


class InProcessLink:
    """The readers of the robot's joint states and wrench (the controller's) and of the torque command (the
    robot's), each None until its side registers."""

    def __init__(self) -> None:
        self.joint_state_reader: Reader | None = None
        self.wrench_reader: Reader | None = None
        self.command_reader: Reader | None = None


#: The process's link (one robot and one controller a process).
LINK = InProcessLink()


class HandleLink:
    """The readers of the device's handle pose and velocity (the master's) and of the force command (the device's),
    each None until its side registers."""

    def __init__(self) -> None:
        self.pose_reader: Reader | None = None
        self.twist_reader: Reader | None = None
        self.force_reader: Reader | None = None


#: The process's handle link (one haptic device and one master a process).
HANDLE_LINK = HandleLink()
