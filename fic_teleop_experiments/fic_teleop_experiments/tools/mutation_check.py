"""Mutation check of the core laws: break each one on purpose and see which test catches it.

Each mutation below is a small textual patch of one law in fic_core (a sign flip, a dropped term, a wrong
switching condition, a limit loosened). For each, the tool copies fic_core/fic_core to a temporary folder,
applies the patch there (the work tree is never touched), and runs the core tests with that copy first on
PYTHONPATH, stopping at the first failure. A mutation that no test catches is reported as SURVIVED, and the tool
exits 1 if any did: every deliberate break must be caught by at least one test.

    source scripts/env.sh && python -m fic_teleop_experiments.tools.mutation_check   # all mutations
    python -m fic_teleop_experiments.tools.mutation_check -k attractor               # those whose name contains
    "attractor" python -m fic_teleop_experiments.tools.mutation_check --list                     # names only
    python -m fic_teleop_experiments.tools.mutation_check --patches                  # only: does every patch still
    apply? python -m fic_teleop_experiments.tools.mutation_check --table                    # and a Markdown table at
    the end

A patch whose text is no longer found in the source (the code changed) is reported as STALE and also fails the
check, so that the list is kept in step with the code.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from fic_teleop_experiments.tools.mutation_verdict import KILLED, SETTINGS_PLUGIN, pytest_verdict, write_settings_plugin
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
PACKAGE = REPO / "fic_core" / "fic_core"
# The core's tests, and the replica closing the loop on the MuJoCo arm.
TESTS = ["test/core", "test/sim/test_replica_on_mujoco.py"]
# Tests marked xfail(strict) for a defect not fixed yet: left out of the mutation runs (a strict xfail that passes
# under a mutation would stop -x before the real tests). None at present: x_d' = 1e3 m on the MuJoCo arm passes
# since the input authority bounds x_d' in front of the loop.
KNOWN_FAILING: list[str] = []


@dataclass
class Mutation:
    name: str           # "<module>: what is broken"
    module: str         # file in fic_core/fic_core
    patches: list[tuple[str, str]]  # (old, new); each old must occur in the file (every occurrence is replaced)
    first: list[str] = field(default_factory=list)  # test files likely to catch it, run on their own first


MUTATIONS = [
    # --- the force profile F_c (paper Eq. 1) -------------------------------------------------------------------
    Mutation("profile: linear region with the wrong sign", "profile.py",
             [("        if magnitude <= self._linear_limit:\n            return self.stiffness * error",
               "        if magnitude <= self._linear_limit:\n            return -self.stiffness * error"),
              ("    return np.where(magnitude <= linear_limit, stiffness * error,",
               "    return np.where(magnitude <= linear_limit, -stiffness * error,")],
             ["test/core/test_profile.py"]),
    Mutation("profile: tanh term not renormalised (the printed Eq. 1)", "profile.py",
             [("math.tanh((magnitude - self.saturation_error) / self._width + math.pi) - _TANH_START) / _TANH_SPAN",
               "math.tanh((magnitude - self.saturation_error) / self._width + math.pi) - 0.0) / 1.0"),
              ("(np.tanh(argument) - _TANH_START) / _TANH_SPAN", "np.tanh(argument)")],
             ["test/core/test_profile.py"]),
    Mutation("profile: saturation starts at x_b instead of xi x_b", "profile.py",
             [("        if magnitude <= self._linear_limit:\n            return self.stiffness * error",
               "        if magnitude <= self.saturation_error:\n            return self.stiffness * error"),
              ("    return np.where(magnitude <= linear_limit, stiffness * error,",
               "    return np.where(magnitude <= saturation_error, stiffness * error,")],
             ["test/core/test_profile.py"]),
    # --- the attractor (paper Eq. 2) ----------------------------------------------------------------------------
    Mutation("attractor: enters C while the error grows (switching condition inverted)", "attractor.py",
             [("else 0.0)) < deadband:", "else 0.0)) > -deadband:"),
              ("if magnitude_rate < deadband and previous * error > 0.0",
               "if magnitude_rate > -deadband and previous * error > 0.0")],
             ["test/core/test_attractor.py"]),
    Mutation("attractor: C law about -e_max/2 (sign flip of the mid-point)", "attractor.py",
             [("force = stiffness * (error - 0.5 * latched)  # Eq. 2, C",
               "force = stiffness * (error + 0.5 * latched)  # Eq. 2, C"),
              ("force = stiffness * (error - 0.5 * previous)  # Eq. 2, C",
               "force = stiffness * (error + 0.5 * previous)  # Eq. 2, C")],
             ["test/core/test_attractor.py"]),
    Mutation("attractor: K_C without its storage cap (2 F/e_max only)", "attractor.py",
             [("stiffness = min(2.0 * latched_force / magnitude, 8.0 * latched_energy / (magnitude * magnitude))",
               "stiffness = 2.0 * latched_force / magnitude")],
             ["test/core/test_passivity.py", "test/core/test_attractor.py"]),
    Mutation("attractor: K_C = F_c(e_max)/e_max (factor 2 dropped)", "attractor.py",
             [("stiffness = min(2.0 * latched_force / magnitude, 8.0 * latched_energy / (magnitude * magnitude))",
               "stiffness = min(1.0 * latched_force / magnitude, 8.0 * latched_energy / (magnitude * magnitude))")],
             ["test/core/test_attractor.py", "test/core/test_oracles.py"]),
    Mutation("attractor: e_max latched at e_k instead of e_{k-1}", "attractor.py",
             [("                latched_max_errors[axis] = previous\n",
               "                latched_max_errors[axis] = error\n")],
             ["test/core/test_passivity.py", "test/core/test_attractor.py"]),
    Mutation("attractor: C -> D without the storage check (the C line not kept)", "attractor.py",
             [("if staying or profile.scalar_energy(previous) > convergence_storage(",
               "if staying or profile.scalar_energy(previous) > 1e300 + convergence_storage(")],
             ["test/core/test_passivity.py"]),
    Mutation("attractor: stays in C across the target (sign-change exit dropped)", "attractor.py",
             [("if (rate < 0.0 and latched > 0.0) if error > 0.0 else \\\n"
               "                        (error < 0.0 and -rate < 0.0 and latched < 0.0):",
               "if (rate < 0.0) if error > 0.0 else \\\n"
               "                        (-rate < 0.0 if error < 0.0 else True):"),
              ("staying = magnitude_rate < 0.0 and ((error > 0.0) == (latched > 0.0)) and \\\n",
               "staying = magnitude_rate < 0.0 or error * latched <= 0.0 or 0.0 * \\\n")],
             ["test/core/test_attractor.py"]),
    Mutation("attractor: C force not clipped to F_max", "attractor.py",
             [("forces.append(max_force if force > max_force else (-max_force if force < -max_force else force))",
               "forces.append(force)")],
             ["test/core/test_attractor.py"]),
    # --- the angle-axis rotation and the exchanged-energy observer (docs/CONTROL_LAWS.md, "Rotation") ----------
    Mutation("rotational attractor: moment along -r (sign of the axis)", "rotational_attractor.py",
             [("moment = (scale * x, scale * y, scale * z)", "moment = (-scale * x, -scale * y, -scale * z)")],
             ["test/core/test_rotational_attractor.py"]),
    Mutation("rotational attractor: angle rate of the opposite sign", "rotational_attractor.py",
             [("angle_rate = (x * rates[0] + y * rates[1] + z * rates[2]) / angle",
               "angle_rate = -(x * rates[0] + y * rates[1] + z * rates[2]) / angle")],
             ["test/core/test_attractor.py"]),
    Mutation("exchanged-energy observer: work with the effort after the step", "exchanged_energy_observer.py",
             [("                work += previous * step\n", "                work += held * step\n")],
             ["test/core/test_exchanged_energy_observer.py"]),
    # --- the passivity observer of one FIC port (docs/CONTROL_LAWS.md, "Passivity of the attractor") -----------
    Mutation("passivity observer: port work F_k (e_{k-1} - e_k) (sign)", "passivity_observer.py",
             [("work[axis] += force * (error - before)", "work[axis] += force * (before - error)")],
             ["test/core/test_passivity_observer.py"]),
    Mutation("passivity observer: margin without the storage change", "passivity_observer.py",
             [("margins.append(work[axis] - (storage - initial[axis]))", "margins.append(work[axis])")],
             ["test/core/test_passivity_observer.py"]),
    Mutation("passivity observer: a restarted port keeps its last error", "passivity_observer.py",
             [("        self._previous_errors = None\n        self._work = [0.0] * self._axes",
               "        self._work = [0.0] * self._axes")],
             ["test/core/test_passivity_observer.py"]),
    # --- the harmonic planner (paper Eqs. 5-6) ------------------------------------------------------------------
    Mutation("planner: D law ignores a_max (Eq. 6)", "planner.py",
             [("np.minimum(self._natural_frequency ** 2 * np.abs(error), self._max_acceleration)",
               "(self._natural_frequency ** 2 * np.abs(error))"),
              ("acceleration = np.clip(acceleration, -self._max_acceleration, self._max_acceleration)",
               "acceleration = acceleration")],
             ["test/core/test_planner.py"]),
    Mutation("planner: C law about -x_T0/2 (sign flip)", "planner.py",
             [("(error - 0.5 * self._latched_displacement) - viscous",
               "(error + 0.5 * self._latched_displacement) - viscous")],
             ["test/core/test_planner.py"]),
    Mutation("planner: enters C while the error grows", "planner.py",
             [("(magnitude_rate < -self._rate_deadband)", "(magnitude_rate > self._rate_deadband)")],
             ["test/core/test_planner.py"]),
    Mutation("quaternion: the planner's fixed orientation not normalised", "quaternion.py",
             [("x, y, z, w = pin.Quaternion(quaternion).normalized().coeffs().tolist()",
               "x, y, z, w = (float(q) for q in quaternion)")],
             ["test/core/test_planner.py"]),
    Mutation("planner: speed not clipped to v_d", "planner.py",
             [("velocity = velocity * (self._max_velocity / speed)", "velocity = velocity")],
             ["test/core/test_planner.py"]),
    # --- the master (paper Eq. 3) -------------------------------------------------------------------------------
    Mutation("master Eq. 3: K_H F_R with the wrong sign", "master.py",
             [("+ self._haptic_gain * replica_force", "- self._haptic_gain * replica_force")],
             ["test/core/test_master.py"]),
    Mutation("master Eq. 3: FIC on +x_M (error sign)", "master.py",
             [("self._attractor.force(-handle_position, -handle_velocity)",
               "self._attractor.force(handle_position, -handle_velocity)")],
             ["test/core/test_master.py"]),
    Mutation("master Eq. 3: K_H not clamped to [0, 1]", "master.py",
             [("self._haptic_gain = min(max(requested, 0.0), 1.0)", "self._haptic_gain = requested")],
             ["test/core/test_master.py"]),
    Mutation("master Eq. 3: FIC rate +dx_M/dt (phase chosen on the wrong rate)", "master.py",
             [("self._attractor.force(-handle_position, -handle_velocity)",
               "self._attractor.force(-handle_position, handle_velocity)")],
             ["test/core/test_master.py"]),
    Mutation("master: device force not saturated", "master.py",
             [("bounded = norm_bounded(force, self._max_device_force)", "bounded = force")],
             ["test/core/test_master.py"]),
    # --- the replica (paper Eq. 7) ------------------------------------------------------------------------------
    Mutation("replica Eq. 7: C qd + G dropped", "replica.py",
             [("desired_torque = nonlinear + drive", "desired_torque = drive + 0.0 * nonlinear")],
             ["test/core/test_oracles.py"]),
    Mutation("replica Eq. 7: J^T FIC with the wrong sign", "replica.py",
             [("task_force = wrench - posture_task_force", "task_force = -wrench - posture_task_force")],
             ["test/core/test_oracles.py"]),
    Mutation("replica Eq. 7: posture not projected into the null space", "replica.py",
             [("task_force = wrench - posture_task_force", "task_force = wrench + 0.0 * posture_task_force")],
             ["test/core/test_oracles.py"]),
    Mutation("replica: rotation error transposed (log(R R_d^T))", "replica.py",
             [("rotation_error = pin.log3(desired_rotation.dot(rotation.T))",
               "rotation_error = pin.log3(rotation.dot(desired_rotation.T))")],
             ["test/core/test_oracles.py"]),
    Mutation("replica feedforward: + Jdot qd instead of - Jdot qd", "replica.py",
             [("desired_acceleration - robot.tcp_bias_acceleration",
               "desired_acceleration + robot.tcp_bias_acceleration")],
             ["test/core/test_oracles.py"]),
    Mutation("replica friction compensation: - D qd_d", "replica.py",
             [("drive += robot.joint_damping * np.minimum(np.maximum(desired_joint_velocity",
               "drive -= robot.joint_damping * np.minimum(np.maximum(desired_joint_velocity")],
             ["test/core/test_oracles.py"]),
    Mutation("replica hold: follows the current TCP instead of the last desired pose", "replica.py",
             [("if self._held_position is None or self._held_rotation is None:\n            self.robot.update(q, qd)",
               "if True:\n            self.robot.update(q, qd)")],
             ["test/core/test_replica.py"]),
    Mutation("replica Eq. 7: posture torque tau_0 dropped", "replica.py",
             [("        drive += posture_joint_torque\n", "        drive += 0.0 * posture_joint_torque\n")],
             ["test/core/test_oracles.py"]),
    Mutation("replica feedforward: Lambda a_d dropped", "replica.py",
             [("            task_force += feedforward_wrench\n",
               "            task_force += 0.0 * feedforward_wrench\n")],
             ["test/core/test_oracles.py"]),
    Mutation("replica friction compensation: not bounded at the joint speed limits", "replica.py",
             [("robot.joint_damping * np.minimum(np.maximum(desired_joint_velocity, -velocity_limit),\n"
               "                                                      velocity_limit)",
               "robot.joint_damping * desired_joint_velocity")],
             ["test/core/test_replica.py"]),
    Mutation("torque slew: the step is not clipped to the rate", "torque_slew.py",
             [("sent = previous + np.minimum(np.maximum(target - previous, -step), step)",
               "sent = np.array(target, dtype=float)")],
             ["test/core/test_replica_loop.py"]),
    Mutation("torque semantics: tau + G(q) sent to an arm that compensates gravity", "torque_semantics.py",
             [("return torque - gravity if self.gravity_compensated_by_robot else torque",
               "return torque + gravity if self.gravity_compensated_by_robot else torque")],
             ["test/core/test_hardware_semantics.py"]),
    Mutation("replica loop: a resume is rate-bounded against the command from before the loss", "replica_loop.py",
             [("        if self.desired.master_stale:\n            self.authority.reset()\n",
               "        if False:\n            self.authority.reset()\n")],
             ["test/core/test_replica_loop.py"]),
    # --- the postural optimisation's limits ---------------------------------------------------------------------
    Mutation("postural optimisation: fast path admits every tau_d", "postural_optimisation.py",
             [("        if self._far_from_limits:\n            if self._fast(",
               "        return VERDICT_INSIDE\n        if self._far_from_limits:\n            if self._fast(")],
             ["test/core/test_postural_optimisation.py"]),
    Mutation("postural optimisation: torque-rate step doubled", "postural_optimisation.py",
             [("self.rate_step = limits.torque_rate * self.control_period",
               "self.rate_step = 2.0 * limits.torque_rate * self.control_period")],
             ["test/core/test_postural_optimisation.py"]),
    Mutation("postural optimisation: Euclidean metric instead of M^-1 (Gauss)", "postural_optimisation.py",
             [("        hessian = mass_matrix_inverse\n        linear = -minv_tau_d",
               "        hessian = np.eye(7)\n        linear = -desired_torque")],
             ["test/core/test_oracles.py"]),
    Mutation("postural optimisation: braking curve without its lag", "postural_optimisation.py",
             [("self._braking_lag = self.horizon + BRAKING_TORQUE_RAMP", "self._braking_lag = 0.0")],
             ["test/core/test_postural_optimisation.py", "test/core/test_oracles.py"]),
    # (Not a mutation: dropping the next-sample range bound q + dt (qd + dt qdd) <= q_max from _joint_bounds. The
    # braking curve implies it: a (sqrt(L^2 + 2 r/a) - L) = 2 r / (sqrt(L^2 + 2 r/a) + L) <= r/L <= r/dt for the
    # room r >= 0, since the lag L = horizon + the torque ramp >= dt; so no input can tell the two apart.)
    Mutation("postural optimisation: past a limit the return speed points outward", "postural_optimisation.py",
             [("        position_high = (room_high / horizon - velocity) / horizon\n",
               "        position_high = (-room_high / horizon - velocity) / horizon\n"),
              ("        position_low = (-(room_low / horizon) - velocity) / horizon\n",
               "        position_low = ((room_low / horizon) - velocity) / horizon\n")],
             ["test/core/test_postural_optimisation.py", "test/core/test_oracles.py"]),
    Mutation("postural optimisation: velocity limit on one tick instead of the horizon", "postural_optimisation.py",
             [("    velocity_high = (velocity_limit - velocity) / horizon\n"
               "    velocity_low = (-velocity_limit - velocity) / horizon",
               "    velocity_high = (velocity_limit - velocity) / dt\n"
               "    velocity_low = (-velocity_limit - velocity) / dt"),
              ("                a_lo.append((-velocity_limit - velocity) / horizon)\n"
               "                a_hi.append((velocity_limit - velocity) / horizon)",
               "                a_lo.append((-velocity_limit - velocity) / dt)\n"
               "                a_hi.append((velocity_limit - velocity) / dt)"),
              ("if not (-velocity_limit - velocity) / horizon <= qdd <= (velocity_limit - velocity) / horizon:",
               "if not (-velocity_limit - velocity) / dt <= qdd <= (velocity_limit - velocity) / dt:")],
             ["test/core/test_postural_optimisation.py", "test/core/test_oracles.py"]),
    Mutation("postural optimisation: TCP speed cuts placed outside the limit", "postural_optimisation.py",
             [("self.limits.tcp_speed * (1.0 - _TCP_CUT_SHRINK)", "self.limits.tcp_speed * 1.5")],
             ["test/core/test_postural_optimisation.py"]),
    # --- the set-point hold (first-order hold of x_d' and x_d'') -----------------------------------------------
    Mutation("set-point hold: extrapolates without bound", "set_point.py",
             [("return min(max(now - self._received, 0.0), self.max_extrapolation)",
               "return max(now - self._received, 0.0)")],
             ["test/core/test_set_point.py"]),
    Mutation("set-point hold: acceleration with the wrong sign", "set_point.py",
             [("((velocity - self._velocity) / elapsed - self._acceleration) * blend",
               "((self._velocity - velocity) / elapsed - self._acceleration) * blend")],
             ["test/core/test_set_point.py"]),
    Mutation("set-point hold: a jump is stepped, not blended", "set_point.py",
             [("position = position + self._jump * min(remaining, 1.0)", "position = position")],
             ["test/core/test_set_point.py"]),
    Mutation("set-point hold: far-off stamps freeze the slope again", "set_point.py",
             [("if elapsed is not None and abs(elapsed) > self.max_sample_gap:",
               "if elapsed is not None and elapsed > self.max_sample_gap:"),
              ("or abs(elapsed) > self.max_sample_gap:\n", ":\n")],
             ["test/core/test_hostile_values.py"]),
    # --- the input authority (bounds on what one command may ask, docs/SECURITY.md) ----------------------------
    Mutation("input authority: stamps in the receiver's future accepted", "input_authority.py",
             [("        if stamp > now + bounds.future_tolerance:\n", "        if False:\n")],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: stamps older than max_age accepted", "input_authority.py",
             [("        if stamp < now - bounds.max_age:\n", "        if False:\n")],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: x_d' not clamped onto the workspace box", "input_authority.py",
             [("clamped_offset = np.clip(offset, self._lower, self._upper)", "clamped_offset = offset.copy()")],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: the rate bound's allowance is never spent", "input_authority.py",
             [("            self._allowance -= step\n", "            self._allowance -= 0.0\n")],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: the burst allowance is not capped", "input_authority.py",
             [("self._allowance = min(self._allowance + bounds.max_offset_speed * elapsed, bounds.max_offset_burst)",
               "self._allowance = self._allowance + bounds.max_offset_speed * elapsed")],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: K_H outside [0, 1] accepted", "input_authority.py",
             [('_in_range("K_H", haptic_gain, bounds.haptic_gain)', '""')],
             ["test/core/test_input_authority.py"]),
    Mutation("input authority: an unknown mode accepted", "input_authority.py",
             [("        if mode not in MODES:\n", "        if False:\n")],
             ["test/core/test_input_authority.py"]),
    Mutation("robot stream guard: a second publisher does not hold", "input_authority.py",
             [("        if len(writers) > 1:\n", "        if len(writers) > 2:\n")],
             ["test/core/test_input_authority.py"]),
    Mutation("robot stream guard: joint-state stamps going back are used", "input_authority.py",
             [("        if last is not None and stamp < last:\n", "        if False:\n")],
             ["test/core/test_input_authority.py"]),
    # --- the command watchdog and its ramp (docs/HARDWARE.md, "Watchdogs") ------------------------------------
    Mutation("command watchdog: rest command inverted (G(q) to an arm that compensates gravity)", "command_watchdog.py",
             [("        if self.semantics.gravity_compensated_by_robot:\n            rest = np.zeros_like",
               "        if not self.semantics.gravity_compensated_by_robot:\n            rest = np.zeros_like")],
             ["test/core/test_command_watchdog.py"]),
    Mutation("command watchdog: a fresh replica command does not end the ramp", "command_watchdog.py",
             [("        ended = self.ramp.fresh(now)\n", "        ended = False\n")],
             ["test/core/test_command_watchdog.py"]),
    Mutation("stale-input ramp: overshoots the rest command (fraction not capped at 1)", "stale_input_ramp.py",
             [("fraction = 1.0 if self.ramp_time == 0.0 else min(1.0, elapsed / self.ramp_time)",
               "fraction = 1.0 if self.ramp_time == 0.0 else elapsed / self.ramp_time")],
             ["test/core/test_command_watchdog.py"]),
    Mutation("stale-input ramp: steps to the rest command (no ramp from the last one)", "stale_input_ramp.py",
             [("self._start = None if last_command is None else np.array(last_command, dtype=float)",
               "self._start = None")],
             ["test/core/test_command_watchdog.py"]),
    Mutation("stale-input ramp: goes stale ten timeouts late", "stale_input_ramp.py",
             [("now - self._last_fresh <= self.timeout", "now - self._last_fresh <= 10.0 * self.timeout")],
             ["test/core/test_command_watchdog.py"]),
    # --- the delayed channel's passivity observer and controllers (time-domain passivity) ----------------------
    Mutation("channel observer: W from this side's own E_in", "channel_passivity_observer.py",
             [("return self.received_input_energy - self.output_energy",
               "return self.input_energy - self.output_energy")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("channel observer: a late, older E_in lowers the received one", "channel_passivity_observer.py",
             [("        if value > self.received_input_energy:\n", "        if True:\n")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("channel observer: tentative W ignores the tick's output", "channel_passivity_observer.py",
             [("return self.energy - max(-power, 0.0) * dt", "return self.energy")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("channel observer: input and output energies swapped", "channel_passivity_observer.py",
             [("        if power > 0.0:\n            self.input_energy", "        if power < 0.0:\n            "
                                                                         "self.input_energy")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("force-port controller: damper adds energy (F + alpha v)", "passivity_controller.py",
             [("damped = force - self.damping * velocity", "damped = force + self.damping * velocity")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("passivity controllers: dissipation not capped at the tick's output", "passivity_controller.py",
             [("return min(deficit, -power * dt) / dt if deficit > 0.0 else 0.0",
               "return deficit / dt if deficit > 0.0 else 0.0")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("passivity controllers: damping while W is still positive", "passivity_controller.py",
             [("    deficit = -observer.tentative(power, dt)\n",
               "    deficit = -observer.tentative(power, dt) + 1.0\n")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("force-port controller: damping not bounded", "passivity_controller.py",
             [("min(needed / square, self.max_damping)", "needed / square")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("motion-port controller: correction with the wrong sign (v - beta F)", "passivity_controller.py",
             [("delivered_velocity = velocity + gain * force", "delivered_velocity = velocity - gain * force")],
             ["test/core/test_channel_passivity.py"]),
    Mutation("motion-port controller: correction per tick not bounded", "passivity_controller.py",
             [("        if correction > self.max_correction:\n", "        if False:\n")],
             ["test/core/test_channel_passivity.py"]),
]


def run_mutation(mutation: Mutation, timeout: float) -> tuple[str, str, float]:
    """(verdict, detail, seconds): KILLED with the first failing test, SURVIVED, STALE or ERROR
    (mutation_verdict.py)."""
    source = (PACKAGE / mutation.module).read_text()
    patched = source
    for old, new in mutation.patches:
        if old not in patched:
            return "STALE", f"patch text not found in {mutation.module}: {old[:60]!r}", 0.0
        patched = patched.replace(old, new)
    with tempfile.TemporaryDirectory(prefix="fic_mutation_") as folder:
        copy = Path(folder) / "fic_core"
        shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
        (copy / mutation.module).write_text(patched)
        write_settings_plugin(Path(folder), derandomize=False)
        env = dict(os.environ)
        env["PYTHONPATH"] = folder + os.pathsep + env.get("PYTHONPATH", "")
        env["PYTHONDONTWRITEBYTECODE"] = "1"
        # A strict xfail that passes under a mutation is not a catch (it would stop -x before the real tests).
        options = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", SETTINGS_PLUGIN, "-x", "-q",
                   "-rfE", "--timeout=600",
                   *[f"--deselect={test}" for test in KNOWN_FAILING]]
        # The likely catchers in a run of their own first: pytest collects a file named before its folder in the
        # folder's order, so "first" in one command line would not run first (a slow attractor test did).
        runs = [[*options, *mutation.first], [*options, *TESTS]] if mutation.first else [[*options, *TESTS]]
        # The copy really is the one imported (else the check would pass vacuously).
        probe = subprocess.run([sys.executable, "-c", "import fic_core; print(fic_core.__file__)"], env=env,
                               capture_output=True, text=True, cwd=REPO)
        if not probe.stdout.strip().startswith(folder):
            return "ERROR", f"fic_core imported from {probe.stdout.strip()}, not the mutated copy", 0.0
        started = time.monotonic()
        for command in runs:
            try:
                result = subprocess.run(command, env=env, capture_output=True, text=True, cwd=REPO, timeout=timeout)
            except subprocess.TimeoutExpired:
                return KILLED, f"tests did not finish in {timeout:.0f} s (a hang counts as killed)", timeout
            if result.returncode != 0:
                break
        seconds = time.monotonic() - started
    verdict, detail = pytest_verdict(result)
    return verdict, detail, seconds


def compact(detail: str) -> str:
    """A failing test's id as the table shows it: file stem and test name, without the parameters."""
    if "::" not in detail:
        return detail.replace("|", "/")
    path, test = detail.split("::", 1)
    return f"`{Path(path).stem}::{test.split('[')[0]}`"


def stale_patch(mutation: Mutation) -> str:
    """The first patch text not found in the module ("" if every one applies)."""
    patched = (PACKAGE / mutation.module).read_text()
    for old, new in mutation.patches:
        if old not in patched:
            return old
        patched = patched.replace(old, new)
    return ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-k", default="", help="only the mutations whose name contains this text")
    parser.add_argument("--list", action="store_true", help="list the mutations and exit")
    parser.add_argument("--patches", action="store_true",
                        help="only check that every patch still applies (STALE ones), without running the tests")
    parser.add_argument("--table", action="store_true", help="end with a Markdown table of the verdicts")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds for the tests of one mutation")
    arguments = parser.parse_args(argv)
    selected = [mutation for mutation in MUTATIONS if arguments.k in mutation.name]
    if arguments.list:
        for mutation in selected:
            print(mutation.name)
        return 0
    if arguments.patches:
        stale = [(mutation, text) for mutation in selected if (text := stale_patch(mutation))]
        for mutation, text in stale:
            print(f"STALE    {mutation.name}\n         patch text not found in {mutation.module}: {text[:60]!r}")
        print(f"{len(selected) - len(stale)} of {len(selected)} mutations apply")
        return 1 if stale else 0
    started = time.monotonic()
    rows = []
    for mutation in selected:
        verdict, detail, seconds = run_mutation(mutation, arguments.timeout)
        rows.append((mutation.name, verdict, detail, seconds))
        print(f"{verdict:8s} {mutation.name}\n         {detail} ({seconds:.0f} s)", flush=True)
    bad = sum(verdict != KILLED for _, verdict, _, _ in rows)
    print(f"{len(selected) - bad} of {len(selected)} mutations killed in {time.monotonic() - started:.0f} s")
    if arguments.table:
        print("\n| mutation | verdict | first failing test | s |\n|---|---|---|---|")
        for name, verdict, detail, seconds in rows:
            print(f"| {name} | {verdict} | {compact(detail)} | {seconds:.0f} |")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
