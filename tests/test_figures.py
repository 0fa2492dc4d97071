"""PNG figures: every joint visible with its true angles, welds marked at their commands, labels
upright and inside the canvas, no text over other text."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from armpath.commands import CommandSequence, deg_to_ticks, ticks_to_deg
from armpath.errors import InvalidInputError
from armpath.model.seed_arm import seed_arm
from armpath.scenes import seed_scene
from armpath.trajectory import minimum_snap
from armpath.viz.figures import (
    plot_joint_angles,
    plot_motion_3d,
    plot_tip_deviation,
    plot_trace_3d,
    plot_trace_deviation,
    plot_trajectory,
)
from armpath.viz.workspace_figures import (
    plot_blind_maps,
    plot_face_blindness,
    plot_workspace_sections,
)
from armpath.workspace import VoxelGrid
from armpath.workspace.blindzones import FaceBlindness, PlaneMap

START = deg_to_ticks([0, -90, 0, 0, -90, 0])


def _ramp(n: int, per_command_ticks: list[int]) -> CommandSequence:
    return CommandSequence(START, np.tile(per_command_ticks, (n, 1)))


def _renderer(fig: Figure):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _labels(fig: Figure) -> list[Text]:
    """Every title, axis label, legend text and annotation that is shown (non-empty); tick
    labels are covered by the figure's tight bounding box."""
    texts: list[Text] = []
    texts += fig.texts  # the figure title
    for legend in fig.legends:
        texts += legend.get_texts()
    for ax in fig.axes:
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label]
        if hasattr(ax, "zaxis"):  # 3-D texts know their place only while drawn
            texts.append(ax.zaxis.label)
        else:
            texts += ax.texts
        if ax.get_legend() is not None:
            texts += ax.get_legend().get_texts()
    return [t for t in texts if t.get_visible() and t.get_text().strip()]


def _assert_inside_canvas(fig: Figure) -> None:
    renderer = _renderer(fig)
    canvas = fig.bbox.padded(0.5)
    for text in _labels(fig):
        box = text.get_window_extent(renderer)
        assert canvas.x0 <= box.x0 and box.x1 <= canvas.x1, (text.get_text(), box, canvas)
        assert canvas.y0 <= box.y0 and box.y1 <= canvas.y1, (text.get_text(), box, canvas)
    tight = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)
    assert fig.bbox.padded(1.0).contains(tight.x0, tight.y0)
    assert fig.bbox.padded(1.0).contains(tight.x1, tight.y1)


def _assert_apart(fig: Figure, texts: list[Text]) -> None:
    """No two of ``texts`` overlap on the canvas."""
    renderer = _renderer(fig)
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts if t.get_text()]
    for i, (a, box_a) in enumerate(boxes):
        for b, box_b in boxes[i + 1 :]:
            assert not Bbox.intersection(box_a, box_b), f"{a!r} overlaps {b!r}"


def _suptitle(fig: Figure) -> Text:
    (title,) = [t for t in fig.texts if t.get_text() == fig.get_suptitle()]
    return title


def _data_lines(ax):
    return [line for line in ax.get_lines() if line.get_gid() != "mark"]


def test_joint_figure_shows_every_joint_with_its_commanded_angles(tmp_path):
    # joints 3 and 4 move identically (as in the seed reach): one line used to hide the other
    seq = _ramp(30, [3, 20, 20, 20, -5, 0])
    fig = plot_joint_angles(tmp_path / "j.png", seq, "reach")
    assert (tmp_path / "j.png").stat().st_size > 0
    degs = ticks_to_deg(seq.states())
    assert len(fig.axes) == 6
    for i, ax in enumerate(fig.axes):
        (line,) = _data_lines(ax)  # one line per panel: nothing can cover it
        assert line.get_visible() and line.get_linewidth() > 0
        assert line.get_alpha() in (None, 1.0)
        np.testing.assert_array_equal(line.get_xdata(), np.arange(31))
        np.testing.assert_array_equal(line.get_ydata(), degs[:, i])  # true values, no offsets
        lo, hi = ax.get_ylim()
        assert lo <= degs[:, i].min() and degs[:, i].max() <= hi
        assert ax.get_ylabel() == f"θ{i + 1} [deg]"
    # the constant joint 6 gets a readable range, not a hair-thin one
    lo, hi = fig.axes[5].get_ylim()
    assert hi - lo >= 10.0
    assert fig.axes[-1].get_xlabel().startswith("command")
    _assert_inside_canvas(fig)


def test_weld_marks_sit_at_the_commands_after_which_the_welds_are_reached(tmp_path):
    seq = _ramp(141, [-1, 1, -1, 1, 0, 0])
    visits = [(60, "weld 4"), (71, "weld 2"), (120, "weld 3"), (141, "weld 1")]
    fig = plot_joint_angles(tmp_path / "w.png", seq, "spot welds", marks=visits)
    for ax in fig.axes:
        xs = sorted(line.get_xdata()[0] for line in ax.get_lines() if line.get_gid() == "mark")
        assert xs == [60, 71, 120, 141]
        lo, hi = ax.get_xlim()
        assert lo < 0 and hi > 141  # the last mark is not hidden under the right spine
    top = fig.axes[0]
    labels = {t.get_text(): t.xy[0] for t in top.texts}
    assert labels == {"weld 4": 60, "weld 2": 71, "weld 3": 120, "weld 1": 141}
    _assert_apart(fig, [*top.texts, _suptitle(fig)])
    _assert_inside_canvas(fig)
    with pytest.raises(InvalidInputError, match="outside the sequence"):
        plot_joint_angles(tmp_path / "x.png", seq, marks=[(142, "weld 9")])


def test_spotweld_writes_its_welds_into_the_joint_figure(tmp_path, monkeypatch):
    """``armpath spotweld`` passes each visit's command and weld number to the joint figure."""
    import armpath.cli.tasks as tasks
    import armpath.export as export
    import armpath.viz.figures as figures

    seen = {}

    def fake_joint_angles(path, seq, title="", marks=()):
        seen["marks"] = list(marks)

    monkeypatch.setattr(figures, "plot_joint_angles", fake_joint_angles)
    monkeypatch.setattr(figures, "plot_motion_3d", lambda *a, **k: None)
    monkeypatch.setattr(export, "write_sequence_files", lambda *a, **k: None)
    visit = SimpleNamespace
    result = SimpleNamespace(
        sequence=_ramp(5, [1, 0, 0, 0, 0, 0]),
        n_commands=5,
        max_error_mm=0.01,
        visits=(
            visit(target_index=3, after_command=2),
            visit(target_index=0, after_command=5),
        ),
    )
    folder = SimpleNamespace(file=lambda name: tmp_path / name)
    tasks._write_tour(folder, result, {"targets": [[0, 0, 0]] * 4}, seed_arm(), seed_scene())
    assert seen["marks"] == [(2, "weld 4"), (5, "weld 1")]


def test_3d_views_keep_the_z_label_upright_and_name_the_curve(tmp_path):
    arm, scene = seed_arm(), seed_scene()
    seq = _ramp(12, [10, 5, -5, 0, 5, 0])
    theta = np.linspace(0, 2 * np.pi, 50)
    curve = np.column_stack([210 + 120 * np.cos(theta), 120 * np.sin(theta), 60 + 0 * theta])
    for name, expected in (("seam", "curve (seam)"), ("", "curve")):
        fig = plot_trace_3d(
            tmp_path / "t.png", arm, scene, seq, curve, [(4, 10)], [curve[:5]], curve_name=name
        )
        texts = [t.get_text() for legend in fig.legends for t in legend.get_texts()]
        assert expected in texts and not any("crack" in t for t in texts)
        ax = fig.axes[0]
        _renderer(fig)
        # 90 deg reads bottom to top; matplotlib turned it past 90 (upside down) for this view
        assert ax.zaxis.label.get_rotation() == 90
        assert ax.get_zlabel() == "z [mm]"
        _assert_inside_canvas(fig)
    fig = plot_motion_3d(tmp_path / "m.png", arm, scene, seq, [[20, -200, 120], [300, 0, 50]])
    assert fig.axes[0].zaxis.label.get_rotation() == 90
    assert [t.get_text() for t in fig.axes[0].texts[:2]] == ["1", "2"]  # numbered targets
    _assert_inside_canvas(fig)


def test_deviation_and_tip_figures_label_their_axes_with_units(tmp_path):
    s = np.linspace(0, 800, 400)
    fig = plot_trace_deviation(
        tmp_path / "d.png", s, 0.05 + 0.03 * np.sin(s / 30), 0.1, [(380, 480)], 865.9, "trace"
    )
    ax = fig.axes[0]
    assert "arc length" in ax.get_xlabel() and "[mm]" in ax.get_xlabel()
    assert "[mm]" in ax.get_ylabel()
    _assert_apart(fig, [ax.title, *ax.get_legend().get_texts()])
    _assert_inside_canvas(fig)
    t = np.linspace(0, 8, 300)
    fig = plot_tip_deviation(
        tmp_path / "r.png", [(t, np.abs(np.sin(t)), "smooth"), (t, np.abs(np.cos(t)), "cmds")], "x"
    )
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time [s]" and "[mm]" in ax.get_ylabel()
    smooth, commands = ax.get_lines()
    assert smooth.get_zorder() > commands.get_zorder()  # the reference is not buried
    _assert_apart(fig, [_suptitle(fig), *ax.get_legend().get_texts()])
    _assert_inside_canvas(fig)


def test_trajectory_figure_separates_coinciding_joints(tmp_path):
    waypoints = np.radians(
        [[0, -90, 0, 0, -90, 0], [30, -60, 40, 40, -60, 0], [60, -30, 80, 80, 0, 0]]
    )
    traj = minimum_snap(waypoints, [0.0, 2.0, 4.0])
    fig = plot_trajectory(tmp_path / "tr.png", traj, "minimum-snap trajectory")
    top = fig.axes[0]
    joints = [line for line in top.get_lines() if line.get_label().startswith("joint")]
    assert len(joints) == 6
    # joints 3 and 4 coincide: at most one joint is solid, the others dashed in their own
    # colour, so a line drawn over another leaves it visible between its dashes
    assert sum(line.get_linestyle() == "-" for line in joints) <= 1
    assert len({line.get_color() for line in joints}) == 6
    assert [ax.get_ylabel() for ax in fig.axes][2] == "acceleration [deg/s²]"
    _assert_apart(fig, [_suptitle(fig), *top.get_legend().get_texts()])
    _assert_inside_canvas(fig)


def _plane_map(axes: tuple[str, str]) -> PlaneMap:
    u, v = np.meshgrid(np.arange(-60, 60), np.arange(-60, 60), indexing="ij")
    r = np.hypot(u, v)
    return PlaneMap(np.array([-600.0, -600.0]), 10.0, (r < 55) & (r > 12), axes, 1000)


def test_workspace_maps_keep_their_axis_labels_inside_the_canvas(tmp_path):
    fig = plot_blind_maps(
        tmp_path / "b.png",
        [
            (_plane_map(("y", "z")), "arm plane (y, z)"),
            (_plane_map(("rho", "z")), "about (rho, z)"),
        ],
        "seed arm: reachable fingertip positions and enclosed blind zones",
    )
    xlabels = [ax.get_xlabel() for ax in fig.axes]
    assert xlabels[0] == "y [mm]" and "ρ" in xlabels[1] and "[mm]" in xlabels[1]
    assert all("cm²" in ax.get_title() for ax in fig.axes)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["not reached", "reachable", "blind: enclosed, not reached"]
    _assert_apart(
        fig, [_suptitle(fig), *(ax.title for ax in fig.axes), *fig.legends[0].get_texts()]
    )
    _assert_inside_canvas(fig)

    occupied = np.zeros((20, 20, 20), dtype=bool)
    i, j, k = np.indices(occupied.shape)
    occupied[np.hypot(np.hypot(i - 10, j - 10), k - 10) < 8] = True
    grid = VoxelGrid(np.array([-200.0, -200.0, -200.0]), 20.0, occupied, 1000, 1000)
    fig = plot_workspace_sections(tmp_path / "s.png", grid, np.zeros(3), "puma: 1.2 m^3 reachable")
    assert fig.get_suptitle() == "puma: 1.2 m³ reachable"
    _assert_apart(
        fig, [_suptitle(fig), *(ax.title for ax in fig.axes), *fig.legends[0].get_texts()]
    )
    _assert_inside_canvas(fig)

    face = FaceBlindness(
        "outer",
        np.array([20.0, 90.0, 160.0]),
        20.0,
        1.1,
        np.array([1000.0, 900.0, 800.0]),
        np.array([0.0, 100.0, 800.0]),
        ((), (), ()),
    )
    fig = plot_face_blindness(tmp_path / "f.png", [face], "faces")
    lo, hi = fig.axes[0].get_xlim()
    assert lo < 0 and hi > 100  # the 0 % and 100 % markers are drawn whole
    _assert_inside_canvas(fig)


def test_capsules_and_meshes_are_drawn_where_they_are(tmp_path):
    """The 3-D figures and animations left capsule and mesh obstacles out (the viewer drew
    them); each is drawn now, its drawn points spanning the obstacle's own extent: the
    capsule's segment widened by its radius, the mesh's vertices."""
    import trimesh

    from armpath.scenes import scene_from_dict
    from armpath.viz.figures import draw_obstacles

    trimesh.creation.icosphere(radius=50.0).export(tmp_path / "ball.stl")
    scene = scene_from_dict(
        {
            "name": "parts",
            "obstacles": [
                {"type": "capsule", "name": "bar", "start": [100, 0, 50], "end": [300, 0, 50],
                 "radius": 20},
                {"type": "mesh", "name": "ball", "file": str(tmp_path / "ball.stl"),
                 "translation": [0, 200, 100]},
            ],
        }
    )  # fmt: skip
    fig = Figure()
    ax = fig.add_subplot(projection="3d")
    bar, ball = draw_obstacles(ax, scene)
    np.testing.assert_allclose(bar.min(axis=0), [80, -20, 30], atol=0.5)  # sampled round
    np.testing.assert_allclose(bar.max(axis=0), [320, 20, 70], atol=0.5)
    np.testing.assert_allclose(ball.min(axis=0), [-50, 150, 50], atol=1e-6)
    np.testing.assert_allclose(ball.max(axis=0), [50, 250, 150], atol=1e-6)
    assert len(ax.collections) >= 4  # the capsule's wall and two ends, the mesh's triangles
