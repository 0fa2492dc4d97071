"""Collision geometry of any arm: physical links, per-model radii, and the self-collision pairs.

The links are checked against the textbook D-H product (the corners of the ``d`` and ``a``
legs), their clearances against a brute-force sampling of points along the capsules (end points
from ``forward_frames``, not the compiled landmark kernel), and the pair rules on built-in
models, a robot file, a URDF and an arm built by hand with zero-length links.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from armpath.errors import InvalidInputError
from armpath.geometry.primitives import Box, HalfSpace
from armpath.geometry.world import CollisionWorld, SlackGroup, link_analysis
from armpath.kinematics import (
    displacement_bounds,
    forward_frames,
    landmark_positions,
    tool_position,
)
from armpath.model.catalog import BUILTIN_MODELS, puma560, resolve_model, ur5
from armpath.model.dh import load_robot_file, robot_from_dict
from armpath.model.serial_arm import JointKind, Landmark, Link, SerialArm
from armpath.model.urdf import arm_from_urdf
from armpath.workspace import sample_workspace
from arms import scara_rows
from independent_dh import _rx, _rz, _tx, _tz

SELF_ONLY = CollisionWorld(())

# The UR5 as its maker's URDF places the joints (metres), zero pose upright.
UR5_URDF = """<robot name="ur5_urdf">
  <link name="base_link"/><link name="shoulder_link"/><link name="upper_arm_link"/>
  <link name="forearm_link"/><link name="wrist_1_link"/><link name="wrist_2_link"/>
  <link name="wrist_3_link"/><link name="ee_link"/>
  <joint name="shoulder_pan" type="revolute"><parent link="base_link"/>
    <child link="shoulder_link"/><origin xyz="0 0 0.089159" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.28" upper="6.28" effort="1" velocity="1"/></joint>
  <joint name="shoulder_lift" type="revolute"><parent link="shoulder_link"/>
    <child link="upper_arm_link"/><origin xyz="0 0.13585 0" rpy="0 1.570796325 0"/>
    <axis xyz="0 1 0"/><limit lower="-6.28" upper="6.28" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper_arm_link"/>
    <child link="forearm_link"/><origin xyz="0 -0.1197 0.425" rpy="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/></joint>
  <joint name="wrist_1" type="revolute"><parent link="forearm_link"/>
    <child link="wrist_1_link"/><origin xyz="0 0 0.39225" rpy="0 1.570796325 0"/>
    <axis xyz="0 1 0"/><limit lower="-6.28" upper="6.28" effort="1" velocity="1"/></joint>
  <joint name="wrist_2" type="revolute"><parent link="wrist_1_link"/>
    <child link="wrist_2_link"/><origin xyz="0 0.093 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.28" upper="6.28" effort="1" velocity="1"/></joint>
  <joint name="wrist_3" type="continuous"><parent link="wrist_2_link"/>
    <child link="wrist_3_link"/><origin xyz="0 0 0.09465" rpy="0 0 0"/><axis xyz="0 1 0"/>
  </joint>
  <joint name="ee_fixed" type="fixed"><parent link="wrist_3_link"/><child link="ee_link"/>
    <origin xyz="0 0.0823 0" rpy="0 0 1.570796325"/></joint>
</robot>"""
UR5_URDF_RADII = (75.0, 60.0, 60.0, 50.0, 45.0, 45.0, 40.0)

# PUMA 560 as a robot file in metres and radians, modified D-H (Craig's table).
PUMA_MDH_FILE = {
    "name": "puma_mdh",
    "convention": "modified",
    "units": {"length": "m", "angle": "rad"},
    "links": [
        {"a": 0.0, "alpha": 0.0, "d": 0.0},
        {"a": 0.0, "alpha": -np.pi / 2, "d": 0.0},
        {"a": 0.4318, "alpha": 0.0, "d": 0.15005},
        {"a": 0.0203, "alpha": -np.pi / 2, "d": 0.4318},
        {"a": 0.0, "alpha": np.pi / 2, "d": 0.0},
        {"a": 0.0, "alpha": -np.pi / 2, "d": 0.0},
    ],
    "link_radii_mm": [0, 0, 80, 55, 0, 0, 0],
}


@pytest.fixture(scope="module")
def arms(tmp_path_factory):
    """Every built-in model, a URDF and a modified-D-H robot file in m/rad."""
    folder = tmp_path_factory.mktemp("robots")
    (folder / "ur5.urdf").write_text(UR5_URDF)
    (folder / "puma_mdh.json").write_text(json.dumps(PUMA_MDH_FILE))
    out = {name: make() for name, make in BUILTIN_MODELS.items()}
    out["urdf"] = arm_from_urdf(folder / "ur5.urdf", link_radii_mm=UR5_URDF_RADII)
    out["mdh_file"] = load_robot_file(folder / "puma_mdh.json")
    return out


ARM_NAMES = [*BUILTIN_MODELS, "urdf", "mdh_file"]


def _within_limits(arm: SerialArm, count: int, seed: int) -> np.ndarray:
    """Uniform joint vectors inside the limits (a turn for unlimited revolute joints)."""
    rng = np.random.default_rng(seed)
    lo = np.maximum(arm.lower, -np.pi)
    hi = np.minimum(arm.upper, np.pi)
    for k, j in enumerate(arm.joints):
        if j.kind is JointKind.PRISMATIC:
            lo[k], hi[k] = j.limits
    return rng.uniform(lo, hi, (count, arm.n_joints))


def _points_by_frames(arm: SerialArm, q: np.ndarray) -> np.ndarray:
    """Landmarks from ``forward_frames`` and the offsets (not the compiled kernel)."""
    frames = forward_frames(arm, q)  # (..., n + 2, 4, 4)
    out = []
    for lm in arm.landmarks:
        T = frames[..., lm.frame, :, :]
        out.append(T[..., :3, :3] @ np.array(lm.offset) + T[..., :3, 3])
    return np.stack(out, axis=-2)


# ------------------------------------------------------------------------------------------
# The links
# ------------------------------------------------------------------------------------------


def _textbook_chain(a, alpha, d, q, *, pedestal=0.0):
    """Distinct points base -> tip of a standard D-H arm: each row's d leg, then its a leg."""
    pts = [np.array([0.0, 0.0, -pedestal])] if pedestal else []
    T = np.eye(4)
    pts.append(T[:3, 3].copy())
    for i in range(len(a)):
        T = T @ _rz(q[i]) @ _tz(d[i])
        pts.append(T[:3, 3].copy())
        T = T @ _tx(a[i]) @ _rx(alpha[i])
        pts.append(T[:3, 3].copy())
    distinct = [pts[0]]
    for p in pts[1:]:
        if np.linalg.norm(p - distinct[-1]) > 1e-9:
            distinct.append(p)
    return np.array(distinct)


@pytest.mark.parametrize(
    ("make", "a", "alpha", "d", "pedestal"),
    [
        (
            puma560,
            [0, 431.8, 20.32, 0, 0, 0],
            np.radians([90, 0, -90, 90, -90, 0]),
            [0, 0, 150.05, 431.8, 0, 0],
            26.45 * 25.4,
        ),
        (
            ur5,
            [0, -425, -392.25, 0, 0, 0],
            np.radians([90, 0, 0, 90, -90, 0]),
            [89.159, 0, 0, 109.15, 94.65, 82.3],
            0.0,
        ),
    ],
)
def test_links_run_through_the_corners_of_the_dh_legs(make, a, alpha, d, pedestal):
    arm = make()
    for q in _within_limits(arm, 20, seed=1):
        chain = _textbook_chain(a, alpha, d, q, pedestal=pedestal)
        pts = landmark_positions(arm, q)
        ends = np.array([pts[arm.links[0].start]] + [pts[lk.end] for lk in arm.links])
        for lk, nxt in zip(arm.links[:-1], arm.links[1:], strict=True):
            assert lk.end == nxt.start  # one polyline, base to tip
        np.testing.assert_allclose(ends, chain, atol=1e-9)


@pytest.mark.parametrize("name", ARM_NAMES)
def test_no_link_has_zero_length_and_radii_are_the_models(arms, name):
    arm = arms[name]
    q = _within_limits(arm, 200, seed=2)
    pts = _points_by_frames(arm, q)
    for lk in arm.links:
        length = np.linalg.norm(pts[:, lk.end] - pts[:, lk.start], axis=-1)
        assert length.max() > 1e-6, lk.name
    expected = {
        "seed": {"BC": 0.0, "CD": 0.0, "DE": 0.0},
        "puma560": {"L0p": 100.0, "L2a": 80.0, "L2b": 80.0, "L3a": 55.0, "L3b": 55.0},
        "ur5": {"L0": 75.0, "L2": 60.0, "L3a": 50.0, "L3b": 50.0, "L4": 45.0, "L5": 45.0},
        "mdh_file": {"L2a": 80.0, "L2b": 80.0, "L3a": 55.0, "L3b": 55.0},
    }.get(name)
    if expected is not None:
        got = {lk.name: lk.radius for lk in arm.links if lk.name in expected}
        assert got == expected


def test_seed_arm_links_and_pairs_are_unchanged():
    arm = BUILTIN_MODELS["seed"]()
    assert [(lk.name, lk.start, lk.end, lk.radius, lk.checked) for lk in arm.links] == [
        ("AB", 0, 1, 0.0, False),
        ("BC", 1, 2, 0.0, True),
        ("CD", 2, 3, 0.0, True),
        ("DE", 3, 4, 0.0, True),
    ]
    world = CollisionWorld(())
    assert world.self_pairs(arm) == ((0, 2), (0, 3), (1, 3))
    assert [p.name for p in world.parts(arm)] == ["BC", "CD", "DE", "DE tip"]


def test_overridden_link_radii_are_what_the_model_says():
    """--link-radius on the seed arm: its parameters say the radius its links have (stress
    suite: a result claimed link_radius_mm 0 for links of radius 3), and no single radius when
    the links differ."""
    arm = BUILTIN_MODELS["seed"]()
    thick = arm.with_link_radii(3.0)
    assert dict(thick.parameters)["link_radius_mm"] == 3.0
    assert [lk.radius for lk in thick.links] == [3.0] * len(arm.links)
    mixed = arm.with_link_radii([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    assert "link_radius_mm" not in dict(mixed.parameters)
    assert dict(mixed.parameters)["BC_mm"] == 255.0


# ------------------------------------------------------------------------------------------
# The pairs
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ARM_NAMES)
def test_home_and_random_configurations_are_not_spuriously_self_colliding(arms, name):
    arm = arms[name]
    world = CollisionWorld((), self_margin=1.0)
    pairs = world.self_pairs(arm)
    home, _ = world.pair_clearances(arm, arm.home)
    assert np.all(home >= world.self_margin), (name, home)
    values, _ = world.pair_clearances(arm, _within_limits(arm, 3000, seed=3))
    if pairs:
        # every pair keeps its clearance somewhere (none breaks the rule by construction) ...
        assert np.all(values.max(axis=0) >= world.self_margin)
        # ... and most configurations inside the limits are free
        assert np.mean(np.any(values < world.self_margin, axis=1)) < 0.4
    info = link_analysis(arm)
    for i, j in pairs:  # no pair of neighbours, none with a zero-length link
        assert not info.degenerate[i] and not info.degenerate[j]
        assert not set(info.ends(arm.links[i])) & set(info.ends(arm.links[j]))


@pytest.mark.parametrize("name", ARM_NAMES)
def test_self_pair_distances_agree_with_brute_force_sampling(arms, name):
    arm = arms[name]
    pairs = SELF_ONLY.self_pairs(arm)
    if not pairs:
        pytest.skip(f"{name} has no self pair")
    q = _within_limits(arm, 60, seed=4)
    values, lowers = SELF_ONLY.pair_clearances(arm, q)
    pts = _points_by_frames(arm, q)
    t = np.linspace(0.0, 1.0, 151)[:, None]
    for k, (i, j) in enumerate(pairs):
        a, b = arm.links[i], arm.links[j]
        for c in range(len(q)):
            pa = pts[c, a.start] + t * (pts[c, a.end] - pts[c, a.start])
            pb = pts[c, b.start] + t * (pts[c, b.end] - pts[c, b.start])
            brute = np.linalg.norm(pa[:, None] - pb[None], axis=-1).min() - a.radius - b.radius
            spacing = (np.linalg.norm(pa[1] - pa[0]) + np.linalg.norm(pb[1] - pb[0])) / 2
            assert values[c, k] <= brute + 1e-9
            assert brute - values[c, k] <= spacing + 1e-9
            assert lowers[c, k] <= values[c, k]


def test_folded_puma_and_ur5_are_self_colliding():
    world = CollisionWorld(())
    arm = puma560()  # upper arm up, forearm folded back down onto the trunk (joint 3 past 45)
    values, _ = world.pair_clearances(arm, np.radians([0, 90, 90, 0, 0, 0]))
    labels = [p.label for p in world.pairs(arm)]
    assert values[labels.index("L0p - L3b")] < 0.0
    arm = ur5()  # elbow folded flat: the wrist comes back onto the shoulder and the base
    values, _ = world.pair_clearances(arm, np.radians([0, 0, 180, 0, 0, 0]))
    labels = [p.label for p in world.pairs(arm)]
    assert values[labels.index("L2 - L3b")] < -50.0
    assert values[labels.index("L0 - L3a")] < -50.0
    assert not world.satisfied(arm, np.radians([0, 0, 180, 0, 0, 0]))
    assert world.satisfied(arm, arm.home)


def test_rules_on_an_arm_built_with_zero_length_links():
    """PUMA 560 with one capsule per pair of consecutive frame origins (the old D-H links):
    zero-length links are dropped, coincident landmarks merged, short chains skipped."""
    model = puma560()
    n = model.n_joints
    landmarks = tuple(Landmark(f"F{k}", k) for k in range(n + 2))
    links = tuple(Link(f"F{k}F{k + 1}", k, k + 1, 60.0, checked=k > 0) for k in range(n + 1))
    arm = SerialArm("puma-frames", model.joints, model.T_flange_tool, landmarks, links, model.home)
    info = link_analysis(arm)
    # frames 0, 1, 2 are the shoulder and 4, 5, 6, 7 the wrist centre
    assert info.point_of.tolist() == [0, 0, 0, 3, 4, 4, 4, 4]
    assert info.degenerate.tolist() == [True, True, False, False, True, True, True]
    assert [p.name for p in SELF_ONLY.parts(arm)] == ["F2F3", "F3F4", "F3F4 tip"]
    # the two real links share frame 3: no pair is left
    assert SELF_ONLY.self_pairs(arm) == ()
    assert SELF_ONLY.satisfied(arm, _within_limits(arm, 50, seed=5)).all()


def test_short_chains_and_rigid_pairs_are_skipped_by_rule():
    arm = ur5()
    names = {(arm.links[i].name, arm.links[j].name) for i, j in SELF_ONLY.self_pairs(arm)}
    # L3b - L5: joined by L4 (94.65 mm) < 50 + 45 + 1 mm: they overlap at every configuration
    assert ("L3b", "L5") not in names
    assert ("L3a", "L4") in names  # joined by L3b (109.15 mm) > 50 + 45 + 1 mm
    # with a larger self margin the chain rule takes L3a - L4 out too
    wide = CollisionWorld((), self_margin=20.0)
    wide_names = {(arm.links[i].name, arm.links[j].name) for i, j in wide.self_pairs(arm)}
    assert ("L3a", "L4") not in wide_names
    # PUMA: the elbow offset L2b lies on joint 3's axis, rigid with the forearm
    arm = puma560()
    info = link_analysis(arm)
    k = {lk.name: i for i, lk in enumerate(arm.links)}
    assert info.rigid[k["L2b"], k["L3b"]] and not info.rigid[k["L2a"], k["L3b"]]
    names = {(arm.links[i].name, arm.links[j].name) for i, j in SELF_ONLY.self_pairs(arm)}
    assert names == {("L0p", "L2b"), ("L0p", "L3a"), ("L0p", "L3b"), ("L2a", "L3a"), ("L2a", "L3b")}


@pytest.mark.parametrize("name", ARM_NAMES)
def test_displacement_bound_holds_for_every_landmark(arms, name):
    """The planners' certificate: no landmark (corners and pedestal included) moves farther
    than ``sum |dq_i| R_i``."""
    arm = arms[name]
    R = displacement_bounds(arm)
    rng = np.random.default_rng(7)
    q = _within_limits(arm, 2000, seed=7)
    dq = rng.uniform(-0.05, 0.05, q.shape)
    moved = np.linalg.norm(_points_by_frames(arm, q + dq) - _points_by_frames(arm, q), axis=-1)
    assert np.all(moved.max(axis=-1) <= np.abs(dq) @ R + 1e-9)


def test_cli_workspace_with_obstacles_keeps_puma_configurations(tmp_path):
    scene = tmp_path / "cell.toml"
    scene.write_text(
        'name = "puma_cell"\n[[obstacles]]\ntype = "half_space"\nname = "floor"\n'
        "point = [0.0, 0.0, -671.83]\nnormal = [0.0, 0.0, 1.0]\n"
    )
    args = ["--model", "puma560", "--obstacles", "--scene", str(scene), "--samples", "20000"]
    proc = subprocess.run(
        [sys.executable, "-m", "armpath", "workspace", *args, "--chunk", "20000", "--voxel", "40"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    kept = re.search(r"kept[^\d]*(\d+)", proc.stdout)
    assert kept is not None, proc.stdout
    assert int(kept.group(1)) > 0.7 * 20000


def test_workspace_with_obstacles_finds_valid_puma_configurations():
    pedestal = 26.45 * 25.4
    floor = HalfSpace("floor", np.array([0.0, 0.0, -pedestal]), np.array([0.0, 0.0, 1.0]))
    post = Box("post", np.array([500.0, 300.0, -300.0]), np.array([100.0, 100.0, 350.0]))
    world = CollisionWorld((floor, post))
    arm = puma560()
    grid = sample_workspace(arm, 20_000, 40.0, world=world, chunk=20_000)
    assert grid.kept > 0.7 * 20_000
    # what was kept is clear, independently of the verdict's broad phase
    q = _within_limits(arm, 2000, seed=6)
    ok = world.satisfied(arm, q)
    assert 0.7 < ok.mean() < 1.0
    assert np.array_equal(ok, world.slack(arm, q) >= 0)


# ------------------------------------------------------------------------------------------
# Robot files: link radii and limits
# ------------------------------------------------------------------------------------------


def _row(**extra):
    return {"a": 100.0, "alpha": 90.0, "d": 50.0, **extra}


def test_null_limits_mean_an_unlimited_joint(tmp_path):
    doc = {
        "links": [
            _row(limits=None),
            _row(limits=[None, 90]),
            _row(limits=[-45, None]),
            _row(),
            _row(type="prismatic", limits=None),
        ]
    }
    path = tmp_path / "free.json"
    path.write_text(json.dumps(doc))
    arm = load_robot_file(path)
    assert not arm.joints[0].is_limited
    assert arm.lower[1] == -np.inf and arm.upper[1] == pytest.approx(np.pi / 2)
    assert arm.lower[2] == pytest.approx(-np.pi / 4) and arm.upper[2] == np.inf
    assert not arm.joints[3].is_limited and not arm.joints[4].is_limited
    arm.check_limits([10.0, -10.0, 10.0, -50.0, 1e6])  # far past a turn: allowed


def test_link_radii_in_a_robot_file():
    arm = robot_from_dict({"links": [_row(), _row()], "link_radii_mm": 12.5})
    assert {lk.radius for lk in arm.links} == {12.5}
    arm = robot_from_dict({"links": [_row(), _row()], "link_radii_mm": [40, 30, 20]})
    assert {lk.name: lk.radius for lk in arm.links} == {
        "L0": 40.0,
        "L1a": 30.0,
        "L1b": 30.0,
        "L2": 20.0,
    }
    with pytest.raises(InvalidInputError, match="list of 3"):
        robot_from_dict({"links": [_row(), _row()], "link_radii_mm": [1, 2]})
    with pytest.raises(InvalidInputError, match=">= 0"):
        robot_from_dict({"links": [_row()], "link_radii_mm": -1})
    with pytest.raises(InvalidInputError, match="must be a number"):
        robot_from_dict({"links": [_row()], "link_radii_mm": "thick"})


def _scene_world(scene_file: str) -> tuple[SerialArm, CollisionWorld]:
    """The seed scene's, the UR5 cell's, or the seed arm in a world with every obstacle kind of
    closed form (a box turned about z among them)."""
    from pathlib import Path

    from scipy.spatial.transform import Rotation

    from armpath.geometry.primitives import Capsule, Sphere, cylinder
    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm

    root = Path(__file__).resolve().parents[1]
    path = root / "examples" / "ur5_cell.toml" if scene_file == "ur5_cell" else None
    scene = load_scene(path)
    arm, world = scene_arm(scene), scene.world
    if scene_file == "every_kind":
        z = np.array([0.0, 0.0, 1.0])
        turned = Rotation.from_euler("z", 30, degrees=True).as_matrix()
        obstacles = (
            HalfSpace("floor", np.array([0.0, 0.0, -5.0]), z),
            Sphere("ball", np.array([250.0, 100.0, 250.0]), 60.0),
            Capsule("bar", np.array([-300.0, 200.0, 100.0]), np.array([300.0, 250.0, 350.0]), 15),
            Box("crate", np.array([200.0, -200.0, 80.0]), np.array([60.0, 40.0, 80.0]), turned),
            cylinder("post", np.array([-150.0, -150.0, 0.0]), z, 30.0, 300.0),
        )
        world = CollisionWorld(obstacles, tip_exempt=5.0)
    return arm, world


@pytest.mark.parametrize("scene_file", ["seed", "ur5_cell", "every_kind"])
def test_smallest_slacks_equal_the_minimum_of_every_pair(scene_file, monkeypatch):
    """The pruned minimum (broad-phase bounds, exact distances only where they can matter)
    equals the plain minimum over :meth:`pair_clearances` for random configurations, random
    pair masks and ceilings: pruning never changes a value. So does the compiled loop of
    :meth:`CollisionWorld.slack` (with the boxes' axis gaps as a further broad phase), with
    and without a ceiling, and the batched fallback of a world without a table; and the
    compiled loop split between threads gives every value it gives in one."""
    arm, world = _scene_world(scene_file)
    rng = np.random.default_rng(7)
    q = _within_limits(arm, 400, seed=3)
    # some configurations near the home pose too, where most pairs are far apart
    q = np.vstack([q, arm.home + rng.normal(0.0, 0.2, (200, arm.n_joints))])
    values, _ = world.pair_clearances(arm, q)
    slack = values - world.required(arm)
    n_pairs = slack.shape[1]
    assert n_pairs > 10
    checked = 0
    for trial in range(12):
        mask = rng.random(n_pairs) < (1.0 if trial == 0 else 0.5)
        ceiling = np.inf if trial < 3 else rng.normal(20.0, 30.0, q.shape[0])
        (got,) = world.smallest_slacks(arm, q, [(mask, ceiling)])
        want = np.minimum(ceiling, np.min(slack[:, mask], axis=1, initial=np.inf))
        np.testing.assert_array_equal(got, want)
        checked += int(mask.sum())
    assert checked > 6 * n_pairs
    np.testing.assert_array_equal(world.slack(arm, q), np.min(slack, axis=1))
    assert world._table is not None
    fallback = CollisionWorld(world.obstacles, world.margin, world.tip_exempt, world.self_margin)
    fallback.__dict__["_table"] = None  # as for a world with a mesh
    for ceiling in (0.0, 25.0):
        want = np.minimum(np.min(slack, axis=1), ceiling)
        np.testing.assert_array_equal(world.slack(arm, q, ceiling), want)
        np.testing.assert_array_equal(fallback.slack(arm, q, ceiling), want)
    assert 0.1 < np.mean(np.min(slack, axis=1) < 0.0) < 0.9  # colliding and clear both met
    # with a floor: exact above it, between the true value and the floor at or below it
    every = np.ones(n_pairs, dtype=bool)
    true = np.min(slack, axis=1)
    for floor in (np.median(true), rng.normal(np.median(true), 20.0, q.shape[0])):
        # the compiled loop and the batched version may stop at different values below floors
        for w in (world, fallback):
            (got,) = w.smallest_slacks(arm, q, [SlackGroup(every, np.inf, floor)])
            above = true > floor
            np.testing.assert_array_equal(got[above], true[above])
            assert np.all(got[~above] >= true[~above]) and np.all(
                got[~above] <= np.broadcast_to(floor, got.shape)[~above]
            )
            assert np.any(~above) and np.any(got[~above] > true[~above])  # work was skipped
    # several groups in one call (the compiled loop measures a pair once for all of them)
    masks = [rng.random(n_pairs) < 0.5 for _ in range(3)]
    ceilings = [np.inf, 10.0, rng.normal(20.0, 30.0, q.shape[0])]
    found = world.smallest_slacks(arm, q, list(zip(masks, ceilings, strict=True)))
    for got, mask, ceiling in zip(found, masks, ceilings, strict=True):
        want = np.minimum(ceiling, np.min(slack[:, mask], axis=1, initial=np.inf))
        np.testing.assert_array_equal(got, want)
    # the same batch split between threads (as where a core is free), with floors too
    import armpath.jit

    groups = [*zip(masks, ceilings, strict=True), SlackGroup(every, np.inf, floor)]
    monkeypatch.setattr(armpath.jit, "threads_pay_off", lambda n, threshold: False)
    serial = world.smallest_slacks(arm, q, groups)
    monkeypatch.setattr(armpath.jit, "threads_pay_off", lambda n, threshold: True)
    monkeypatch.setattr(armpath.jit.os, "cpu_count", lambda: 3)  # uneven slices
    threaded = world.smallest_slacks(arm, q, groups)
    for got, want in zip(threaded, serial, strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(threaded[0], found[0])


@pytest.mark.parametrize("scene_file", ["seed", "ur5_cell", "every_kind"])
def test_compiled_segment_check_equals_satisfied_at_every_sample(scene_file):
    """The compiled edge test's verdict equals :meth:`CollisionWorld.satisfied` at every sample
    of every segment (independent: all samples, no early exit, no coarse-to-fine order), for
    the seed scene, the UR5 cell and a world with every obstacle kind of closed form, with and
    without extra clearance; and the batched fallback (no table) agrees too."""
    arm, world = _scene_world(scene_file)
    assert world._table is not None
    rng = np.random.default_rng(5)
    a = np.vstack(
        [_within_limits(arm, 300, seed=9), arm.home + rng.normal(0.0, 0.1, (150, arm.n_joints))]
    )
    b = a + rng.normal(0.0, 0.25, a.shape)
    counts = (
        np.maximum(np.ceil((np.abs(b - a) @ displacement_bounds(arm)) / 3.0), 1).astype(np.int64)
        + 1
    )
    owner = np.repeat(np.arange(a.shape[0]), counts)
    start = np.cumsum(counts) - counts
    frac = (np.arange(owner.size) - start[owner]) / (counts[owner] - 1)
    samples = a[owner] + frac[:, None] * (b - a)[owner]
    for extra in (0.0, 2.0):
        want = np.ones(a.shape[0], dtype=bool)
        want[owner[~world.satisfied(arm, samples, extra)]] = False
        assert 0.1 < want.mean() < 0.95  # both verdicts are met
        got = world.segments_satisfied(arm, a, b, counts, extra, (8, 1))
        np.testing.assert_array_equal(got, want)
        fallback = CollisionWorld(
            world.obstacles, world.margin, world.tip_exempt, world.self_margin
        )
        fallback.__dict__["_table"] = None  # as for a world with a mesh
        np.testing.assert_array_equal(
            fallback.segments_satisfied(arm, a, b, counts, extra, (8, 1)), want
        )


def test_the_ur5_elbow_cannot_fold_past_its_band_whatever_the_other_joints():
    """The elbow's self-collision ranges: every sampled configuration inside them breaks the
    rule whatever the other joints are. The pair behind them, upper arm and forearm
    (``L2 - L3b``), keeps the same clearance whatever the other joints are (a scan of the elbow
    every 0.005 deg at four settings of them), and breaks the rule within 0.2 deg before the
    upper range. The seed arm and the PUMA 560 have none (their joint limits stop them first)."""
    arm = ur5()
    bands = SELF_ONLY.joint_bands(arm)
    assert sorted(bands) == [2] and len(bands[2]) == 2
    rng = np.random.default_rng(7)
    for lo, hi in bands[2]:
        assert np.degrees(hi - lo) > 20.0 and lo < np.radians(180.0) * np.sign(lo + hi) < hi
        q = rng.uniform(arm.lower, arm.upper, size=(400, 6))
        q[:, 2] = rng.uniform(lo, hi, size=400)
        assert not SELF_ONLY.satisfied(arm, q).any()
    first_up = min(lo for lo, hi in bands[2] if lo > 0)
    pair = [p.label for p in SELF_ONLY.pairs(arm)].index("L2 - L3b")
    required = SELF_ONLY.required(arm)[pair]
    slacks = []
    for row in np.vstack([arm.home, rng.uniform(arm.lower, arm.upper, size=(3, 6))]):
        q = np.repeat(row[None, :], 4001, axis=0)
        q[:, 2] = first_up + np.radians(np.arange(4001) * 0.005 - 10.0)
        slacks.append(SELF_ONLY.pair_clearances(arm, q)[0][:, pair] - required)
        fails = slacks[-1] < 0.0
        assert fails[-1]
        assert 0.0 <= np.degrees(first_up - q[int(np.argmax(fails)), 2]) <= 0.2
    assert np.ptp(np.array(slacks), axis=0).max() <= 1e-6
    for name in ("seed", "puma560"):
        assert SELF_ONLY.joint_bands(resolve_model(name)) == {}


def test_a_prismatic_leg_that_retracts_to_nothing_joins_its_neighbours():
    """A SCARA whose quill (joint 3, 0..200 mm) is fully retracted at home: the links on
    either side of the quill's leg then meet at one point (by the textbook D-H product here),
    so checking them against each other put home in self-collision (slack -41 mm with 20 mm
    radii). Only the slide moves them apart, so they now count as neighbours, as links joined
    by a chain shorter than their radii do; every other pair is still checked, and the arm
    plans from home."""
    from armpath.model.dh import dh_arm
    from armpath.planning.motion import MotionOptions, plan_motion

    rows = scara_rows(elbow_limit_rad=2.5)
    home = np.array([0.0, np.radians(30.0), 0.0, 0.0])
    arm = dh_arm(rows, name="scara", link_radii_mm=20.0, home=home)

    def frame_origins(q):  # the textbook standard D-H product, frames 0..4
        T, out = np.eye(4), [np.zeros(3)]
        for row, v in zip(rows, q, strict=True):
            theta, d = (v, row.d) if row.kind is JointKind.REVOLUTE else (row.theta, row.d + v)
            T = T @ _rz(theta) @ _tz(d) @ _tx(row.a) @ _rx(row.alpha)
            out.append(T[:3, 3].copy())
        return np.array(out)

    for q in (home, np.array([0.4, -1.0, 120.0, 2.0])):  # the model is the SCARA's D-H table
        np.testing.assert_allclose(tool_position(arm, q), frame_origins(q)[-1], atol=1e-9)
    names = [lk.name for lk in arm.links]
    quill = next(k for k, lk in enumerate(arm.links) if lk.end == 3)  # its leg ends at frame 3
    before, after = quill - 1, quill + 1
    pts = landmark_positions(arm, home[None])[0]
    gap = np.linalg.norm(pts[arm.links[before].end] - pts[arm.links[after].start])
    assert gap == pytest.approx(0.0, abs=1e-9)  # the neighbours meet at home
    pairs = SELF_ONLY.self_pairs(arm)
    every = {(i, j) for i in range(len(names)) for j in range(i + 2, len(names))}
    assert every - set(pairs) == {(before, after)}
    assert SELF_ONLY.satisfied(arm, home[None])[0]
    # welder003's first and last links also meet where its axis (0..700 mm) retracts, but its
    # wrist moves the last one about whatever the slide: that pair stays checked
    welder = BUILTIN_MODELS["welder003"]()
    (pair,) = SELF_ONLY.self_pairs(welder)
    first, last = (welder.links[k] for k in pair)
    q = np.tile(welder.home, (50, 1))
    q[:, [3, 4, 5]] = np.random.default_rng(5).uniform(-np.pi, np.pi, (50, 3))
    p = landmark_positions(welder, q)
    apart = np.linalg.norm(p[:, last.end] - p[:, first.start], axis=-1)
    assert np.ptp(apart) > 10.0  # the slide held, the pair's ends still move apart
    goal = arm.lattice.to_ticks(np.array([*np.radians([20.0, 10.0]), 50.0, np.pi / 3]), "goal")
    start = arm.lattice.to_ticks(home, "home")
    plan = plan_motion(arm, SELF_ONLY, start, goal[None], MotionOptions())
    assert plan.clearance.certified_ok and plan.sequence.final_ticks.tolist() == goal.tolist()
