"""fic_core: the Fractal Impedance Controller's mathematics for haptic teleoperation (pure Python, no ROS)."""
# Control laws (paper Sec. II): profile (Eq. 1), attractor (Eq. 2), baseline, master (Eq. 3), teleoperation
# modes, harmonic planner (Eqs. 5-6) and its trajectory sources.
from fic_core.errors import FicInputError
from fic_core.profile import ForceProfile, force_profile
from fic_core.attractor import FractalAttractor, Phase, PoseAttractor
from fic_core.baseline import LinearImpedance, make_baseline_like
from fic_core.master import MasterLaw
from fic_core.teleoperation import TeleoperationCommandIntegrator, TeleoperationMode
from fic_core.planner import HarmonicPlanner
from fic_core.trajectories import Circle, FixedPoint, ViaPoints
from fic_core.set_point import SampledSetPoint, ShrinkingOffset
# Replica (paper Eq. 7, docs/CONTROL_LAWS.md): Pinocchio model, Panda limits, null-space posture, postural optimisation.
from fic_core.robot_model import RobotModel
from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.posture import NullSpacePosture
from fic_core.postural_optimisation import PosturalOptimisation, ShapedTorque
from fic_core.quaternion import rotation_from_quaternion, unit_quaternion
from fic_core.replica import ReplicaCommand, ReplicaController
