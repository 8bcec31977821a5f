"""The damping that gives back what a spring loses to its sample-and-hold when the law's ticks come late.

The FIC has no damping term: its only dissipation is the C -> D switch (fic_core/attractor.py). A spring of stiffness
K whose force is computed every T seconds and held in between (the robot applies each torque until the next one: a
zero-order hold) lags the motion by about T/2, and on a mass that lag is a negative damping of K T/2: the sampled
spring injects energy unless the physical damping b exceeds K T/2 (Colgate and Schenkel, "Passivity of a class of
sampled-data systems: application to haptic interfaces", 1997: b > K T/2 + |B| for a sampled spring K and damper B).
At the nominal 2 ms the FIC's largest joint-space stiffness on the Panda's wrist, 40 N m/rad (the rotational FIC's
20 N m/rad doubled in its convergent phase), loses 0.04 N m s/rad against the arm's own 0.5; on ticks 48 ms apart,
which a starved replica runs inside its loop bounds, it loses 0.96, and the wrist rings up instead of down
(docs/CONTROL_LAWS.md, "The law on late ticks"; python -m fic_teleop_experiments.tools.sampled_law).

On a late tick the attractor adds, per axis, a damper on the error rate of

    B = K (T - T_0) / 2

with K the axis's stiffness in its phase (K_0 in D, the profile's largest slope; K_C in C), T the interval the
last torque was held (capped at the loop's max_tick_gap: beyond it the loop holds and no law runs) and T_0 the
nominal control period: what the hold loses beyond the nominal law's loss, given back. A tick on time (T up to 1.5
T_0, the jitter of a tick's stamp) adds nothing, so the law on time is the law as it was, bit for bit.

The damper is itself sampled, and a sampled damper on an inertia I is stable only while B T / I < 2 (its
discrete loop gain). At the bound (T = 50 ms, K = 40 N m/rad) B = 0.96 N m s/rad on the wrist's 0.107 kg m^2
(joint 7, its armature included) gives B T / I = 0.45; the translational FIC's 2 K_0 = 400 N/m (B = 9.6 N s/m)
through the wrist's 0.2 m lever adds about 0.5 N m s/rad on joint 6 (0.154 kg m^2): 0.47, below the bound with room
for the coupling.
"""
from __future__ import annotations

#: A tick counts as late when the interval since the last one exceeds this many nominal periods: below it the
#: interval is the stamps' jitter, and the law stays exactly the nominal one.
LATE_TICK_PERIODS = 1.5


def late_hold(interval: float, nominal_period: float, longest_interval: float) -> float:
    """T - T_0 [s] of a tick ``interval`` seconds after the last (capped at ``longest_interval``), or 0.0 for a tick
    on time (within LATE_TICK_PERIODS nominal periods)."""
    if not interval > LATE_TICK_PERIODS * nominal_period:   # NaN: on time
        return 0.0
    return max(min(interval, longest_interval) - nominal_period, 0.0)


def hold_damping(stiffness: float, late: float) -> float:
    """B = K (T - T_0) / 2 [N s/m or N m s/rad] for a spring of ``stiffness`` K held ``late`` = T - T_0 seconds
    beyond the nominal period (module docstring)."""
    return 0.5 * stiffness * late
