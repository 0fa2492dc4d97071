"""Animations: frames drawn from the states given, clear errors for what cannot be written."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from armpath.errors import InvalidInputError
from armpath.model.seed_arm import seed_arm
from armpath.viz.animation import Animation, frames_for, write_animation


def test_frames_are_spread_over_the_states():
    assert frames_for(np.arange(5), 10).tolist() == [0, 1, 2, 3, 4]
    idx = frames_for(np.arange(1001), 11)
    assert idx.tolist() == list(range(0, 1001, 100))


def test_gif_has_one_frame_per_chosen_state(tmp_path):
    arm = seed_arm()
    q = np.linspace(np.radians([0, -90, 0, 0, -90, 0]), np.radians([40, -60, 30, 90, -45, 10]), 50)
    n = write_animation(tmp_path / "a.gif", Animation(arm, q, np.linspace(0, 2, 50)), max_frames=10)
    gif = Image.open(tmp_path / "a.gif")
    assert n == 10 and gif.n_frames == 10
    # Successive frames differ: the arm moves.
    gif.seek(0)
    first = np.asarray(gif.convert("L"), dtype=float)
    gif.seek(9)
    last = np.asarray(gif.convert("L"), dtype=float)
    assert np.abs(first - last).mean() > 0.5


def test_bad_animation_requests(tmp_path):
    arm = seed_arm()
    q = np.zeros((3, 6))
    with pytest.raises(InvalidInputError, match="animation must be one of"):
        write_animation(tmp_path / "a.avi", Animation(arm, q, np.arange(3.0)))
    with pytest.raises(InvalidInputError, match="one state of 6 joints per time"):
        write_animation(tmp_path / "a.gif", Animation(arm, q[:, :5], np.arange(3.0)))
    assert not (tmp_path / "a.gif").exists()


def test_mp4_is_written_with_ffmpeg_or_refused_clearly(tmp_path):
    import shutil

    arm = seed_arm()
    q = np.linspace(np.radians([0, -90, 0, 0, -90, 0]), np.radians([40, -60, 30, 90, -45, 10]), 6)
    anim = Animation(arm, q, np.arange(6.0))
    if shutil.which("ffmpeg") is None:
        with pytest.raises(InvalidInputError, match="MP4 needs ffmpeg"):
            write_animation(tmp_path / "a.mp4", anim)
        assert not (tmp_path / "a.mp4").exists()
    else:
        assert write_animation(tmp_path / "a.mp4", anim) == 6
        assert (tmp_path / "a.mp4").read_bytes()[4:8] == b"ftyp"
