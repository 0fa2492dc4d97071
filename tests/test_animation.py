"""Animations: frames drawn from the states given, everything drawn inside the axes, text
large enough to read, clear errors for what cannot be written."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text
from matplotlib.transforms import Bbox
from PIL import Image

from armpath.commands import CommandSequence, deg_to_ticks
from armpath.errors import InvalidInputError
from armpath.model.seed_arm import seed_arm
from armpath.scenes import seed_scene
from armpath.viz.animation import (
    ANIMATION_DPI,
    Animation,
    Overlay,
    animation_frames,
    frames_for,
    sequence_animation,
    write_animation,
)


def test_frames_are_spread_over_the_states():
    assert frames_for(np.arange(5), 10).tolist() == [0, 1, 2, 3, 4]
    idx = frames_for(np.arange(1001), 11)
    assert idx.tolist() == list(range(0, 1001, 100))


@pytest.mark.slow
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


def _drawn_points(ax) -> np.ndarray:
    """Every point a frame draws in the 3-D axes: line and marker vertices, text anchors."""
    pts = [np.column_stack(line.get_data_3d()) for line in ax.get_lines()]
    pts += [np.array([t.get_position_3d()]) for t in ax.texts]
    pts = np.vstack([p.astype(float) for p in pts if len(p)])
    return pts[np.all(np.isfinite(pts), axis=1)]


def _assert_frames_inside_limits(frames) -> None:
    ax = frames.axes
    for i in range(frames.n_frames):
        frames.draw(i)
        pts = _drawn_points(ax)
        for k, (lo, hi) in enumerate((ax.get_xlim(), ax.get_ylim(), ax.get_zlim())):
            assert lo - 1e-9 <= pts[:, k].min() and pts[:, k].max() <= hi + 1e-9, (i, k)


def test_every_frame_draws_inside_the_axes():
    """Nothing leaves the plotted box: the fixed-point rotation's wrist circle runs far below
    the table height, which the limits used to cut off at z = -10 mm."""
    arm = seed_arm()
    q = np.linspace(np.radians([0, -90, 0, 0, -90, 0]), np.radians([40, -150, 120, 90, 45, 10]), 40)
    t = np.linspace(0.0, 2 * np.pi, 60)
    ring = np.column_stack([600 + 0 * t, 250 * np.cos(t), -150 + 250 * np.sin(t)])
    anim = Animation(
        arm,
        q,
        np.linspace(0, 4, 40),
        "rotation about a point",
        overlays=(
            Overlay(np.array([[600.0, 0.0, -150.0]]), "fixed point", "points"),
            Overlay(ring, "wrist circle", "line", "tab:purple"),
        ),
    )
    frames = animation_frames(anim, max_frames=12)
    assert frames.axes.get_zlim()[0] <= ring[:, 2].min() < -390.0
    _assert_frames_inside_limits(frames)

    # in the seed scene, with numbered targets and a curve
    seq = CommandSequence(
        deg_to_ticks([0, -90, 0, 0, -90, 0]), np.tile([-20, 15, 20, 5, 0, 0], (25, 1))
    )
    targets = np.array([[20.0, -200.0, 120.0], [300.0, 0.0, 50.0]])
    curve = np.column_stack([210 + 100 * np.cos(t), 100 * np.sin(t), 100 + 0 * t])
    anim = sequence_animation(arm, seed_scene(), seq, "scene", targets, curve)
    frames = animation_frames(anim, max_frames=10)
    assert sorted(t.get_text() for t in frames.axes.texts) == ["1", "2"]
    _assert_frames_inside_limits(frames)


def _visible_texts(fig):
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


def test_gif_text_is_large_enough_to_read_and_inside_the_frame(tmp_path):
    arm = seed_arm()
    q = np.linspace(np.radians([0, -90, 0, 0, -90, 0]), np.radians([40, -60, 30, 90, -45, 10]), 20)
    title = (
        "a long title of an animation that would not fit on one line of the frame: "
        "163 commands, largest deviation 0.090 mm, wall measured normal to the surface"
    )
    anim = Animation(
        arm,
        q,
        np.linspace(0, 2, 20),
        title,
        overlays=(Overlay(np.array([[300.0, 0.0, 100.0]]), "target", "points"),),
        caption=lambda k: f"tip off the point {k / 10:6.2f} mm",
    )
    frames = animation_frames(anim, max_frames=5)
    fig = frames.figure
    assert fig.dpi == ANIMATION_DPI
    canvas = FigureCanvasAgg(fig)
    for i in range(frames.n_frames):
        frames.draw(i)
        canvas.draw()
        renderer = canvas.get_renderer()
        texts = _visible_texts(fig)
        # the clock, title, legend and axis labels are all there, none under 13 px
        assert any(t.get_text().startswith("t =") for t in texts)
        for text in texts:
            assert text.get_fontsize() * fig.dpi / 72 >= 13.0, text.get_text()
        # 2-D texts (title, legend, caption) inside the frame and apart from each other
        legend_texts = [t for legend in fig.legends for t in legend.get_texts()]
        flat = [*fig.texts, *legend_texts]
        assert (
            len(legend_texts) == 3 and len(fig.texts) == 2
        )  # target, arm, tip path; title, caption
        boxes = [t.get_window_extent(renderer) for t in flat]
        for text, box in zip(flat, boxes, strict=True):
            assert fig.bbox.contains(box.x0, box.y0) and fig.bbox.contains(box.x1, box.y1), (
                text.get_text()
            )
        for a in range(len(boxes)):
            for b in range(a + 1, len(boxes)):
                assert not Bbox.intersection(boxes[a], boxes[b]), (
                    flat[a].get_text(),
                    flat[b].get_text(),
                )
        tight = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)
        assert fig.bbox.padded(1.0).contains(tight.x0, tight.y0)
        assert fig.bbox.padded(1.0).contains(tight.x1, tight.y1)
    assert "\n" in fig.get_suptitle()  # wrapped to the frame's width
    write_animation(tmp_path / "a.gif", anim, max_frames=3)
    assert Image.open(tmp_path / "a.gif").size == (640, 560)
