"""The demonstrations profile: the launcher becomes a session of episodes (each a launcher run of its own, with the
next seed, in its own folder), then one export; without the session the profile's task still reaches run.json."""
from __future__ import annotations

import sys
from pathlib import Path

from fic_teleop_bringup import demonstrations, teleop_launcher


def _args(*argv: str):
    args = teleop_launcher.parse_arguments(list(argv))
    teleop_launcher.resolve_defaults(args)
    return args


def test_the_profile_is_a_session_of_three_e1_episodes_with_its_task() -> None:
    args = _args("--profile", "demonstrations")
    assert demonstrations.is_session(args) and args.run_profile["dataset"]["episodes"] == 3
    assert args.scene == "superimposition" and args.operator == "scripted"
    assert args.task == args.run_profile["dataset"]["task"]
    graph = {spec.name: spec for spec in teleop_launcher.graph(args, Path("bag"))}
    assert graph["robot"].params["object_pose_rate_hz"] == 30.0   # the camera's source at the dataset's 30 fps
    episode = _args("--profile", "demonstrations", demonstrations.EPISODE_FLAG, "--task", "mine")
    assert not demonstrations.is_session(episode) and episode.task == "mine"
    assert not demonstrations.is_session(_args()) and _args().task is None


def test_the_session_runs_each_episode_with_the_next_seed_then_exports_them(tmp_path, monkeypatch) -> None:
    commands, failing, exported = [], {}, []

    class Child:   # a launcher run: its folder gets a bag; the episodes in `failing` exit with their code
        def __init__(self, command):
            commands.append(command)
            self.folder = Path(command[-4])     # [..., "--out", folder, "--seed", seed, EPISODE_FLAG]
            (self.folder / "bag").mkdir(parents=True, exist_ok=True)

        def wait(self):
            return failing.get(self.folder.name, 0)

        poll = wait

    monkeypatch.setattr(demonstrations.subprocess, "Popen", Child)
    monkeypatch.setattr(demonstrations, "export", lambda episodes, out, dataset: exported.append((episodes, out)) or 0)
    argv = ["--profile", "demonstrations", "--seed", "5", "--out", str(tmp_path)]
    assert demonstrations.run(argv, _args(*argv), tmp_path) == 0
    assert all(c[:3] == [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher"] and c[3:9] == argv and
               c[-5] == "--out" and c[-3] == "--seed" and c[-1] == demonstrations.EPISODE_FLAG for c in commands)
    assert [c[-2] for c in commands] == ["5", "6", "7"]
    assert [Path(c[-4]).name for c in commands] == ["episode_1", "episode_2", "episode_3"]
    assert [path.name for path in exported[0][0]] == ["episode_1", "episode_2", "episode_3"]
    assert exported[0][1] == tmp_path / "dataset"

    failing.update({"episode_2": 6, "episode_3": 3})   # starved (timing only); a limit broken (safety)
    exported.clear()
    assert demonstrations.run(argv, _args(*argv), tmp_path / "again") == 6   # the first failed episode's code;
    assert [path.name for path in exported[0][0]] == ["episode_1", "episode_2"]   # the unsafe one left out
