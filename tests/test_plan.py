"""General collision-free planning in scenes other than the seed scene, replayed independently."""

import json
import subprocess
import sys

import numpy as np
import pytest

import independent
from armpath.commands import deg_to_ticks
from armpath.errors import CollisionError, InvalidInputError, PlanningError, SceneError
from armpath.geometry import CollisionWorld, HalfSpace, Sphere
from armpath.model import seed_arm
from armpath.planning.motion import MotionOptions, Objective, plan_motion
from armpath.planning.rrt import RrtOptions, path_cost, rrt_connect, shortcut
from armpath.scenes import load_scene

ARM = seed_arm()
HOME = [0, -90, 0, 0, -90, 0]
LIMITS = np.array([np.inf, 125, 138, np.inf, 133.5, np.inf])

POST_SCENE = """\
name: post
description: a post and a ball in the way of the direct sweep
obstacles:
  - {type: half_space, name: table, point: [0, 0, 0], normal: [0, 0, 1]}
  - {type: box, name: post, center: [-330, 330, 100], size: [60, 60, 200],
     rotation_deg: [0, 0, 45]}
  - {type: sphere, name: ball, center: [-150, -420, 120], radius: 50}
"""


def box_distance(p, center, half, yaw_deg):
    """Signed distance to a box rotated about z, written from scratch for the checks."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    local = np.abs((p - center) @ R) - half
    return np.linalg.norm(np.maximum(local, 0), axis=-1) + np.minimum(local.max(axis=-1), 0)


@pytest.fixture(scope="module")
def post_scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "post.yaml"
    path.write_text(POST_SCENE)
    return path


def test_yaml_scene_with_primitives(post_scene):
    scene = load_scene(post_scene)
    assert [o.name for o in scene.world.obstacles] == ["table", "post", "ball"]
    box = scene.world.obstacles[1]
    p = np.array([[-330.0, 330.0, 250.0], [-330.0, 330.0, 100.0]])
    np.testing.assert_allclose(
        box.signed_distance(p), box_distance(p, [-330, 330, 100], [30, 30, 100], 45), atol=1e-9
    )


def test_plan_around_a_post_replayed_independently(post_scene):
    proc = subprocess.run(
        [sys.executable, "-m", "armpath", "plan", "--scene", str(post_scene), "--json",
         "--to", "180", "-90", "0", "0", "-90", "0"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    cmds = np.array(doc["commands"])
    assert cmds.dtype.kind == "i" and np.abs(cmds).max() <= 20
    states = independent.replay(HOME, cmds)
    np.testing.assert_allclose(states[-1], [180, -90, 0, 0, -90, 0])
    assert np.all(np.abs(states) <= LIMITS + 1e-9)
    # the straight sweep would hit the post: the plan is a detour, not the direct motion
    direct = independent.motion_points(HOME, [[20, 0, 0, 0, 0, 0]] * 90, 4)
    samples, _ = independent.link_samples(direct, 1.0)
    post = box_distance(samples.reshape(-1, 3), np.array([-330, 330, 100]), [30, 30, 100], 45)
    assert post.min() < 0
    # the plan keeps 1 mm from post, ball and table along its continuous motion
    pts = independent.motion_points(HOME, cmds, 12)
    samples, _ = independent.link_samples(pts, 1.0)
    flat = samples.reshape(-1, 3)
    post = box_distance(flat, np.array([-330, 330, 100]), [30, 30, 100], 45)
    ball = np.linalg.norm(flat - [-150, -420, 120], axis=-1) - 50
    assert min(post.min(), ball.min(), flat[:, 2].min()) >= 1.0
    assert doc["clearance"]["certified"]
    assert doc["n_commands"] >= doc["lower_bound_commands"] == 90
    for key in ("commands", "tip_path_mm", "energy_deg"):
        assert key in doc["metrics"]


def test_plans_are_deterministic_and_objectives_reported(post_scene):
    scene = load_scene(post_scene)
    start = deg_to_ticks(HOME)
    goal = deg_to_ticks([150, -60, 30, 0, -90, 0])[None, :]
    a = plan_motion(ARM, scene.world, start, goal, MotionOptions(seed=3))
    b = plan_motion(ARM, scene.world, start, goal, MotionOptions(seed=3))
    np.testing.assert_array_equal(a.sequence.commands, b.sequence.commands)
    e = plan_motion(ARM, scene.world, start, goal, MotionOptions(objective=Objective.ENERGY))
    travel = np.abs(e.sequence.commands).sum(axis=0) / 10
    assert e.metrics.energy_deg == pytest.approx(travel.sum())
    assert e.clearance.certified_ok and a.clearance.certified_ok


def test_rrt_connect_and_shortcut_on_a_2d_maze():
    """A 2-D configuration space with a wall: the path must go around its end."""

    def clear(a, b):
        a, b = np.atleast_2d(a), np.atleast_2d(b)
        s = np.linspace(0, 1, 200)[None, :, None]
        p = a[:, None] + s * (b - a)[:, None]
        in_wall = (np.abs(p[..., 0]) < 0.1) & (p[..., 1] < 0.5)
        return ~np.any(in_wall, axis=1)

    rng = np.random.default_rng(0)
    start, goal = np.array([-1.0, 0.0]), np.array([1.0, 0.0])
    res = rrt_connect(start, goal[None], np.array([-2.0, -2]), np.array([2.0, 2]), clear, rng)
    assert res.success
    np.testing.assert_allclose(res.path[0], start)
    np.testing.assert_allclose(res.path[-1], goal)
    assert np.all(clear(res.path[:-1], res.path[1:]))
    short = shortcut(res.path, clear, rng)
    assert np.all(clear(short[:-1], short[1:]))
    assert path_cost(short) <= path_cost(res.path) + 1e-12
    # the best path goes over the wall's end at y = 0.5 (largest-change length 2.0)
    assert path_cost(short) < 2.3


def test_planning_errors_are_clear(tmp_path):
    start = deg_to_ticks(HOME)
    with pytest.raises(InvalidInputError, match="objective"):
        MotionOptions(objective="fastest")
    # a goal inside the post
    boxed = CollisionWorld((HalfSpace("table", np.zeros(3), np.array([0, 0, 1.0])),
                            Sphere("cage", np.array([0.0, 510.0, 75.0]), 30.0)))  # fmt: skip
    with pytest.raises(CollisionError, match=r"goal state is in collision: DE.* cage"):
        plan_motion(ARM, boxed, deg_to_ticks([10, -90, 0, 0, -90, 0]), start[None], MotionOptions())
    # two goals, both caged: no search can reach them
    goals = np.stack([start, start + np.array([5, 0, 0, 0, 0, 0])])
    fast = MotionOptions(rrt=RrtOptions(max_samples=200), attempts=1)
    with pytest.raises(PlanningError, match="no collision-free motion"):
        plan_motion(ARM, boxed, deg_to_ticks([40, -90, 0, 0, -90, 0]), goals, fast)
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nobstacles:\n  - {type: pyramid, name: p}\n")
    with pytest.raises(SceneError, match="obstacles"):
        load_scene(bad)
    bad.write_text("name: [unclosed\n")
    with pytest.raises(SceneError, match="YAML"):
        load_scene(bad)
    missing = tmp_path / "mesh.yaml"
    missing.write_text("name: m\nobstacles:\n  - {type: mesh, name: part, file: nowhere.stl}\n")
    with pytest.raises(SceneError, match=r"nowhere\.stl"):
        load_scene(missing)


def test_mesh_obstacle_from_a_scene_file(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=[60, 60, 200]).export(tmp_path / "post.stl")
    (tmp_path / "mesh.toml").write_text(
        'name = "mesh"\n[[obstacles]]\ntype = "mesh"\nname = "post"\nfile = "post.stl"\n'
        "translation = [-330.0, 330.0, 100.0]\nrotation_deg = [0.0, 0.0, 45.0]\n"
    )
    scene = load_scene(tmp_path / "mesh.toml")
    mesh = scene.world.obstacles[0]
    p = np.array([[-330.0, 330.0, 250.0], [-250.0, 330.0, 100.0], [-330.0, 330.0, 150.0]])
    np.testing.assert_allclose(
        mesh.signed_distance(p), box_distance(p, [-330, 330, 100], [30, 30, 100], 45), atol=1e-6
    )


def test_mesh_broad_phase_keeps_the_verdict(tmp_path):
    """Ball, then frustum proxy, then coal: the verdict equals the exact clearances."""
    trimesh = pytest.importorskip("trimesh")
    cone = trimesh.creation.cone(radius=80, height=200, sections=64)
    cone.apply_translation([250, -150, 0])
    from armpath.geometry.mesh import MeshObstacle

    mesh = MeshObstacle.from_trimesh(cone, "cone")
    proxy = mesh.enclosing_solid()
    assert np.all(proxy.signed_distance(cone.vertices) <= 1e-6)  # the proxy contains the mesh
    world = CollisionWorld((HalfSpace("table", np.zeros(3), np.array([0, 0, 1.0])), mesh))
    rng = np.random.default_rng(4)
    lim = np.radians([180, 125, 138, 180, 133.5, 180])
    q = rng.uniform(-lim, lim, (400, 6))
    values, _ = world.pair_clearances(ARM, q)
    for margin in (0.0, 5.0):
        exact = np.all(values - world.required(ARM) >= margin, axis=-1)
        np.testing.assert_array_equal(world.satisfied(ARM, q, margin), exact)
        assert 0.05 < exact.mean() < 0.95


def test_a_searched_motion_does_not_turn_a_joint_round_to_a_copy_of_its_goal():
    """Between two of the UR5 cell's welds the direct motion is blocked, so the motion is
    searched; the goals' whole-turn copies are goals too (a joint that cannot get round the near
    way may reach the copy). The search once reached the copy of a wrist goal 340 deg away and
    took 188 commands where 15 do: the first search now looks only for the goals within half a
    turn of the nearest one. The plan replays on the lattice, reaches its goal and turns no joint
    by more than a half turn."""
    from armpath.scenes.arm import scene_arm
    from test_ur5_cell import CELL

    scene = load_scene(CELL)
    arm = scene_arm(scene)
    start = np.array([1478, -429, 1298, -1790, -365, 0])
    goals = np.array(
        [[1526, -439, 1042, -1446, -659, 0], [1514, -433, 1033, -1414, -621, 0],
         [1519, -438, 1084, -1560, -637, 0], [1505, -425, 1119, -1673, -592, 0]]
    )  # fmt: skip
    plan = plan_motion(arm, scene.world, start, goals, MotionOptions(), turn_copies=True)
    assert plan.method != "direct"
    states = plan.sequence.states()
    assert np.array_equal(states[0], start)
    assert any(np.array_equal(states[-1], g) for g in goals)  # a goal itself, not a copy
    assert np.abs(np.diff(states, axis=0)).max() <= arm.lattice.max_ticks.max()
    assert np.abs(states - start).max() < 1800  # ticks: no joint turned by half a turn
    assert plan.sequence.n_commands <= 30


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_fewest_through_states_is_the_shortest_path_over_the_states(seed):
    """Against brute force over every choice of corners among a sequence's states: straight
    motions between them in as many commands as their largest joint change, allowed where a
    made-up edge test passes them (consecutive states always); with every pair askable, the
    programme finds the optimum, and its motions go through the chosen states only."""
    import itertools

    from armpath.commands import CommandSequence
    from armpath.planning.motion import fewest_through_states

    grid = seed_arm().lattice
    rng = np.random.default_rng(seed)
    steps = rng.integers(-20, 21, size=(11, 6))
    states = np.vstack([np.zeros(6, dtype=np.int64), np.cumsum(steps, axis=0)])
    seq = CommandSequence.from_states(states, grid)
    n = states.shape[0]
    allowed = rng.random((n, n)) < 0.35
    asked = []

    def edges_clear(a, b):
        i = int(np.flatnonzero((grid.nearest_ticks(a[0]) == states).all(axis=1))[0])
        j = int(np.flatnonzero((grid.nearest_ticks(b[0]) == states).all(axis=1))[0])
        asked.append((i, j))
        return np.array([j == i + 1 or bool(allowed[i, j])])

    best = np.inf
    for inner in itertools.product([False, True], repeat=n - 2):
        corners = [0, *[k + 1 for k, on in enumerate(inner) if on], n - 1]
        pairs = list(itertools.pairwise(corners))
        if all(j == i + 1 or allowed[i, j] for i, j in pairs):
            best = min(best, sum(grid.commands_needed(states[j] - states[i]) for i, j in pairs))
    found = fewest_through_states(seq, edges_clear, max_checks=10_000)
    assert found.n_commands == best <= seq.n_commands
    np.testing.assert_array_equal(found.states()[[0, -1]], states[[0, -1]])
    kept = {tuple(s) for s in states}
    corners = [s for s in found.states() if tuple(s) in kept]
    assert len(corners) >= 2
    # no straight motion is asked twice
    assert len(asked) == len(set(asked))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_waypoints_drawn_on_fewest_command_ways(seed):
    """Every waypoint ``fewest_command_waypoints`` draws lies within the seed arm's limits and
    splits the straight motion's commands, counted here as ``ceil(largest change / 20 ticks)``,
    into two parts that need no more together; the draws reach across the whole of that set
    (each joint's extremes near its ends) and keep joint 6, which moves no point of the arm,
    on the straight line."""
    from armpath.planning.motion import fewest_command_waypoints

    rng = np.random.default_rng(seed)
    start = deg_to_ticks(HOME)
    goal = start + rng.integers(-900, 901, 6)
    room = (LIMITS * 10 - 50)[[1, 2, 4]]
    goal[[1, 2, 4]] = np.clip(goal[[1, 2, 4]], -room, room)

    def commands(d):
        return np.ceil(np.abs(d).max(axis=-1) / 20.0).astype(int)

    n = int(commands(goal - start))
    w = fewest_command_waypoints(ARM, start, goal, 4000, np.random.default_rng(seed))
    assert 3000 <= w.shape[0] <= 4000  # a few beyond the limits at most are left out
    assert np.all(np.abs(w[:, [1, 2, 4]] / 10.0) <= LIMITS[[1, 2, 4]])
    two = commands(w - start) + commands(goal - w)
    assert np.all(two == n)  # never more, and no two straight motions need fewer
    # at k commands along, joint j lies within k steps of the start and n - k of the goal;
    # the draws come near both ends of that for the middle k
    k = n // 2
    mid = (commands(w - start) == k) & (commands(goal - w) == n - k)
    lo = np.maximum(start - 20 * k, goal - 20 * (n - k))
    hi = np.minimum(start + 20 * k, goal + 20 * (n - k))
    assert mid.sum() >= 20
    for j in (0, 3):  # joints without limits
        assert w[mid, j].min() <= lo[j] + 0.2 * (hi[j] - lo[j])
        assert w[mid, j].max() >= hi[j] - 0.2 * (hi[j] - lo[j])
    on_line = np.round(start[5] + np.arange(1, n) / n * (goal[5] - start[5]))
    assert np.isin(w[:, 5], on_line).all()
    # one command's way has no waypoint
    assert fewest_command_waypoints(ARM, start, start + 20, 10, rng).shape == (0, 6)
