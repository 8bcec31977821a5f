"""The virtual operator: a human hand on the haptic handle, pulled toward a target.

The hand is a spring-damper between a target and the handle (``Hand``):

    f_hand = K_hand * (target + correction - x_M) - B_hand * v_M ,   |f_hand| <= max_force

K_hand = 300 N/m and B_hand = 15 N s/m are mid-range figures for a relaxed human arm holding a stylus (arm
endpoint stiffness is a few hundred N/m at low co-contraction, damping 10-20 N s/m); with the device's 0.5 kg
and 2 N s/m they give about 3.9 Hz and a damping ratio of about 0.7, like a hand that follows without ringing.

The master's own FIC pulls the handle toward its origin (paper Eq. 3, ``FIC(-x_M)``), so a pure spring would
leave the handle short of its target by the ratio of the two stiffnesses. A person looks at the handle and the
robot and leans in until the handle is where they want it; ``correction`` models that: it integrates the
position error at ``correction_rate`` (1/s) and is bounded by ``max_correction`` (metres, so the extra force is
bounded by K_hand * max_correction) so a blocked robot never makes the hand push without limit. Set
``correction_rate = 0`` for the plain spring-damper. With the correction the steady-state gain from target to
handle is exactly 1, so in velocity mode the area under the handle displacement equals the area under the
target's: that is what lets an open-loop script travel a planned distance.

Targets come from:
- ``ScriptedOperator``: timed waypoints in handle coordinates [m] (linear or smooth interpolation) and timed
  button events (toggle teleoperation mode, K_H up, K_H down), loaded from YAML in config/operator_scripts/;
- ``JoyTarget``: a target moved at a velocity given by joystick/keyboard axes, clamped to the workspace.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar
from fic_core.norm_bound import norm_bounded
from fic_core.operator_buttons import BUTTON_COUNT, BUTTON_NAMES, OperatorButton  # noqa: F401 (BUTTON_COUNT re-exported)

Vector3 = NDArray[np.float64]

# sensor_msgs/Joy button indices on /operator/joy: the one map is fic_core.operator_buttons (the master reads it).
BUTTON_TOGGLE_MODE = int(OperatorButton.TOGGLE_MODE)
BUTTON_HAPTIC_GAIN_UP = int(OperatorButton.HAPTIC_GAIN_UP)
BUTTON_HAPTIC_GAIN_DOWN = int(OperatorButton.HAPTIC_GAIN_DOWN)
BUTTONS = {name: int(button) for name, button in BUTTON_NAMES.items()}

INTERPOLATIONS = ("linear", "smooth")


@dataclass(frozen=True)
class HandParameters:
    stiffness: float = 300.0          # K_hand [N/m]
    damping: float = 15.0             # B_hand [N s/m]
    correction_rate: float = 2.0      # how fast the operator leans in to reach the target [1/s] (0: never)
    max_correction: float = 0.10      # bound on the lean-in [m]
    max_force: float = 40.0           # strongest push of the hand [N]

    def __post_init__(self) -> None:
        finite_scalar("stiffness", self.stiffness, minimum=0.0, minimum_inclusive=False)
        finite_scalar("damping", self.damping, minimum=0.0)
        finite_scalar("correction_rate", self.correction_rate, minimum=0.0)
        finite_scalar("max_correction", self.max_correction, minimum=0.0)
        finite_scalar("max_force", self.max_force, minimum=0.0, minimum_inclusive=False)


class Hand:
    """The operator's hand: a bounded spring-damper toward ``target + correction``."""

    def __init__(self, parameters: HandParameters | None = None) -> None:
        self.parameters = parameters if parameters is not None else HandParameters()
        self.target = np.zeros(3)
        self.correction = np.zeros(3)

    def update(self, target: ArrayLike, handle_position: ArrayLike, dt: float) -> None:
        """Set the target for the next interval and let the operator lean in by the remaining error."""
        self.target = finite_array("target", target, shape=(3,)).copy()
        position = finite_array("handle_position", handle_position, shape=(3,))
        dt = finite_scalar("dt", dt, minimum=0.0)
        parameters = self.parameters
        if parameters.correction_rate > 0.0:
            self.correction = self.correction + parameters.correction_rate * dt * (self.target - position)
            self.correction = norm_bounded(self.correction, parameters.max_correction)

    def force(self, position: Vector3, velocity: Vector3) -> Vector3:
        """Force of the hand on the handle at the given handle state (called at every device substep)."""
        parameters = self.parameters
        stiffness, damping = parameters.stiffness, parameters.damping
        # k (target + correction - x) - b v per axis on Python floats (the same operations in the same order as on
        # arrays, at a fraction of numpy's per-call cost on 3-vectors; this runs at every 1 kHz device substep).
        force = np.array([stiffness * (aim + shift - at) - damping * speed for aim, shift, at, speed
                          in zip(self.target.tolist(), self.correction.tolist(), position.tolist(), velocity.tolist())])
        return norm_bounded(force, parameters.max_force)


class Waypoint(NamedTuple):
    time: float          # [s] from the script's start
    position: Vector3    # handle target [m] in haptic_base


class ScriptEvent(NamedTuple):
    time: float          # [s] from the script's start
    button: int          # BUTTON_* index


@dataclass(frozen=True)
class OperatorScript:
    """Timed handle targets and button presses for one scene. Before the first waypoint the target is the
    first waypoint's position; after the last it stays at the last one."""

    name: str
    waypoints: tuple[Waypoint, ...]
    events: tuple[ScriptEvent, ...] = ()
    interpolation: str = "smooth"
    description: str = ""
    parameters: Mapping[str, Any] = field(default_factory=dict)   # the numbers the script was derived from

    def __post_init__(self) -> None:
        if not self.waypoints:
            raise FicInputError(f"script {self.name!r}: needs at least one waypoint")
        if self.interpolation not in INTERPOLATIONS:
            raise FicInputError(f"script {self.name!r}: interpolation must be one of {INTERPOLATIONS}, "
                                f"got {self.interpolation!r}")
        times = [w.time for w in self.waypoints]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise FicInputError(f"script {self.name!r}: waypoint times must increase strictly, got {times}")
        event_times = [e.time for e in self.events]
        if any(b < a for a, b in zip(event_times, event_times[1:])):
            raise FicInputError(f"script {self.name!r}: event times must not decrease, got {event_times}")
        object.__setattr__(self, "_times", np.array(times))
        object.__setattr__(self, "_positions", np.array([w.position for w in self.waypoints]))

    @property
    def duration(self) -> float:
        return max(self.waypoints[-1].time, self.events[-1].time if self.events else 0.0)

    def target(self, time: float) -> Vector3:
        """Handle target at ``time`` [s from the script's start]."""
        times: NDArray[np.float64] = self._times  # type: ignore[attr-defined]
        positions: NDArray[np.float64] = self._positions  # type: ignore[attr-defined]
        if time <= times[0]:
            return positions[0].copy()
        if time >= times[-1]:
            return positions[-1].copy()
        index = int(np.searchsorted(times, time, side="right")) - 1
        fraction = (time - times[index]) / (times[index + 1] - times[index])
        if self.interpolation == "smooth":
            # Quintic smoothstep: zero velocity and acceleration at every waypoint, as a hand moves between
            # points of rest (minimum-jerk reaching). It keeps the area of each segment at its linear value.
            fraction = fraction ** 3 * (10.0 - 15.0 * fraction + 6.0 * fraction ** 2)
        return positions[index] + fraction * (positions[index + 1] - positions[index])

    def check_workspace(self, half_extents: ArrayLike) -> None:
        """Raise FicInputError if a waypoint lies outside the device workspace box."""
        extents = finite_array("half_extents", half_extents, shape=(3,))
        for waypoint in self.waypoints:
            if np.any(np.abs(waypoint.position) > extents + 1e-12):
                raise FicInputError(f"script {self.name!r}: waypoint at t={waypoint.time} "
                                    f"{waypoint.position.tolist()} is outside the workspace +-{extents.tolist()}")


class ScriptedOperator:
    """Plays an ``OperatorScript``: the target now, and the button presses that fell due since the last poll."""

    def __init__(self, script: OperatorScript) -> None:
        self.script = script
        self._next_event = 0

    def target(self, time: float) -> Vector3:
        return self.script.target(time)

    def poll_events(self, time: float) -> list[ScriptEvent]:
        """Events with ``event.time <= time`` not returned before, in script order."""
        events = self.script.events
        start = self._next_event
        while self._next_event < len(events) and events[self._next_event].time <= time:
            self._next_event += 1
        return list(events[start:self._next_event])

    def finished(self, time: float) -> bool:
        return time >= self.script.duration and self._next_event == len(self.script.events)


class JoyTarget:
    """A hand target driven at a velocity by joystick axes: axes[0..2] in [-1, 1] map to x, y, z at up to
    ``max_speed`` m/s; a small dead zone ignores stick noise; the target stays ``margin`` inside the workspace
    so the hand never drives the handle into the soft walls on its own."""

    def __init__(self, half_extents: ArrayLike, max_speed: float = 0.10, dead_zone: float = 0.05,
                 margin: float = 0.005) -> None:
        self.half_extents = finite_array("half_extents", half_extents, shape=(3,))
        self.max_speed = finite_scalar("max_speed", max_speed, minimum=0.0)
        self.dead_zone = finite_scalar("dead_zone", dead_zone, minimum=0.0, maximum=1.0, maximum_inclusive=False)
        self.margin = finite_scalar("margin", margin, minimum=0.0)
        if np.any(self.half_extents <= self.margin):
            raise FicInputError("margin must be smaller than every workspace half-extent")
        self.target = np.zeros(3)

    def update(self, axes: Sequence[float], dt: float) -> Vector3:
        """Move the target by the axes' velocity over ``dt``; missing axes count as zero, NaN is refused."""
        dt = finite_scalar("dt", dt, minimum=0.0)
        command = np.zeros(3)
        given = finite_array("axes", list(axes)[:3])
        command[: given.size] = np.clip(given, -1.0, 1.0)
        command[np.abs(command) < self.dead_zone] = 0.0
        limit = self.half_extents - self.margin
        self.target = np.clip(self.target + self.max_speed * dt * command, -limit, limit)
        return self.target.copy()


def script_from_mapping(data: Mapping[str, Any]) -> OperatorScript:
    """Build a script from its YAML form (see config/operator_scripts/*.yaml)."""
    try:
        name = str(data["name"])
        raw_waypoints = data["waypoints"]
    except (KeyError, TypeError) as exc:
        raise FicInputError(f"operator script needs 'name' and 'waypoints': {exc}") from exc
    waypoints = []
    for entry in raw_waypoints:
        try:
            waypoints.append(Waypoint(finite_scalar("waypoint t", entry["t"]),
                                      finite_array("waypoint position", entry["position"], shape=(3,))))
        except (KeyError, TypeError) as exc:
            raise FicInputError(f"script {name!r}: waypoint {entry!r} needs 't' and 'position'") from exc
    events = []
    for entry in data.get("events", None) or ():
        try:
            button = entry["button"]
            time = finite_scalar("event t", entry["t"])
        except (KeyError, TypeError) as exc:
            raise FicInputError(f"script {name!r}: event {entry!r} needs 't' and 'button'") from exc
        if button not in BUTTONS:
            raise FicInputError(f"script {name!r}: unknown button {button!r}; known: {sorted(BUTTONS)}")
        events.append(ScriptEvent(time, BUTTONS[button]))
    return OperatorScript(name=name, waypoints=tuple(waypoints), events=tuple(events),
                          interpolation=str(data.get("interpolation", "smooth")),
                          description=str(data.get("description", "")),
                          parameters=dict(data.get("parameters", None) or {}))


def script_to_mapping(script: OperatorScript) -> dict[str, Any]:
    """The YAML form of a script (inverse of ``script_from_mapping``)."""
    names = {index: name for name, index in BUTTONS.items()}
    return {
        "name": script.name,
        "description": script.description,
        "interpolation": script.interpolation,
        "parameters": dict(script.parameters),
        "waypoints": [{"t": round(float(w.time), 6), "position": [round(float(p), 6) + 0.0 for p in w.position]}
                      for w in script.waypoints],
        "events": [{"t": round(float(e.time), 6), "button": names[e.button]} for e in script.events],
    }


def load_script(path: str | Path) -> OperatorScript:
    """Read an operator script from a YAML file."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise FicInputError(f"cannot read operator script {path}: {exc}") from exc
    if not isinstance(data, Mapping):
        raise FicInputError(f"operator script {path} must be a YAML mapping")
    return script_from_mapping(data)
