"""The simulated robot's side of the torque interface, one physics step per ``update``: what robot_node steps on its
physics thread and the in-process runner steps on its one clock.

    torque computed on a joint state --> ``admits`` (command_state_timeout: a torque on a state older than the bound
        is refused, never applied, the watchdog not released) --> ``receive`` (the torque the arm follows from now,
        the watchdog released; with the physics-rate dynamics the law's C qd + G of its tick is swapped for the
        arm's own at this step)
    ``update(now)``: the velocity reflex on the state about to be stepped (latched: the hold torque for the rest of
        the run), the stale-command watchdog (the hold torque once the newest torque is older than command_timeout,
        when ``hold_on_stale``), then one physics step with the torque chosen

The caller owns the clocks: ``now`` is the watchdog's clock (wall seconds in realtime, simulated seconds in lockstep
and in process), and the state-age rule takes both times in one unit of the caller's (robot_node: nanoseconds on its
stamp grid; the runner: simulated seconds). Transitions come back as events, each once, for the caller to log.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.arm_profile import arm_profile
from fic_core.panda_description import ARM_JOINT_NAMES
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.robot_parameters import RobotParameters
from sim_bridge.robot.velocity_reflex import ReflexEvent, VelocityReflex
from sim_bridge.robot.watchdog import CommandStateAge, CommandWatchdog, WatchdogEvent

_NO_DAMPING = np.zeros(7)


@dataclass(frozen=True)
class RobotUpdate:
    """What one physics step said: the watchdog's transition and the reflex's trip, each None if none."""

    watchdog: WatchdogEvent | None
    reflex: ReflexEvent | None


class RobotStation:
    """The simulated arm with its watchdog, its rule on a torque's state, its velocity reflex and its hold (module
    docstring). ``dynamics_at_physics_rate``: a torque's C qd + G of the law's tick (``receive``'s
    ``tick_dynamics``) is replaced by the arm's own at the step it arrives (the in-process bandwidth sweeps:
    docs/EXPERIMENTS.md "Bandwidth sweeps")."""

    def __init__(self, sim: PandaSimulation, *, command_timeout: float, command_state_timeout: float = math.inf,
                 hold_on_stale: bool = True, reflex: VelocityReflex | None = None,
                 dynamics_at_physics_rate: bool = False) -> None:
        self.sim = sim
        self._watchdog = CommandWatchdog(command_timeout)
        self._state_age = CommandStateAge(command_state_timeout)
        self._reflex = reflex
        self.hold_on_stale = hold_on_stale
        self.dynamics_at_physics_rate = dynamics_at_physics_rate
        self._command: NDArray[np.float64] | None = None   # the torque the arm follows (the newest received)
        self._tick_dynamics = np.zeros(7)
        self.joint_speed_max = 0.0   # the fastest joint over every step so far [rad/s]
        model = sim.model
        self._arm_dof = np.array([model.jnt_dofadr[model.joint(name).id] for name in ARM_JOINT_NAMES])
        self._arm_velocity, self._arm_momentum = np.zeros(model.nv), np.zeros(model.nv)
        self._geoms: dict[str, int] = {}

    @classmethod
    def from_parameters(cls, sim: PandaSimulation, parameters: RobotParameters, joint_names: Sequence[str], *,
                        nanosecond_stamps: bool = False, state_age_rule: bool = True,
                        dynamics_at_physics_rate: bool = False) -> RobotStation:
        """The robot node's station from its parameters, for robot_node and the in-process runner alike: the
        stale-command hold (``command_timeout``, ``hold_on_stale_commands``), the state-age rule
        (``command_state_timeout``: in nanoseconds on the node's stamp grid with ``nanosecond_stamps``, else in
        seconds; ``state_age_rule`` False: none, the robot before the rule existed) and the velocity reflex on
        ``joint_names`` (``velocity_reflex``). The simulated arm is the Panda; behind the franka_ros2 twin it stands
        for an FR3 and stops at its limits."""
        p = parameters
        arm = "fr3" if p.driver_interface == "franka_ros2" else "panda"
        reflex = VelocityReflex(arm_profile(arm).joint_velocity, joint_names) if p.velocity_reflex else None
        state_timeout = (round(p.command_state_timeout * 1e9) if nanosecond_stamps else p.command_state_timeout) \
            if state_age_rule else math.inf
        return cls(sim, command_timeout=p.command_timeout, command_state_timeout=state_timeout,
                   hold_on_stale=p.hold_on_stale_commands, reflex=reflex,
                   dynamics_at_physics_rate=dynamics_at_physics_rate)

    # --- read-outs -------------------------------------------------------------------------------------------
    @property
    def holding(self) -> bool:
        """The watchdog holds the arm (no torque yet, or the newest one stale)."""
        return self._watchdog.holding

    @property
    def command_timeout(self) -> float:
        return self._watchdog.timeout

    @property
    def command_state_timeout(self) -> float:
        return self._state_age.timeout

    @property
    def watchdog_engagements(self) -> int:
        return self._watchdog.engagements

    @property
    def refused_torques(self) -> int:
        """Torques refused as computed on a state older than command_state_timeout."""
        return self._state_age.refused

    @property
    def reflex_tripped(self) -> bool:
        return self._reflex is not None and self._reflex.tripped

    @property
    def reflex_event(self) -> ReflexEvent | None:
        return None if self._reflex is None else self._reflex.event

    @property
    def command(self) -> NDArray[np.float64] | None:
        """The torque the arm follows while no hold is on (None before the first)."""
        return self._command

    def arm_kinetic_energy(self) -> float:
        """1/2 qd^T M(q) qd of the arm's joints now [J] (the scene's other bodies at rest in it)."""
        sim, velocity, momentum = self.sim, self._arm_velocity, self._arm_momentum
        velocity[self._arm_dof] = sim.joint_velocities
        mujoco.mj_mulM(sim.model, sim.data, momentum, velocity)   # M(q) qd
        return 0.5 * float(velocity @ momentum)

    def touches(self, geom: str) -> bool:
        """Whether any contact of the last step involves the scene's geom named ``geom``."""
        index = self._geoms.get(geom)
        if index is None:
            index = self._geoms[geom] = self.sim.model.geom(geom).id
        data = self.sim.data
        if not data.ncon:
            return False
        contacts = data.contact[:data.ncon]
        return bool(np.any((contacts.geom1 == index) | (contacts.geom2 == index)))

    # --- inputs ----------------------------------------------------------------------------------------------
    def admits(self, state_time: float, newest_state_time: float) -> bool:
        """Whether a torque computed on the state of ``state_time`` may be applied, the newest state published being
        of ``newest_state_time`` (counted when not)."""
        return self._state_age.admits(state_time, newest_state_time)

    def receive(self, torque: ArrayLike, now: float,
                tick_dynamics: NDArray[np.float64] | None = None) -> WatchdogEvent | None:
        """A torque to follow from ``now`` on (already admitted); the watchdog's release event if it ends a hold.
        ``tick_dynamics``: the law's C qd + G at the control tick that computed it (physics-rate dynamics only;
        None: the last tick's, a torque held between ticks)."""
        torque = np.asarray(torque, dtype=float)
        if self.dynamics_at_physics_rate:
            if tick_dynamics is not None:
                self._tick_dynamics = tick_dynamics
            torque = torque - self._tick_dynamics + self.sim.hold_torque(_NO_DAMPING)
        self._command = torque
        return self._watchdog.command_received(now)

    def check_watchdog(self, now: float) -> WatchdogEvent | None:
        """The watchdog at ``now`` without a step (robot_node's lockstep wait, before its first step)."""
        return self._watchdog.check(now)

    # --- the step --------------------------------------------------------------------------------------------
    def torque(self) -> NDArray[np.float64]:
        """The torque the next step applies: the hold torque when the reflex has stopped the arm, before the first
        torque, or while the watchdog holds (``hold_on_stale``); else the torque followed."""
        if self.reflex_tripped or self._command is None or (self._watchdog.holding and self.hold_on_stale):
            return self.sim.hold_torque()
        return self._command

    def update(self, now: float) -> RobotUpdate:
        """One physics step at the watchdog's clock ``now`` (module docstring)."""
        sim = self.sim
        reflex = None if self._reflex is None else self._reflex.check(sim.joint_velocities, sim.time)
        event = self._watchdog.check(now)
        sim.step(self.torque())
        # max |qd| on Python floats: the value numpy's abs().max() gives, at a third of its cost per step.
        self.joint_speed_max = max(self.joint_speed_max, max(map(abs, sim.joint_velocities.tolist())))
        return RobotUpdate(event, reflex)


__all__ = ["RobotStation", "RobotUpdate"]
