"""The launcher's options and run folder, checked before any node starts.

A value the graph cannot run with (``--delay nan``, ``--control-rate 0``, ``--duration inf``, a domain id Fast DDS
has no ports for) used to pass argparse, start eight nodes, kill them one by one and leave a report of nulls; an
``--out`` that cannot be a folder ended in a traceback. Here each is refused in one line that names the option,
and the launcher exits with EXIT_REFUSED (launch_supervision.py) before anything starts.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from fic_teleop_bringup.launch_isolation import VALID_DOMAIN_RANGES, valid_domain

# The replica's control_rate parameter range (fic_teleop_replica NUMBERS: 1-1000 Hz, at most the joint-state rate).
CONTROL_RATE_RANGE_HZ = (1.0, 1000.0)
# A seed goes to numpy's generators through a ROS integer parameter (int64) and is passed on +1 for the backward
# channel: any non-negative value below 2^62 is safe everywhere.
SEED_RANGE = (0, 2 ** 62)


class ArgumentRefusal(ValueError):
    """An option the run cannot use; the message is the one line the launcher prints."""


def _number(name: str, value: float, low: float, high: float, *, low_open: bool = False) -> None:
    """``value`` finite and in [low, high] (or (low, high] with ``low_open``), else ArgumentRefusal naming it."""
    if not math.isfinite(value):
        raise ArgumentRefusal(f"{name} must be a finite number, got {value}")
    if (value <= low if low_open else value < low) or value > high:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}]"
        raise ArgumentRefusal(f"{name} must be in {interval}, got {value:g}")


def check_options(args: argparse.Namespace) -> None:
    """Every numeric option of the launcher, for finiteness and range. Raises ArgumentRefusal."""
    _number("--duration [s]", args.duration, 0.0, 86400.0, low_open=True)
    _number("--quiet-tail [s]", getattr(args, "quiet_tail", 0.0), 0.0, 3600.0)
    _number("--delay [s]", args.delay, 0.0, 60.0)
    _number("--jitter [s]", args.jitter, 0.0, 60.0)
    _number("--drop (a probability)", args.drop, 0.0, 1.0)
    _number("--rate-cap [Hz] (0: none)", args.rate_cap, 0.0, 1.0e4)
    if args.blackout_at is not None:
        _number("--blackout-at [s]", args.blackout_at, 0.0, 86400.0)
    if args.blackout_window is not None:
        start, end = args.blackout_window
        _number("--blackout-window START [s]", start, 0.0, 86400.0)
        _number("--blackout-window END [s]", end, 0.0, 86400.0)
        if end <= start:
            raise ArgumentRefusal(f"--blackout-window must end after it starts, got {start:g} to {end:g}")
    if args.control_rate is not None:
        _number("--control-rate [Hz]", args.control_rate, *CONTROL_RATE_RANGE_HZ)
    if getattr(args, "joint_state_rate", None) is not None:
        _joint_state_rate(args)
    if args.wall_limit is not None:
        _number("--wall-limit [s]", args.wall_limit, 0.0, 7 * 86400.0, low_open=True)
    if not SEED_RANGE[0] <= args.seed < SEED_RANGE[1]:
        raise ArgumentRefusal(f"--seed must be in [0, 2^62), got {args.seed}")
    if getattr(args, "operator", "scripted") == "closed-loop" and (args.scene != "superimposition" or args.interactive):
        raise ArgumentRefusal("--operator closed-loop drives the superimposition scene's scripted run only "
                              f"(got --scene {args.scene}{' --interactive' if args.interactive else ''})")
    if getattr(args, "operator", "scripted") == "shape-sorting" and (args.scene != "shape_sorting" or args.interactive):
        raise ArgumentRefusal("--operator shape-sorting drives the shape_sorting scene only "
                              f"(got --scene {args.scene}{' --interactive' if args.interactive else ''})")
    if args.domain_id is not None and not valid_domain(args.domain_id):
        ranges = " or ".join(f"{low}-{high}" for low, high in VALID_DOMAIN_RANGES)
        raise ArgumentRefusal(f"--domain-id must be {ranges} (the ROS 2 domains with valid DDS ports), "
                              f"got {args.domain_id}")


def whole_states_per_tick(joint_state_rate: float, control_rate: float) -> bool:
    """Whether the replica, ticking on joint states, ticks on every n-th of them (n >= 1) at ``control_rate``."""
    states = joint_state_rate / control_rate
    return states >= 1.0 and abs(states - round(states)) <= 1e-9


def _joint_state_rate(args: argparse.Namespace) -> None:
    """--joint-state-rate: realtime only, a whole number of 1 ms physics steps between states, and a whole number
    of states per replica tick (the replica ticks on joint states)."""
    rate = args.joint_state_rate
    _number("--joint-state-rate [Hz]", rate, 0.0, 1000.0, low_open=True)
    if args.time_mode != "realtime":
        raise ArgumentRefusal("--joint-state-rate is for realtime runs (lockstep publishes a state every step, the "
                              "replica answers each)")
    if getattr(args, "hardware_twin", False) and rate != 1000.0:
        raise ArgumentRefusal("--joint-state-rate: the driver twin publishes at the Franka broadcaster's 1000 Hz")
    if abs(1000.0 / rate - round(1000.0 / rate)) > 1e-9:
        raise ArgumentRefusal(f"--joint-state-rate must divide 1000 Hz (the physics steps), got {rate:g}")
    if args.control_rate is not None and rate < args.control_rate:
        raise ArgumentRefusal(f"--joint-state-rate {rate:g} Hz is below the replica's control rate "
                              f"{args.control_rate:g} Hz (it ticks on joint states)")
    if args.control_rate is not None and not whole_states_per_tick(rate, args.control_rate):
        raise ArgumentRefusal(f"--joint-state-rate {rate:g} Hz: the replica's control rate {args.control_rate:g} Hz "
                              "must tick on every n-th joint state (its rate a divisor of this one)")


def domain_from_environment(value: str | None) -> int | None:
    """ROS_DOMAIN_ID as a given domain (None when unset or empty); ArgumentRefusal when it is not a valid one."""
    if value is None or value.strip() == "":
        return None
    try:
        domain = int(value)
    except ValueError:
        raise ArgumentRefusal(f"ROS_DOMAIN_ID in the environment is not an integer: {value!r}") from None
    if not valid_domain(domain):
        ranges = " or ".join(f"{low}-{high}" for low, high in VALID_DOMAIN_RANGES)
        raise ArgumentRefusal(f"ROS_DOMAIN_ID in the environment must be {ranges}, got {domain}")
    return domain


def prepare_run_folder(run_dir: Path) -> None:
    """Create the run folder and its logs/; ArgumentRefusal in one line if it cannot be one (a file in the way,
    no permission, a read-only file system) or already holds a bag (the report would describe the old run)."""
    bag = run_dir / "bag"
    try:
        if bag.exists() and any(bag.iterdir()):
            raise ArgumentRefusal(f"{bag} already holds a bag; give another --out")
        (run_dir / "logs").mkdir(parents=True, exist_ok=True)
        probe = run_dir / ".write_check"
        probe.write_bytes(b"")
        probe.unlink()
    except ArgumentRefusal:
        raise
    except OSError as exc:
        raise ArgumentRefusal(f"--out {run_dir} cannot be the run folder: {exc.strerror or exc}"
                              + (f" ({exc.filename})" if exc.filename and str(exc.filename) != str(run_dir) else "")
                              ) from None
