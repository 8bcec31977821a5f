"""What the two real drivers publish and subscribe, so the simulated robot and device can speak exactly that.

``driver_interface: franka_ros2`` on robot_node and ``driver_interface: forcedimension`` on haptic_device_node
make the simulation a twin of the driver (docs/HARDWARE.md, "Driver twins"); the graph then runs through the
same profiles and adapter a real arm and device need. Each entry below is read from the driver's source
(repository and path in docs/HARDWARE.md):

franka_ros2 (jazzy), as franka_bringup's franka.launch.py starts it with config/controllers.yaml:
- joint_state_broadcaster, remapped ``joint_states:=franka/joint_states``: sensor_msgs/JointState at the
  controller manager's 1 kHz, ``rclcpp::SystemDefaultsQoS()`` (reliable, keep last 10), frame_id ``base_link``
  (the broadcaster's default), names ``fr3_joint1..7``, effort = measured joint torque;
- joint_state_publisher on ``/joint_states`` at 30 Hz (``joint_state_rate``), merging franka/joint_states
  (and the gripper's): what RViz uses, too slow for control;
- franka_robot_state_broadcaster: ``~/external_wrench_in_base_frame`` (geometry_msgs/WrenchStamped,
  ``rclcpp::QoS(1).best_effort()``, frame_id the URDF root ``base``) at ``convenience_publish_rate``;
- a forward effort controller (ros2_controllers' JointGroupEffortController, which the profile's
  controllers.yaml adds) on ``/effort_controller/commands`` (std_msgs/Float64MultiArray,
  ``SystemDefaultsQoS``): it applies the last command until another comes, with no timeout;
- the arm compensates its own gravity: the command is tau - G(q).

forcedimension_ros2 (main), as fd_bringup's fd.launch.py starts it in namespace ``fd``:
- ee_pose_broadcaster: ``/fd/ee_pose`` (geometry_msgs/PoseStamped, frame_id ``fd_base``) and
  ``/fd/button_state`` (std_msgs/Bool), ``SystemDefaultsQoS``, stamped with the node clock;
- joint_state_broadcaster: ``/fd/joint_states`` (fd_x, fd_y, fd_z [m, m/s, N]), ``SystemDefaultsQoS``;
- fd_clutch_broadcaster: ``/fd/fd_clutch`` (std_msgs/Bool, true = workspace engaged);
- fd_controller (effort_controllers/JointGroupEffortController over fd_x, fd_y, fd_z):
  ``/fd/fd_controller/commands`` (Float64MultiArray, forces in fd_base), last command held, NaN -> zero force;
- all at the controller manager's ``update_rate`` (1000 Hz in fd_description's fd_controllers.yaml).
"""
from __future__ import annotations

from dataclasses import dataclass

from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

#: rclcpp::SystemDefaultsQoS() as the RMW resolves it (Fast DDS, Jazzy): reliable, volatile, keep last 10.
SYSTEM_DEFAULTS_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)
#: franka_robot_state_broadcaster's convenience topics: rclcpp::QoS(1).best_effort().
FRANKA_CONVENIENCE_QOS = QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST,
                                    depth=1)

ROBOT_INTERFACES = ("sim", "franka_ros2")
DEVICE_INTERFACES = ("sim", "forcedimension")


@dataclass(frozen=True)
class FrankaRos2Topics:
    joint_states: str = "/franka/joint_states"
    joint_states_frame: str = "base_link"
    slow_joint_states: str = "/joint_states"   # joint_state_publisher, 30 Hz
    slow_joint_states_rate_hz: float = 30.0
    external_wrench: str = "/franka_robot_state_broadcaster/external_wrench_in_base_frame"
    external_wrench_frame: str = "base"
    command: str = "/effort_controller/commands"
    joint_prefix: str = "fr3"


@dataclass(frozen=True)
class ForceDimensionTopics:
    ee_pose: str = "/fd/ee_pose"
    frame: str = "fd_base"
    joint_states: str = "/fd/joint_states"
    joint_names: tuple[str, ...] = ("fd_x", "fd_y", "fd_z")
    button: str = "/fd/button_state"
    clutch: str = "/fd/fd_clutch"
    command: str = "/fd/fd_controller/commands"
    update_rate_hz: float = 1000.0


FRANKA_ROS2 = FrankaRos2Topics()
FORCE_DIMENSION = ForceDimensionTopics()
