"""How the viewer draws an arm and names its page: links at their own radius, joint markers
sized by the links they join, the base's axes at the arm's base, the page's title, counts of
commands, and the reach panel's starting target. Regression tests of a review of the viewer
on a UR5 cell (links and the 3 mm tool drawn 120 mm thick, "/base" at the world origin)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armpath.commands import CommandSequence
from armpath.kinematics import tool_position
from armpath.model.seed_arm import seed_arm
from armpath.report import commands_text
from armpath.results import Result
from armpath.scenes import load_scene, scene_from_dict, seed_scene
from armpath.scenes.arm import scene_arm
from armpath.viewer.app import (
    DEFAULT_REACH_TARGET_MM,
    JOINT_MARKER_SCALE,
    MIN_DRAWN_RADIUS_OF_LENGTH,
    ArmViewer,
    base_frame_pose,
    free_port,
    joint_marker_radii,
    reach_target_start_mm,
    replay_html,
    tab_title,
    with_title,
)

UR5_CELL = Path(__file__).resolve().parent.parent / "examples" / "ur5_cell.toml"
MM = 1e-3
SEED_START = np.array([0, -900, 0, 0, -900, 0])


@pytest.fixture(scope="module")
def ur5_viewer():
    scene = load_scene(UR5_CELL)
    viewer = ArmViewer(scene_arm(scene), scene, port=free_port())
    yield viewer
    viewer.stop()


def _drawn_thickness_mm(viewer):
    """Each drawn segment's thickness on the page (mm), in the viewer's drawing order."""
    n = sum(members.size for _, members in viewer._link_groups)
    out = np.full(n, np.nan)
    for handle, members in viewer._link_groups:
        out[members] = handle.thickness / MM
    return out


def _one_command_reach(target_mm=None):
    """A seed-arm reach result of one command (2 deg of joint 1) from SEED_START."""
    arm = seed_arm()
    seq = CommandSequence(SEED_START, np.array([[20, 0, 0, 0, 0, 0]]), arm.lattice)
    if target_mm is None:
        target_mm = tool_position(arm, seq.states_joint()[-1])
    targets = np.asarray(target_mm, dtype=float).reshape(1, 3)
    return Result("reach", {}, arm, seed_scene(), seq, targets, None)


def test_links_are_drawn_at_their_own_radius_not_the_largest(ur5_viewer):
    """The UR5's links keep their radii (60, 50, 45 mm; the base 75 mm) and the 3 mm tool is
    drawn at the least radius, 1.25 % of the arm's length (16 mm), not inside 120 mm tubes."""
    arm = ur5_viewer.arm
    radius_of = {lk.name: lk.radius for lk in arm.links}
    least = MIN_DRAWN_RADIUS_OF_LENGTH * ur5_viewer._reach_mm
    assert least == pytest.approx(16.41, abs=0.01)
    drawn = [p.link for p in ur5_viewer._parts] + [lk.name for lk in ur5_viewer._base_links]
    expected = np.array([2.0 * max(radius_of[name], least) for name in drawn])
    assert _drawn_thickness_mm(ur5_viewer) == pytest.approx(expected, rel=1e-12)
    by_link = dict(zip(drawn, _drawn_thickness_mm(ur5_viewer), strict=True))
    assert by_link["L2"] == pytest.approx(120.0)
    assert by_link["L5"] == pytest.approx(90.0)
    assert by_link["L0"] == pytest.approx(150.0)
    assert by_link["tool"] == pytest.approx(2.0 * least)  # the tool and its tip alike
    assert by_link["tool"] < 0.4 * by_link["L5"]


def test_the_seed_arm_keeps_its_look():
    """The seed arm's links (radius 0) are all drawn at the least radius: 17.9 mm thick on its
    715 mm of links (18 mm before), its joints 1.15 times that."""
    viewer = ArmViewer(seed_arm(), seed_scene(), port=free_port())
    try:
        thickness = _drawn_thickness_mm(viewer)
        assert thickness.size == 5 and thickness == pytest.approx(17.875)
        scales = np.asarray(viewer._joints.batched_scales) / MM
        assert scales == pytest.approx(JOINT_MARKER_SCALE * 17.875 / 2, rel=1e-6)
    finally:
        viewer.stop()


def test_joint_markers_are_sized_by_the_links_they_join(ur5_viewer):
    arm = ur5_viewer.arm
    length = ur5_viewer._reach_mm
    least = MIN_DRAWN_RADIUS_OF_LENGTH * length
    radii = joint_marker_radii(arm, length)
    assert np.asarray(ur5_viewer._joints.batched_scales) == pytest.approx(radii * MM, rel=1e-6)
    named = dict(zip([lm.name for lm in arm.landmarks], radii, strict=True))
    # the tool's end joins the tool only; the last wrist joint the 45 mm wrist and the tool
    assert named["TCP"] == pytest.approx(JOINT_MARKER_SCALE * least)
    assert named["J6"] == pytest.approx(JOINT_MARKER_SCALE * 45.0)
    assert named["J3"] == pytest.approx(JOINT_MARKER_SCALE * 60.0)
    # every marker stands a little proud of each link meeting at it, never 1.3x the largest
    for k, r in enumerate(radii):
        meeting = [max(lk.radius, least) for lk in arm.links if k in (lk.start, lk.end)]
        if meeting:
            assert max(meeting) < r <= JOINT_MARKER_SCALE * max(meeting) + 1e-9


def test_base_axes_sit_at_the_arms_base(ur5_viewer):
    assert np.asarray(ur5_viewer._base_frame.position) == pytest.approx([-0.15, 0.0, 0.25])
    assert np.asarray(ur5_viewer._base_frame.wxyz) == pytest.approx([1.0, 0.0, 0.0, 0.0])
    turned = scene_from_dict(
        {
            "name": "turned",
            "arm": {
                "model": "ur5",
                "base": {"position_mm": [100, -200, 30], "rotation_deg": [0, 0, 90]},
            },
        }
    )
    wxyz, position_m = base_frame_pose(scene_arm(turned))
    assert position_m == pytest.approx([0.1, -0.2, 0.03])
    half = np.sqrt(0.5)
    assert wxyz == pytest.approx([half, 0.0, 0.0, half])


def test_counts_of_one_command_are_singular():
    assert [commands_text(n) for n in (0, 1, 2, 175)] == [
        "0 commands",
        "1 command",
        "2 commands",
        "175 commands",
    ]
    result = _one_command_reach()
    assert result.title() == "reach: 1 command"
    viewer = ArmViewer(result.arm, result.scene, port=free_port(), result=result)
    try:
        assert viewer.replay_info.content == "**reach: 1 command**"
        viewer.set_ticks(SEED_START)
        viewer._on_reach()  # plans to the same target: one command again
        assert viewer._replay is not None and viewer._replay.n_commands == 1
        assert viewer.reach_status.content.startswith("1 command, error ")
        assert viewer.replay_info.content.endswith(" mm: 1 command**")
    finally:
        viewer.stop()


def test_page_title_names_armpath_and_the_replay():
    result = _one_command_reach()
    page = replay_html(result, max_frames=2)
    assert "<title>armpath - reach: 1 command</title>" in page
    assert "<title>Viser</title>" not in page
    assert tab_title("trace: 175 commands") == "armpath - trace: 175 commands"
    assert with_title("<head><title>Viser</title></head>", "a <b> & c") == (
        "<head><title>a &lt;b&gt; &amp; c</title></head>"
    )
    viewer = ArmViewer(result.arm, result.scene, port=free_port(), result=result)
    try:
        assert viewer.page_title == "armpath - reach: 1 command"
        # the live page sets document.title from the markup the viewer sends
        assert "document.title = &quot;armpath - reach: 1 command&quot;" in (
            viewer._title_setter.content
        )
    finally:
        viewer.stop()


def test_reach_panel_starts_at_a_loaded_reachs_target():
    result = _one_command_reach(target_mm=[20.0, -200.0, 120.0])
    assert reach_target_start_mm(result) == (20.0, -200.0, 120.0)
    assert reach_target_start_mm(None) == DEFAULT_REACH_TARGET_MM
    trace_like = Result(
        "trace", {}, result.arm, result.scene, result.sequence, np.zeros((0, 3)), None
    )
    assert reach_target_start_mm(trace_like) == DEFAULT_REACH_TARGET_MM
    # no reach loaded: the scene's own reach task's target where it names one (the seed's)
    assert reach_target_start_mm(trace_like, seed_scene()) == (20.0, -200.0, 120.0)
    assert reach_target_start_mm(None, scene_from_dict({"name": "x"})) == DEFAULT_REACH_TARGET_MM
    viewer = ArmViewer(result.arm, result.scene, port=free_port(), result=result)
    try:
        assert tuple(viewer.target_input.value) == (20.0, -200.0, 120.0)
    finally:
        viewer.stop()
