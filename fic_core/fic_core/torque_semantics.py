"""What the torque command means to the driver that receives it: who compensates gravity (paper Eq. 7).

Eq. 7 asks for tau = C(q, qd) qd + G(q) + J^T FIC(x~_R) (+ the posture and the optimisation, fic_core.replica):
the torque the joints must apply. Who adds which term depends on the arm behind the topic:

- The simulated Panda (sim_bridge robot_node, default) applies the command as it is: the replica sends all of
  Eq. 7, G(q) included (``gravity_compensated_by_robot = False``).
- A Franka arm under torque control (franka_ros2's ros2_control effort interface on libfranka) compensates
  gravity itself, with its own model of the arm and of the configured load: franka_ros2's
  gravity-compensation example controller commands 0 N m on every joint and the arm floats. Sending G(q) as
  well would count gravity twice (an arm pushed up with its own weight). So the replica sends tau - G(q)
  (``gravity_compensated_by_robot = True``).
- Coriolis and centrifugal torques C(q, qd) qd are NOT compensated by the Franka: its Cartesian impedance example
  controller adds ``getCoriolisForceVector()`` to its own command. The replica therefore keeps C(q, qd) qd in
  the command in both semantics (computed with Pinocchio on the loaded model, docs/HARDWARE.md "Model").

The postural optimisation bounds tau, the torque the motors then apply (command plus the robot's own gravity
torque): that is the quantity the datasheet torque limits are about. The replica's slew (fic_core.torque_slew)
bounds the rate of tau; the published tau - G(q) changes at that rate plus dG/dt, which the replica does not
bound: franka_hardware passes effort commands through libfranka's limitRate(kMaxTorqueRate) when its rate
limiter is on (docs/HARDWARE.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class TorqueSemantics:
    """How the replica's torque tau (all of Eq. 7) becomes the command a driver expects."""

    gravity_compensated_by_robot: bool = False

    def command(self, torque: NDArray[np.float64], gravity: NDArray[np.float64]) -> NDArray[np.float64]:
        """The command to publish: tau, or tau - G(q) when the robot adds G(q) itself."""
        return torque - gravity if self.gravity_compensated_by_robot else torque

    def rest_command(self, gravity: NDArray[np.float64]) -> NDArray[np.float64]:
        """The command that holds the arm against gravity alone (no feedback, no motion): G(q), or zero when
        the robot compensates gravity itself (what franka_ros2's gravity-compensation example sends)."""
        return np.zeros_like(gravity) if self.gravity_compensated_by_robot else gravity.copy()
