"""Write config/live_view.json, the Foxglove layout of the live view (`scripts/run_teleop.sh --live`).

Built with the SDK's own layout types (foxglove.layouts), so the file is what Foxglove imports;
test/bringup/test_launch_file.py regenerates it and compares, and checks that every field it plots is a field of a
recorded topic's message. Panels: the arm in 3D (its URDF through the server's assets, posed by /live/transforms) with
x_d (/replica/desired_pose) and x_R (/replica/tcp_pose); the interaction forces; the FIC phases and energy (paper Eq. 2:
divergence D = 0, convergence C = 1 per axis); the limit flags of the postural optimisation; the operator's tools
(/master/operator_tools: engaged, clutched or homing, the loop gain k_F s_M K_H, the guidance fixture's force).

usage: python -m fic_teleop_tools.recording.live_view_layout [--check]
       (--check: exit 1 if config/live_view.json differs)
"""
from __future__ import annotations

import argparse
import sys

import foxglove.layouts as fl

from fic_teleop_runtime.workspace import config_folder

LAYOUT_PATH = config_folder() / "live_view.json"
URDF_URL = "package://example-robot-data/robots/panda_description/urdf/panda.urdf"
AXES = ("x", "y", "z")


def _series(path: str, label: str) -> fl.PlotSeries:
    return fl.PlotSeries(value=path, label=label, timestamp_method="receiveTime")


def _plot(title: str, series: list[fl.PlotSeries]) -> fl.PlotPanel:
    return fl.PlotPanel(title=title, config=fl.PlotConfig(paths=series, show_legend=True, time_window_mode="sliding",
                                                          x_axis_val="timestamp"))


def arm_panel() -> fl.ThreeDeePanel:
    return fl.ThreeDeePanel(title="arm, x_d and x_R", config=fl.ThreeDeeConfig(
        follow_tf="panda_link0",
        layers={
            "grid": fl.BaseRendererGridLayerSettings(layer_id="foxglove.Grid", frame_id="panda_link0", size=2.0),
            "panda": fl.BaseRendererUrdfLayerSettings(layer_id="foxglove.Urdf", label="Panda", source_type="url",
                                                      url=URDF_URL, control_mode="transforms"),
        },
        topics={
            "/replica/desired_pose": fl.BaseRendererPoseTopicSettings(visible=True, type="axis", axis_scale=0.6),
            "/replica/tcp_pose": fl.BaseRendererPoseTopicSettings(visible=True, type="arrow", color="#e05050"),
        }))


def forces_panel() -> fl.PlotPanel:
    series = [_series(f"/ft_sensor/wrench.wrench.force.{a}", f"F_R {a} (F/T)") for a in AXES]
    series += [_series(f"/haptic/wrench_command.wrench.force.{a}", f"f {a} (handle)") for a in AXES]
    return _plot("interaction force F_R and handle force f [N]", series)


def fic_panel() -> fl.TabContainer:
    phases = fl.StateTransitionsPanel(title="FIC phase per axis (0 D, 1 C)", config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value=f"/replica/fic_state.phase[{i}]", label=f"phase {a}")
               for i, a in enumerate(AXES)]))
    energy = _plot("FIC energy [J]", [_series("/replica/fic_state.total_energy", "total")]
                   + [_series(f"/replica/fic_state.stored_energy[{i}]", f"stored {a}") for i, a in enumerate(AXES)])
    error = _plot("tracking error x_d - x_R [m]",
                  [_series(f"/replica/fic_state.error[{i}]", f"e {a}") for i, a in enumerate(AXES)])
    return fl.TabContainer(selected_tab_index=0, tabs=[fl.TabItem(title="phases", content=phases),
                                                       fl.TabItem(title="energy", content=energy),
                                                       fl.TabItem(title="error", content=error)])


def limits_panel() -> fl.SplitContainer:
    def indicator(path: str, title: str) -> fl.IndicatorPanel:
        return fl.IndicatorPanel(title=title, config=fl.IndicatorConfig(path=path, style="background", rules=[
            fl.IndicatorRule(raw_value="0", operator=">", color="#d03030", label=f"{title}: set")],
            fallback_color="#2f8f2f", fallback_label=f"{title}: clear"))
    flags = fl.StateTransitionsPanel(title="limit flags (1 torque, 2 rate, 4 qd, 8 q, 16 TCP speed)",
                                     config=fl.StateTransitionsConfig(paths=[
                                         fl.StateTransitionsSeries(value="/replica/limit_status.shaping",
                                                                   label="shaping"),
                                         fl.StateTransitionsSeries(value="/replica/limit_status.violations",
                                                                   label="violations")]))
    return fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=indicator("/replica/limit_status.violations", "violation")),
        fl.SplitItem(proportion=1, content=indicator("/replica/fic_state.master_stale", "master stale")),
        fl.SplitItem(proportion=3, content=flags)])


def operator_tools_panel() -> fl.SplitContainer:
    """The master's operator tools (docs/TOOLS.md): whether the handle drives x_d', and what the scales and the
    guidance fixture put on the handle."""
    tools = "/master/operator_tools"
    engagement = fl.IndicatorPanel(title="handle", config=fl.IndicatorConfig(path=f"{tools}.engagement",
                                                                             style="background", rules=[
        fl.IndicatorRule(raw_value="1", operator="=", color="#d08a20", label="clutched: x_d' held"),
        fl.IndicatorRule(raw_value="2", operator="=", color="#3070c0", label="homing: x_d' held")],
        fallback_color="#2f8f2f", fallback_label="engaged"))
    plot = _plot("guidance force at the handle [N], loop gain k_F s_M K_H",
                 [_series(f"{tools}.guidance_force.{a}", f"guidance {a}") for a in AXES]
                 + [_series(f"{tools}.loop_gain", "loop gain")])
    return fl.SplitContainer(direction="row", items=[fl.SplitItem(proportion=1, content=engagement),
                                                     fl.SplitItem(proportion=3, content=plot)])


def layout() -> fl.Layout:
    right = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=forces_panel()),
        fl.SplitItem(proportion=1, content=fic_panel()),
        fl.SplitItem(proportion=1, content=limits_panel()),
        fl.SplitItem(proportion=1, content=operator_tools_panel())])
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=3, content=arm_panel()), fl.SplitItem(proportion=2, content=right)]))


def layout_text() -> str:
    return layout().to_json() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args(argv)
    text = layout_text()
    if args.check:
        if not LAYOUT_PATH.exists() or LAYOUT_PATH.read_text() != text:
            print(f"{LAYOUT_PATH} is not what python -m fic_teleop_tools.recording.live_view_layout writes; run it",
                  file=sys.stderr)
            return 1
        return 0
    LAYOUT_PATH.write_text(text)
    print(f"wrote {LAYOUT_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
