"""The tool's collision capsule follows the tool: a torch tilted from the last joint's axis is
one straight leg from the last joint's frame to the tool point. Before, its leg turned at the
point where the torch's approach axis passes nearest the flange, which for a torch tilted 30 deg
and 150 mm out lay 76 mm off the torch, so a ball there put the arm "in collision" with nothing
of it near. Checked against hand-composed transforms of the robot file."""

from __future__ import annotations

import os

import numpy as np
import pytest

URDF = """<robot name="tilted">
  <link name="base"/><link name="a"/><link name="b"/><link name="tcp"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.4 0 0" rpy="0 1.5707963267948966 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="torch" type="fixed"><parent link="b"/><child link="tcp"/>
    <origin xyz="0.04 0 0.15" rpy="0.5235987755982988 0 0"/></joint>
</robot>
"""


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _by_hand(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint 2's origin and the tool point (mm), composing the file's transforms by hand."""
    R1 = _rot_z(q[0])
    j2 = R1 @ np.array([400.0, 0, 0]) + [0, 0, 300.0]
    R2 = R1 @ _rot_y(np.pi / 2) @ _rot_z(q[1])
    return j2, j2 + R2 @ np.array([40.0, 0, 150.0])


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


@pytest.fixture
def tilted(tmp_path):
    import armpath

    path = tmp_path / "tilted.urdf"
    path.write_text(URDF, encoding="utf-8")
    return armpath.load_arm(path)


def test_a_tilted_torchs_capsule_runs_straight_from_the_flange_to_its_point(tilted):
    from armpath.kinematics import landmark_positions

    rng = np.random.default_rng(3)
    for q in rng.uniform(-2.5, 2.5, size=(5, 2)):
        pts = landmark_positions(tilted, q)
        j2, tip = _by_hand(q)
        np.testing.assert_allclose(pts[2], j2, atol=1e-9)
        for link in tilted.links:
            if link.end == len(tilted.joints) + 1 or link.start == len(tilted.joints) + 1:
                # the tool's leg: its ends are joint 2's origin and the tool point
                ends = {tuple(np.round(pts[link.start], 9)), tuple(np.round(pts[link.end], 9))}
                assert ends == {tuple(np.round(j2, 9)), tuple(np.round(tip, 9))}
        # every point of the arm beyond joint 2 lies on the torch's straight line
        beyond = [i for i, lm in enumerate(tilted.landmarks) if lm.frame >= 2]
        for i in beyond:
            assert _segment_distance(pts[i], j2, tip) <= 1e-9


def test_a_ball_where_the_tilted_axis_passes_the_flange_is_clear(tilted, tmp_path):
    """The ball sits where the old leg turned (the point of the torch's axis nearest joint 2's
    origin, 5 mm radius): nothing of the arm comes near it."""
    import armpath

    q = np.zeros(2)
    j2, tip = _by_hand(q)
    R2 = _rot_y(np.pi / 2)
    u = R2 @ np.array([0.0, -np.sin(np.pi / 6), np.cos(np.pi / 6)])  # the tool's approach axis
    corner = tip - ((tip - j2) @ u) * u
    assert _segment_distance(corner, j2, tip) > 30.0  # the old corner lay well off the torch
    scene = {
        "name": "ball at the old corner",
        "arm": {"model": str(tmp_path / "tilted.urdf"), "home_deg": [0, 0]},
        "obstacles": [{"type": "sphere", "name": "ball", "center": corner.tolist(), "radius": 5.0}],
    }
    placed = armpath.load_arm(scene=scene)
    torch = next(lk for lk in placed.links if lk.end == len(placed.joints) + 1)
    # one tick of joint 1 moves the torch's point 550 mm * 0.1 deg = 0.96 mm at most
    r = armpath.plan(None, to_deg=[0.1, 0.0], scene=scene)
    least = _segment_distance(corner, j2, tip) - torch.radius - 5.0 - 0.96
    assert r.doc["min_clearance_mm"] >= least


def test_a_new_tool_is_not_reached_through_the_old_tools_corner(tmp_path):
    """An offset gripper along the last joint's axis keeps its two legs (sideways, then along
    it); a scene's tool put on it (50 mm further out) turns at its own corner, as the same
    tool written in the file would, and not at the old gripper's point."""
    import armpath
    from armpath.kinematics import landmark_positions

    path = tmp_path / "offset.urdf"
    path.write_text(URDF.replace(' rpy="0.5235987755982988 0 0"', ""), encoding="utf-8")
    arm = armpath.load_arm(path)
    q = np.array([0.3, -0.7])
    j2, tip = _by_hand(q)  # the file's tool point: no tilt changes where it is
    pts = landmark_positions(arm, q)
    R2 = _rot_z(q[0]) @ _rot_y(np.pi / 2) @ _rot_z(q[1])
    corner = j2 + R2 @ np.array([40.0, 0, 0])
    assert min(np.linalg.norm(p - corner) for p in pts) <= 1e-9  # sideways, then along
    T = np.eye(4)
    T[2, 3] = 50.0
    other = arm.with_tool(T, radius=3.0)
    pts = landmark_positions(other, q)
    new_tip = tip + R2 @ np.array([0, 0, 50.0])
    np.testing.assert_allclose(pts[len(arm.joints) + 1], new_tip, atol=1e-9)
    names = other.landmark_names
    assert "tool" not in names  # the old tool point is gone
    np.testing.assert_allclose(pts[names.index("TCP'")], corner, atol=1e-9)
    for i, lm in enumerate(other.landmarks):
        if lm.frame >= 2:  # on the new tool's L: to the corner, then along the axis
            on = min(
                _segment_distance(pts[i], j2, corner), _segment_distance(pts[i], corner, new_tip)
            )
            assert on <= 1e-9


def test_model_show_says_where_a_urdf_tool_is_and_what_a_scene_tool_is_given_from(tmp_path):
    """``model show`` said the torch was "40 0 150 mm from the flange", but that was from the
    last joint's frame; the URDF's tip link is the flange, and a scene's tool is given from it
    (copying the shown offset into a scene applied it twice)."""
    import subprocess
    import sys

    path = tmp_path / "tilted.urdf"
    path.write_text(URDF, encoding="utf-8")
    shown = subprocess.run(
        [sys.executable, "-m", "armpath", "model", "show", str(path)],
        capture_output=True, text=True, check=True, env={**os.environ, "COLUMNS": "300"},
    ).stdout  # fmt: skip
    assert "tool: 0 0 0 mm from the flange (40 0 150 mm from the last joint's frame" in shown


def test_a_dh_tables_last_a_leg_and_an_offset_gripper_keep_their_turn(tmp_path):
    """A standard D-H table's last row with both a and alpha folds them into the tool's
    transform, so its approach axis is not the last joint's; the skeleton must still turn at
    the end of that a leg (where the independent D-H product puts the last frame's origin),
    not cut across. An offset gripper given as a scene's tool turns as the same gripper in
    the robot file does."""
    from armpath.kinematics import landmark_positions
    from armpath.model.dh import DHRow, dh_arm
    from independent_dh import dh_pose

    limits = (-3.0, 3.0)
    a, alpha, d = [0.0, 400.0, 100.0], [np.pi / 2, 0.0, np.pi / 2], [300.0, 0.0, 0.0]
    rows = [DHRow(a[i], alpha[i], d[i], limits=limits) for i in range(3)]
    tool = np.eye(4)
    tool[2, 3] = 150.0
    arm = dh_arm(rows, "standard", T_flange_tool=tool, link_radii_mm=20)
    q = np.array([0.4, -0.3, 0.9])
    pts = landmark_positions(arm, q)
    turn = dh_pose(a, alpha, d, q)[:3, 3]  # the last frame's origin: the a leg's end
    tip = (dh_pose(a, alpha, d, q) @ [0.0, 0.0, 150.0, 1.0])[:3]
    names = arm.landmark_names
    assert np.linalg.norm(pts[names.index("tool'")] - turn) <= 1e-9
    assert np.linalg.norm(pts[names.index("tool")] - tip) <= 1e-9
    legs = {(names[lk.start], names[lk.end]) for lk in arm.links}
    assert ("tool'", "tool") in legs

    rows = [DHRow(0.0, 0.0, 300.0, limits=limits), DHRow(0.0, np.pi / 2, 0.0, limits=limits),
            DHRow(400.0, 0.0, 0.0, limits=limits)]  # fmt: skip
    gripper = np.eye(4)
    gripper[:3, 3] = [100.0, 0.0, 150.0]
    in_file = dh_arm(rows, "modified", T_flange_tool=gripper, link_radii_mm=20)
    as_scene_tool = dh_arm(rows, "modified", link_radii_mm=20).with_tool(gripper)
    for one in (in_file, as_scene_tool):
        at = landmark_positions(one, q)
        ends = sorted(
            tuple(np.round(at[p], 6)) for lk in one.links[-2:] for p in (lk.start, lk.end)
        )
        first = sorted(tuple(np.round(at[p], 6)) for lk in in_file.links[-2:]
                       for p in (lk.start, lk.end))  # fmt: skip
        assert len(one.links) == len(in_file.links) and ends == first
