"""A law object built without an argument is the shipped one: each keyword default of fic_core's constructors that
a node also sets from config/ equals the value config/ ships (the one home of the defaults), the limits' defaults
are the datasheet's figures as docs/CONTROL_LAWS.md quotes them, and the replica loop's hold damps each joint as
the simulated robot's own stale-command hold does (loop_health.HOLD_DAMPING says it is sim_bridge's), so a hold of
either brakes the arm alike."""
from __future__ import annotations

import ast
import inspect
import re
from pathlib import Path

import pytest
from config_values import config_values

from fic_core.attractor import FractalAttractor
from fic_core.limits import PandaLimits
from fic_core.loop_health import HOLD_DAMPING
from fic_core.master import MasterLaw
from fic_core.pose_attractor import PoseAttractor
from fic_core.postural_optimisation import PosturalOptimisation
from fic_core.posture import NullSpacePosture
from fic_core.replica import ReplicaController
from fic_core.rotational_attractor import RotationalAttractor
from fic_core.teleoperation import TeleoperationCommandIntegrator
from fic_core.trajectories import Circle, ViaPoints

REPOSITORY = Path(__file__).resolve().parents[2]
PLANNER = config_values("planner.yaml")
REPLICA = config_values("replica.yaml")
MASTER = config_values("master.yaml")

# (constructor, keyword, the shipped value of the same setting)
SHIPPED = [
    (ViaPoints, "dwell_s", PLANNER["via_dwell"]),
    (ViaPoints, "tolerance", PLANNER["via_tolerance"]),
    (Circle, "diameter", PLANNER["circle_diameter"]),
    (Circle, "period", PLANNER["circle_period"]),
    (Circle, "phase", PLANNER["circle_phase"]),
    (FractalAttractor, "rate_deadband", REPLICA["rate_deadband_translation"]),
    (RotationalAttractor, "rate_deadband", REPLICA["rate_deadband_rotation"]),
    (PoseAttractor, "rate_deadband_translation", REPLICA["rate_deadband_translation"]),
    (PoseAttractor, "rate_deadband_rotation", REPLICA["rate_deadband_rotation"]),
    (NullSpacePosture, "stiffness", REPLICA["posture_stiffness"]),
    (NullSpacePosture, "damping", REPLICA["posture_damping"]),
    (NullSpacePosture, "limit_band", REPLICA["posture_limit_band"]),
    (NullSpacePosture, "limit_stiffness", REPLICA["posture_limit_stiffness"]),
    (PosturalOptimisation, "velocity_horizon", REPLICA["velocity_horizon"]),
    (ReplicaController, "control_period", 1.0 / REPLICA["control_rate"]),
    (MasterLaw, "force_scale", MASTER["force_scale"]),
    (TeleoperationCommandIntegrator, "workspace_scale", MASTER["workspace_scale"]),
]


@pytest.mark.parametrize("constructor, keyword, shipped", SHIPPED,
                         ids=[f"{constructor.__name__}.{keyword}" for constructor, keyword, _ in SHIPPED])
def test_a_constructors_default_is_the_shipped_value(constructor, keyword: str, shipped) -> None:
    default = inspect.signature(constructor).parameters[keyword].default
    assert default is not inspect.Parameter.empty
    assert default == shipped, (constructor.__name__, keyword, default, shipped)


def test_the_limits_defaults_are_the_datasheet_figures_the_docs_quote() -> None:
    """docs/CONTROL_LAWS.md, "The limits": torque rate 1000 N m/s, end-effector speed 1.7 m/s."""
    text = " ".join((REPOSITORY / "docs" / "CONTROL_LAWS.md").read_text().split())
    torque_rate = float(re.search(r"torque rate ([0-9.]+) N m/s;", text).group(1))
    tcp_speed = float(re.search(r"end-effector speed ([0-9.]+) m/s;", text).group(1))
    parameters = inspect.signature(PandaLimits).parameters
    assert (parameters["torque_rate"].default, parameters["tcp_speed"].default) == (torque_rate, tcp_speed)


def test_the_replica_loops_hold_damps_as_the_simulated_robots_hold() -> None:
    """sim_bridge's mujoco_panda.HOLD_DAMPING, read from its source (test/core imports no simulator)."""
    source = (REPOSITORY / "sim_bridge" / "sim_bridge" / "robot" / "mujoco_panda.py").read_text()
    robot_damping = None
    for node in ast.parse(source).body:
        if isinstance(node, ast.Assign) and any(getattr(target, "id", None) == "HOLD_DAMPING"
                                                for target in node.targets):
            value = node.value
            if isinstance(value, ast.Call):   # np.array([...])
                value = value.args[0]
            robot_damping = tuple(ast.literal_eval(value))
    assert robot_damping is not None and len(robot_damping) == 7
    assert tuple(HOLD_DAMPING) == robot_damping
