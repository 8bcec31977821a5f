"""Offscreen pictures: a key frame shows the scene, and a taped run becomes PNG key frames and an animated GIF."""
import numpy as np
import pytest
from PIL import Image

from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.render import OffscreenRenderer, StateTape, check_video_path, default_view, render_tape
from sim_bridge.robot.scenes import PIECE_RGBA


def test_key_frame_of_the_shape_sorting_scene_shows_the_pieces_and_the_robot():
    sim = PandaSimulation("shape_sorting", seed=0)
    with OffscreenRenderer(sim.model, default_view("shape_sorting"), width=320, height=240) as renderer:
        image = renderer.render(sim.data)
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    pixels = image.reshape(-1, 3).astype(int)
    # Each piece's colour (under lighting) is on screen: a pixel dominated by that colour channel.
    for shape, rgba in PIECE_RGBA.items():
        channel = int(np.argmax(rgba[:3]))
        others = [c for c in range(3) if c != channel]
        dominant = (pixels[:, channel] > 100) & np.all(pixels[:, channel, None] > 2 * pixels[:, others], axis=1)
        assert dominant.sum() >= 5, shape
    assert (pixels.min(axis=1) > 200).sum() > 500  # the white robot


def test_a_taped_run_renders_to_png_key_frames_and_a_gif(tmp_path):
    sim = PandaSimulation("superimposition", seed=0)
    tape = StateTape(frame_interval=0.1)
    tape.maybe_record(sim.data)
    for _ in range(500):
        sim.step(sim.hold_torque() + np.array([8.0, 0, 0, 0, 0, 0, 0]))
        tape.maybe_record(sim.data)
    assert len(tape) == 6 and tape.times[-1] == pytest.approx(0.5)
    written = render_tape(sim.model, tape, default_view("superimposition"), video_path=tmp_path / "run.gif",
                          snapshot_dir=tmp_path / "frames", snapshot_interval=0.2, fps=5, width=160, height=120)
    pngs = sorted(p for p in written if p.suffix == ".png")
    assert [p.name for p in pngs] == ["frame_0000.000s.png", "frame_0000.200s.png", "frame_0000.400s.png",
                                      "frame_0000.500s.png"]  # every 0.2 s, and the last
    with Image.open(tmp_path / "run.gif") as gif:
        assert gif.n_frames == 6 and gif.size == (160, 120)
        first = np.asarray(gif.convert("RGB"))
        gif.seek(5)
        last = np.asarray(gif.convert("RGB"))
    assert np.abs(first.astype(int) - last.astype(int)).max() > 50  # the arm turned between them
    # A taped frame is the picture of the live state (kinematics, lights and all): same pixels.
    with OffscreenRenderer(sim.model, default_view("superimposition"), width=160, height=120) as renderer:
        live = renderer.render(sim.data)
    np.testing.assert_array_equal(np.asarray(Image.open(pngs[-1]).convert("RGB")), live)


def test_unwritable_video_formats_are_refused_up_front(tmp_path):
    with pytest.raises(ValueError, match="gif"):
        check_video_path(tmp_path / "run.avi")
