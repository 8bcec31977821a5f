"""Measure the simulated robot: lockstep steps per second (in process and through the node), realtime step
lateness and rate through the node with a 1 kHz controller answering, and render time per frame.

    source scripts/env.sh && python -m fic_teleop_experiments.tools.bench_sim [--node] [--seconds 10]

The node figures start robot_node as a real process (domain 90, localhost only) and answer every joint state
from this process with gravity compensation + damping (Pinocchio), as the replica does.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import sim_bridge  # noqa: F401  (selects EGL before mujoco is imported)
from fic_teleop_runtime.workspace import config_folder, executable


def in_process(scenes: list[str], steps: int) -> None:
    from sim_bridge.robot.mujoco_panda import PandaSimulation

    for scene in scenes:
        sim = PandaSimulation(scene, seed=0)
        for _ in range(200):
            sim.step(sim.hold_torque())
        started = time.perf_counter()
        for _ in range(steps):
            sim.step(sim.hold_torque())
        elapsed = time.perf_counter() - started
        print(f"in-process lockstep {scene:16s}: {steps / elapsed:8.0f} steps/s ({elapsed / steps * 1e6:.0f} us/step)")


def render(scenes: list[str], frames: int) -> None:
    from sim_bridge.robot.mujoco_panda import PandaSimulation
    from sim_bridge.robot.render import OffscreenRenderer, default_view

    for scene in scenes:
        sim = PandaSimulation(scene, seed=0)
        with OffscreenRenderer(sim.model, default_view(scene)) as renderer:
            renderer.render(sim.data)
            times = []
            for _ in range(frames):
                started = time.perf_counter()
                renderer.render(sim.data)
                times.append(time.perf_counter() - started)
        print(f"render 640x480 {scene:16s}: median {statistics.median(times) * 1e3:.1f} ms/frame")


def through_node(mode: str, seconds: float, scene: str) -> None:
    import pinocchio as pin
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from fic_core.panda_description import load_pinocchio_model

    env = dict(os.environ, ROS_DOMAIN_ID="90", ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=tempfile.mkdtemp(prefix="bench_sim_"))
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")})
    command = [str(executable("sim_bridge", "robot_node"))]
    command += ["--ros-args", "--params-file", str(config_folder() / "robot.yaml"), "-p", f"mode:={mode}",
                "-p", f"scene:={scene}", "-p", "diagnostics_rate_hz:=1.0"]
    log = open(Path(env["ROS_LOG_DIR"]) / "robot_node.out", "w")
    robot = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)
    rclpy.init()
    node = rclpy.create_node("bench_controller")
    qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
    model, data, _ = load_pinocchio_model()
    publisher = node.create_publisher(Float64MultiArray, "/effort_controller/commands", qos)
    stamps: list[float] = []
    diagnostics: list[dict[str, str]] = []

    def on_state(message: JointState) -> None:
        stamps.append(time.monotonic())
        q, qd = np.array(message.position), np.array(message.velocity)
        torque = pin.computeGeneralizedGravity(model, data, q) - 2.0 * qd
        publisher.publish(Float64MultiArray(data=torque.tolist()))

    def on_diagnostics(message: DiagnosticArray) -> None:
        for status in message.status:
            if status.name == "robot_sim":
                diagnostics.append({kv.key: kv.value for kv in status.values})

    node.create_subscription(JointState, "/joint_states", on_state, qos)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        deadline = time.monotonic() + 60.0
        while len(stamps) < 100 and time.monotonic() < deadline:  # started and answering
            executor.spin_once(timeout_sec=0.1)
        first, count0 = time.monotonic(), len(stamps)
        while time.monotonic() - first < seconds:
            executor.spin_once(timeout_sec=0.1)
        rate = (len(stamps) - count0) / (time.monotonic() - first)
        print(f"through the node, {mode:8s} {scene}: {rate:7.0f} joint states/s received and answered")
        if diagnostics:
            last = diagnostics[-1]
            keys = ["steps", "lockstep_timeouts", "lateness_p50_ms", "lateness_p99_ms", "lateness_max_ms",
                    "achieved_rate_hz", "overruns"]
            print("    node diagnostics: " + ", ".join(f"{k}={last[k]}" for k in keys if k in last))
    finally:
        robot.send_signal(2)
        robot.wait(timeout=15)
        node.destroy_node()
        rclpy.shutdown()
        log.close()


def channel_throughput(messages: int = 20_000) -> None:
    """The channel's push + pop cost per message at 1 kHz with 200 ms delay, jitter and drops (a speed: it was a
    timed unit test; budget 100 us a message, under 10 % of one core at 1 kHz)."""
    from sim_bridge.channel.channel import Channel, ChannelConfig

    channel = Channel(ChannelConfig(delay=0.2, jitter=0.01, drop_probability=0.05, seed=0))
    payload = bytes(200)
    start = time.perf_counter()
    for i in range(messages):
        now = i * 1e-3
        channel.push(payload, now, now)
        channel.pop_due(now)
    print(f"channel: {(time.perf_counter() - start) / messages * 1e6:.1f} us a message (push + pop, 1 kHz)")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--node", action="store_true", help="also measure through the robot node (needs ROS)")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args(argv)
    scenes = ["free_space", "superimposition", "shape_sorting"]
    print(f"load average before: {os.getloadavg()}")
    in_process(scenes, args.steps)
    channel_throughput()
    render(scenes, 10)
    if args.node:
        for mode in ("lockstep", "realtime"):
            through_node(mode, args.seconds, "superimposition")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
