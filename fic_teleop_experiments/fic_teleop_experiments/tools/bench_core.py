"""Per-tick compute time of the fic_core control steps (the replica's budget: median < 60 us, p99 < 200 us).

    python -m fic_teleop_experiments.tools.bench_core [--ticks 20000] [--json PATH]

- replica: ReplicaController.command (Pinocchio terms, paper Eq. 7 with the FIC, null-space posture, postural
  optimisation) on a realistic moving trajectory: the Panda (Pinocchio forward dynamics, 1 ms, the simulator's
  joint damping; not timed) tracks the paper's circle (0.20 m diameter, 5 s period) superimposed with a
  teleoperated offset that jumps by 8 cm every 2 s, so that some ticks have the torque-rate and other limits
  active and the QP runs. Timed separately: all ticks, the fast-path ticks, and the ticks that solved the QP.
- replica + report: the same plus reading the LimitStatus ratios and the FicState energies a node publishes.
- master: MasterLaw.force + TeleoperationCommandIntegrator.update (500 Hz device loop).
- planner: HarmonicPlanner.step + Circle.point (250 Hz).
- numpy reference: one addition of two 7-vectors, to compare figures taken under different loads.
With --feedforward the replica also gets the circle's acceleration (ReplicaController's inertial feedforward).
Figures are wall-clock (time.perf_counter) and depend on the machine's load (a shared 2-core VM here): a tick
during which the process was descheduled counts in full. "replica (CPU time)" uses the thread's CPU clock
(time.thread_time, about 1 us resolution), which leaves out the time the scheduler gave to other processes.
Report the figures with the command used and the load average (written in the JSON).
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import sys
import time

import numpy as np
import pinocchio as pin

from fic_core.attractor import FractalAttractor
from fic_core.master import MasterLaw
from fic_core.panda_description import JOINT_DAMPING, NOMINAL_CONFIGURATION
from fic_core.passivity_observer import PassivityObserver
from fic_core.planner import HarmonicPlanner
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel
from fic_core.teleoperation import TeleoperationCommandIntegrator
from fic_core.trajectories import Circle

DT = 0.001


def statistics(samples: list[float]) -> dict[str, float]:
    array = np.asarray(samples) * 1e6
    if array.size == 0:
        return {"count": 0}
    return {"count": int(array.size), "median_us": float(np.median(array)), "p99_us": float(np.percentile(array, 99)),
            "mean_us": float(np.mean(array)), "max_us": float(np.max(array))}


def bench_replica(ticks: int, feedforward: bool = False) -> dict[str, dict[str, float]]:
    robot = RobotModel()
    controller = PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), ForceProfile(20.0, 0.5, 0.5, 10.0))
    replica = ReplicaController(robot, controller, control_period=DT)
    observer = PassivityObserver(6)
    model = robot.model
    data = model.createData()
    q, qd = NOMINAL_CONFIGURATION.copy(), np.zeros(7)
    robot.update(q, qd)
    start, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    circle = Circle(start - np.array([0.10, 0.0, 0.0]))
    centre = circle.centre
    rate_squared = (2.0 * np.pi / circle.period) ** 2
    everything, fast, solved, reported, cpu, cpu_solved = [], [], [], [], [], []
    gc.disable()  # the collector's pauses are the interpreter's, not the control law's
    try:
        for tick in range(ticks):
            t = tick * DT
            offset = np.array([0.08, -0.08, 0.0]) * ((int(t / 2.0) % 2) * 2 - 1) * (t >= 2.0)
            point = circle.point(t)
            target = point + offset
            # The circle's acceleration -w^2 (p - c), fed forward with --feedforward (the offset's jumps are not).
            acceleration = -rate_squared * (point - centre) if feedforward else None
            cpu_begin = time.thread_time()
            begin = time.perf_counter()
            command = replica.command(q, qd, target, rotation, None, acceleration)
            observer.observe_snapshot(command.controller_snapshot)  # the node's passivity observer, every tick
            end = time.perf_counter()
            cpu.append(time.thread_time() - cpu_begin)
            if command.solved_qp:
                cpu_solved.append(cpu[-1])
            # What a node reads to fill LimitStatus and FicState, timed apart.
            _ = (command.torque_ratio, command.torque_rate_ratio, command.joint_velocity_ratio,
                 command.joint_position_margin, command.total_energy)
            reported.append(time.perf_counter() - begin)
            everything.append(end - begin)
            (solved if command.solved_qp else fast).append(end - begin)
            qdd = pin.aba(model, data, q, qd, command.torque - JOINT_DAMPING * qd)
            qd = qd + DT * qdd
            q = q + DT * qd
    finally:
        gc.enable()
    result = {"replica": statistics(everything), "replica fast path": statistics(fast),
              "replica QP ticks": statistics(solved), "replica + report": statistics(reported),
              "replica (CPU time)": statistics(cpu), "replica QP (CPU time)": statistics(cpu_solved)}
    result["replica"]["shaped_ticks"] = replica.shaped_ticks
    result["replica"]["violation_ticks"] = replica.violation_ticks
    result["replica"]["passivity_violation_ticks"] = observer.violation_ticks
    result["replica"]["passivity_margin_min_j"] = observer.min_margin
    return result


def bench_reference(ticks: int) -> dict[str, float]:
    """One numpy addition of two 7-vectors: how slow small numpy calls are on the machine right now (about
    0.3-0.5 us on an idle desktop core), to compare figures measured under different loads."""
    a, b = np.ones(7), np.ones(7)
    samples = []
    for _ in range(ticks):
        begin = time.perf_counter()
        a + b
        samples.append(time.perf_counter() - begin)
    return statistics(samples)


def bench_master(ticks: int) -> dict[str, float]:
    master = MasterLaw(FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), 3), haptic_gain=0.5,
                       max_device_force=20.0)
    integrator = TeleoperationCommandIntegrator()
    samples = []
    for tick in range(ticks):
        t = tick * 0.002
        handle = 0.03 * np.array([np.sin(t), np.cos(0.7 * t), 0.5 * np.sin(1.3 * t)])
        velocity = 0.03 * np.array([np.cos(t), -0.7 * np.sin(0.7 * t), 0.65 * np.cos(1.3 * t)])
        replica_force = np.array([2.0 * np.sin(0.3 * t), 0.0, -1.0])
        begin = time.perf_counter()
        master.force(handle, velocity, replica_force)
        integrator.update(handle, 0.002)
        samples.append(time.perf_counter() - begin)
    return statistics(samples)


def bench_planner(ticks: int) -> dict[str, float]:
    circle = Circle(np.array([0.4, 0.0, 0.4]))
    planner = HarmonicPlanner(natural_frequency=10.0, max_velocity=0.2)
    planner.reset(circle.point(0.0))
    samples = []
    for tick in range(ticks):
        t = tick * 0.004
        begin = time.perf_counter()
        planner.step(circle.point(t), 0.004)
        samples.append(time.perf_counter() - begin)
    return statistics(samples)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ticks", type=int, default=20000, help="ticks per benchmark (>= 10000 for the report)")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    parser.add_argument("--feedforward", action="store_true",
                        help="pass the circle's acceleration as desired_acceleration (inertial feedforward)")
    args = parser.parse_args(argv)
    load_before = os.getloadavg()
    results = {"numpy reference": bench_reference(args.ticks)}
    results.update(bench_replica(args.ticks, args.feedforward))
    results["master"] = bench_master(args.ticks)
    results["planner"] = bench_planner(args.ticks)
    load = os.getloadavg()
    print(f"load average {load_before[0]:.2f} before, {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} after, on "
          f"{os.cpu_count()} cores{'; with the inertial feedforward' if args.feedforward else ''}")
    print(f"{'step':<20} {'ticks':>7} {'median us':>10} {'p99 us':>9} {'max us':>9}")
    for name, figures in results.items():
        if figures.get("count"):
            print(f"{name:<20} {figures['count']:>7} {figures['median_us']:>10.1f} {figures['p99_us']:>9.1f} "
                  f"{figures['max_us']:>9.0f}")
    replica = results["replica"]
    print(f"replica: {replica['shaped_ticks']} shaped ticks, {replica['violation_ticks']} violation ticks; "
          f"budget median < 60 us: {'met' if replica['median_us'] < 60 else 'NOT met'}, "
          f"p99 < 200 us: {'met' if replica['p99_us'] < 200 else 'NOT met'}")
    if args.json:
        results["machine"] = {"python": sys.version.split()[0], "platform": platform.platform(),
                              "load_average_before": [round(x, 2) for x in load_before],
                              "load_average": [round(x, 2) for x in os.getloadavg()], "cpus": os.cpu_count(),
                              "feedforward": args.feedforward}
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump(results, stream, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
