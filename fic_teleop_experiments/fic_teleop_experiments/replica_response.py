"""The replica's answer to the command it receives, estimated from the claim sweep's open-loop control runs
(docs/EXPERIMENTS.md "Claims", "Open-loop controls").

In a control run the master's K_H is 0, so no force loop closes through the channel: the operator's offset that
reaches the replica (x_d - x_d'', the command after the link's delay and sample-and-hold) does not depend on what the
replica does. It is an exogenous input, and the replica's frequency response to it can be estimated from the run
itself, per axis, as Welch's H1 estimate

    H(f) = S_ux(f) / S_uu(f),   u = x_d - x_d'' (received offset),   x = x_R - x_d'' (the arm about the planner)

with the coherence |S_ux|^2 / (S_uu S_xx) saying how much of x is the linear answer to u. |H| = 1 with no phase is
perfect tracking; |H| > 1 near a frequency is a resonance: the arm moves more than it was told. The estimate is
averaged over the three axes weighted by their input power, then summarised per law as the median over seeds with
its quartiles, on the band where the operator's hand puts power (0.2-2 Hz).

    python -m fic_teleop_experiments.replica_response results/claims.json    # -> results/replica_response.json, .png
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.signal import csd, welch

from fic_teleop_experiments.claims import SETTLE_S, load_series
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
#: The band reported [Hz]: the operator's moves, wander and the reactive hand's own oscillation lie in it.
BAND_HZ = (0.2, 2.0)
#: Welch segment length [s]: 0.1 Hz resolution over the ~28 s a 30 s run keeps after its start-up.
SEGMENT_S = 10.0


def response(time: NDArray, received_offset: NDArray, arm_offset: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """(frequencies [Hz], H (complex), coherence) of ``arm_offset`` to ``received_offset`` ((n, 3) each, on the
    uniform ``time``), the axes pooled by their input power."""
    step = float(np.median(np.diff(time)))
    rate = 1.0 / step
    segment = min(len(time), int(round(SEGMENT_S * rate)))
    u = received_offset - received_offset.mean(axis=0)
    x = arm_offset - arm_offset.mean(axis=0)
    frequencies, s_uu = welch(u, fs=rate, nperseg=segment, axis=0)
    _, s_xx = welch(x, fs=rate, nperseg=segment, axis=0)
    _, s_ux = csd(u, x, fs=rate, nperseg=segment, axis=0)
    # Pooled over the axes: sum of cross spectra over sum of input spectra (an axis without input adds nothing).
    transfer = s_ux.sum(axis=1) / np.maximum(s_uu.sum(axis=1), 1e-30)
    coherence = np.abs(s_ux.sum(axis=1)) ** 2 / np.maximum(s_uu.sum(axis=1) * s_xx.sum(axis=1), 1e-30)
    return frequencies, transfer, coherence


def run_response(series: Path) -> tuple[NDArray, NDArray, NDArray]:
    """The response of one kept run (claims.save_series), after its start-up."""
    result = load_series(series)
    keep = result.time >= SETTLE_S
    return response(result.time[keep], (result.desired - result.planner)[keep], (result.tcp - result.planner)[keep])


def summarise(rows: list[dict], directory: Path, band: tuple[float, float] = BAND_HZ) -> dict:
    """Per (cell, hand, law): the median and quartiles over seeds of |H|, its phase and the coherence on the band,
    and the peak of the median |H| with its frequency."""
    grouped: dict[tuple, list] = defaultdict(list)
    frequencies = None
    for row in rows:
        path = directory / row["series"]
        if not path.exists():
            continue
        f, transfer, coherence = run_response(path)
        inside = (f >= band[0]) & (f <= band[1])
        frequencies = f[inside]
        grouped[(row["cell"], row["hand"], row["controller"])].append(
            (np.abs(transfer[inside]), np.degrees(np.angle(transfer[inside])), coherence[inside], row["seed"]))
    out = []
    for (cell, hand, law), runs in sorted(grouped.items()):
        gain = np.array([r[0] for r in runs])
        phase = np.array([r[1] for r in runs])
        coherence = np.array([r[2] for r in runs])
        median = np.median(gain, axis=0)
        peak = int(np.argmax(median))
        out.append(dict(cell=cell, hand=hand, law=law, seeds=sorted(r[3] for r in runs),
                        frequency_hz=frequencies.round(3).tolist(), gain_median=median.round(4).tolist(),
                        gain_q25=np.percentile(gain, 25, axis=0).round(4).tolist(),
                        gain_q75=np.percentile(gain, 75, axis=0).round(4).tolist(),
                        phase_median_deg=np.median(phase, axis=0).round(1).tolist(),
                        coherence_median=np.median(coherence, axis=0).round(3).tolist(),
                        peak_gain=float(median[peak]), peak_frequency_hz=float(frequencies[peak]),
                        peak_gain_by_seed=[float(g) for g in gain[:, peak]]))
    return {"band_hz": list(band), "segment_s": SEGMENT_S, "responses": out}


def plot(document: dict, path: Path) -> Path | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = sorted({(r["cell"], r["hand"]) for r in document["responses"]})
    if not cells:
        return None
    fig, axes = plt.subplots(1, len(cells), figsize=(6.0 * len(cells), 4.0), squeeze=False, sharey=True)
    for axis, (cell, hand) in zip(axes[0], cells):
        for r in (r for r in document["responses"] if (r["cell"], r["hand"]) == (cell, hand)):
            line, = axis.plot(r["frequency_hz"], r["gain_median"], label=f"{r['law']} (n = {len(r['seeds'])})")
            axis.fill_between(r["frequency_hz"], r["gain_q25"], r["gain_q75"], color=line.get_color(), alpha=0.15)
        axis.axhline(1.0, color="black", linewidth=0.8)
        axis.set_title(f"{cell}, {hand} hand", fontsize=9)
        axis.set_xlabel("frequency [Hz]")
        axis.grid(alpha=0.3)
    axes[0][0].set_ylabel("|H|: arm offset / received offset (median, quartiles)")
    axes[0][-1].legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("claims", type=Path, nargs="?", default=REPO / "results" / "claims_runs.jsonl",
                        help="the sweep's run log or judged document (default results/claims_runs.jsonl)")
    parser.add_argument("--series", type=Path, default=REPO / "results" / "claims_runs", help="kept series")
    parser.add_argument("--cells", nargs="+", default=["delay_1__rate_10__feedback_off",
                                                       "delay_0.2__rate_10__feedback_off"],
                        help="cells whose command is exogenous (default: the open-loop controls)")
    parser.add_argument("--out", type=Path, default=REPO / "results" / "replica_response.json")
    args = parser.parse_args(argv)
    from fic_teleop_experiments.claims_report import read_runs

    rows = [row for row in read_runs(args.claims) if row.get("cell") in args.cells]
    if not rows:
        print(f"no run of {', '.join(args.cells)} in {args.claims}", file=sys.stderr)
        return 1
    document = summarise(rows, args.series)
    args.out.write_text(json.dumps(document, indent=1))
    figure = plot(document, args.out.with_suffix(".png"))
    for r in document["responses"]:
        print(f"{r['cell']} {r['hand']} {r['law']}: peak |H| {r['peak_gain']:.2f} at {r['peak_frequency_hz']:.2f} Hz "
              f"(n = {len(r['seeds'])})")
    print(f"-> {args.out}" + (f", {figure}" if figure else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
