"""Closed orientation loops driven from outside, and the work a held moment exchanges on them.

The environment imposes the robot's orientation R_k at each sample (the target R_d = I rests), from rest at
R = I around a closed loop back to rest there. The controller computes its moment M_k at sample k from
r_k = log3(R_d R_k^T) and the measured angular velocity, and holds it while the robot turns by the base-frame
increment phi_k = log3(R_{k+1} R_k^T). The work done on the controller over the step is -M_k . phi_k (the
zero-order-hold work: the moment actually applied times the motion actually made).

For an angle-axis law M = F(theta) r/theta whose scalar port is passive (V_k - V_0 <= sum_j F_j (theta_j -
theta_{j-1})), the held-moment work obeys

    sum_k -M_k . phi_k = sum_k -M_{k+1} . phi_k + sum_k (M_{k+1} - M_k) . phi_k
                      >= (V_end - V_0) - sum_k |M_{k+1} . phi_k + F_{k+1} (theta_{k+1} - theta_k)|
                                       - sum_k |M_{k+1} - M_k| |phi_k|

The last two sums are the sampling terms: the held moment's lag, and the difference between -u . phi and the
change of the angle over a finite step (d theta = -u . w dt holds exactly only in the limit). Each is second
order in the step, so over a loop they are O(dt).

Used by test/core/test_rotational_attractor.py, test/core/test_exchanged_energy_observer.py and passivity_cycles.py.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

#: A moment law: (r, w_d - w) -> M, each (3,), base frame.
MomentLaw = Callable[[np.ndarray, np.ndarray], np.ndarray]


def loop_rotation_vectors(amplitude: float, speed: float, dt: float) -> np.ndarray:
    """The error r = log3(R_d R^T) along a closed loop through five corners of both signs and all three axes,
    at ``speed`` [rad/s] in r, sampled at ``dt``; starts and ends at r = 0. Returns (n, 3)."""
    corners = amplitude * np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.8, 0.8, 0.0], [0.0, 1.0, 0.5],
                                    [-0.3, 0.2, 1.0], [0.0, 0.0, 0.0]])
    samples = [corners[0]]
    for start, end in zip(corners[:-1], corners[1:]):
        steps = max(1, int(round(float(np.linalg.norm(end - start)) / (speed * dt))))
        samples.extend(start + (end - start) * index / steps for index in range(1, steps + 1))
    samples.extend([corners[-1]] * 3)  # at rest at the end
    return np.array(samples)


@dataclass
class LoopRun:
    rotations: list[np.ndarray]   #: R_k, robot orientation in the base frame (R_d = I)
    moments: np.ndarray           #: M_k held over [k, k+1) (n, 3)
    increments: np.ndarray        #: phi_k = log3(R_{k+1} R_k^T) (n - 1, 3)
    zoh_work: float               #: sum_k -M_k . phi_k: work done on the controller [J]
    held_force_term: float        #: sum_k |M_{k+1} - M_k| |phi_k| [J]
    geometric_term: float         #: sum_k |M_{k+1} . phi_k + F_{k+1} (theta_{k+1} - theta_k)| [J]

    @property
    def sampling_tolerance(self) -> float:
        """The bound on how far below V_end - V_0 the held-moment work of an angle-axis law can fall (module
        docstring): both terms are second order per step, so the sum vanishes linearly with dt."""
        return self.held_force_term + self.geometric_term


def drive_loop(law: MomentLaw, rotation_vectors: np.ndarray, dt: float) -> LoopRun:
    """Drive ``law`` round the loop (module docstring); the angular velocity it reads is the measured one,
    phi_{k-1}/dt (the motion of the last step), so the error rate is w_d - w = -phi_{k-1}/dt."""
    rotations = [pin.exp3(vector).T for vector in rotation_vectors]  # R_d R^T = exp(r)
    increments = np.array([pin.log3(after @ before.T) for before, after in zip(rotations[:-1], rotations[1:])])
    moments = np.empty((len(rotations), 3))
    rate = np.zeros(3)
    for index, rotation in enumerate(rotations):
        if index > 0:
            rate = -increments[index - 1] / dt
        moments[index] = law(pin.log3(rotation.T), rate)
    zoh_work = float(-np.sum(moments[:-1] * increments))
    held = float(np.sum(np.linalg.norm(np.diff(moments, axis=0), axis=1) * np.linalg.norm(increments, axis=1)))
    errors = rotation_vectors  # r_k, exactly (log3 of exp3 for |r| < pi)
    angles = np.linalg.norm(errors, axis=1)
    safe = np.where(angles > 0.0, angles, 1.0)
    scalar_forces = np.where(angles > 0.0, np.sum(moments * errors, axis=1) / safe, 0.0)  # M = F r/theta
    geometric = float(np.sum(np.abs(np.sum(moments[1:] * increments, axis=1) + scalar_forces[1:] * np.diff(angles))))
    return LoopRun(rotations, moments, increments, zoh_work, held, geometric)
