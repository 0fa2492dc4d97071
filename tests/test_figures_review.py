"""Figures and animations of short results and their details: the faded parts of a trace view
are the parts behind an obstacle, a motion of no or one command still shows, titles say
"1 command", GIF frames last whole hundredths rounded to the nearest with the end pose held,
one palette for every frame, joint labels of a 3-D view that do not cover each other."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.text import Text
from matplotlib.transforms import Bbox
from mpl_toolkits.mplot3d import proj3d
from PIL import Image

from armpath.commands import CommandSequence, deg_to_ticks
from armpath.kinematics import landmark_positions, tool_position
from armpath.model.seed_arm import seed_arm
from armpath.scenes import seed_scene
from armpath.viz.animation import (
    GIF_HOLD_LAST_S,
    animation_frames,
    gif_frame_durations_ms,
    render_frames,
    sequence_animation,
    write_animation,
)
from armpath.viz.figures import (
    _TRACE_VIEW,
    _eye_direction,
    _hidden,
    plot_joint_angles,
    plot_motion_3d,
    plot_trace_3d,
)

START = deg_to_ticks([0, -90, 0, 0, -90, 0])


def _ramp(n: int, per_command_ticks: list[int]) -> CommandSequence:
    return CommandSequence(START, np.tile(per_command_ticks, (n, 1)).reshape(n, len(START)))


def _circle() -> np.ndarray:
    theta = np.linspace(0, 2 * np.pi, 50)
    return np.column_stack([210 + 120 * np.cos(theta), 120 * np.sin(theta), 60 + 0 * theta])


def _gif_frames(path) -> tuple[list[np.ndarray], list[int]]:
    gif = Image.open(path)
    frames, durations = [], []
    for i in range(gif.n_frames):
        gif.seek(i)
        durations.append(gif.info["duration"])
        frames.append(np.asarray(gif.convert("RGB")))
    return frames, durations


# -- 1: faded means behind an obstacle ------------------------------------------------------


@pytest.mark.parametrize("turn", [5, -5])  # the final arm in front of the workpiece, or behind
def test_trace_view_fades_only_what_is_behind_an_obstacle(tmp_path, turn):
    arm, scene = seed_arm(), seed_scene()
    seq = _ramp(40, [turn, 5, -5, 0, 5, 0])
    fig = plot_trace_3d(tmp_path / "t.png", arm, scene, seq, _circle(), [(4, 30)])
    ax = fig.axes[0]
    eye = _eye_direction(*_TRACE_VIEW)
    final_arm = []
    for line in ax.get_lines():
        xyz = np.column_stack(line.get_data_3d()).astype(float)
        if line.get_color() == "0.6" and len(xyz):
            final_arm.append((line, xyz))
        if (line.get_alpha() or 1.0) > 0.5 or not len(xyz):  # faded: 0.3 (0.27 of a pass)
            continue
        hidden = _hidden(np.nan_to_num(xyz), scene, eye)
        finite = np.all(np.isfinite(xyz), axis=1)
        if line.get_linestyle() in ("None", "", " "):  # dots: each one hidden
            assert hidden[finite].all(), line
        else:  # a faded segment has an end behind an obstacle
            seg = finite[:-1] & finite[1:]
            assert (hidden[:-1] | hidden[1:])[seg].all(), line
    # the final arm is drawn at every landmark, solid wherever it is seen
    ends = landmark_positions(arm, seq.states_joint()[-1:])[0]
    seen = ~_hidden(ends, scene, eye)
    solid = [xyz for line, xyz in final_arm if (line.get_alpha() or 1.0) >= 1.0]
    solid_pts = np.vstack(solid)
    for p in ends[seen]:
        assert np.min(np.linalg.norm(solid_pts - p, axis=1)) < 1e-6
    texts = [t.get_text() for t in fig.texts]
    assert "faded: behind an obstacle" in texts


# -- 2: a motion of no or one command ---------------------------------------------------------


def _visible_ticks(ax) -> np.ndarray:
    lo, hi = ax.get_xlim()
    ticks = np.asarray(ax.get_xticks(), dtype=float)
    return ticks[(ticks >= lo) & (ticks <= hi)]


def test_joint_figure_of_no_commands_shows_the_start_as_dots(tmp_path):
    fig = plot_joint_angles(tmp_path / "j.png", _ramp(0, [0] * 6), "reach")
    for ax in fig.axes:
        (line,) = [line for line in ax.get_lines() if line.get_gid() != "mark"]
        assert line.get_marker() not in (None, "None", "", " ")  # one point: a dot, not nothing
        assert line.get_markersize() >= 3
        assert len(line.get_xdata()) == 1
    assert _visible_ticks(fig.axes[-1]).tolist() == [0.0]


@pytest.mark.parametrize(("n", "ticks"), [(1, [0, 1]), (2, [0, 1, 2]), (3, [0, 1, 2, 3])])
def test_command_axis_has_whole_commands_only(tmp_path, n, ticks):
    fig = plot_joint_angles(None, _ramp(n, [20, 20, 0, 0, 0, 0]))
    assert _visible_ticks(fig.axes[-1]).tolist() == ticks
    fig = plot_joint_angles(None, _ramp(37, [20, 20, 0, 0, 0, 0]))
    visible = _visible_ticks(fig.axes[-1])
    assert len(visible) >= 3 and np.all(visible == np.round(visible))


def test_short_sequence_animation_lasts_long_enough_to_see(tmp_path):
    arm, scene = seed_arm(), seed_scene()
    anim = sequence_animation(arm, scene, _ramp(1, [20, 20, 0, 0, 0, 0]), "one")
    assert len(anim.times) >= 25  # more instants of the one command, not 5
    n = write_animation(tmp_path / "a.gif", anim, max_frames=64)
    frames, durations = _gif_frames(tmp_path / "a.gif")
    assert len(frames) == n >= 25
    motion_ms = sum(durations[:-1])
    assert motion_ms >= 1000 and durations[-1] >= 1000
    # no commands: one still frame, shown for the hold
    n = write_animation(tmp_path / "z.gif", sequence_animation(arm, scene, _ramp(0, [0] * 6), "z"))
    frames, durations = _gif_frames(tmp_path / "z.gif")
    assert n == len(frames) == 1 and durations[0] >= 1000


# -- 3: "1 command" --------------------------------------------------------------------------


def test_titles_say_one_command_in_the_singular(tmp_path):
    from armpath.report import passes_text

    assert [passes_text(n) for n in (1, 2)] == ["1 pass", "2 passes"]
    arm, scene = seed_arm(), seed_scene()
    seq = _ramp(1, [20, 20, 0, 0, 0, 0])
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq)
    assert fig.axes[0].get_title() == "1 command"
    fig = plot_trace_3d(tmp_path / "t.png", arm, scene, seq, _circle(), [(0, 1)])
    assert fig.axes[0].get_title() == "curve trace: 1 command, 1 pass"
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, _ramp(3, [20, 20, 0, 0, 0, 0]))
    assert fig.axes[0].get_title() == "3 commands"


# -- 4: GIF timing -----------------------------------------------------------------------------


def test_gif_frame_durations_round_to_the_nearest_hundredth_and_hold_the_end():
    hold = round(1000 * GIF_HOLD_LAST_S)
    # 15 fps: 66.7 ms -> 70 ms (Pillow cut 67 ms to 60 ms: 16.7 fps)
    assert gif_frame_durations_ms(40, 15) == [70] * 39 + [70 + hold]
    assert gif_frame_durations_ms(100, 50) == [20] * 99 + [20 + hold]
    assert gif_frame_durations_ms(100, 40)[0] == 30  # 25 ms: half up
    assert gif_frame_durations_ms(100, 30)[0] == 30
    assert gif_frame_durations_ms(40, 50)[0] == 30  # 39 x 20 ms would move for 0.78 s
    assert gif_frame_durations_ms(200, 1)[0] == 1000
    # five frames would move for 0.28 s: each lasts long enough for the motion to last 1 s
    five = gif_frame_durations_ms(5, 15)
    assert sum(five[:-1]) >= 1000 and five[0] == 250
    assert gif_frame_durations_ms(1, 15) == [70 + hold]
    for n in (1, 2, 5, 40):
        assert all(d % 10 == 0 for d in gif_frame_durations_ms(n, 15))


def test_written_gif_frames_last_what_was_asked(tmp_path):
    arm = seed_arm()
    anim = sequence_animation(arm, None, _ramp(30, [20, 10, 0, 0, 0, 0]), "thirty", substeps=1)
    n = write_animation(tmp_path / "a.gif", anim, fps=15, max_frames=31)
    frames, durations = _gif_frames(tmp_path / "a.gif")
    assert len(frames) == n == 31
    assert durations == gif_frame_durations_ms(31, 15)
    assert durations[0] == 70 and durations[-1] == 70 + round(1000 * GIF_HOLD_LAST_S)


# -- 5: one palette --------------------------------------------------------------------------


@pytest.mark.slow
def test_gif_frames_keep_the_colours_of_what_does_not_move(tmp_path):
    arm, scene = seed_arm(), seed_scene()
    seq = _ramp(40, [-20, 15, 20, 5, 0, 0])
    targets = np.array([[20.0, -200.0, 120.0], [300.0, 0.0, 50.0]])
    anim = sequence_animation(arm, scene, seq, "forty commands", targets, _circle(), substeps=1)
    n = write_animation(tmp_path / "a.gif", anim, max_frames=12)
    gif, _ = _gif_frames(tmp_path / "a.gif")
    rendered = [im[..., :3] for im in render_frames(animation_frames(anim, 12))]
    assert len(gif) == len(rendered) == n
    still = np.all([np.all(im == rendered[0], axis=-1) for im in rendered], axis=0)
    assert still.mean() > 0.8
    for frame in gif[1:]:  # what is the same in every drawn frame is the same in the GIF
        assert np.array_equal(frame[still], gif[0][still])
    # the red path, the green targets and the blue arm keep their exact colours
    for name in ("tab:red", "tab:green", "tab:blue"):
        colour = np.round(np.array(to_rgb(name)) * 255).astype(np.uint8)
        for frame in (gif[0], gif[-1]):
            assert np.all(frame == colour, axis=-1).sum() >= 20, name


# -- 6: joint labels apart ----------------------------------------------------------------------


def _text_boxes(fig) -> list[tuple[str, Bbox]]:
    """The window box of every text of the 3-D view (with its padded background box, if any):
    a 3-D text knows its place only while drawn, so each is projected here as the draw does."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    ax = fig.axes[0]
    out = []
    for t in ax.texts:
        if not t.get_text():
            continue
        x, y, z = (np.array([c], dtype=float) for c in t.get_position_3d())
        xs, ys, _ = proj3d.proj_transform(x, y, z, ax.M)
        flat = Text(
            xs[0],
            ys[0],
            t.get_text(),
            fontproperties=t.get_fontproperties(),
            ha=t.get_ha(),
            va=t.get_va(),
            transform=t.get_transform(),
            figure=fig,
        )
        box = flat.get_window_extent(renderer)
        patch = t.get_bbox_patch()
        if patch is not None:
            box = box.padded(patch.get_boxstyle().pad * t.get_fontsize() * fig.dpi / 72)
        out.append((t.get_text(), box))
    return out


def _assert_apart(boxes: list[tuple[str, Bbox]]) -> None:
    """No joint label overlaps another text (touching is allowed: half a pixel); target
    numbers may overlap each other where the targets are close, which no label placing helps."""
    for i, (a, box_a) in enumerate(boxes):
        for b, box_b in boxes[i + 1 :]:
            if not (a.isdigit() and b.isdigit()):
                assert not box_a.padded(-0.5).overlaps(box_b), f"{a!r} overlaps {b!r}"


def _ur5_cell():
    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm

    scene = load_scene("examples/ur5_cell.toml")
    arm = scene_arm(scene)
    commands = np.zeros((40, arm.n_joints), dtype=np.int64)
    commands[:, 1] = 15
    commands[:, 2] = -20
    seq = CommandSequence(arm.lattice.nearest_ticks(arm.home), commands, arm.lattice)
    tip = tool_position(arm, seq.states_joint()[-1])
    return arm, scene, seq, tip


def test_joint_labels_do_not_cover_each_other_or_the_weld_numbers(tmp_path):
    arm, scene, seq, tip = _ur5_cell()
    welds = np.array(
        [tip, tip + np.array([0, 60, 0]), tip + np.array([40, -50, 10]), [450, 100, 150]]
    )
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq, welds, "welds")
    boxes = _text_boxes(fig)
    _assert_apart(boxes)
    names = [name for name, _ in boxes]
    assert {"1", "2", "3", "4"} <= set(names)  # every weld numbered
    assert len(names) >= 4 + 4  # and most joints named


def test_joint_labels_leave_the_target_clear_and_name_the_tool_point(tmp_path):
    arm, scene, seq, tip = _ur5_cell()
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq, tip, "reach")
    boxes = _text_boxes(fig)
    _assert_apart(boxes)
    joints = [part for name, _ in boxes for part in name.split("/")]
    assert arm.landmark_names[-1] in joints and "base" in joints
    ax = fig.axes[0]
    xs, ys, _ = proj3d.proj_transform(*(np.array([c]) for c in tip), ax.M)
    x, y = ax.transData.transform((xs[0], ys[0]))
    half = 4.0 * fig.dpi / 72  # the star: about 8 points across
    star = Bbox.from_extents(x - half, y - half, x + half, y + half)
    for name, box in boxes:
        assert not box.padded(-0.5).overlaps(star), name


def test_seed_arm_keeps_every_joint_label(tmp_path):
    arm, scene = seed_arm(), seed_scene()
    for seq, targets in (
        (_ramp(30, [-20, 15, 20, 5, 0, 0]), [[450.0, -150.0, 250.0]]),
        (_ramp(63, [-20, 5, 10, 5, 3, 0]), None),
    ):
        fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq, targets)
        boxes = _text_boxes(fig)
        _assert_apart(boxes)
        assert set(arm.landmark_names) <= {name.strip() for name, _ in boxes}


def test_the_tool_path_ends_at_the_tool_and_the_arm_is_drawn_along_its_links(tmp_path):
    """A UR5's landmarks list its corner (J4') after the tool point: the figure drew the arm
    in that order, a line from the tool back to the elbow, and its red path followed the
    corner, ending nowhere near the target. The path now ends at the tool point the maker's
    D-H product puts there (the cell's base and 120 mm tool), and each drawn segment of the
    arm is one of its links."""
    from arms import UR5_DH
    from independent_dh import dh_pose

    arm, scene, seq, _ = _ur5_cell()
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq)
    lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
    path = np.column_stack(lines["tool point path"].get_data_3d()).astype(float)
    T = dh_pose(*UR5_DH, seq.states_joint()[-1])
    tool = (T @ [0.0, 0.0, 120.0, 1.0])[:3] + np.array([-150.0, 0.0, 250.0])
    np.testing.assert_allclose(path[-1], tool, atol=1e-6)
    end = np.column_stack(lines["end"].get_data_3d()).astype(float)
    pts = landmark_positions(arm, seq.states_joint()[-1])
    pairs = {frozenset((lk.start, lk.end)) for lk in arm.links}
    index = [int(np.argmin(np.linalg.norm(pts - p, axis=1))) for p in end]
    for a, b in itertools.pairwise(index):
        if np.linalg.norm(pts[a] - pts[b]) > 1e-9:  # two names of one point join no link
            assert frozenset((a, b)) in pairs
    np.testing.assert_allclose(end[-1], tool, atol=1e-6)
