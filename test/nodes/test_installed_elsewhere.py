"""Installed nodes run outside the checkout: the planner and the channel node, started from their install/
executables in a folder that is not the repository and without FIC_TELEOP_ROOT, take their defaults from the
config installed with the runtime (share/fic_teleop_runtime/config, fic_teleop_runtime.workspace) and start; the
planner publishes x_d''. No module finds the repository beside its own source file."""
from __future__ import annotations

from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")

from geometry_msgs.msg import PoseStamped  # noqa: E402
from master_peer import QOS, STARTUP_TIMEOUT  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402

from fic_teleop_runtime.workspace import ROOT_VARIABLE, config_folder  # noqa: E402

pytestmark = pytest.mark.nodes


@pytest.fixture
def elsewhere(ros_env: dict[str, str], tmp_path: Path) -> tuple[dict[str, str], Path]:
    """The test's environment without the checkout's root, and an empty working folder."""
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    return {key: value for key, value in ros_env.items() if key != ROOT_VARIABLE}, folder


def test_the_installed_config_is_the_share_folders(elsewhere, monkeypatch) -> None:
    monkeypatch.delenv(ROOT_VARIABLE, raising=False)
    installed = config_folder()
    assert installed.parts[-3:] == ("share", "fic_teleop_runtime", "config"), installed
    assert (installed / "planner.yaml").is_file() and (installed / "channel.yaml").is_file()


def test_the_installed_planner_starts_and_publishes_from_another_folder(start_node, rclpy_context, elsewhere):
    env, folder = elsewhere
    planner = start_node("fic_teleop_planner", "planner_node", env=env, cwd=folder)
    assert planner.wait_for_output("planner up", STARTUP_TIMEOUT), planner.output()
    node = rclpy.create_node("elsewhere_peer", context=rclpy_context)
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(node)
    poses: list = []
    node.create_subscription(PoseStamped, "/planner/desired_pose", poses.append, QOS)
    try:
        for _ in range(3000):
            if len(poses) >= 10:
                break
            executor.spin_once(timeout_sec=0.01)
        assert len(poses) >= 10, planner.output()
        assert poses[-1].header.frame_id == "panda_link0"
    finally:
        executor.shutdown()
        node.destroy_node()
    assert not list(folder.iterdir()), "the node wrote into its working folder"


def test_the_installed_channel_node_starts_from_another_folder(start_node, elsewhere):
    env, folder = elsewhere
    channel = start_node("sim_bridge", "channel_node", env=env, cwd=folder, name="channel_forward")
    assert channel.wait_for_output("channel up", STARTUP_TIMEOUT), channel.output()
