"""Motions into a hollow workpiece through waypoints in its opening, checked independently.

* the openings of hollow frusta against the SPEC's geometry (the independent workpiece's inner
  radius at the rim);
* the waypoints: the independent forward kinematics put the fingertip next to the sampled
  points in and about the opening, and the independent distances keep the clearance rule;
* ``armpath.plan`` to a point inside the workpiece: two straight motions through a waypoint,
  fewer commands than the search gives for the same goal states, accepted by the independent
  replay (limits, target, clearance of the continuous motion).
"""

import numpy as np
import pytest

import armpath
import independent
import independent_replay as ir
from armpath.commands import deg_to_ticks
from armpath.geometry.primitives import hollow_frustum
from armpath.model.seed_arm import seed_arm
from armpath.planning.motion import plan_motion
from armpath.planning.passages import passage_points, passage_source, passage_waypoints
from armpath.planning.reach import goal_states
from armpath.scenes import scene_from_dict, seed_scene

HOME_DEG = [0, -90, 0, 0, -90, 0]
INSIDE_MM = [190.0, -125.0, 81.98]  # on the inner wall, a spot weld of Task 3


def test_the_openings_of_a_hollow_frustum():
    world = seed_scene().world
    (top,) = world.openings()
    np.testing.assert_allclose(top.center, [210.0, 0.0, 180.0])
    np.testing.assert_allclose(top.normal, [0.0, 0.0, 1.0])
    assert top.radius == pytest.approx(independent.Workpiece().r_in(180.0), abs=1e-9)
    # open at the bottom, closed at the top: the bottom rim, its normal pointing down
    cup = hollow_frustum("cup", [0, 0, 50], 100.0, 60.0, 40.0, 5.0,
                         open_top=False, closed_bottom=False)  # fmt: skip
    (bottom,) = cup.openings()
    np.testing.assert_allclose(bottom.center, [0.0, 0.0, 50.0])
    np.testing.assert_allclose(bottom.normal, [0.0, 0.0, -1.0])
    slope = (60.0 - 40.0) / 100.0
    assert bottom.radius == pytest.approx(60.0 - 5.0 * np.sqrt(1 + slope**2), abs=1e-9)
    table = scene_from_dict(
        {
            "name": "t",
            "obstacles": [
                {"type": "half_space", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1]}
            ],
        }
    )
    assert table.world.openings() == ()
    assert passage_source(seed_arm(), table.world, deg_to_ticks(HOME_DEG)) is None


def test_waypoints_put_the_fingertip_in_the_opening_and_keep_clear():
    world = seed_scene().world
    points = passage_points(world)
    radial = np.hypot(points[:, 0] - 210.0, points[:, 1])
    assert np.all(radial <= 0.95 * independent.Workpiece().r_in(180.0) + 1e-9)
    assert sorted(set(np.round(points[:, 2], 6))) == pytest.approx(
        [180.0 - 0.35 * 87.38373630858479, 180.0, 180.0 + 0.25 * 87.38373630858479]
    )
    states = passage_waypoints(seed_arm(), world, deg_to_ticks(HOME_DEG))
    assert states.shape[0] > 1000
    pick = states[np.linspace(0, states.shape[0] - 1, 400).astype(int)]
    pts = independent.points(pick / 10.0)
    tip = pts[:, -1]
    # rounding to the 0.1 deg lattice moves the fingertip by at most a few mm
    gap = np.linalg.norm(tip[:, None, :] - points[None, :, :], axis=-1).min(axis=1)
    assert gap.max() < 3.0
    samples, is_tip = independent.link_samples(pts)
    wp = independent.Workpiece().distance(samples.reshape(-1, 3)).reshape(samples.shape[:2])
    need = np.where(is_tip, 0.0, 1.0)
    assert np.all(wp >= need - 1e-6)
    assert np.all(samples[..., 2] >= need - 1e-6)  # the table z = 0


@pytest.mark.slow
def test_a_motion_into_the_workpiece_goes_through_a_waypoint():
    arm, world = seed_arm(), seed_scene().world
    start = deg_to_ticks(HOME_DEG)
    goals, _ = goal_states(arm, world, start, INSIDE_MM, 0.05)
    searched = plan_motion(arm, world, start, goals, turn_copies=True)
    via = plan_motion(
        arm, world, start, goals, turn_copies=True, waypoints=passage_source(arm, world, start)
    )
    assert via.method.startswith("direct through a waypoint")
    assert via.sequence.n_commands < searched.sequence.n_commands
    assert via.sequence.n_commands >= via.direct_commands  # the straight motion is blocked
    result = armpath.plan("seed", to_mm=INSIDE_MM)
    assert result.doc["method"] == via.method
    assert result.doc["n_commands"] == via.sequence.n_commands
    rep = ir.replay_result(
        result.doc, truth=ir.Truth(start_deg=HOME_DEG, target=INSIDE_MM, tolerance=0.05)
    )
    assert rep.ok, rep.problems
    # what the tour bound's passage assumes (tests/test_opening_bound.py): the fingertip, from
    # outside the workpiece, enters it across the disc inside its rim
    tip = independent.motion_points(HOME_DEG, result.commands, 20)[:, -1]
    wp = independent.Workpiece()
    radial = np.hypot(tip[:, 0] - 210.0, tip[:, 1])
    assert tip[0, 2] > wp.h or radial[0] > wp.r_out(tip[0, 2])
    down = np.flatnonzero((tip[:-1, 2] > wp.h) & (tip[1:, 2] <= wp.h))
    assert down.size >= 1
    i = down[-1]
    f = (tip[i, 2] - wp.h) / (tip[i, 2] - tip[i + 1, 2])
    crossing = tip[i] + f * (tip[i + 1] - tip[i])
    assert np.hypot(crossing[0] - 210.0, crossing[1]) <= wp.r_in(wp.h) + 1e-6
    # two straight motions: the states lie on two joint-space segments
    states = independent.replay(HOME_DEG, result.commands)
    k = int(np.argmax(_bends(states))) + 1  # the waypoint
    for part in (states[: k + 1], states[k:]):
        if part.shape[0] > 2:
            d = part[-1] - part[0]
            off = (part - part[0]) - np.outer((part - part[0]) @ d / (d @ d), d)
            assert np.abs(off).max() <= 0.15  # within rounding to the ticks of the segment


def _bends(states):
    """How far each interior state lies off the straight line through its neighbours (deg):
    the waypoint is where the direction of motion changes most."""
    mid = (states[:-2] + states[2:]) / 2.0
    return np.abs(states[1:-1] - mid).max(axis=1)
