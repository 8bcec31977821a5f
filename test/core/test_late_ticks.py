"""The law on late control ticks (docs/CONTROL_LAWS.md, "The law on late ticks"): the FIC's springs, computed every
T and held in between, lose K T/2 of damping to the hold; on the wrist that rang the arm up in the stress runs
(0.99 of joint 7's datasheet speed on ticks up to 57 ms apart). On a late tick each axis now gets B = K (T - T_0)/2
on its error rate (fic_core/sampled_spring_damping.py); a tick on time is the law as before."""
from __future__ import annotations

import numpy as np
import pytest

from fic_teleop_experiments.tools.sampled_law import sampled_run

WRIST_KICK = (0.5, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0)   # [rad/s] joints 5-7 at 0.38 of their datasheet speed


@pytest.mark.parametrize("period", [0.045, 0.048])
def test_a_kicked_wrist_on_ticks_near_the_loop_bound_rings_down_not_up(period: float) -> None:
    """Ticks 45 and 48 ms apart (inside the loop's 50 ms bound): before, the kick grew (joint 7 to 0.63 of its
    speed at 45 ms; joint 5's swing in the fourth second as large as in the first at 48 ms)."""
    result = sampled_run(period, WRIST_KICK, duration=4.0)
    kick = max(WRIST_KICK[4:]) / 2.61
    wrist = result["peak_speed_over_datasheet"][4:]
    assert result["holds"] == 0
    assert max(wrist) <= 1.1 * kick, wrist
    assert max(result["last_over_first_second"]) < 0.2, result["last_over_first_second"]


def test_ticks_drawn_between_20_and_48_ms_apart_do_not_pump_the_wrist() -> None:
    """A starved replica's ticks, 20-48 ms apart (seeded): before, the wrist reached 0.46-0.54 of its speed from the
    kick's 0.38."""
    for seed in (3, 4):
        result = sampled_run(0.02, WRIST_KICK, duration=3.0, longest=0.048, seed=seed)
        assert max(result["peak_speed_over_datasheet"][4:]) <= 1.15 * max(WRIST_KICK[4:]) / 2.61, result


def test_a_tick_on_time_is_the_nominal_law_and_a_late_one_adds_k_times_the_lateness_over_two() -> None:
    from fic_core.pose_attractor import PoseAttractor
    from fic_core.profile import ForceProfile
    from fic_core.sampled_spring_damping import late_hold

    assert late_hold(0.002, 0.002, 0.05) == 0.0
    assert late_hold(0.0029, 0.002, 0.05) == 0.0           # within 1.5 periods: jitter
    assert late_hold(0.032, 0.002, 0.05) == pytest.approx(0.030)
    assert late_hold(0.3, 0.002, 0.05) == pytest.approx(0.048)   # capped at the loop's bound
    assert late_hold(float("nan"), 0.002, 0.05) == 0.0

    def attractor() -> PoseAttractor:
        return PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), ForceProfile(20.0, 0.5, 0.5, 5.0))

    position, rotation = [0.01, -0.02, 0.005], [0.05, 0.0, -0.02]
    twist = [0.001, 0.002, -0.001, 0.003, -0.001, 0.002]   # below the dead-band: every axis stays in D
    nominal = attractor().wrench_values(position, rotation, twist)
    on_time = attractor()
    on_time.late_tick(0.0)
    assert on_time.wrench_values(position, rotation, twist) == nominal   # bit for bit
    late = attractor()
    late.late_tick(0.03)
    damped = np.array(late.wrench_values(position, rotation, twist))
    expected = np.array(nominal) + np.array([200.0] * 3 + [20.0] * 3) * 0.03 / 2.0 * np.array(twist)
    np.testing.assert_allclose(damped, expected, rtol=1e-12, atol=1e-15)
    # In C an axis's damper follows its convergent stiffness K_C (up to twice K_0).
    converging = attractor()
    converging.wrench_values([0.02, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0] * 6)
    converging.late_tick(0.03)
    force = converging.wrench_values([0.019, 0.0, 0.0], [0.0, 0.0, 0.0], [-0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    snapshot = converging.snapshot().translation
    assert snapshot.in_convergence[0]
    k_c = snapshot.convergence_stiffness[0]
    assert k_c > 200.0
    assert force[0] == pytest.approx(snapshot.forces[0] + k_c * 0.03 / 2.0 * -0.1, rel=1e-12)
