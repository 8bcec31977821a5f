"""``reset`` forgets everything a law object has seen (each one's docstring: at rest, the estimates and anchors
forgotten, the rate bound started afresh): after a first run and a reset, a second run gives, value for value, what
the same run gives on an object just built, for every law object of fic_core that has a reset. The first run takes
each object through its states (the FIC's C phase and saturation, a planner in C, a filled token bucket, a set-point
with a slope, a reached via-point); the second starts later on the same clocks."""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.baseline import LinearImpedance
from fic_core.errors import FicInputError
from fic_core.input_authority import AuthorityBounds, CommandAuthority, _BoundedPoint
from fic_core.master import MasterLaw
from fic_core.planner import HarmonicPlanner
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor
from fic_core.set_point import SampledSetPoint
from fic_core.teleoperation import TeleoperationCommandIntegrator
from fic_core.trajectories import ViaPoints

TRANSLATION = ForceProfile(200.0, 0.05, 0.5, 10.0)
ROTATION = ForceProfile(20.0, 0.5, 0.5, 5.0)


def wave(k: int, start: int, amplitude: float) -> tuple[float, float]:
    """An error and its rate at tick k of a 1 kHz, 0.8 Hz sine (out to saturation and back through zero)."""
    phase = 2.0 * math.pi * 0.8 * (k + start) * 0.001
    return amplitude * math.sin(phase), amplitude * 2.0 * math.pi * 0.8 * math.cos(phase)


def drive_attractor(law: FractalAttractor, start: int) -> list:
    out = []
    for k in range(0, 1500, 7):
        error, rate = wave(k, start, 0.09)
        out += law.force([error, 0.5 * error, -0.2 * error], [rate, 0.5 * rate, -0.2 * rate]).tolist()
    return out


def drive_rotation(law: RotationalAttractor, start: int) -> list:
    out = []
    for k in range(0, 1500, 7):
        angle, rate = wave(k, start, 0.9)
        out += law.moment([angle, 0.3 * angle, 0.0], [rate, 0.3 * rate, 0.0]).tolist()
    return out


def drive_pose(law: PoseAttractor | LinearImpedance, start: int) -> list:
    out = []
    for k in range(0, 1500, 7):
        error, rate = wave(k, start, 0.09)
        out += law.wrench_values([error, 0.0, 0.5 * error], [10.0 * error, 0.0, 0.0],
                                 [rate, 0.0, 0.5 * rate, 10.0 * rate, 0.0, 0.0])
    return out


def drive_master(law: MasterLaw, start: int) -> list:
    out = []
    for k in range(0, 1500, 7):
        position, velocity = wave(k, start, 0.06)
        out += law.force([position, 0.0, 0.0], [velocity, 0.0, 0.0], [0.0, 30.0, 0.0]).tolist()
    out.append(law.device_force_saturated)
    return out


def drive_planner(planner: HarmonicPlanner, start: int) -> list:
    out = []
    for k in range(150):
        out += planner.step([0.1 if (k + start // 40) % 100 < 50 else -0.05, 0.02, 0.0], 0.01).tolist()
        out += planner.phase.tolist()
    return out


def drive_set_point(hold: SampledSetPoint, start: int) -> list:
    out = []
    for k in range(40):
        stamp = 0.01 * (k + start)
        hold.add(stamp, [0.5 * stamp, -0.1 * stamp, 0.0], stamp + 0.003)
        for read in (hold.position, hold.velocity, hold.acceleration):
            out += read(stamp + 0.008).tolist()
    return out


def drive_integrator(integrator: TeleoperationCommandIntegrator, start: int) -> list:
    out = []
    for k in range(100):
        out += integrator.update([0.05 * math.sin(0.1 * (k + start)), 0.01, 0.0], 0.004).tolist()
    return out


def drive_via_points(points: ViaPoints, start: int) -> list:
    out = []
    for k in range(60):
        t = 0.1 * (k + start)
        out += points.point(t, points.point(t)).tolist()
        out.append(points.index)
    return out


def drive_authority(authority: CommandAuthority, start: int) -> list:
    out = []
    for k in range(30):
        now = 0.01 * (k + start)
        verdict = authority.check(stamp=now, now=now, mode=0, haptic_gain=0.5, workspace_scale=1.0,
                                  velocity_gain=1.0, handle_position=[0.0, 0.0, 0.0],
                                  desired_offset=[0.004 * k if k % 10 else 0.2, 0.0, 0.0])
        out += verdict.offset.tolist() + [verdict.rate_limited]
    return out


def drive_bounded_point(point: _BoundedPoint, start: int) -> list:
    out = []
    for k in range(30):
        taken, outside, limited = point.take(np.array([0.004 * k if k % 10 else 0.2, 0.0, 0.0]), 0.01 * (k + start))
        out += taken.tolist() + [outside, limited]
    return out


BOUNDS = AuthorityBounds()
CASES: list[tuple[str, Callable[[], object], Callable[[object, int], list]]] = [
    ("FractalAttractor", lambda: FractalAttractor(TRANSLATION, 3), drive_attractor),
    ("RotationalAttractor", lambda: RotationalAttractor(ROTATION), drive_rotation),
    ("PoseAttractor", lambda: PoseAttractor(TRANSLATION, ROTATION), drive_pose),
    ("LinearImpedance", lambda: LinearImpedance(200.0, 20.0, 39.6, 1.98, max_force=(10.0, 5.0)), drive_pose),
    ("MasterLaw", lambda: MasterLaw(FractalAttractor(ForceProfile(100.0, 0.04, 0.5, 4.0), 3), 0.5, 20.0),
     drive_master),
    ("HarmonicPlanner", lambda: HarmonicPlanner(8.0, 0.25), drive_planner),
    ("SampledSetPoint", lambda: SampledSetPoint(3), drive_set_point),
    ("TeleoperationCommandIntegrator", lambda: TeleoperationCommandIntegrator(2.0, 1.0), drive_integrator),
    ("ViaPoints", lambda: ViaPoints([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.1, 0.0]], dwell_s=0.5),
     drive_via_points),
    ("CommandAuthority", lambda: CommandAuthority(BOUNDS), drive_authority),
    ("BoundedPoint", lambda: _BoundedPoint(np.full(3, -0.5), np.full(3, 0.5), BOUNDS.max_offset_speed,
                                           BOUNDS.max_offset_burst), drive_bounded_point),
]


@pytest.mark.parametrize("name, build, drive", CASES, ids=[name for name, _, _ in CASES])
def test_after_a_reset_an_object_answers_as_one_just_built(name: str, build, drive) -> None:
    used = build()
    first = drive(used, 0)
    if name == "HarmonicPlanner":
        used.reset([0.0, 0.0, 0.0])   # at rest at the origin, where a new planner starts
    else:
        used.reset()
    again = drive(used, 1000)
    assert again == drive(build(), 1000)
    assert first != again or name == "ViaPoints"   # the second run starts elsewhere on the clocks


def rest_report(name: str, law) -> object:
    """What the object reports before any input: written out per object below."""
    if name == "FractalAttractor":
        return tuple(law.snapshot())[1:], law.phase.tolist()
    if name == "RotationalAttractor":
        snapshot = law.snapshot()
        return snapshot.angle, snapshot.moment, tuple(snapshot.scalar)[1:]
    if name == "LinearImpedance":
        snapshot = law.snapshot()
        return snapshot.stiffness, snapshot.errors, snapshot.forces
    if name == "MasterLaw":
        return law.device_force_saturated
    if name == "SampledSetPoint":
        try:
            law.position(5.0)
        except FicInputError as error:
            return law.has_sample, str(error)
        return law.has_sample, "a position"
    if name == "TeleoperationCommandIntegrator":
        offset = law.desired_offset.tolist()
        law.workspace_scale = 4.0   # anchors x_d' and x_M where they are: at the origin
        return offset, law.update([0.01, 0.02, 0.03], 0.004).tolist()
    if name == "ViaPoints":
        return law.index
    raise AssertionError(name)


AT_REST = {
    "FractalAttractor": (((False,) * 3,) + ((0.0,) * 3,) * 5, [0, 0, 0]),
    "RotationalAttractor": (0.0, (0.0, 0.0, 0.0), ((False,),) + ((0.0,),) * 5),
    "LinearImpedance": ((200.0,) * 3 + (20.0,) * 3, (0.0,) * 6, (0.0,) * 6),
    "MasterLaw": False,
    "SampledSetPoint": (False, "no sample yet"),
    # x_d' = 0 and the anchor at the origin: offset mode reads x_d' = s_M x_M (s_M = 4 set before the update)
    "TeleoperationCommandIntegrator": ([0.0] * 3, [0.04, 0.08, 0.12]),
    "ViaPoints": 0,
}


@pytest.mark.parametrize("name, build, drive", [case for case in CASES if case[0] in AT_REST],
                         ids=[name for name, _, _ in CASES if name in AT_REST])
def test_built_or_reset_an_object_reports_rest(name: str, build, drive) -> None:
    """The report written out: D on every axis with nothing latched, stored or pushed; no saturation; the first
    via-point; x_d' = 0 with the anchor at the origin; no position held before a sample. Built, and reset after a
    run."""
    assert rest_report(name, build()) == AT_REST[name]
    used = build()
    drive(used, 0)
    used.reset()
    assert rest_report(name, used) == AT_REST[name]
