"""Issue 18: a UR5 in a welding cell (``examples/ur5_cell.toml``), every task replayed.

The cell: a UR5 standing on a pedestal (base transform), a 120 mm torch (tool transform, radius
3 mm, its last 10 mm bare), a table, a clamp and a hollow conical workpiece. Through the command
line it plans to a point low beside the workpiece, traces the plane section of the workpiece's
outer face, traces a circle in free space and visits four spot welds lifted onto the outer face.

Everything is judged without armpath: the UR5's forward kinematics is the textbook product of
Universal Robots' published D-H table with the base and tool read from the scene file here; the
links are capsules around the D-H legs with the UR5's radii; the obstacles, the clearance along
the continuous motion and the deviation from the curve are ``tests/independent_replay.py``'s;
the seam is the plane-section curve in closed form and the welds are lifted onto the cone here.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import independent_replay as ir

ROOT = Path(__file__).resolve().parents[1]
CELL = ROOT / "examples" / "ur5_cell.toml"
SPEC = tomllib.loads(CELL.read_text(encoding="utf-8"))

# Universal Robots' published D-H parameters of the UR5 (standard convention, mm and rad)
UR5_A = np.array([0.0, -425.0, -392.25, 0.0, 0.0, 0.0])
UR5_D = np.array([89.159, 0.0, 0.0, 109.15, 94.65, 82.3])
UR5_ALPHA = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0])

# Landmarks: 0 the base, 1..6 the D-H frame origins O1..O6 (O6 the flange), 7 the tool point.
# Links are capsules around the D-H legs: the base column (fixed, not checked), the upper arm
# O1-O2, the forearm O2-O3, the wrist legs O3-O4 (d4), O4-O5 (d5), O5-O6 (d6), and the torch.
LINKS = ((0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6), (6, 7))
NAMES = ("column", "upper arm", "forearm", "wrist 1", "wrist 2", "wrist 3", "torch")
UR5_RADII = (75.0, 60.0, 50.0, 50.0, 45.0, 45.0)
# Links at least two apart, except two whose distance no motion can change enough to matter:
# wrist 1 and wrist 3 hang on wrist 2, 94.65 mm long, less than their radii plus the 1 mm self
# margin (50 + 45 + 1); wrist 2 lies on joint 5's axis and the torch on joint 6's axis, at a
# fixed offset from it, so their distance never changes.
SELF_PAIRS = tuple(
    (i, j) for i in range(7) for j in range(i + 2, 7) if (i, j) not in {(3, 5), (4, 6)}
)


def _placement(spec: dict) -> np.ndarray:
    """A ``{position_mm, rotation_deg}`` placement of the scene file (rotations are zero here)."""
    assert spec.get("rotation_deg", [0, 0, 0]) == [0, 0, 0]
    T = np.eye(4)
    T[:3, 3] = spec["position_mm"]
    return T


BASE = _placement(SPEC["arm"]["base"])
TOOL = _placement(SPEC["arm"]["tool"])
TOOL_RADIUS = float(SPEC["arm"]["tool"]["radius_mm"])


def _dh(theta: np.ndarray, i: int) -> np.ndarray:
    """Rz(theta) Tz(d) Tx(a) Rx(alpha) for a batch of angles: ``(N, 4, 4)``."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = math.cos(UR5_ALPHA[i]), math.sin(UR5_ALPHA[i])
    A = np.zeros((len(theta), 4, 4))
    A[:, 0, 0], A[:, 0, 1], A[:, 0, 2], A[:, 0, 3] = ct, -st * ca, st * sa, UR5_A[i] * ct
    A[:, 1, 0], A[:, 1, 1], A[:, 1, 2], A[:, 1, 3] = st, ct * ca, -ct * sa, UR5_A[i] * st
    A[:, 2, 1], A[:, 2, 2], A[:, 2, 3] = sa, ca, UR5_D[i]
    A[:, 3, 3] = 1.0
    return A


def ur5_landmarks(theta_deg: np.ndarray) -> np.ndarray:
    """Base, O1..O6 and the tool point ``(..., 8, 3)`` (mm) for joint angles in degrees."""
    q = np.radians(np.asarray(theta_deg, dtype=float))
    shape = q.shape[:-1]
    q = q.reshape(-1, 6)
    T = np.broadcast_to(BASE, (len(q), 4, 4)).copy()
    out = [T[:, :3, 3].copy()]
    for i in range(6):
        T = T @ _dh(q[:, i], i)
        out.append(T[:, :3, 3].copy())
    out.append((T @ TOOL)[:, :3, 3])
    return np.stack(out, axis=1).reshape(*shape, 8, 3)


def _ur5_arm() -> ir.CapsuleArm:
    leg = np.abs(UR5_A) + np.abs(UR5_D)
    tool_length = float(np.linalg.norm(TOOL[:3, 3]))
    # every point beyond joint i lies within the legs after it (and the torch) of its axis
    reach = np.array([leg[i:].sum() + tool_length for i in range(6)])
    return ir.CapsuleArm(
        landmarks=ur5_landmarks,
        links=LINKS,
        radii=(*UR5_RADII, TOOL_RADIUS),
        checked=(False, True, True, True, True, True, True),
        link_names=NAMES,
        self_pairs=SELF_PAIRS,
        reach_per_joint=reach,
        limits_deg=((-360.0, 360.0),) * 6,
        tip_index=7,
    )


ARM = _ur5_arm()
SCENE = ir.Scene.from_spec(SPEC, CELL.parent)
HOME_DEG = SPEC["arm"]["home_deg"]


def _armpath(args: list[str], cwd: Path) -> dict:
    proc = subprocess.run(
        [sys.executable, "-m", "armpath", *args, "--json"],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def _accepted(doc: dict, truth: ir.Truth) -> ir.Replay:
    rep = ir.replay_result(doc, SCENE, truth, arm=ARM)
    assert rep.ok, rep.problems
    # links at least the margin clear of every obstacle (the torch's bare end may touch)
    body = [c for c in rep.clearance if not c.is_self and " tip - " not in c.label]
    assert min(c.sampled_min + c.required for c in body) >= SCENE.margin - 1e-6
    return rep


def test_the_independent_model_is_the_cells_arm():
    """The replay's UR5 is armpath's (at random states, to 1e-9 mm), so the checks below are
    about the motions, not about two readings of the arm."""
    from armpath.kinematics import landmark_positions
    from armpath.scenes.arm import scene_arm
    from armpath.scenes.load import load_scene

    arm = scene_arm(load_scene(CELL))
    q = np.random.default_rng(18).uniform(-180, 180, (40, 6))
    ours = ur5_landmarks(q)
    theirs = landmark_positions(arm, np.radians(q))
    names = [lm.name for lm in arm.landmarks]
    for k, name in enumerate(["base", "J1", "J3", "J4'", "J4", "J5", "J6", "TCP"]):
        np.testing.assert_allclose(ours[:, k], theirs[:, names.index(name)], atol=1e-9)


def test_plan_to_a_point_low_beside_the_workpiece(tmp_path):
    """From home to 360, 0, 160 mm (above the table, beside the workpiece's wall). The goal
    keeps the elbow on its side of the fold through the upper arm: a goal across it is nearer
    the shorter way round but the elbow would have to go the long way (124 commands when goals
    were ranked so); this one takes 72. The result replays within 0.05 mm and clear, and the
    elbow stays between -163.6 and 163.6 deg at every state."""
    target = [360.0, 0.0, 160.0]
    doc = _armpath(
        ["plan", "--scene", str(CELL), "--to-xyz", *map(str, target)],
        tmp_path,
    )
    rep = _accepted(doc, ir.Truth(start_deg=HOME_DEG, target=target, tolerance=0.05))
    assert rep.facts["error_mm"] <= 0.05
    # a point goal: the direct motion to the goal state it took bounds nothing over the point
    assert doc["lower_bound_commands"] is None
    assert doc["direct_commands"] <= doc["n_commands"] <= 80
    states = np.asarray(HOME_DEG) + np.cumsum(np.asarray(doc["commands"]), axis=0) / 10.0
    assert np.abs(states[:, 2]).max() < 163.6


@pytest.mark.slow
def test_seam_around_the_workpiece(tmp_path):
    """The scene's seam (a tilted plane cutting the cone's outer face): every pass within
    0.1 mm of the closed-form section, links >= 1 mm clear, and the passes with the arcs
    reported as not traced cover the whole seam."""
    doc = _armpath(["trace", "--scene", str(CELL)], tmp_path)
    wp = next(o for o in SPEC["obstacles"] if o["name"] == "workpiece")
    curve_spec = SPEC["tasks"]["trace"]["curve"]
    seam = ir.frustum_section_curve(
        wp["base_center"],
        [0.0, 0.0, 1.0],
        wp["height"],
        wp["r_bottom"],
        wp["r_top"],
        curve_spec["plane_point"],
        curve_spec["plane_normal"],
    )
    rep = _accepted(doc, ir.Truth(start_deg=HOME_DEG, curve=seam, tolerance=0.1))
    assert rep.facts["max_deviation_mm"] <= 0.1
    assert rep.facts["curve_hausdorff_mm"] <= 0.01
    length = float(doc["curve"]["length_mm"])
    traced = sum(abs(p["end_mm"] - p["start_mm"]) for p in doc["pass_details"])
    skipped = sum(a["end_mm"] - a["start_mm"] for a in doc["not_traced"])
    assert traced >= 0.8 * length  # most of the seam is welded
    assert traced + skipped == pytest.approx(length, abs=1.0)
    # one pass; 177 commands before a stalled command along the reference (4 of them crept
    # 0.2-1 mm where joint 1 turns back) was compared with commands turned along the family,
    # 174 before the tracer listed every lattice state the band holds a little farther on
    # (its motion then came 0.005 mm near the workpiece, proven clear at 0.002 mm)
    assert len(doc["passes"]) == 1 and doc["n_commands"] <= 171


def _cell_with_circle(
    tmp_path: Path, name: str, c: tuple[float, float, float], r: float
) -> tuple[Path, ir.DenseCurve]:
    """The cell with a horizontal circle (centre ``c``, radius ``r`` mm) as its trace task,
    written as a parametric curve, and the circle sampled densely for the replay."""
    scene = tmp_path / f"{name}.toml"
    text = CELL.read_text(encoding="utf-8").split("[tasks.reach]")[0]
    scene.write_text(
        text
        + "[tasks.trace.curve]\n"
        + f'type = "parametric"\nname = "{name}"\n'
        + f'x = "{c[0]} + {r} * cos(t)"\ny = "{c[1]} + {r} * sin(t)"\nz = "{c[2]}"\n'
        + f"t = [0, {2 * math.pi!r}]\n",
        encoding="utf-8",
    )
    n = 200_000
    phi = np.linspace(0.0, 2 * math.pi, n + 1)[:-1]
    circle = ir.DenseCurve(
        np.c_[c[0] + r * np.cos(phi), c[1] + r * np.sin(phi), np.full_like(phi, c[2])],
        closed=True,
        allowance=r * (1 - math.cos(math.pi / n)),
    )
    return scene, circle


@pytest.mark.slow
def test_circle_in_free_space(tmp_path):
    """A 40 mm circle above the table beside the workpiece, as a parametric curve: traced
    whole, within 0.1 mm, clear (without the bound: --no-bound leaves it out)."""
    r = 40.0
    scene, circle = _cell_with_circle(tmp_path, "circle", (330.0, -200.0, 150.0), r)
    doc = _armpath(["trace", "--scene", str(scene), "--no-bound"], tmp_path)
    assert doc["lower_bound"] is None and doc["lower_bound_commands"] is None  # as asked
    rep = _accepted(doc, ir.Truth(start_deg=HOME_DEG, curve=circle, tolerance=0.1))
    assert rep.facts["max_deviation_mm"] <= 0.1
    assert doc["not_traced"] == []
    traced = sum(abs(p["end_mm"] - p["start_mm"]) for p in doc["pass_details"])
    assert traced == pytest.approx(2 * math.pi * r, abs=0.5)
    # begun where the family comes nearest the arm: 103 commands (108 from the scan's first point)
    assert doc["n_commands"] <= 105


@pytest.mark.slow
def test_a_circle_round_the_arm_is_traced_in_one_pass(tmp_path):
    """A 450 mm circle round the UR5's base, above everything in the cell: joint 1 turns a
    whole turn, past 180 deg, within its +-360 deg. One pass, accepted by the independent
    replay (Universal Robots' D-H table, the cell's obstacles). Before the reference followed
    the family's members round (they were brought to [-180, 180) deg, and joint 1's jump there
    read as a turn): two passes and 343 commands, 160 of them turning joint 1 back between;
    then, before the direction was chosen with the limits in view, one pass of 360, begun
    after 177 commands turning joint 1 the long way to where the limits let it go round."""
    r = 450.0
    scene, circle = _cell_with_circle(tmp_path, "round", (-150.0, 0.0, 400.0), r)
    doc = _armpath(["trace", "--scene", str(scene), "--no-bound"], tmp_path)
    rep = _accepted(doc, ir.Truth(start_deg=HOME_DEG, curve=circle, tolerance=0.1))
    assert rep.facts["max_deviation_mm"] <= 0.1
    assert len(doc["passes"]) == 1 and doc["not_traced"] == []
    traced = sum(abs(p["end_mm"] - p["start_mm"]) for p in doc["pass_details"])
    assert traced == pytest.approx(2 * math.pi * r, abs=0.5)
    (i, j) = doc["passes"][0]
    joint1 = rep.states_ticks[i : j + 1, 0] / 10.0  # deg
    # round once, one way, within its limits: the tip's azimuth turns 360 deg, joint 1 a little
    # less (349 deg), the pass ending on another member of the family than it began on
    assert np.ptp(joint1) >= 340.0
    assert abs(joint1[-1] - joint1[0]) >= np.ptp(joint1) - 2.0
    assert doc["n_commands"] <= 200  # 187: 6 onto the circle, 181 round it


@pytest.mark.slow
def test_spot_welds_on_the_outer_face(tmp_path):
    """The four welds, given as xy and lifted onto the cone's outer face (here: the outer
    radius falls linearly from r_bottom to r_top over the height), each visited within
    0.05 mm, clear along the whole tour."""
    doc = _armpath(["spotweld", "--scene", str(CELL)], tmp_path)
    wp = next(o for o in SPEC["obstacles"] if o["name"] == "workpiece")
    cx, cy, z0 = wp["base_center"]
    targets = []
    for x, y in SPEC["tasks"]["spotweld"]["points_xy_mm"]:
        rho = math.hypot(x - cx, y - cy)
        z = z0 + (wp["r_bottom"] - rho) * wp["height"] / (wp["r_bottom"] - wp["r_top"])
        targets.append([x, y, z])
    rep = _accepted(doc, ir.Truth(start_deg=HOME_DEG, targets=np.array(targets), tolerance=0.05))
    assert rep.facts["error_mm"] <= 0.05
    assert len(doc["visits"]) == 4
    # goal states chosen together (armpath.planning.tour_guide): 393 commands with each weld's
    # goal states picked nearest the start; planned again with three searches per leg, being
    # far above the goal states' bound (SECOND_LOOK_RATIO): 173 rather than 194; through members
    # keeping 0.5 mm beyond the margin as well as 1.5 mm (tour.GUIDE_BUFFERS_MM): 164 on the
    # machine where that was measured, 175 (legs 116 + 23 + 20 + 16) with the same code and
    # package versions on another (an AVX-512 EPYC): the tour's choices among nearly equal
    # lattice states differ between the two, where exactly was not found. The guide measuring
    # the elbow on the start's side of its fold and searched legs looking for the goals within
    # half a turn first (no wrist turned round to a goal's copy): 131 (76 + 17 + 28 + 10) on
    # the second machine; with members keeping only 0.2 mm beyond the margin tried too: 119
    # (77 + 14 + 18 + 10); through the lattice goal states nearest the guide's members as
    # well as the most accurate ones (tour.GUIDED_NEAREST): 118 (77 + 16 + 16 + 9); the kept
    # legs merged where certified straight motions need fewer commands: 115 (77 + 15 + 15 + 8);
    # the legs' states placed for fewer commands (armpath.planning.tighten): 112 (75 + 9 + 20
    # + 8); the legs through pools of goal states placed so too: 107 (order 1-2-3-4, legs 76 +
    # 13 + 12 + 6, each its direct count), the bound itself. Issue 21 asks for 5 %
    assert doc["lower_bound_commands"] <= doc["n_commands"]
    assert doc["n_commands"] <= 1.05 * doc["lower_bound_commands"]
    # issue 21: every weld's lattice goal states listed (clearance looked at in boxes 32, 16
    # and 8 ticks wide), the bound over them 107 (87 from the family's samples, where the
    # listing ran out of its budget)
    assert "lattice states within the tolerance" in doc["lower_bound"]["method"]
    assert doc["lower_bound"]["sampling"]["lattice_goal_states"] > 5000
    assert doc["lower_bound_commands"] >= 105


@pytest.mark.slow
def test_a_certified_merge_shortens_a_leg_between_two_welds():
    """A searched motion from one weld to another backs off the surface, searches and comes
    back down in parts merged apart; merged across them where a straight motion's continuous
    motion is certified, it needs fewer commands: same ends, every command legal, and the
    independent replay accepts its clearance. Which searched legs the merge shortens depends on
    the search's path, and that on the machine's arithmetic (4 -> 1 on one machine, 3 -> 4 and
    1 -> 4 on an AVX-512 one), so three searched legs are planned and at least one must
    shorten; none may lengthen."""
    from armpath.export import plan_result_dict
    from armpath.planning.motion import MotionOptions, plan_motion
    from armpath.planning.reach import goal_states
    from armpath.scenes.arm import scene_arm
    from armpath.scenes.load import load_scene

    scene = load_scene(CELL)
    arm = scene_arm(scene)
    home = arm.lattice.from_display(HOME_DEG, "home")
    welds = scene.spotweld_targets_mm()
    shortened = 0
    for weld_from, weld_to in [(3, 0), (2, 3), (0, 3)]:
        at_weld = goal_states(arm, scene.world, home, welds[weld_from], 0.05)[0][1]
        to_weld, _ = goal_states(arm, scene.world, home, welds[weld_to], 0.05)
        apart = plan_motion(
            arm, scene.world, at_weld, to_weld, MotionOptions(), turn_copies=True,
            certified_merge=False,
        )  # fmt: skip
        merged = plan_motion(arm, scene.world, at_weld, to_weld, MotionOptions(), turn_copies=True)
        assert "certified merge" not in apart.method
        assert merged.direct_commands <= merged.sequence.n_commands <= apart.sequence.n_commands
        np.testing.assert_array_equal(merged.sequence.start_ticks, apart.sequence.start_ticks)
        np.testing.assert_array_equal(merged.sequence.final_ticks, apart.sequence.final_ticks)
        if "certified merge" not in merged.method:
            continue
        assert merged.sequence.n_commands < apart.sequence.n_commands
        assert np.abs(merged.sequence.commands).max() <= 20
        doc = plan_result_dict(merged, arm, scene, "commands", None, None)
        _accepted(doc, ir.Truth(start_deg=arm.lattice.display(at_weld)))
        shortened += 1
    assert shortened >= 1
