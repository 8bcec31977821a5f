"""What an E2 trial's operator log and force trace say, the same for a trial in process and on the graph: per piece
its phases, attempts, retries, time and peak force, and the forces of the contact phases a failed piece went through.
"""
from __future__ import annotations

import numpy as np

FORCE_OF_NOTE_N = 10.0   # the replica's F_max: time spent above it is reported, as in the graph's E2 table


def operator_outcome(moves: list[tuple[str, float, float]], force: np.ndarray, time: np.ndarray) -> dict:
    """Per piece, from the operator's phase log: when it was started and finished (seen inside, or given up), the
    grasp and insertion attempts (a retry is any attempt after the first), the phases it went through with their
    start times, and the peak force at the replica between its start and finish."""
    pieces: dict[str, dict] = {}
    for label, start, value in moves:
        shape, phase = label.split(":", 1)
        piece = pieces.setdefault(shape, {"start_s": round(start, 2), "end_s": None, "result": "unfinished",
                                          "grasps": 0, "insertions": 0, "phases": []})
        if phase == "reach":
            piece["grasps"] += 1
        elif phase == "descend":
            piece["insertions"] += 1
        elif phase in ("done", "gave_up"):
            piece["end_s"], piece["result"] = round(start, 2), "inside" if phase == "done" else "gave up"
        if not piece["phases"] or piece["phases"][-1][0] != phase:
            piece["phases"].append((phase, round(start, 2), round(value, 4)))
    for piece in pieces.values():
        end = piece["end_s"] if piece["end_s"] is not None else float(time[-1])
        window = (time >= piece["start_s"]) & (time <= end)
        piece["duration_s"] = round(end - piece["start_s"], 2)
        piece["retries"] = max(piece["grasps"] - 1, 0) + max(piece["insertions"] - piece["grasps"], 0)
        piece["peak_force_n"] = round(float(force[window].max()), 1) if window.any() else 0.0
    return pieces


#: The contact phases whose forces tell why a piece failed: the press that forms the bond, the insertion, the lock
#: against the hole's wall and the pull that should break the bond.
CONTACT_PHASES = ("press_felt", "descend", "search", "insert", "lock", "pull")


def phase_forces(row: dict) -> list[tuple[str, float, float, float, float | None]]:
    """From a trial's trace: each contact phase (CONTACT_PHASES) as (label, start, end, the replica's peak |F_R| in
    it [N], the largest |x_d - x_R| in it [m] or None when the trace has no error), in order."""
    trace = row["trace"]
    time, force = np.asarray(trace["time"]), np.asarray(trace["force_n"])
    error = np.asarray(trace["error_m"]) if "error_m" in trace else None
    phases = trace["phases"]
    result = []
    for (label, start), (_, end) in zip(phases, [*phases[1:], ("end", float(time[-1]))]):
        if label.split(":", 1)[1] not in CONTACT_PHASES:
            continue
        window = (time >= start) & (time < end)
        if not window.any():
            continue
        result.append((label, start, end, round(float(force[window].max()), 1),
                       None if error is None else round(float(error[window].max()), 3)))
    return result
