"""``ShapedTorque.iterations`` is the QP solver's iterations for that step (postural_optimisation.py: "QP solver
iterations (0 on the fast path)"): every iteration of every daqp solve the step made, counted once, and nothing
else. A solver spy (the real daqp, its reports kept) is the oracle, over seeded random states near and at the
limits with huge demands: steps with no solve report 0, steps with one solve its iterations, steps with several
(the TCP cone's cuts, or a solve found infeasible and solved again with the prediction rows soft) their sum."""
from __future__ import annotations

import numpy as np

from fic_core import postural_optimisation as postural
from fic_core.limits import PandaLimits
from fic_core.robot_model import RobotModel


def test_the_iterations_are_those_the_solver_reported_summed(robot: RobotModel, limits: PandaLimits,
                                                            monkeypatch) -> None:
    reported: list[int] = []
    real_solve = postural.daqp.solve

    def spy(*arguments, **keywords):
        answer = real_solve(*arguments, **keywords)
        reported.append(int(answer[3]["iterations"]))
        return answer

    monkeypatch.setattr(postural.daqp, "solve", spy)
    rng = np.random.default_rng(558)
    lower, upper = limits.lower_array, limits.upper_array
    v_max = limits.joint_velocity_array
    seen = {"no solve": 0, "one solve": 0, "solved again": 0, "cut": 0}
    for dt in (0.001, 0.004):
        optimisation = postural.PosturalOptimisation(limits, dt)
        for _ in range(150):
            near = rng.random(7) < 0.3
            edge = np.where(rng.random(7) < 0.5, lower + rng.uniform(-0.02, 0.1, 7), upper - rng.uniform(-0.02, 0.1, 7))
            q = np.where(near, edge, rng.uniform(lower, upper))
            qd = rng.uniform(-1.1, 1.1, 7) * v_max * rng.choice([0.1, 0.5, 1.0])
            robot.update(q, qd)
            bias = robot.nonlinear_effects + robot.joint_damping * robot.qd
            previous = None if rng.random() < 0.2 else np.clip(
                bias + rng.normal(size=7), -limits.torque_array, limits.torque_array)
            desired = bias + rng.normal(size=7) * rng.choice([0.3, 3.0, 30.0, 1000.0])
            reported.clear()
            result = optimisation.shape(desired, previous, robot.q, robot.qd, bias, robot.mass_matrix_inverse,
                                        robot.tcp_jacobian[:3])
            assert result.iterations == sum(reported), (result.iterations, reported)
            assert result.solved_qp == bool(reported)
            if not reported:
                seen["no solve"] += 1
            elif len(reported) == 1:
                seen["one solve"] += 1
            elif result.relaxed and len(reported) == 2 and reported[1] > 0:
                seen["solved again"] += 1
            else:
                seen["cut"] += 1
    assert seen["no solve"] >= 15 and seen["one solve"] >= 50 and seen["solved again"] >= 30 and seen["cut"] >= 10, seen
