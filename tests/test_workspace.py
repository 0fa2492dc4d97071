"""Workspace sampling and dexterous points, against analytic shapes and textbook kinematics."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from armpath.errors import InvalidInputError
from armpath.geometry.world import CollisionWorld
from armpath.ik import complete_solver
from armpath.kinematics import tool_pose
from armpath.model.catalog import BUILTIN_MODELS
from armpath.model.dh import DHRow, dh_arm
from armpath.model.serial_arm import JointKind
from armpath.scenes import seed_scene
from armpath.workspace import GridSpec, joint_ranges, sample_workspace
from armpath.workspace.dexterous import dexterity, orientation_grid
from armpath.workspace.sampling import joint_samples, reach_bound
from independent_dh import dh_pose

ARMPATH = [sys.executable, "-m", "armpath"]


def _shell_arm(r_in: float, r_out: float):
    """Two revolute joints that point a prismatic joint in every direction: the tool point
    sweeps the spherical shell r_in <= |p| <= r_out around the base."""
    rows = [
        DHRow(a=0.0, alpha=-np.pi / 2, d=0.0),
        DHRow(a=0.0, alpha=np.pi / 2, d=0.0),
        DHRow(a=0.0, alpha=0.0, d=0.0, kind=JointKind.PRISMATIC, limits=(r_in, r_out)),
    ]
    return dh_arm(rows, "standard", name="shell")


def test_spherical_shell_voxels_match_the_analytic_shell():
    r_in, r_out, voxel = 200.0, 500.0, 25.0
    grid = sample_workspace(_shell_arm(r_in, r_out), 3_000_000, voxel, seed=1)
    all_voxels = np.ones_like(grid.occupied)
    rho = np.linalg.norm(grid.centers(all_voxels), axis=1).reshape(grid.occupied.shape)
    half_diag = voxel * np.sqrt(3.0) / 2.0
    surely_in = (rho > r_in + half_diag) & (rho < r_out - half_diag)
    surely_out = (rho < r_in - half_diag) | (rho > r_out + half_diag)
    assert surely_in.sum() > 20_000
    assert grid.occupied[surely_in].all()  # every voxel well inside the shell is reached
    assert not grid.occupied[surely_out].any()  # and none well outside
    exact = 4.0 / 3.0 * np.pi * (r_out**3 - r_in**3)
    assert surely_in.sum() * voxel**3 < grid.volume < (~surely_out).sum() * voxel**3
    assert abs(grid.volume / exact - 1.0) < 0.12
    # boundary voxels lie near the two spheres
    rb = np.linalg.norm(grid.centers(grid.boundary()), axis=1)
    assert np.all((np.abs(rb - r_in) < 2 * voxel) | (np.abs(rb - r_out) < 2 * voxel))
    section, extent = grid.section("z", 0.0)
    assert section.any() and extent[0] < -r_out and extent[1] > r_out


def test_voxels_agree_with_textbook_forward_kinematics():
    """The same joint samples through the textbook D-H product mark the same voxels."""
    rng = np.random.default_rng(3)
    a, d = rng.uniform(-300, 300, 6), rng.uniform(-300, 300, 6)
    alpha = rng.uniform(-np.pi, np.pi, 6)
    limits = [(-2.0, 2.5), (-1.0, 1.0), (-3.0, 0.5), (-np.pi, np.pi), (0.0, 2.0), (-1.0, 1.0)]
    arm = dh_arm(
        [DHRow(a=a[i], alpha=alpha[i], d=d[i], limits=limits[i]) for i in range(6)], "standard"
    )
    n, voxel = 20_000, 30.0
    grid = sample_workspace(arm, n, voxel, seed=5, chunk=n)
    q = joint_samples(joint_ranges(arm), n, np.random.default_rng(5), "uniform")
    assert np.allclose(joint_ranges(arm), limits)
    points = np.array([dh_pose(a, alpha, d, qi)[:3, 3] for qi in q])
    spec = GridSpec.for_arm(arm, voxel)
    idx = np.floor((points - spec.origin) / voxel).astype(int)
    truth = np.zeros(spec.shape, dtype=bool)
    truth[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    assert grid.n_occupied == truth.sum() > 1000
    assert np.array_equal(grid.occupied, truth)
    assert grid.contains(points).all()


def test_stratified_samples_fill_every_stratum():
    ranges = np.array([[-1.0, 1.0], [0.0, 700.0], [-np.pi, np.pi]])
    q = joint_samples(ranges, 1000, np.random.default_rng(0), "stratified")
    for j in range(3):
        cell = np.floor((q[:, j] - ranges[j, 0]) / (ranges[j, 1] - ranges[j, 0]) * 1000)
        assert np.array_equal(np.sort(cell), np.arange(1000))


def test_clearance_rule_only_removes_voxels():
    arm = BUILTIN_MODELS["seed"]()
    world: CollisionWorld = seed_scene().world
    free = sample_workspace(arm, 20_000, 20.0, seed=2)
    safe = sample_workspace(arm, 20_000, 20.0, seed=2, world=world)
    q = joint_samples(joint_ranges(arm), 20_000, np.random.default_rng(2), "uniform")
    assert safe.kept == int(np.sum(world.slack(arm, q) >= 0.0)) < 20_000
    assert not (safe.occupied & ~free.occupied).any()
    assert safe.n_occupied < free.n_occupied


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"samples": 0, "voxel": 10.0}, "samples"),
        ({"samples": 10, "voxel": -1.0}, "voxel"),
        ({"samples": 10, "voxel": 0.001}, r"of a 0.001 mm grid .* voxel of at least [0-9.]+ mm\)"),
        ({"samples": 10, "voxel": 10.0, "method": "sobol"}, "sampling method"),
    ],
)
def test_bad_sampling_requests(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        sample_workspace(BUILTIN_MODELS["seed"](), **kwargs)


def test_seed003_point_is_dexterous_in_all_9261_orientations():
    """Seed 003's check: tool tip at (0.7, 0, 0.15) m, fixed angles in [-pi, pi] every 0.1 pi."""
    arm = BUILTIN_MODELS["welder003"]()
    rotations = orientation_grid(0.1 * np.pi)
    result = dexterity(arm, [700.0, 0.0, 150.0], rotations)
    assert result.n_tested == 9261 and result.n_reached == 9261 and result.dexterous
    assert result.solutions.min() >= 1


def _welder_dexterous_truth(p: np.ndarray, margin: float) -> bool | None:
    """Geometry of welder003: the wrist centre sweeps the solid around the circle of radius
    500 mm (axis 2's track) within 700 mm (d3 in [0, 700], joint 2 a full turn), and the tool
    (200 mm) turns freely about it. Dexterous iff the 200 mm sphere around p lies in that solid.
    None when within ``margin`` of the border (a finite orientation grid cannot decide)."""
    u = np.random.default_rng(0).normal(size=(20_000, 3))
    x = p + 200.0 * u / np.linalg.norm(u, axis=1, keepdims=True)
    dist = np.hypot(np.hypot(x[:, 0], x[:, 1]) - 500.0, x[:, 2])
    worst = dist.max()
    if abs(worst - 700.0) < margin:
        return None
    return bool(worst < 700.0)


def test_dexterity_matches_the_welders_geometry():
    arm = BUILTIN_MODELS["welder003"]()
    rotations = orientation_grid(0.25 * np.pi)
    rng = np.random.default_rng(9)
    decided = 0
    for p in rng.uniform([-1300, -1300, -800], [1300, 1300, 800], (40, 3)):
        truth = _welder_dexterous_truth(p, margin=40.0)
        if truth is None:
            continue
        decided += 1
        result = dexterity(arm, p, rotations)
        assert result.dexterous == truth, (p, result.n_reached)
    assert decided >= 25
    # every solution counted is a real one: FK of the within-limits solutions hits the pose
    result = dexterity(arm, [900.0, 0.0, 0.0], rotations)
    assert result.dexterous
    solver = complete_solver(arm)
    assert solver is not None
    T = np.zeros((len(rotations), 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = rotations, [900.0, 0.0, 0.0], 1.0
    out = solver.solve_batch(T)
    for i in range(0, len(rotations), 50):
        for s in out[i].solutions:
            assert np.allclose(tool_pose(arm, s), T[i], atol=1e-6)


def test_cli_workspace_writes_grid_table_and_figure(tmp_path):
    out = tmp_path / "ws"
    proc = subprocess.run(
        [
            *ARMPATH,
            "workspace",
            "--model",
            "welder003",
            "--samples",
            "200000",
            "--voxel",
            "40",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    data = np.load(out / "workspace.npz")
    occupied = data["occupied"]
    volume_m3 = occupied.sum() * float(data["voxel_mm"]) ** 3 / 1e9
    rows = dict(line.split(",")[:2] for line in (out / "workspace.csv").read_text().splitlines())
    assert rows["samples"] == "200000" and rows["voxel"] == "40"
    assert float(rows["volume"]) == pytest.approx(volume_m3, abs=1e-4)
    assert f"{volume_m3:.4f}" in proc.stdout and "m^3" in proc.stdout
    assert (out / "workspace_sections.png").stat().st_size > 10_000
    # welder003 reaches 500 + 700 + 200 mm from axis 1 at most
    assert float(rows["x range"].split("..")[1]) <= 1400 + 40


def test_cli_workspace_bad_input_leaves_nothing(tmp_path):
    out = tmp_path / "ws"
    proc = subprocess.run(
        [*ARMPATH, "workspace", "--samples", "0", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == ["error: --samples must be >= 1, got 0"]
    assert not out.exists()


def test_seed003_torus_dexterous_workspace():
    """The report's second arm (d3 up to 0.3 m): the wrist centre sweeps a solid torus of tube
    radius 300 mm about the 500 mm circle of axis 2, so the tip (200 mm further) is dexterous
    exactly within 100 mm of that circle: a torus of volume 2 pi^2 * 500 * 100^2 mm^3. Monte
    Carlo over the report's half grid of orientations ([0, pi], steps of 0.2 pi) agrees."""
    from armpath.model.catalog import welder003
    from armpath.workspace.dexterous import dexterous_workspace

    rotations = orientation_grid(0.2 * np.pi, 0.0, np.pi)
    assert rotations.shape == (216, 3, 3)
    sample = dexterous_workspace(
        welder003(300.0), 2000, rotations, [-700, -700, -250], [700, 700, 250], seed=4
    )
    p = sample.points
    dist = np.hypot(np.hypot(p[:, 0], p[:, 1]) - 500.0, p[:, 2])
    assert sample.dexterous[dist < 95.0].all()
    assert not sample.dexterous[dist > 130.0].any()
    exact = 2.0 * np.pi**2 * 500.0 * 100.0**2
    assert abs(sample.volume - exact) < 3.0 * sample.standard_error + 0.1 * exact


# --- bounds on the work (issue 17, item 4) ----------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"samples": 200_000_001, "voxel": 10.0}, "joint samples: this would need"),
        ({"samples": 10, "voxel": 10.0, "chunk": 4_000_001}, "samples a chunk"),
        ({"samples": 10, "voxel": 10.0, "chunk": 0}, "chunk must be >= 1"),
        ({"samples": 10, "voxel": 10.0, "seed": -1}, "random seed"),
        ({"samples": 10.5, "voxel": 10.0}, "whole number"),
        ({"samples": 10, "voxel": 1e-300}, "voxels.*an unbounded number"),
    ],
)
def test_sizes_are_refused_before_any_work(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        sample_workspace(BUILTIN_MODELS["seed"](), **kwargs)


def test_voxel_grid_at_its_limit():
    """The seed arm reaches at most AB + BC + CD + DE = 715 mm from joint 1's origin; the grid
    is a cube of ceil(2 (715 + v) / v) voxels a side, at most MAX_GRID_CELLS (368^3 fits,
    369^3 does not): v = 3.91 mm gives 368, v = 3.90 mm gives 369."""
    from armpath.budget import MAX_GRID_CELLS

    arm = BUILTIN_MODELS["seed"]()
    assert reach_bound(arm) == pytest.approx(715.0)
    assert 368**3 <= MAX_GRID_CELLS < 369**3
    for voxel, edge in ((3.91, 368), (20.0, 74)):
        assert int(np.ceil(2 * (715.0 + voxel) / voxel)) == edge
        assert GridSpec.for_arm(arm, voxel).shape == (edge, edge, edge)
    with pytest.raises(InvalidInputError, match=r"50,243,409.*change --voxel"):
        GridSpec.for_arm(arm, 3.90, "--voxel")


def test_obstacle_checks_in_batches_keep_the_same_samples(monkeypatch):
    """The clearance rule applied a batch at a time (bounded memory) keeps exactly the samples
    it keeps all at once, counted independently here."""
    import armpath.workspace.sampling as sampling

    arm = BUILTIN_MODELS["seed"]()
    world: CollisionWorld = seed_scene().world
    whole = sample_workspace(arm, 3_000, 20.0, seed=4, world=world)
    monkeypatch.setattr(sampling, "OBSTACLE_BATCH", 7)
    parts = sample_workspace(arm, 3_000, 20.0, seed=4, world=world)
    q = joint_samples(joint_ranges(arm), 3_000, np.random.default_rng(4), "uniform")
    assert parts.kept == whole.kept == int(np.sum(world.slack(arm, q) >= 0.0)) < 3_000
    assert np.array_equal(parts.occupied, whole.occupied)


def test_time_limit_ends_the_sampling():
    import time

    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    with time_limit(0.01), pytest.raises(TimeLimitError, match="sampling the workspace"):
        time.sleep(0.02)
        sample_workspace(BUILTIN_MODELS["seed"](), 1_000_000, 20.0)


def test_orientation_and_dexterity_bounds(monkeypatch):
    """101^3 orientations (step 2 pi / 100) are more than MAX_ORIENTATIONS; dexterity solved in
    batches of 100 poses gives the same counts as in one batch; too many points or poses are
    refused before any IK."""
    import armpath.workspace.dexterous as dex
    from armpath.workspace.dexterous import dexterous_workspace

    with pytest.raises(InvalidInputError, match=r"orientations of the grid.*1,030,301"):
        orientation_grid(2 * np.pi / 100)
    with pytest.raises(InvalidInputError, match="finite step"):
        orientation_grid(float("nan"))
    arm = BUILTIN_MODELS["welder003"]()
    rotations = orientation_grid(0.25 * np.pi)
    assert rotations.shape == (9**3, 3, 3)
    whole = dexterity(arm, [700.0, 0.0, 150.0], rotations)
    monkeypatch.setattr(dex, "POSE_BATCH", 100)
    parts = dexterity(arm, [700.0, 0.0, 150.0], rotations)
    assert np.array_equal(parts.solutions, whole.solutions) and parts.n_reached == 9**3
    box = ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    with pytest.raises(InvalidInputError, match="poses"):
        dexterous_workspace(arm, 1_000_000, rotations, *box)  # 7.3e8 poses
    with pytest.raises(InvalidInputError, match="points held at once"):
        dexterous_workspace(arm, 5_000_000, rotations[:1], *box)


def test_workspace_obstacles_of_another_arm_are_its_own_links_without_a_scene(tmp_path):
    """`workspace --model ur5 --obstacles` kept the UR5's samples clear of the seed scene's
    table and workpiece (placed for the seed arm) although every other command stands another
    arm alone: now the arm alone (its links against each other), as the table says; the seed
    scene only where asked for."""
    from armpath.api import default_scene
    from cli_in_process import run_in_process

    ur5 = BUILTIN_MODELS["ur5"]()
    args = ["workspace", "--model", "ur5", "--obstacles", "--samples", "20000", "--seed", "3"]
    alone = sample_workspace(ur5, 20_000, 20.0, seed=3, world=default_scene("ur5").world)
    in_seed = sample_workspace(ur5, 20_000, 20.0, seed=3, world=seed_scene().world)
    assert alone.kept != in_seed.kept
    for extra, grid, scene in (
        ((), alone, "none (the arm alone)"),
        (
            ("--scene", "seed"),
            in_seed,
            "seed",
        ),
    ):
        r = run_in_process([*args, *extra], tmp_path)
        assert r.returncode == 0, r.stderr
        (row,) = [ln.split() for ln in r.stdout.splitlines() if "kept (clearance rule)" in ln]
        assert row[3] == str(grid.kept) and " ".join(row[4:]) == f"scene: {scene}"
    # a scene's [arm] places the arm (and gives it without --model): the UR5 on its pedestal
    from pathlib import Path

    from armpath.api import arm_and_scene

    cell_file = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
    placed, cell = arm_and_scene(None, cell_file)
    in_cell = sample_workspace(placed, 20_000, 20.0, seed=3, world=cell.world)
    for model in ([], ["--model", "ur5"]):
        r = run_in_process([*args[:1], *model, *args[3:], "--scene", str(cell_file)], tmp_path)
        assert r.returncode == 0, r.stderr
        (row,) = [ln.split() for ln in r.stdout.splitlines() if "kept (clearance rule)" in ln]
        assert row[3] == str(in_cell.kept) and in_cell.kept > 0


def test_a_planar_arms_workspace_is_one_voxel_thick_and_says_so(tmp_path):
    """A planar two-link arm (300 and 200 mm) reaches an annulus in the plane z = 0, which has
    no volume; the table gave 0.0158 m^3 (its voxels') without a word. Now a note says the
    occupied voxels are one layer thick in z, and their count times a voxel's face is the
    annulus' area, pi (500^2 - 100^2) mm^2, within the voxels along its two edges."""
    from arms import planar_two_link_file
    from cli_in_process import run_in_process

    model = planar_two_link_file(tmp_path / "planar2.json")
    out = tmp_path / "ws"
    args = ["workspace", "--model", str(model), "--voxel", "10", "--out", str(out)]
    proc = run_in_process(args, tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = dict(line.split(",")[:2] for line in (out / "workspace.csv").read_text().splitlines())
    assert rows["note"].startswith("one voxel thick in z:")
    occupied = np.load(out / "workspace.npz")["occupied"]
    assert np.count_nonzero(occupied.any(axis=(0, 1))) == 1
    area = np.pi * (500.0**2 - 100.0**2)
    edges = 2.0 * np.pi * (500.0 + 100.0) * 10.0 * np.sqrt(2.0)  # a voxel's diagonal each side
    assert abs(occupied.sum() * 10.0**2 - area) <= edges
    # an arm that fills space gets no such note
    ur5 = run_in_process(["workspace", "--model", "ur5", "--samples", "20000"], tmp_path)
    assert "one voxel thick" not in ur5.stdout
