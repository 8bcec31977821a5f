"""The experiments' figures (E2 interaction force, E3 blackout, E4 sweeps and stability map) from the cells'
result dictionaries and their run folders; matplotlib with the Agg backend, no display needed."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fic_teleop_experiments.runner import CONTROLLERS
from fic_teleop_tools.verdict.bag_series import read_run


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_sweep(cells: list[dict], sweep: str, out: Path) -> Path | None:
    chosen = [c for c in cells if sweep in c["labels"].get("sweep", "").split("+")
              and c.get("stability", {}).get("stable") is not None]
    if not chosen:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    key = "delay" if sweep == "delay" else "rate"
    for controller, colour in (("fic", "tab:blue"), ("linear", "tab:orange")):
        rows = sorted((c["labels"][key], c["stability"]["max_error_last_half"], c["stability"]["stable"])
                      for c in chosen if c["labels"]["controller"] == controller)
        if not rows:
            continue
        x = [r[0] for r in rows]
        y = [r[1] for r in rows]
        ax.plot(x, y, "-", color=colour, label="FIC" if controller == "fic" else "linear baseline (same K0)")
        for xi, yi, stable in rows:
            ax.plot(xi, yi, "o" if stable else "X", color=colour, markersize=8 if stable else 11,
                    markerfacecolor=colour if stable else "white")
    criterion = chosen[0]["stability"].get("criterion", {})
    if criterion.get("error_bound"):
        ax.axhline(criterion["error_bound"], color="grey", ls="--", lw=1, label="error bound of the criterion")
    ax.axhline(0.05, color="grey", ls=":", lw=1, label="x_b = 0.05 m")
    if sweep == "rate":
        ax.set_xscale("log")
        ax.invert_xaxis()
        ax.set_xlabel("controller rate: channel rate cap and replica control rate [Hz]")
    else:
        ax.set_xlabel("one-way delay, both directions [s]")
    ax.set_ylabel("max tracking error, last half [m]")
    ax.set_title(f"E4 {sweep} sweep (o stable, X unstable by the criterion)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = out / f"e4_{sweep}_sweep.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_stability_map(cells: list[dict], out: Path) -> Path | None:
    columns = [c for c in cells if c["labels"].get("controller") == "fic"]
    if not columns:
        return None
    plt = _plt()
    names = [(f"{c['labels']['delay']:g} s" + ("\n1000 Hz" if "rate" in c["labels"]["sweep"] else ""))
             if c["labels"]["sweep"].startswith("delay") else f"{c['labels']['rate']:g} Hz" for c in columns]
    fig, ax = plt.subplots(figsize=(1.0 + 0.8 * len(columns), 2.6))
    for row, controller in enumerate(CONTROLLERS):
        for col, fic_cell in enumerate(columns):
            twin = fic_cell["id"].replace("_fic", f"_{controller}")
            cell = next((c for c in cells if c["id"] == twin), None)
            stable = cell.get("stability", {}).get("stable") if cell else None
            colour = {True: "#8fd18f", False: "#f08a8a", None: "#cccccc"}[stable]
            ax.add_patch(plt.Rectangle((col, row), 1, 1, color=colour, ec="white"))
            error = cell.get("stability", {}).get("max_error_last_half") if cell else None
            text = ("stable" if stable else "unstable" if stable is False else "n/a")
            if error is not None:
                text += f"\n{error * 100:.1f} cm"
            ax.text(col + 0.5, row + 0.5, text, ha="center", va="center", fontsize=7)
    ax.set_xlim(0, len(columns))
    ax.set_ylim(0, len(CONTROLLERS))
    ax.set_xticks(np.arange(len(columns)) + 0.5, names, fontsize=8)
    ax.set_yticks([0.5, 1.5], ["FIC", "linear"])
    split = sum(1 for c in columns if c["labels"]["sweep"].startswith("delay"))
    ax.axvline(split, color="black", lw=2)
    ax.set_title("E4: delay sweep (full rate) | rate sweep (zero delay); max error over the last half", fontsize=9)
    fig.tight_layout()
    path = out / "e4_stability_map.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_e2_forces(runs: list[tuple[dict, Path]], out: Path, max_force: float | None) -> Path | None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    drawn = False
    for result, run_dir in runs:
        bag = run_dir / "bag"
        if not bag.exists():
            continue
        series = read_run(bag)
        if not series.force.size:
            continue
        t = series.wrench_time - series.wrench_time[0]
        ax.plot(t, np.linalg.norm(series.force, axis=1), lw=0.6, label=f"seed {result['labels'].get('seed')}")
        drawn = True
    if not drawn:
        plt.close(fig)
        return None
    if max_force:
        ax.axhline(max_force, color="k", ls="--", lw=1, label=f"F_max = {max_force:g} N (replica FIC)")
    ax.axhline(10.0, color="grey", ls=":", lw=1, label="10 N")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|F| at the wrist F/T sensor [N]")
    ax.set_title("E2 shape sorting: interaction force")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = out / "e2_interaction_force.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_e3(result: dict, run_dir: Path, out: Path) -> Path | None:
    bag = run_dir / "bag"
    if not bag.exists():
        return None
    series = read_run(bag)
    if not series.fic_time.size:
        return None
    plt = _plt()
    t0 = series.fic_time[0]
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 6.0), sharex=True)
    axes[0].plot(series.fic_time - t0, series.total_energy, lw=0.8)
    axes[0].set_ylabel("FIC + kinetic energy [J]")
    axes[1].plot(series.fic_time - t0, np.linalg.norm(series.error, axis=1), lw=0.8)
    axes[1].set_ylabel("|x_d - x_R| [m]")
    if series.force.size:
        axes[2].plot(series.wrench_time - t0, np.linalg.norm(series.force, axis=1), lw=0.6)
    axes[2].set_ylabel("|F| [N]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.axvline(result["options"]["blackout_at"], color="red", ls="--", lw=1)
        ax.grid(alpha=0.3)
    axes[0].set_title(f"E3: communication lost from t = {result['options']['blackout_at']:g} s (red)")
    fig.tight_layout()
    path = out / "e3_blackout.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _cell_label(row: dict) -> str:
    return "\n".join(str(row[name]) for name in ("cell", "operator", "hand") if row.get(name) is not None)


def plot_claim_proportions(document: dict, path: Path) -> Path | None:
    """Per claim cell and law, the stable and the safe share with their Wilson 95 % intervals (results/claims.json),
    one panel per verdict and hand; a law's n is written under its point."""
    cells = [c for c in document.get("cells", [])
             if any(s["stable"]["n"] or s["safe"]["n"] for s in c["laws"].values())]
    if not cells:
        return None
    laws = list(dict.fromkeys(law for c in cells for law in c["laws"]))
    names = list(dict.fromkeys(c["cell"] for c in cells))
    hands = list(dict.fromkeys(c.get("hand") for c in cells))
    by_key = {(c["cell"], c.get("hand")): c for c in cells}
    plt = _plt()
    panels = [(verdict, hand) for verdict in ("stable", "safe") for hand in hands]
    fig, axes = plt.subplots(len(panels), 1, figsize=(max(6.4, min(18.0, 0.9 * len(names) + 2.0)),
                                                      1.0 + 2.3 * len(panels)), sharex=True, squeeze=False)
    width = 0.8 / max(1, len(laws))
    colours = plt.get_cmap("tab10")
    for ax, (verdict, hand) in zip(axes[:, 0], panels):
        for j, law in enumerate(laws):
            for i, name in enumerate(names):
                share = by_key.get((name, hand), {}).get("laws", {}).get(law, {}).get(verdict)
                if not share or not share["n"]:
                    continue
                x = i - 0.4 + width * (j + 0.5)
                p = share["k"] / share["n"]
                low, high = share["interval_95"]
                ax.errorbar(x, p, yerr=[[p - low], [high - p]], fmt="o", color=colours(j), ms=4, capsize=2)
                ax.text(x, -0.08, str(share["n"]), ha="center", va="top", fontsize=6, color=colours(j))
        ax.set_ylim(-0.15, 1.05)
        ax.set_ylabel(f"{verdict}" + (f", {hand} hand" if hand else "") + "\n(Wilson 95 %)", fontsize=8)
        ax.grid(alpha=0.3, axis="y")
        for i in range(1, len(names)):
            ax.axvline(i - 0.5, color="grey", lw=0.5)
    axes[-1, 0].set_xticks(range(len(names)), names, fontsize=7, rotation=30, ha="right")
    handles = [plt.Line2D([], [], color=colours(j), marker="o", ls="-", ms=4) for j in range(len(laws))]
    fig.suptitle("Claim cells: share of runs judged stable / safe (n under each point)", fontsize=9, y=0.995)
    top = 1.0 - 0.75 / fig.get_figheight()          # room for the title and the legend's row
    fig.tight_layout(rect=(0, 0, 1, top))
    fig.legend(handles, laws, fontsize=7, ncol=len(laws), loc="upper center", bbox_to_anchor=(0.5, top + 0.4 /
                                                                                              fig.get_figheight()))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_claim_differences(document: dict, path: Path) -> Path | None:
    """The reference law's stable share minus each baseline's, per claim cell, with Newcombe's 95 % interval: an
    interval clear of 0 is a difference the seeds resolve."""
    rows = [c for c in document.get("comparisons", []) if c["stable"]["difference"] is not None]
    if not rows:
        return None
    cells = list(dict.fromkeys(_cell_label(c) for c in rows))
    baselines = list(dict.fromkeys(c["baseline"] for c in rows))
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.0, min(14.0, max(3.0, 0.1 * len(rows) + 2.0))))
    colours = plt.get_cmap("tab10")
    height = 0.8 / max(1, len(baselines))
    for row in rows:
        i, j = cells.index(_cell_label(row)), baselines.index(row["baseline"])
        y = i - 0.4 + height * (j + 0.5)
        d = row["stable"]["difference"]
        low, high = row["stable"]["difference_interval_95"]
        ax.errorbar(d, y, xerr=[[d - low], [high - d]], fmt="o", color=colours(j + 1), ms=4, capsize=2,
                    label=row["baseline"])
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    ax.legend(unique.values(), [f"{document.get('reference_law', 'fic')} - {name}" for name in unique],
              fontsize=7, loc="best")
    ax.axvline(0.0, color="black", lw=1)
    ax.set_xlim(-1.05, 1.05)
    ax.set_yticks(range(len(cells)), [c.replace("\n", " ") for c in cells], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("difference of the stable shares (Newcombe 95 %)")
    ax.grid(alpha=0.3, axis="x")
    ax.set_title(f"Is {document.get('reference_law', 'fic')} more often stable than each baseline?", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
