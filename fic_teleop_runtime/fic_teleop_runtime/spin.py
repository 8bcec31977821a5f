"""Spin a node (EventsExecutor; SingleThreadedExecutor under simulated time) until Ctrl-C, SIGTERM or an external
shutdown.

Why not ``EventsExecutor().spin()``: with rclpy 7.1 from the wheels, ``spin()`` does not return after SIGINT
or SIGTERM (rclpy's signal handler shuts the context down, but the executor keeps running at about half a core;
measured here). Spinning in short ``spin_once`` slices and checking the context between them exits within
one slice and costs nothing measurable.
"""
from __future__ import annotations

import gc
from collections.abc import Sequence

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.task import Future

from fic_teleop_runtime import stop_signals
from fic_teleop_runtime.shared_clock import share_clock_subscription

SLICE = 0.1   # [s] longest wait between two checks of the context


def spin_until_shutdown(nodes: Node | Sequence[Node], slice_s: float = SLICE, follow_sim_time: bool = True) -> None:
    """Run the callbacks of ``nodes`` (one node, or several sharing this process) until the process is asked to
    stop. Returns normally on Ctrl-C / SIGTERM.

    ``follow_sim_time=False``: the EventsExecutor even under simulated time, for a node whose timers need not land
    on simulated time and which takes the 1 kHz streams (the recorder: the wait-set executor costs more a message).
    """
    nodes = [nodes] if isinstance(nodes, Node) else list(nodes)
    node = nodes[0]
    # Under simulated time (lockstep) the EventsExecutor's timers do not follow /clock: measured here, the master's
    # 100 Hz timer fired in bursts (10 commands with one stamp) and then fell silent for 100 ms of simulated time.
    # The wait-set executor checks timers against the node's clock, so timer ticks land on simulated time.
    sim_time = follow_sim_time and any(member.get_parameter("use_sim_time").value for member in nodes)
    executor = SingleThreadedExecutor(context=node.context) if sim_time else EventsExecutor(context=node.context)
    share_clock_subscription(nodes)   # a group's nodes under simulated time: one /clock subscription (shared_clock.py)
    for member in nodes:
        executor.add_node(member)
    # The start-up heap (rclpy, numpy, Pinocchio, MuJoCo: ~60k objects) moved out of the collector's reach: a
    # full collection of it took 25 ms here, and with it every loop in the graph stalled every few seconds.
    gc.collect()
    gc.freeze()
    try:
        # A slice runs every callback due in it inside the executor, not one per Python call: a 1 kHz timer cost
        # 77-82 us a tick here against 92-101 us with spin_once (the future never completes; the slice bounds the wait).
        never = Future()
        stop_signals.running()  # a signal now only asks the loop to stop; the node is destroyed before the context
        while rclpy.ok(context=node.context) and not stop_signals.requested():
            try:
                executor.spin_until_future_complete(never, timeout_sec=slice_s)
            except (KeyboardInterrupt, ExternalShutdownException):
                break
            except Exception:
                # A callback that ran while the signal handler was shutting the context down (a timer's publish
                # on the invalidated context, a pybind11 conversion error in a take) is not a fault of the node.
                if rclpy.ok(context=node.context):
                    raise
                break
    finally:
        executor.shutdown(timeout_sec=1.0)
