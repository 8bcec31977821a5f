"""The paper-style figures of a session (matplotlib, Agg, PNG). Times on the x axes: header stamps - t0 [s]."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)
import numpy as np  # noqa: E402

from .bag_data import FIC_STATE_TOPIC, BagData  # noqa: E402
from .metrics import Analysis, ReportSettings  # noqa: E402

AXES = "xyz"
COLOURS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
CONTACT = dict(color="tab:orange", alpha=0.18, lw=0)


def _shade_contacts(ax, analysis: Analysis, label: bool = True) -> None:
    for i, (start, end) in enumerate(analysis.contact_intervals):
        ax.axvspan(start, end, label="contact" if (label and i == 0) else None, **CONTACT)


def _sorted(series, t0: float):
    order = np.argsort(series.stamp, kind="stable")
    return series.stamp[order] - t0, {k: v[order] for k, v in series.values.items()}


def plot_position(data: BagData, analysis: Analysis, out: Path) -> Path | None:
    """(a) replica TCP position and desired position per axis against time."""
    if not (data.has("/replica/tcp_pose") or data.has("/replica/desired_pose")):
        return None
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(9, 6.5))
    for ax, a in zip(axes, AXES):
        _shade_contacts(ax, analysis, label=a == "x")
        if data.has("/replica/desired_pose"):
            t, v = _sorted(data.series["/replica/desired_pose"], analysis.t0)
            ax.plot(t, v[a], "--", color="black", lw=1.2, label="desired $x_d$")
        if data.has("/replica/tcp_pose"):
            t, v = _sorted(data.series["/replica/tcp_pose"], analysis.t0)
            ax.plot(t, v[a], color=COLOURS[a], lw=1.4, label="replica $x_R$")
        ax.set_ylabel(f"{a} [m]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[0].set_title("Replica TCP position and desired position")
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "position.png")


def plot_error(data: BagData, analysis: Analysis, settings: ReportSettings, out: Path) -> Path | None:
    """(b) tracking error |x_d - x_R| with the x_b line, contact shaded, warm-up marked."""
    if len(analysis.error) == 0:
        return None
    fig, ax = plt.subplots(figsize=(9, 3.6))
    _shade_contacts(ax, analysis)
    ax.plot(analysis.error_t, analysis.error, color="tab:blue", lw=1.2, label="tracking error $|x_d - x_R|$")
    ax.axhline(settings.error_bound_m, color="black", ls="--", lw=1.2, label=f"$x_b$ = {settings.error_bound_m} m")
    if settings.warmup_s > 0:
        ax.axvspan(analysis.error_t.min(), settings.warmup_s, color="grey", alpha=0.12, lw=0, label="warm-up")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("error [m]")
    ax.set_ylim(bottom=0, top=max(settings.error_bound_m * 1.3, float(np.nanmax(analysis.error)) * 1.1))
    ax.set_title(f"Tracking error ({analysis.metrics['tracking_error_source']})")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    return _save(fig, out / "tracking_error.png")


def plot_force(data: BagData, analysis: Analysis, settings: ReportSettings, out: Path) -> Path | None:
    """(c) interaction force (F/T sensor): magnitude and components, F_max when known."""
    if not data.has("/ft_sensor/wrench"):
        return None
    t, v = _sorted(data.series["/ft_sensor/wrench"], analysis.t0)
    force = np.column_stack([v["fx"], v["fy"], v["fz"]])
    fig, ax = plt.subplots(figsize=(9, 3.8))
    _shade_contacts(ax, analysis)
    for k, a in enumerate(AXES):
        ax.plot(t, force[:, k], color=COLOURS[a], lw=0.9, alpha=0.8, label=f"$F_{a}$")
    ax.plot(t, np.linalg.norm(force, axis=1), color="black", lw=1.4, label="$|F|$")
    if settings.max_force_n:
        ax.axhline(settings.max_force_n, color="tab:purple", ls="--", lw=1.2, label=f"$F_{{max}}$ = "
                                                                                    f"{settings.max_force_n:g} N")
    ax.axhline(settings.free_force_threshold_n, color="grey", ls=":", lw=1, label="free-motion threshold")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [N]")
    ax.set_title("Interaction force at the wrist F/T sensor")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    return _save(fig, out / "interaction_force.png")


def plot_paths(data: BagData, analysis: Analysis, out: Path) -> Path | None:
    """(d) 3-D paths: master (x_d' from the teleop command, drawn from the desired path's start), desired x_d,
    replica TCP."""
    have = [t for t in ("/replica/tcp_pose", "/replica/desired_pose", "/master/teleop_command") if data.has(t)]
    if not have:
        return None
    fig = plt.figure(figsize=(7.5, 6.5))
    ax = fig.add_subplot(projection="3d")
    origin = np.zeros(3)
    if data.has("/replica/desired_pose"):
        _, v = _sorted(data.series["/replica/desired_pose"], analysis.t0)
        path = np.column_stack([v[a] for a in AXES])
        origin = path[0]
        ax.plot(*path.T, "--", color="black", lw=1.2, label="desired $x_d = x_d' + x_d''$")
    if data.has("/master/teleop_command"):
        _, v = _sorted(data.series["/master/teleop_command"], analysis.t0)
        offset = np.column_stack([v[f"offset_{a}"] for a in AXES])
        ax.plot(*(origin + offset - offset[0]).T, color="tab:purple", lw=1.2, label="master $x_d'$ (from start)")
    if data.has("/replica/tcp_pose"):
        _, v = _sorted(data.series["/replica/tcp_pose"], analysis.t0)
        ax.plot(*np.column_stack([v[a] for a in AXES]).T, color="tab:blue", lw=1.4, label="replica $x_R$")
    # Equal scale on the three axes (a circle looks like a circle), at least 5 cm wide.
    lines = [np.column_stack(line.get_data_3d()) for line in ax.get_lines()]
    points = np.concatenate(lines) if lines else np.zeros((1, 3))
    centre = (points.max(axis=0) + points.min(axis=0)) / 2
    half = max(float((points.max(axis=0) - points.min(axis=0)).max()) / 2, 0.025)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title("Master, desired and replica paths")
    ax.legend(loc="upper left", fontsize=8)
    return _save(fig, out / "paths_3d.png")


def plot_fic(data: BagData, analysis: Analysis, out: Path) -> Path | None:
    """(e) FIC phase per translation axis (D = 0, C = 1) and the controller's total energy."""
    if not data.has(FIC_STATE_TOPIC):
        return None
    t, v = _sorted(data.series[FIC_STATE_TOPIC], analysis.t0)
    fig, (ax_phase, ax_energy, ax_passivity) = plt.subplots(3, 1, sharex=True, figsize=(9, 7))
    for k, a in enumerate(AXES):
        ax_phase.step(t, v[f"phase_{a}"] + 1.5 * k, where="post", color=COLOURS[a], lw=1, label=a)
    ax_phase.set_yticks([0, 1, 1.5, 2.5, 3, 4], ["x: D", "x: C", "y: D", "y: C", "z: D", "z: C"])
    ax_phase.set_title(f"FIC phases (controller: {data.controller or 'unknown'}) and energy")
    ax_phase.grid(alpha=0.3)
    _shade_contacts(ax_energy, analysis)
    ax_energy.plot(t, v["total_energy"], color="tab:brown", lw=1.2, label="total energy")
    ax_energy.set_ylabel("energy [J]")
    ax_energy.grid(alpha=0.3)
    ax_energy.legend(loc="upper right", fontsize=8)
    # The passivity observer: work done on the FIC's port, its storage, and the run's smallest margin W - (V - V0).
    ax_passivity.plot(t, v["port_work"], color="tab:blue", lw=1.0, label="port work W (sum of axes)")
    ax_passivity.plot(t, v["storage"], color="tab:green", lw=1.0, label="storage V (sum of axes)")
    ax_passivity.plot(t, v["passivity_margin_min"], color="tab:red", lw=1.0, label="min margin W - (V - V0)")
    ax_passivity.axhline(0.0, color="k", lw=0.8)
    ax_passivity.set_ylabel("energy [J]")
    ax_passivity.set_xlabel("time [s]")
    ax_passivity.grid(alpha=0.3)
    ax_passivity.legend(loc="upper left", fontsize=8)
    return _save(fig, out / "fic_state.png")


def plot_all(data: BagData, analysis: Analysis, settings: ReportSettings, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    made = [plot_position(data, analysis, out), plot_error(data, analysis, settings, out),
            plot_force(data, analysis, settings, out), plot_paths(data, analysis, out), plot_fic(data, analysis, out)]
    return [p for p in made if p is not None]


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    # zlib level 1: a plot's PNG in a fifth of the default level's time (6), about a third larger.
    fig.savefig(path, dpi=110, pil_kwargs={"compress_level": 1})
    plt.close(fig)
    return path
