"""One time axis for a run's joint swing: joint speeds, the torque the arm felt, and which torque it was.

A starved run's arm can swing toward its datasheet joint speed around the replica's loop holds (docs/RESULTS.md,
"Stress"). This lays out, on the arm's clock (the joint-state stamps, t = 0 at the first joint state), from a run
folder's bag and logs:

- |qd_i| / datasheet limit per joint (fic_core.limits), at every joint state in the window, thinned to --step;
- the torque applied (the ``effort`` of /joint_states) matched to the command it equals: which command (its
  phase: law, hold, ramp, from the replica's log; its state stamp, fic_core.command_stamp), how long the arm has
  run on it (age = state time - the command's state time), or "robot" when no command matches (the robot's own
  stale-command hold: gravity and damping);
- tau - G(q) on joints 2 and 4 (the part of the applied torque that is not gravity);
- |x_d - x_R| and the speeds of x_d and x_R from /replica/desired_pose and /replica/tcp_pose (the replica's own
  view, published while the law runs);
- the events of replica.log and robot.log, mapped from the wall clock to the arm's clock through the recorder's
  receive times of the joint states.

    python -m fic_teleop_experiments.tools.swing_timeline --run runs/x --start 2.0 --end 3.6 [--step 0.01]
    python -m fic_teleop_experiments.tools.swing_timeline --run runs/x --peak     # one line: peak |qd|/limit, when,
    phase
"""
from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fic_core.command_stamp import stamp_ns
from fic_core.limits import PANDA_JOINT_VELOCITY_LIMIT
from fic_core.loop_health import LoopHealthBounds
from fic_teleop_runtime.stamps import seconds

LOG_LINE = re.compile(r"^\[(\w+)\] \[(\d+\.\d+)\] \[([^\]]+)\]: (.*)$")
RESUME_RAMP = LoopHealthBounds().resume_ramp   # [s] the replica's loop_resume_ramp default


@dataclass
class Run:
    t0: float                      # [s] the first joint state's stamp (the arm's clock)
    state_time: np.ndarray         # (n,) joint-state stamps
    state_wall: np.ndarray         # (n,) the recorder's receive times of them
    q: np.ndarray                  # (n, 7)
    qd: np.ndarray                 # (n, 7)
    effort: np.ndarray             # (n, 7) the torque the robot applied
    command_wall: np.ndarray       # (m,) the recorder's receive times of the torque commands
    command_state: np.ndarray      # (m,) the state stamp each was computed on (nan: unstamped)
    command: np.ndarray            # (m, 7)
    pose_time: np.ndarray          # (k,) /replica/desired_pose stamps
    pose_error: np.ndarray         # (k,) |x_d - x_R| [m]
    desired_speed: np.ndarray      # (k,) |dx_d/dt| [m/s] between the pose messages (over at least 20 ms)
    tcp_speed: np.ndarray          # (k,) |dx_R/dt| [m/s], likewise
    events: list[tuple[float, str, str]]   # (wall, node, text)


def load(run_dir: Path) -> Run:
    from mcap_ros2.reader import read_ros2_messages

    states, commands, desired, tcp = [], [], {}, {}
    topics = ["/joint_states", "/effort_controller/commands", "/replica/desired_pose", "/replica/tcp_pose"]
    for file in sorted((run_dir / "bag").glob("*.mcap")):
        for message in read_ros2_messages(str(file), topics=topics):
            msg, topic, wall = message.ros_msg, message.channel.topic, message.log_time_ns * 1e-9
            if topic == "/joint_states":
                stamp = seconds(msg.header.stamp)
                states.append((stamp, wall, list(msg.position[:7]), list(msg.velocity[:7]), list(msg.effort[:7])))
            elif topic == "/effort_controller/commands":
                dims = msg.layout.dim
                computed_on = stamp_ns(dims[0].label) if dims else None
                commands.append((wall, np.nan if computed_on is None else computed_on * 1e-9, list(msg.data[:7])))
            else:
                stamp = seconds(msg.header.stamp)
                p = msg.pose.position
                (desired if topic == "/replica/desired_pose" else tcp)[stamp] = np.array([p.x, p.y, p.z])
    states.sort(key=lambda row: row[0])
    commands.sort(key=lambda row: row[0])
    both = sorted(set(desired) & set(tcp))
    pose_time = np.array(both)
    desired_speed, tcp_speed = (_speed(pose_time, np.array([series[s] for s in both]).reshape(-1, 3))
                                for series in (desired, tcp))
    events = []
    for name in ("replica.log", "robot.log"):
        path = run_dir / "logs" / name
        for line in path.read_text().splitlines() if path.exists() else []:
            match = LOG_LINE.match(line)
            if match:
                events.append((float(match.group(2)), match.group(3).split(".")[-1], match.group(4)))
    events.sort()
    return Run(t0=states[0][0],
               state_time=np.array([s[0] for s in states]), state_wall=np.array([s[1] for s in states]),
               q=np.array([s[2] for s in states]), qd=np.array([s[3] for s in states]),
               effort=np.array([s[4] for s in states]),
               command_wall=np.array([c[0] for c in commands]), command_state=np.array([c[1] for c in commands]),
               command=np.array([c[2] for c in commands]).reshape(-1, 7),
               pose_time=pose_time, pose_error=np.array([np.linalg.norm(desired[s] - tcp[s]) for s in both]),
               desired_speed=desired_speed, tcp_speed=tcp_speed,
               events=events)


def _speed(times: np.ndarray, positions: np.ndarray, span: float = 0.02) -> np.ndarray:
    """|dp/dt| at each sample, from the sample at least ``span`` earlier (nan for the first ones)."""
    speed = np.full(len(times), np.nan)
    for k in range(len(times)):
        j = np.searchsorted(times, times[k] - span, side="right") - 1
        if j >= 0 and times[k] - times[j] < 0.2:
            speed[k] = np.linalg.norm(positions[k] - positions[j]) / (times[k] - times[j])
    return speed


def arm_time(run: Run, wall: float) -> float:
    """The arm's clock when the recorder's wall clock read ``wall`` (its receive times of the joint states)."""
    order = np.argsort(run.state_wall)
    return float(np.interp(wall, run.state_wall[order], run.state_time[order]))


def phases(run: Run) -> np.ndarray:
    """Per command: 'law', 'hold' or 'ramp' (the replica log's hold and resume notices, on the wall clock)."""
    phase = np.full(len(run.command_wall), "law", dtype=object)
    holds = [(wall, text) for wall, node, text in run.events if node == "replica" and "replica loop" in text]
    for index, (wall, text) in enumerate(holds):
        if "unhealthy" not in text:
            continue
        resume = next((w for w, t in holds[index + 1:] if "healthy for" in t), np.inf)
        phase[(run.command_wall >= wall) & (run.command_wall < resume)] = "hold"
        phase[(run.command_wall >= resume) & (run.command_wall < resume + RESUME_RAMP)] = "ramp"
    return phase


def applied_command(run: Run) -> np.ndarray:
    """Per joint state: the index of the command its applied torque equals (-1: none, the robot's own hold)."""
    index = np.full(len(run.state_time), -1)
    if not len(run.command):
        return index
    for i, effort in enumerate(run.effort):
        # Only a command computed on this state or an earlier one can be what the arm applies at it.
        match = np.flatnonzero(np.all(np.abs(run.command - effort) < 1e-9, axis=1)
                               & ~(run.command_state > run.state_time[i] + 1e-9))
        if len(match):
            index[i] = match[-1] if len(match) == 1 else match[np.argmin(np.abs(run.command_wall[match]
                                                                                  - run.state_wall[i]))]
    return index


def gravity_torques(run: Run, rows: np.ndarray) -> np.ndarray:
    from fic_core.robot_model import RobotModel

    robot = RobotModel()
    out = np.zeros((len(rows), 7))
    for k, i in enumerate(rows):
        robot.update(run.q[i], run.qd[i])
        out[k] = robot.gravity[:7]
    return out


def speed_ratio(run: Run) -> np.ndarray:
    return np.abs(run.qd) / np.array(PANDA_JOINT_VELOCITY_LIMIT)


def timeline(run: Run, start: float, end: float, step: float) -> list[str]:
    t = run.state_time - run.t0
    ratio, phase, applied = speed_ratio(run), phases(run), applied_command(run)
    rows, last = [], -np.inf
    for i in np.flatnonzero((t >= start) & (t <= end)):
        changed = rows and applied[i] != applied[rows[-1]]
        if t[i] - last >= step - 1e-9 or changed:
            rows.append(i)
            last = t[i]
    rows = np.array(rows, dtype=int)
    gravity = gravity_torques(run, rows)
    lines = ["t[s]   |qd|/limit j1..j7                 applied (phase, computed on t, held for)"
             "     tau-G j2  tau-G j4  |xd-xR|[mm] |xd'| |xR'| [m/s]"]
    events = [(arm_time(run, wall) - run.t0, node, text) for wall, node, text in run.events]
    events = [e for e in events if start <= e[0] <= end]
    for k, i in enumerate(rows):
        while events and events[0][0] <= t[i]:
            time, node, text = events.pop(0)
            lines.append(f"{time:6.3f} ** {node}: {text[:110]}")
        c = applied[i]
        if c < 0:
            source = "robot's own hold (no command matches)"
        else:
            computed_on = run.command_state[c] - run.t0
            source = f"cmd#{c:<5d}{phase[c]:4s} on {computed_on:6.3f} held {1e3 * (t[i] - computed_on):5.1f} ms"
        near = np.searchsorted(run.pose_time, run.state_time[i], side="right") - 1
        error = f"{1e3 * run.pose_error[near]:7.1f}  {run.desired_speed[near]:5.2f} {run.tcp_speed[near]:5.2f}" \
            if near >= 0 and run.state_time[i] - run.pose_time[near] < 0.05 else "      -"
        speeds = " ".join(f"{r:4.2f}" for r in ratio[i])
        extra = run.effort[i] - gravity[k]
        lines.append(f"{t[i]:6.3f} {speeds}  {source:44s} {extra[1]:8.2f} {extra[3]:9.2f}  {error}")
    for time, node, text in events:
        lines.append(f"{time:6.3f} ** {node}: {text[:110]}")
    return lines


def peak(run: Run) -> str:
    """The run's peak joint speed against the datasheet: when, which joint, on what applied torque."""
    ratio, phase, applied = speed_ratio(run), phases(run), applied_command(run)
    i, j = np.unravel_index(np.argmax(ratio), ratio.shape)
    t = run.state_time[i] - run.t0
    c = applied[i]
    source = "robot hold" if c < 0 else f"{phase[c]} held {1e3 * (run.state_time[i] - run.command_state[c]):.0f} ms"
    holds = [f"{arm_time(run, wall) - run.t0:.2f}" for wall, node, text in run.events
             if node == "replica" and "unhealthy" in text]
    return (f"peak |qd|/limit {ratio[i, j]:.2f} (joint {j + 1}, {abs(run.qd[i, j]):.2f} rad/s) at t={t:.2f} s on "
            f"{source}; replica holds at t={','.join(holds) or 'none'}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", type=Path, required=True, nargs="+", help="run folder(s), each with bag/ and logs/")
    parser.add_argument("--start", type=float, default=0.0, help="[s] on the arm's clock from the first joint state")
    parser.add_argument("--end", type=float, default=np.inf)
    parser.add_argument("--step", type=float, default=0.01, help="[s] thin the rows (a change of torque always shows)")
    parser.add_argument("--peak", action="store_true", help="one line per run: its peak joint speed and when")
    args = parser.parse_args(argv)
    for run_dir in args.run:
        run = load(run_dir)
        if args.peak:
            print(f"{run_dir}: {peak(run)}")
        else:
            print("\n".join(timeline(run, args.start, args.end, args.step)))


if __name__ == "__main__":
    main()
