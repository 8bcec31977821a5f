"""Why a claim run's quiet tail keeps moving: the free response in free space against a tail begun in contact.

At 1 s of delay the claim sweep's runs that are not judged stable are nearly all seeds 7 and 8, for every law, and
those seeds' runs touch the fixed obstacle in the tail far more often than the others'. This A/B re-simulates such
runs with one thing changed at a time:

- ``as swept``: the claim run itself (claims.ClaimRun, 30 s task then the quiet tail);
- ``no force feedback``: the master's K_H = 0 (the open-loop control of the sweep): the replica's contact force no
  longer reaches the operator's hand, so a cycle through the hand and the delayed force feedback cannot close;
- ``stop 2 s earlier`` / ``stop 2 s later``: the same run with the task stopped at 28 s or 32 s: the same laws, hand
  and link, with the quiet tail begun at another point of the circle (and of the operator's moves around the
  obstacle);
- ``no offset feedforward`` / ``no joint damping compensation`` / ``no planner feedforward``: the replica without
  one of its terms beyond paper Eq. 7 (fic_core.replica; the paper's law has none of the three);
- ``contact gate``: the offset feedforward waiting out a contact's echo (fic_core.offset_feedforward_gate, off by
  default).

For each run: the verdict (fic_teleop_tools.verdict.run_verdict), the obstacle contact time and peak contact force
in the tail, and the tail's last-window swing of x_M about the operator's target, the figure the verdict names.

    python -m fic_teleop_experiments.tail_contact --seeds 5 7 8 --controllers fic linear --workers 1
    python -m fic_teleop_experiments.tail_contact --plot results/tail_contact.png --seeds 8 --controllers fic
"""
from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from fic_teleop_experiments.claims import ClaimRun, duration_for, tail_for
from fic_teleop_experiments.in_process import RunConfig, run

VARIANTS = ("as swept", "no force feedback", "stop 2 s earlier", "stop 2 s later", "no offset feedforward",
            "no joint damping compensation", "no planner feedforward", "contact gate")
#: The variants that switch off one of the replica's terms beyond paper Eq. 7 (fic_core.replica): the replica
#: parameter each sets false.
TERMS_OFF = {"no offset feedforward": "offset_feedforward",
             "no joint damping compensation": "joint_damping_compensation",
             "no planner feedforward": "planner_feedforward"}


def variant_run(claim: ClaimRun, variant: str) -> ClaimRun:
    """``claim`` with the one change ``variant`` names (module docstring)."""
    if variant == "as swept":
        return claim
    if variant == "no force feedback":
        return replace(claim, force_feedback=False)
    if variant == "stop 2 s earlier":
        return replace(claim, duration=claim.duration - 2.0)
    if variant == "stop 2 s later":
        return replace(claim, duration=claim.duration + 2.0)
    if variant in TERMS_OFF or variant == "contact gate":
        return claim
    raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")


def variant_config(claim: ClaimRun, variant: str) -> RunConfig:
    """The in-process run of ``variant`` of ``claim`` (its task and tail changed, or one replica term off)."""
    config = variant_run(claim, variant).config()
    if variant in TERMS_OFF:
        config = replace(config, replica_overrides={**config.replica_overrides, TERMS_OFF[variant]: False})
    if variant == "contact gate":
        config = replace(config, replica_overrides={**config.replica_overrides,
                                                    "offset_feedforward_contact_gate": True})
    return config


def tail_figures(claim: ClaimRun, variant: str) -> dict[str, Any]:
    """Simulate ``variant`` of ``claim`` and return its verdict and tail figures."""
    from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

    changed = variant_run(claim, variant)
    result = run(variant_config(claim, variant))
    verdict = judge(VerdictInput.from_run_result(result, one_way_delay=changed.delay))
    tail = result.time >= changed.duration
    step = float(np.median(np.diff(result.time)))
    force = np.linalg.norm(result.force, axis=1)
    contact = result.obstacle_contact[tail] if result.obstacle_contact is not None else np.zeros(int(tail.sum()), bool)
    return dict(seed=claim.seed, controller=claim.controller, hand=claim.hand, delay=claim.delay,
                rate_hz=claim.rate_hz, variant=variant, stable=verdict.stable, safe=verdict.safe,
                stable_reasons=verdict.stable_reasons, swing_m=verdict.figures.get("swing_m"),
                tail_motion_max_m=verdict.figures.get("tail_motion_max_m"),
                tail_obstacle_contact_s=float(contact.sum() * step),
                tail_force_max_n=float(force[tail].max()) if tail.any() else 0.0)


def plot_tails(claim: ClaimRun, path: Path) -> None:
    """The tail of ``claim`` as swept beside the same run stopped 2 s earlier: |x_M - operator target| and |F_R|
    from one round trip before the stop to the end, contact with the fixed obstacle shaded."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(2, 2, figsize=(11, 5.5), sharex="col", sharey="row")
    for column, variant in enumerate(("as swept", "stop 2 s earlier")):
        changed = variant_run(claim, variant)
        result = run(changed.config())
        shown = result.time >= changed.duration - 2.0 * changed.delay
        time = result.time[shown] - changed.duration
        handle = np.linalg.norm(result.master[shown] - result.operator_target[shown], axis=1) * 1e3
        force = np.linalg.norm(result.force[shown], axis=1)
        contact = result.obstacle_contact[shown]
        for axis in axes[:, column]:
            axis.fill_between(time, 0, 1, where=contact, transform=axis.get_xaxis_transform(), color="tab:red",
                              alpha=0.15, linewidth=0, label="touching the fixed obstacle")
            axis.axvline(0.0, color="0.4", linestyle="--", linewidth=0.8)
        axes[0, column].plot(time, handle, color="tab:blue")
        axes[1, column].plot(time, force, color="tab:orange")
        axes[0, column].set_title(f"seed {claim.seed}, {claim.controller}, {claim.delay:g} s, "
                                  f"{claim.rate_hz:g} Hz: {variant}")
        axes[1, column].set_xlabel("time after the task stops [s]")
    axes[0, 0].set_ylabel("|x_M - operator target| [mm]")
    axes[1, 0].set_ylabel("|F_R| [N]")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[5, 7, 8])
    parser.add_argument("--controllers", nargs="+", default=["fic", "linear"])
    parser.add_argument("--hand", default="passive")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--rate", type=float, default=10.0, help="link rate [Hz] (0: full rate)")
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("results/tail_contact.json"))
    parser.add_argument("--plot", type=Path, default=None,
                        help="instead: plot the first seed's and controller's tail as swept and stopped 2 s earlier")
    args = parser.parse_args(argv)
    if args.plot is not None:
        plot_tails(ClaimRun(args.delay, args.rate, args.controllers[0], args.hand, args.seeds[0],
                            duration_for(args.delay), tail=tail_for(args.delay)), args.plot)
        print(f"plot: {args.plot}")
        return 0
    jobs = [(ClaimRun(args.delay, args.rate, controller, args.hand, seed, duration_for(args.delay),
                      tail=tail_for(args.delay)), variant)
            for seed in args.seeds for controller in args.controllers for variant in args.variants]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(tail_figures, *zip(*jobs)))
    for row in rows:
        print(f"seed {row['seed']} {row['controller']:<7} {row['variant']:<18} "
              f"{'stable' if row['stable'] else 'NOT stable' if row['stable'] is False else 'not assessed':<12} "
              f"tail contact {row['tail_obstacle_contact_s']:.2f} s, peak {row['tail_force_max_n']:.1f} N, "
              f"swing {(row['swing_m'] or 0) * 1e3:.1f} mm", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(dict(command="python -m fic_teleop_experiments.tail_contact " + " ".join(
        sys.argv[1:] if argv is None else argv), runs=rows), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
