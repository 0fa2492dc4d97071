"""The Python API (issue 19): docs/api.md runs as written; results are the CLI's documents and
replay independently; poses in every accepted form agree; exported trajectories replay to the
commanded states with consistent times and velocities."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import independent
import independent_dh
import independent_replay as ir

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def seed_reach():
    import armpath

    return armpath.reach("seed", [300.0, 100.0, 200.0])


@pytest.mark.slow
def test_docs_api_examples_run(tmp_path, monkeypatch):
    """Every ```python block of docs/api.md, in order, in one namespace, in a scratch folder."""
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 7
    covered = " ".join(blocks)
    for call in (
        "armpath.reach(",
        "armpath.trace(",
        "armpath.plan(",
        "scene=cell",
        ".save(",
        "armpath.load_result(",
        '("wxyz"',
        "joint_trajectory(",
        "armpath.forward_kinematics(",
        "armpath.inverse_kinematics(",
    ):
        assert call in covered, call
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(ROOT / "docs" / "api.md"), "exec"), namespace)
    # what the examples computed, checked independently
    result = namespace["result"]
    tip = independent.points(result.states_deg[-1])[-1]
    assert np.linalg.norm(tip - [300.0, 100.0, 200.0]) <= 0.05
    assert (tmp_path / "reach.json").is_file() and (tmp_path / "reach_joints.png").is_file()
    traced = namespace["traced"]
    rep = ir.replay_result(
        traced.doc,
        ir.Scene.from_spec({"name": "none", "obstacles": []}),
        ir.Truth(
            start_deg=[0, -90, 0, 0, -90, 0],
            curve=ir.polyline_curve(namespace["square"], closed=True),
            tolerance=0.1,
        ),
    )
    assert rep.ok, rep.problems
    assert rep.facts["max_deviation_mm"] <= 0.1


def test_reach_is_the_clis_document_and_replays(seed_reach, tmp_path):
    """The API's document equals ``armpath reach --json`` for the same request, and the
    independent replay accepts it (limits, target, clearance)."""
    cli = subprocess.run(
        [sys.executable, "-m", "armpath", "reach", "300", "100", "200", "--json"],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    )
    assert json.loads(cli.stdout) == seed_reach.doc
    rep = ir.replay_result(
        seed_reach.doc, truth=ir.Truth(start_deg=[0, -90, 0, 0, -90, 0], target=[300, 100, 200])
    )
    assert rep.ok, rep.problems
    states = independent.replay([0, -90, 0, 0, -90, 0], seed_reach.commands)
    np.testing.assert_allclose(seed_reach.states_deg, states, atol=1e-9)
    np.testing.assert_allclose(
        seed_reach.tool_positions_mm, independent.points(states)[:, -1], atol=1e-9
    )


def test_plan_to_a_point_with_a_tool_axis_is_the_clis_document(tmp_path):
    """``armpath.plan`` to a point with a tool-axis rule and ``armpath plan --to-xyz
    --tool-axis`` are one path (the same document); the independent seed kinematics put the
    tool point within the tolerance and the last link within the cone, at the angle reported."""
    import armpath

    api = armpath.plan("seed", to_mm=[300.0, 100.0, 200.0], tool_axis=[0, 0, -1],
                       axis_tolerance_deg=20.0)  # fmt: skip
    cli = subprocess.run(
        [sys.executable, "-m", "armpath", "plan", "--to-xyz", "300", "100", "200",
         "--tool-axis", "0", "0", "-1", "--axis-tolerance", "20", "--json"],
        capture_output=True, text=True, check=True, cwd=tmp_path,
    )  # fmt: skip
    assert json.loads(cli.stdout) == api.doc
    states = independent.replay(api.doc["initial_deg"], api.doc["commands"])
    pts = independent.points(states[-1:])[0]
    assert np.linalg.norm(pts[-1] - [300.0, 100.0, 200.0]) <= 0.05
    axis = (pts[-1] - pts[-2]) / np.linalg.norm(pts[-1] - pts[-2])
    angle = np.degrees(np.arccos(axis @ [0.0, 0.0, -1.0]))
    assert angle <= 20.0
    assert api.doc["tool_orientation"]["angle_deg"] == pytest.approx(angle, abs=1e-6)
    # the table says the rule in words, not its type id ("16.787 deg from the axis cone")
    table = subprocess.run(
        [sys.executable, "-m", "armpath", "plan", "--to-xyz", "300", "100", "200",
         "--tool-axis", "0", "0", "-1", "--axis-tolerance", "20"],
        capture_output=True, text=True, check=True, cwd=tmp_path,
        env={**os.environ, "COLUMNS": "200"},
    ).stdout  # fmt: skip
    assert f"tool axis {angle:.3f} deg from (0, 0, -1) (at most 20 deg)" in table
    with pytest.raises(armpath.errors.InvalidInputError, match="go with to_mm"):
        armpath.plan("seed", to_deg=[0, -90, 0, 0, -90, 0], tool_axis=[0, 0, -1])


def test_saved_result_loads_back_and_views_anywhere(seed_reach, tmp_path):
    import armpath

    path = seed_reach.save(tmp_path / "sub" / "r.json")
    assert json.loads(path.read_text(encoding="utf-8")) == seed_reach.doc
    back = armpath.load_result(path)
    assert back.n_commands == seed_reach.n_commands and back.path == path
    np.testing.assert_array_equal(back.commands, seed_reach.commands)
    assert "n_commands=41" in repr(back) and "lower_bound_commands=41" in repr(back)
    fig = back.plot()
    assert len(fig.axes) == 6


def test_a_result_is_saved_as_the_cli_writes_it_by_its_suffix(seed_reach, tmp_path):
    """``save("r.csv")`` wrote the JSON document into r.csv; a result is now written by its
    suffix as the CLI writes it (the command table of ``armpath reach --out``, byte for byte;
    the workbook's commands sheet the same rows), each row's tool point the independent seed
    kinematics' at its joint values; other suffixes, and a figure's, are refused by name, and
    the command period of a trajectory must be a number."""
    from openpyxl import load_workbook

    from armpath.errors import InvalidInputError

    subprocess.run([sys.executable, "-m", "armpath", "reach", "300", "100", "200", "--out", "o"],
                   capture_output=True, check=True, cwd=tmp_path)  # fmt: skip
    csv = seed_reach.save(tmp_path / "r.csv").read_text(encoding="utf-8")
    assert csv == (tmp_path / "o" / "reach.csv").read_text(encoding="utf-8")
    rows = [line.split(",") for line in csv.splitlines()[1:]]
    assert len(rows) == seed_reach.n_commands == 41
    for row in rows:
        tip = independent.points(np.array([float(v) for v in row[7:13]]))[-1]
        np.testing.assert_allclose([float(v) for v in row[13:16]], tip, atol=1e-5)
    sheet = load_workbook(seed_reach.save(tmp_path / "r.xlsx"))["commands"]
    cells = [[str(c) for c in r] for r in sheet.iter_rows(min_row=2, values_only=True)]
    assert [[float(v) for v in r] for r in cells] == [[float(v) for v in r] for r in rows]
    for call, words in (
        (lambda: seed_reach.save(tmp_path / "r.txt"), "written as .json, .csv, .xlsx"),
        (lambda: seed_reach.plot(tmp_path / "p.txt"), "written as .png, .svg, .pdf"),
        (lambda: seed_reach.joint_trajectory(period_s="0.1"), "must be a number of seconds"),
        (lambda: seed_reach.joint_trajectory(period_s=True), "must be a number of seconds"),
    ):
        with pytest.raises(InvalidInputError, match=words):
            call()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "r.csv", "r.xlsx"]


def test_a_result_is_read_from_and_saved_to_paths_of_files_only(seed_reach, tmp_path):
    """``load_result(5)``, ``load_result(path, scene=5)`` and ``save(5)`` raised TypeError;
    ``save("dir/")`` said a result is written as .json, .csv or .xlsx, "got 'dir'". Each is
    now an InvalidInputError naming the parameter. ``save`` creates missing folders on the
    way, as the CLI's ``--out`` does, and the file it wrote loads back."""
    import armpath
    from armpath.errors import InvalidInputError

    saved = seed_reach.save(tmp_path / "new" / "deeper" / "r.json")
    assert saved == tmp_path / "new" / "deeper" / "r.json"
    assert armpath.load_result(saved).n_commands == seed_reach.n_commands == 41
    folder = "must name a file (a folder and a file name, e.g. results/reach.json), got the folder"
    for call, words in (
        (lambda: armpath.load_result(saved, scene=5), "scene must be a Scene or a scene file"),
        (lambda: armpath.load_result(b"r.json"), "path must be a result file's path"),
        (
            lambda: seed_reach.save(5),
            "path must be a file's path (str or pathlib.Path), got int",
        ),
        (lambda: seed_reach.save(f"{tmp_path}/out/"), f"{folder} '{tmp_path}/out/'"),
        (lambda: seed_reach.save(tmp_path / "new"), f"{folder} '{tmp_path}/new'"),
        (lambda: seed_reach.plot(5), "path must be a file's path"),
        (
            lambda: seed_reach.animate(None),
            "path must be a file's path (str or pathlib.Path), got NoneType",
        ),
    ):
        with pytest.raises(InvalidInputError, match=re.escape(words)):
            call()
    assert not (tmp_path / "out").exists()
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == ["deeper"]
    # a result cut short says where its JSON breaks off (the message stopped at "starting at")
    cut = tmp_path / "cut.json"
    text = saved.read_text()
    cut.write_text(text[: text.index('"task"') + 4])
    with pytest.raises(InvalidInputError, match=re.escape("line 2 column 3 (char 4)")):
        armpath.load_result(cut)


def test_poses_in_every_form_agree():
    from scipy.spatial.transform import Rotation

    from armpath.errors import InvalidInputError
    from armpath.poses import pose_matrix, rotation_matrix

    r = Rotation.from_euler("zyx", [30, -20, 75], degrees=True)
    m = r.as_matrix()
    xyzw = r.as_quat()
    wxyz = np.roll(xyzw, 1)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = m, [1.0, 2.0, 3.0]

    class SE3Like:  # spatialmath's SE3 and SO3 hold their matrix in ``A``
        A = T

    for form in (r, m, T, ("xyzw", xyzw), ("wxyz", wxyz), SE3Like()):
        np.testing.assert_allclose(rotation_matrix(form), m, atol=1e-12)
    np.testing.assert_allclose(pose_matrix(SE3Like())[:3, 3], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(pose_matrix(T)[:3, 3], [1.0, 2.0, 3.0])
    for bad, message in (
        (xyzw, "must say its order"),
        (("wxzy", wxyz), "order must be one of"),
        (("wxyz", 2 * wxyz), "unit length"),
        (m * 2, "orthonormal"),
        (np.diag([1.0, 1.0, -1.0]), "determinant"),
        (np.zeros((2, 2)), "a pose must be"),
    ):
        with pytest.raises(InvalidInputError, match=message):
            rotation_matrix(bad)


def test_a_quaternion_pose_is_reached_within_its_angle():
    """The tool frame of the final state (independent DH product for the UR5) is within the
    angle tolerance of the quaternion asked for, and the tool point within 0.05 mm."""
    from scipy.spatial.transform import Rotation

    import armpath
    from independent_dh import dh_pose

    down = Rotation.from_euler("x", 180, degrees=True)
    posed = armpath.reach(
        "ur5", [400.0, 100.0, 300.0], pose=("xyzw", down.as_quat()), angle_tolerance_deg=2.0
    )
    d = np.pi / 180  # the UR5's standard D-H table (Universal Robots' published values)
    T = dh_pose(
        [0, -425.0, -392.25, 0, 0, 0],
        [90 * d, 0, 0, 90 * d, -90 * d, 0],
        [89.159, 0, 0, 109.15, 94.65, 82.3],
        np.radians(posed.states_deg[-1]),
    )
    assert np.linalg.norm(T[:3, 3] - [400.0, 100.0, 300.0]) <= 0.05
    angle = np.degrees((Rotation.from_matrix(T[:3, :3]) * down.inv()).magnitude())
    assert angle <= 2.0 + 1e-6


def test_joint_trajectory_replays_the_commands(seed_reach):
    """Positions back on the lattice are the commanded states; times strictly increase by the
    period in whole nanoseconds; interior velocities are the central differences and equal the
    mean of the two commands' joint speeds; the ends are at rest."""
    period = 0.037
    msg = seed_reach.joint_trajectory(period_s=period)
    assert msg["joint_names"] == [f"theta{i}" for i in range(1, 7)]
    pts = msg["points"]
    assert len(pts) == seed_reach.n_commands + 1
    pos = np.array([p["positions"] for p in pts])
    ticks = pos / (math.pi / 1800.0)
    start = np.array([0, -900, 0, 0, -900, 0])
    np.testing.assert_allclose(
        ticks, start + np.vstack([0 * start, np.cumsum(seed_reach.commands, 0)]), atol=1e-6
    )
    t_ns = np.array(
        [p["time_from_start"]["sec"] * 10**9 + p["time_from_start"]["nanosec"] for p in pts]
    )
    assert all(0 <= p["time_from_start"]["nanosec"] < 10**9 for p in pts)
    np.testing.assert_array_equal(np.diff(t_ns), round(period * 1e9))
    vel = np.array([p["velocities"] for p in pts])
    speeds = np.diff(pos, axis=0) / period  # each command's joint speed (rad/s)
    np.testing.assert_allclose(vel[1:-1], 0.5 * (speeds[1:] + speeds[:-1]), atol=1e-9)
    assert np.all(vel[0] == 0) and np.all(vel[-1] == 0)


def test_csv_and_steps_exports(seed_reach):
    rows = [line.split(",") for line in seed_reach.export_text("csv", 0.25).splitlines()]
    assert rows[0][0] == "time_s" and rows[0][1] == "theta1_deg"
    values = np.array(rows[1:], dtype=float)
    np.testing.assert_allclose(values[:, 0], 0.25 * np.arange(seed_reach.n_commands + 1))
    np.testing.assert_allclose(values[:, 1:], seed_reach.states_deg, atol=1e-6)
    steps = np.array(
        [
            r.split(",")
            for r in seed_reach.export_text(
                "steps", steps_per_tick=[1, 2, 3, 4, 5, 6]
            ).splitlines()[1:]
        ],
        dtype=float,
    )
    np.testing.assert_array_equal(steps[:, 2:], seed_reach.commands * np.arange(1, 7))
    np.testing.assert_array_equal(steps[:, 0], np.arange(1, seed_reach.n_commands + 1))


def test_cli_export_writes_or_refuses(seed_reach, tmp_path):
    src = seed_reach.save(tmp_path / "reach.json")
    out = tmp_path / "traj.json"
    ok = subprocess.run(
        [
            sys.executable,
            "-m",
            "armpath",
            "export",
            str(src),
            "--format",
            "joint-trajectory",
            "--command-period",
            "0.05",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
    assert json.loads(out.read_text())["points"][2]["time_from_start"] == {
        "sec": 0,
        "nanosec": 100000000,
    }
    for args, message in (
        (["--format", "ros"], "Invalid value for '--format': 'ros'"),  # a usage error: exit 2
        (["--command-period", "0"], "command period must be between"),
        (["--steps-per-tick", "1,2"], "--steps-per-tick"),
        # given with a format that has no steps it was ignored
        (["--steps-per-tick", "0"], "steps per tick (--steps-per-tick) go with the steps format"),
    ):
        bad = subprocess.run(
            [
                sys.executable,
                "-m",
                "armpath",
                "export",
                str(src),
                *args,
                "--out",
                str(tmp_path / "x"),
            ],
            capture_output=True,
            text=True,
        )
        status = 2 if args[0] == "--format" else 1
        assert bad.returncode == status and bad.stderr.startswith("error:")
        assert message in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists()


def test_a_tours_tool_axis_is_the_clis_and_holds_at_each_weld(tmp_path):
    """``armpath.spotweld(..., tool_axis=, axis_tolerance_deg=)`` (the CLI's --tool-axis and
    --axis-tolerance, missing from Python) gives the CLI's document; by the independent seed
    kinematics each weld is reached within the tolerance, its last link within the cone."""
    import armpath

    welds = [[300.0, -50.0, 150.0], [320.0, -50.0, 150.0]]
    api = armpath.spotweld("seed", welds, scene="none", order="given", tool_axis=[0, 0, -1],
                           axis_tolerance_deg=10.0, bound=False, pools=False)  # fmt: skip
    (tmp_path / "w.toml").write_text(f'name = "w"\n[tasks.spotweld]\npoints_mm = {welds}\n')
    cli = subprocess.run(
        [sys.executable, "-m", "armpath", "spotweld", "--scene", "w.toml", "--order", "given",
         "--tool-axis", "0 0 -1", "--axis-tolerance", "10", "--no-bound", "--no-pools",
         "--json"],
        capture_output=True, text=True, check=True, cwd=tmp_path,
    )  # fmt: skip
    cli_doc, api_doc = json.loads(cli.stdout), api.doc
    assert cli_doc["commands"] == api_doc["commands"] and cli_doc["order"] == api_doc["order"]
    states = independent.replay(api_doc["initial_deg"], api_doc["commands"])
    for visit in api_doc["visits"]:
        pts = independent.points(states[visit["after_command"]])
        assert np.linalg.norm(pts[-1] - visit["target"]) <= 0.05
        axis = (pts[-1] - pts[-2]) / np.linalg.norm(pts[-1] - pts[-2])
        assert np.degrees(np.arccos(axis @ [0.0, 0.0, -1.0])) <= 10.0


def test_kinematics_from_python_in_degrees_are_the_clis_and_the_textbooks(tmp_path):
    """``armpath.forward_kinematics`` and ``armpath.inverse_kinematics`` (deg and mm, as the
    other functions; the package had only radian-valued ones in submodules) give the
    documents ``armpath fk --json`` and ``armpath ik --json`` print; the seed arm's tool point
    is the independent seed kinematics', each UR5 solution reproduces its pose by the
    textbook D-H product, and ``near_deg`` turns the angles toward it (-187 deg, not 173)."""
    import armpath
    from arms import UR5_DH
    from independent_dh import dh_pose, pose_residual

    def cli(*args: str) -> dict:
        run = subprocess.run([sys.executable, "-m", "armpath", *args, "--json"],
                             capture_output=True, text=True, check=True, cwd=tmp_path)  # fmt: skip
        return json.loads(run.stdout)

    q = [10.0, -80.0, 30.0, 20.0, -70.0, 5.0]
    doc = armpath.forward_kinematics("seed", q)
    assert doc == cli("fk", *map(str, q))
    np.testing.assert_allclose(doc["tip"], independent.points(np.array(q))[-1], atol=1e-6)
    assert armpath.forward_kinematics("seed", [0, 120, 0, 0, 0, 0])["warnings"] == [
        "part of the arm is below the table (z < 0)"
    ]
    target = np.diag([1.0, -1.0, -1.0, 1.0])
    target[:3, 3] = [400.0, 100.0, 300.0]
    doc = armpath.inverse_kinematics("ur5", pose=target[:3, :3], target_mm=target[:3, 3])
    rows = " ".join(f"{v:.17g}" for v in target.ravel())
    assert doc == cli("ik", "--model", "ur5", "--pose", rows)
    assert doc["count"] == 8 and doc["family_dimension"] == 0
    for sol in doc["solutions"]:
        assert max(pose_residual(dh_pose(*UR5_DH, np.radians(sol)), target)) < 1e-6
    near = [10.0, -80.0, 70.0, -60.0, -90.0, 20.0]
    doc = armpath.inverse_kinematics("ur5", target_mm=[400.0, 100.0, 300.0], near_deg=near)
    assert doc["family_dimension"] == 2 and doc["count"] > 8
    first = np.array(doc["solutions"][0])
    assert np.linalg.norm(dh_pose(*UR5_DH, np.radians(first))[:3, 3] - [400, 100, 300]) < 1e-6
    # each angle is the turn of it nearest near_deg within the +-360 deg limits
    assert np.all(np.abs(first - near) <= 180.0 + 1e-9) and np.all(np.abs(first) <= 360.0)
    assert armpath.inverse_kinematics("seed", target_mm=[4000.0, 0.0, 0.0])["count"] == 0


def test_an_arm_given_as_an_object_is_told_where_the_scene_stands_its_arm():
    """A ``SerialArm`` is used as it is, at its own base; the UR5 cell's [arm] stands its UR5
    on a pedestal, so the object met the pedestal with no word of why. The error now says
    where the scene stands its arm and how to stand it there; placed so, it plans."""
    import armpath
    from armpath.errors import CollisionError
    from armpath.scenes.arm import placement_matrix

    cell = armpath.load_scene(ROOT / "examples" / "ur5_cell.toml")
    ur5 = armpath.load_arm("ur5")
    from armpath.errors import ArmpathWarning

    with (
        pytest.raises(CollisionError, match=r"not at \(-150, 0, 250\) mm where the scene"),
        pytest.warns(ArmpathWarning, match="stands where its own base puts it"),
    ):
        armpath.reach(ur5, [450.0, -150.0, 250.0], scene=cell)
    placed = ur5.placed(placement_matrix(cell.arm_spec.base))
    with pytest.warns(ArmpathWarning, match=r"\('ur5'\) carries another tool, not as"):
        result = armpath.reach(placed, [450.0, -150.0, 250.0], scene=cell)
    np.testing.assert_allclose(result.tool_positions_mm[-1], [450.0, -150.0, 250.0], atol=0.05)


def test_the_reach_bounds_configuration_is_a_whole_joint_state_at_the_target(seed_reach):
    """The bound's configuration listed joints 1-5 of the seed arm's six; it now lists all six
    (joint 6 where it starts), and the independent seed kinematics put its tool point within
    the tolerance of the target."""
    doc = seed_reach.doc
    config = doc["lower_bound"]["configuration_deg"]
    assert len(config) == 6 and config[5] == doc["initial_deg"][5]
    tip = independent.points(np.array(config))[-1]
    assert np.linalg.norm(tip - [300.0, 100.0, 200.0]) <= doc["tolerance_mm"] + 1e-9


def test_a_reach_refused_for_its_lattice_names_the_orientation_rule_it_held():
    """A tool axis held within 0.17 deg (radians meant) was refused as if the position
    tolerance alone were too tight; the message now names the rule and the wider tolerance."""
    import armpath
    from armpath.errors import PlanningError

    with pytest.raises(PlanningError) as caught:
        armpath.reach("ur5", [400, 100, 300], tool_axis=[0, 0, -1], axis_tolerance_deg=0.17)
    text = str(caught.value)
    assert "with the tool axis within 0.17 deg of (0, 0, -1)" in text
    assert "a wider axis tolerance (--axis-tolerance; axis_tolerance_deg=)" in text


def test_api_refuses_bad_input_with_clear_errors():
    import armpath
    from armpath.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match="target_mm must be three"):
        armpath.reach("seed", [1.0, 2.0])
    with pytest.raises(InvalidInputError, match="exactly one goal"):
        armpath.plan("seed")
    with pytest.raises(InvalidInputError, match="objective must be one of"):
        armpath.plan("seed", to_deg=[0, -90, 0, 0, -90, 0], objective="fast")
    with pytest.raises(InvalidInputError, match="welds_mm must be"):
        armpath.spotweld("seed", [[1.0, 2.0]])
    # coordinates beyond 1e9 mm are refused before any work (1e200 used to overflow the
    # nearest-point search into a wrong answer and a warning)
    limit = r"beyond the largest coordinate accepted \(1e\+09 mm\)"
    with pytest.raises(InvalidInputError, match="target_mm: 1e\\+200 mm is " + limit):
        armpath.reach("seed", [1e200, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="to_mm: -2e\\+09 mm is " + limit):
        armpath.plan("seed", to_mm=[0.0, -2e9, 0.0])
    with pytest.raises(InvalidInputError, match="welds_mm: 3e\\+10 mm is " + limit):
        armpath.spotweld("seed", [[100.0, 0.0, 50.0], [0.0, 0.0, 3e10]])
    with pytest.raises(InvalidInputError, match="start_deg"):
        armpath.reach("seed", [300.0, 100.0, 200.0], start_deg=[0.05, -90, 0, 0, -90, 0])


#: A 4x4 pose whose position is not the target's (the target gives the position).
_SHIFTED = np.diag([1.0, -1.0, -1.0, 1.0])
_SHIFTED[:3, 3] = [400.0, 100.0, 250.0]


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda a: a.reach("seed", [300, 100, 200], seed="a"), "seed must be a whole number"),
        (lambda a: a.plan("seed", to_mm=[300, -170, 15], seed=1.5), "seed must be a whole"),
        (lambda a: a.plan("seed", to_mm=[300, -170, 15], seed=None), "seed must be a whole"),
        (lambda a: a.reach("seed", "300,100,200"), "target_mm must be three finite numbers"),
        (lambda a: a.reach("seed", [300 + 1j, 0, 0]), "target_mm must be three finite"),
        (lambda a: a.reach("seed", [300, 100, 200], tolerance_mm="0.1"), "tolerance_mm must be a"),
        (lambda a: a.reach("seed", [300, 100, 200], scene=5), "scene must be a Scene"),
        (lambda a: a.load_scene({"name": "x", "radius": 3}), "scene given as a dict"),
        (lambda a: a.load_arm("ur5", link_radius_mm="3"), "link_radius_mm must be a number"),
        (lambda a: a.trace("seed", [[300, 0, 99], [320, 0, 99]], closed="no"), "closed must be"),
        (lambda a: a.spotweld("seed", bound_samples=2.5), "bound_samples must be a whole"),
        (lambda a: a.plan("seed", to_deg=["a", 0, 0, 0, 0, 0]), "to_deg must be real numbers"),
        # None for a tolerance failed deep in the planners (a TypeError); text that numpy
        # parses ("1") or a complex number (its imaginary part dropped with a ComplexWarning)
        # was taken as joint values, while tolerance_mm="0.1" was refused. (None is the
        # scene's tolerance for reach, trace and spotweld: their scene tasks may give one.)
        (lambda a: a.plan("seed", to_mm=[300, 100, 200], tolerance_mm=None), "tolerance_mm mus"),
        (lambda a: a.trace("seed", tolerance_mm="0.1"), "tolerance_mm must be a number, got '0"),
        (lambda a: a.spotweld("seed", tolerance_mm=True), "tolerance_mm must be a number"),
        (lambda a: a.forward_kinematics("seed", [1j] * 6), r"joints_deg must be real numbers"),
        (lambda a: a.forward_kinematics("seed", ["1"] * 6), r"joints_deg must be real numbers"),
        (lambda a: a.forward_kinematics("seed", [True] * 6), r"joints_deg must be real numbers"),
        (lambda a: a.reach("seed", ["300", "100", "200"]), "target_mm must be three finite"),
        (
            lambda a: a.inverse_kinematics("seed", target_mm=[300, 100, 200], near_deg=[1j] * 6),
            "near_deg must be real numbers",
        ),
        (
            lambda a: a.plan(
                "seed", to_deg=[10, -90, 0, 0, -90, 0], objective="energy", energy_weights="abc"
            ),
            "energy_weights must be real numbers, got 'abc'",
        ),
        (lambda a: a.load_result(5), r"path must be a result file's path \(str or pathlib"),
        (lambda a: a.reach("ur5", [400, 100, 300], pose=_SHIFTED), "is not the target"),
        # a joint state of the wrong shape failed deep inside (an IndexError from the tracer,
        # "needs 6 joint values, got 6" from the reach)
        (
            lambda a: a.trace("seed", [[300, 0, 99], [320, 0, 99]], start_deg=[[0] * 6]),
            r"start_deg must be one joint state: 6 values .* got shape \(1, 6\)",
        ),
        (lambda a: a.plan("seed", to_deg=[[0, -90, 0, 0, -90, 0]]), r"to_deg must be one"),
        (lambda a: a.trace("seed", [["a", "b", "c"], [260, 0, 250]]), "curve must be points"),
        (lambda a: a.trace("seed", [[260, 0, 250]]), r"curve must be .* K >= 2"),
        (lambda a: a.spotweld("seed", [["a", 0, 0]]), "welds_mm must be points"),
        (lambda a: a.spotweld("seed", np.zeros((0, 3))), r"welds_mm must be .* K >= 1"),
        # a tolerance without the rule it qualifies was ignored
        (lambda a: a.reach("seed", [300, 100, 200], axis_tolerance_deg=5), "give tool_axis"),
        (lambda a: a.reach("seed", [300, 100, 200], angle_tolerance_deg=5), "give pose too"),
        (lambda a: a.trace("seed", axis_tolerance_deg=5), "qualifies tool_axis"),
        (lambda a: a.spotweld("seed", tool_axis="norml"), "tool_axis must be 'normal' or a"),
        # a reach's tool axis is a direction: 'normal' was refused as "numbers (mm)"
        (
            lambda a: a.reach("seed", [300, 100, 200], tool_axis="normal"),
            r"tool_axis of a reach or a plan is a direction \(x, y, z\), got 'normal'",
        ),
        (
            lambda a: a.plan("seed", to_mm=[300, 100, 200], tool_axis=[1, "a", 0]),
            r"tool_axis must be three finite numbers \(a direction x, y, z\)",
        ),
        (lambda a: a.trace("seed", tool_axis=[0, 0, 1], axis_tolerance_deg=0), "in \\(0, 180\\]"),
        (lambda a: a.reach("ur5", [400, 100, 300], pose="down"), "a pose must be a 3x3 rotation"),
        (lambda a: a.forward_kinematics("ur5", [1, 2]), "joints_deg must be one joint state: 6"),
        (lambda a: a.forward_kinematics(3, [0] * 6), "arm must be a SerialArm"),
        (lambda a: a.inverse_kinematics("ur5"), "give pose"),
        (lambda a: a.inverse_kinematics("ur5", target_mm=[1, 2, 3], method="x"), "method must"),
        (
            lambda a: a.plan("seed", to_deg=[10, -90, 0, 0, -90, 0], energy_weights=[1] * 6),
            "energy weights go with the energy objective",
        ),
    ],
)
def test_api_refuses_values_of_the_wrong_kind_by_name(call, words):
    """Keyword values of the wrong kind are refused at the boundary, naming the keyword, before
    any work (a seed of "a" used to fail inside numpy after 12 s of planning)."""
    import armpath
    from armpath.errors import InvalidInputError

    with warnings.catch_warnings():  # refused before any work: no warning either
        warnings.simplefilter("error")
        with pytest.raises(InvalidInputError, match=words):
            call(armpath)


def test_float32_joint_values_stay_on_the_lattice():
    """12.3 as float32 is 12.300000190734863, not a whole number of 0.1 deg ticks: joint values
    of a lower precision are read by their shortest decimal, so the plan goes to 12.3 deg."""
    import armpath

    goal = np.array([12.3, -90.1, 0.7, 33.3, -90.9, 0.1], dtype=np.float32)
    result = armpath.plan("seed", to_deg=goal)
    last = np.array(result.doc["initial_deg"]) + np.sum(result.doc["commands"], axis=0) / 10.0
    np.testing.assert_allclose(last, goal.astype(np.float64), atol=1e-6)


def test_the_controllers_period_and_steps_come_from_the_scene_arm(tmp_path):
    """A scene's ``[arm]`` names its controller's command period and motor steps per tick:
    exports take them by default, results and model documents carry them, bad values are
    refused at the boundary."""
    import armpath
    from armpath.errors import InvalidInputError
    from armpath.model.serialize import arm_from_dict, arm_to_dict

    cell = tmp_path / "stepper.toml"
    cell.write_text(
        'name = "stepper cell"\n[arm]\nmodel = "seed"\n'
        "steps_per_tick = [8, 8, 4, 4, 2, 2]\ncommand_period_s = 0.02\n",
        encoding="utf-8",
    )
    result = armpath.reach(None, [300.0, 100.0, 200.0], scene=cell)
    arm = result.arm
    assert arm.command_period_s == 0.02
    assert arm.lattice.steps_per_tick.tolist() == [8, 8, 4, 4, 2, 2]
    lattice = result.doc["model"]["lattice"]
    assert lattice["steps_per_tick"] == [8, 8, 4, 4, 2, 2] and lattice["command_period_s"] == 0.02
    rows = [line.split(",") for line in result.export_text("steps").splitlines()[1:]]
    steps = np.array([r[2:] for r in rows], dtype=int)
    np.testing.assert_array_equal(steps, result.commands * [8, 8, 4, 4, 2, 2])
    times = [p["time_from_start"] for p in result.joint_trajectory()["points"][:3]]
    assert times == [{"sec": 0, "nanosec": k * 20_000_000} for k in range(3)]
    back = arm_from_dict(json.loads(json.dumps(arm_to_dict(arm))))
    assert back.command_period_s == 0.02 and back.lattice.steps_per_tick.tolist() == [
        8,
        8,
        4,
        4,
        2,
        2,
    ]
    # the result file replays with the same controller
    again = armpath.load_result(result.save(tmp_path / "r.json"))
    assert again.export_text("steps") == result.export_text("steps")
    for key, value, message in (
        ("command_period_s", "0", "command period must be between"),
        ("steps_per_tick", "0", "whole numbers in \\[1"),
    ):
        bad = tmp_path / "bad.toml"
        bad.write_text(f'name = "bad"\n[arm]\nmodel = "seed"\n{key} = {value}\n', encoding="utf-8")
        with pytest.raises(InvalidInputError, match=message):
            armpath.reach(None, [300.0, 100.0, 200.0], scene=bad)


def _in_metres(doc: dict) -> dict:
    """An arm document with every length divided by 1000 (the test's own scaling, not
    armpath's): placements, landmark offsets, radii, a prismatic joint's limits, tick and
    home value."""
    doc = json.loads(json.dumps(doc))
    doc["length_unit"] = "m"

    def moved(T: list) -> None:
        for row in T[:3]:
            row[3] /= 1000.0

    for i, joint in enumerate(doc["joints"]):
        moved(joint["T_parent_joint"])
        if joint["kind"] == "prismatic":
            joint["limits"] = [v / 1000.0 for v in joint["limits"]]
            joint["tick"] /= 1000.0
            doc["home"][i] /= 1000.0
    moved(doc["T_flange_tool"])
    moved(doc["T_world_base"])
    for mark in doc["landmarks"]:
        mark["offset"] = [v / 1000.0 for v in mark["offset"]]
    for link in doc["links"]:
        link["radius"] /= 1000.0
    return doc


@pytest.mark.slow
def test_an_arm_in_metres_is_taken_in_millimetres(tmp_path):
    """A model document in metres plans as the same arm in mm: a target, tolerance and scene
    given in mm were applied as metres (the UR5's (300, 200, 400) mm 'out of reach ... 537.5 m
    away'). Checked against the mm arm: the same forward kinematics (x 1000, a prismatic joint
    too), the same plan from the CLI and from Python."""
    import armpath
    from armpath.kinematics import tool_position
    from armpath.model.serialize import arm_from_dict, arm_to_dict

    for name in ("welder003", "ur5"):
        arm_mm = armpath.load_arm(name)
        metres = arm_from_dict(_in_metres(arm_to_dict(arm_mm)))
        assert metres.length_unit == "m"
        rng = np.random.default_rng(3)
        lo, hi = np.maximum(arm_mm.lower, -np.pi), np.minimum(arm_mm.upper, np.pi)
        q_mm = rng.uniform(lo, hi, (20, arm_mm.n_joints))
        prismatic = np.array([j.kind.value == "prismatic" for j in arm_mm.joints])
        q_m = np.where(prismatic, q_mm / 1000.0, q_mm)
        expected = tool_position(arm_mm, q_mm)
        np.testing.assert_allclose(tool_position(metres, q_m) * 1000.0, expected, atol=1e-9)
        back = metres.in_mm()
        assert back.length_unit == "mm" and back.lattice.tick.tolist() == pytest.approx(
            arm_mm.lattice.tick.tolist(), rel=1e-12
        )
        np.testing.assert_allclose(tool_position(back, q_mm), expected, atol=1e-9)
        np.testing.assert_allclose(back.home, arm_mm.home, atol=1e-12)
        assert [lk.radius for lk in back.links] == pytest.approx([lk.radius for lk in arm_mm.links])

    ur5 = armpath.load_arm("ur5")
    file = tmp_path / "ur5_in_metres.json"
    file.write_text(json.dumps(_in_metres(arm_to_dict(ur5))), encoding="utf-8")
    target = [300.0, 200.0, 400.0]
    plain = armpath.reach(ur5, target, tolerance_mm=1.0)
    from_file = armpath.reach(armpath.load_arm(file), target, tolerance_mm=1.0)
    in_metres = arm_from_dict(_in_metres(arm_to_dict(ur5)))
    from_python = armpath.reach(in_metres, target, tolerance_mm=1.0)
    for other in (from_file, from_python):
        np.testing.assert_array_equal(other.commands, plain.commands)
        assert other.arm.length_unit == "mm"
    d = np.pi / 180  # the UR5's standard D-H table (mm, rad), the textbook product
    T = independent_dh.dh_pose(
        [0, -425.0, -392.25, 0, 0, 0],
        [90 * d, 0, 0, 90 * d, -90 * d, 0],
        [89.159, 0, 0, 109.15, 94.65, 82.3],
        np.radians(plain.states_deg[-1]),
    )
    assert np.linalg.norm(T[:3, 3] - target) <= 1.0


def test_the_modules_below_the_api_refuse_a_models_name_by_name():
    """``tool_position("ur5", q)``, ``solve_ik("ur5", T)`` and ``sample_workspace("ur5", ...)``
    raised AttributeError from deep inside; they take a SerialArm and now say so."""
    from armpath.errors import InvalidInputError
    from armpath.ik import solve_ik
    from armpath.kinematics import tool_position
    from armpath.workspace import sample_workspace

    for call in (
        lambda: tool_position("ur5", [0.0] * 6),
        lambda: solve_ik("ur5", np.eye(4)),
        lambda: sample_workspace("ur5", 1000, 10.0),
    ):
        with pytest.raises(InvalidInputError, match=r"armpath.load_arm\('ur5'\) gives one"):
            call()


def test_a_tours_visits_record_the_tool_axis_rule_and_the_angle_met():
    """A tour with --tool-axis recorded neither the rule nor the angle at each weld (a trace
    does). Each visit now carries the rule and the angle of the tool's approach axis from it,
    which the independent seed kinematics (the last link's direction at the visit's state)
    agrees with, within the tolerance; without a rule, null."""
    import armpath

    welds = [[300.0, -50.0, 150.0], [320.0, -50.0, 150.0]]
    doc = armpath.spotweld("seed", welds, scene="none", order="given", tool_axis=[0, 0, -1],
                           axis_tolerance_deg=10, bound=False).doc  # fmt: skip
    states = independent.replay(doc["initial_deg"], np.array(doc["commands"]))
    for v in doc["visits"]:
        rule = v["tool_orientation"]
        assert rule["type"] == "axis_cone" and rule["tolerance_deg"] == pytest.approx(10.0)
        p = independent.points(states[v["after_command"]])
        axis = (p[-1] - p[-2]) / np.linalg.norm(p[-1] - p[-2])  # the last link, to the tip
        angle = np.degrees(np.arccos(np.clip(axis @ [0.0, 0.0, -1.0], -1.0, 1.0)))
        assert rule["angle_deg"] == pytest.approx(angle, abs=1e-6) and angle <= 10.0 + 1e-6
    plain = armpath.spotweld("seed", welds, scene="none", order="given", bound=False).doc
    assert all(v["tool_orientation"] is None for v in plain["visits"])


def test_a_scene_is_given_as_a_dict_of_a_scene_files_contents(tmp_path):
    """``armpath.load_scene({...})`` said a scene must be a Scene or a file; building one in
    Python needed an undocumented function. A dict of a scene file's contents now makes the
    same scene as the file: the same obstacles, and a reach in it the same commands and end."""
    import tomllib

    import armpath

    text = (
        'name = "cell"\n[arm]\nmodel = "ur5"\nbase = { position_mm = [0, 0, 250] }\n'
        '[[obstacles]]\ntype = "box"\nname = "pedestal"\ncenter = [0, 0, 125]\n'
        "size = [220, 220, 250]\n"
    )
    (tmp_path / "cell.toml").write_text(text)
    from_file = armpath.load_scene(tmp_path / "cell.toml")
    from_dict = armpath.load_scene(tomllib.loads(text))
    assert [o.name for o in from_dict.world.obstacles] == ["pedestal"]
    assert from_dict.name == from_file.name == "cell"
    a = armpath.reach(None, [400, 100, 500], scene=from_file)
    b = armpath.reach(None, [400, 100, 500], scene=from_dict)
    assert a.n_commands == b.n_commands
    np.testing.assert_array_equal(a.states_deg[-1], b.states_deg[-1])


@pytest.mark.slow
def test_a_target_only_self_collision_forbids_says_so_not_obstacles():
    """In an empty cell a target at the seed arm's base (one given in metres, say) was refused
    because "no configuration ... keeps the links 1 mm clear of the obstacles": there are none.
    The refusal then named what it asks: the links clear of each other, with the room the
    planner keeps; now, before any search, why: the point lies by the base column AB
    (sqrt(0.5^2 + 0.2^2) = 0.5385 mm from its axis), which the link DE ending at the tool point
    cannot come within 1 mm of."""
    import armpath
    from armpath.errors import CollisionError

    with pytest.raises(CollisionError) as caught:
        armpath.reach("seed", [0.5, 0.2, 0.6], scene="none")
    assert str(caught.value) == (
        "no configuration reaching (0.5, 0.2, 0.6) mm keeps the links apart: the point lies "
        "0.5385 mm from link AB, which no joint moves, so link DE, which ends at the tool "
        "point, would come within 0.5885 mm of it (with the 0.05 mm tolerance), where the two "
        "must keep 1 mm apart (their radii and the 1 mm between links)"
    )
    assert "obstacles" not in str(caught.value)


def test_an_arm_is_loaded_as_a_scene_places_it():
    """Forward kinematics in a cell's frame needed the undocumented ``arm_and_scene``:
    ``load_arm`` gave the model in its own base frame only. ``load_arm(scene=...)`` now gives
    the arm as the scene's ``[arm]`` places it (the UR5 cell: base at (-150, 0, 250) mm, a
    120 mm tool); its tool point at the home pose is the maker's D-H product moved there."""
    from pathlib import Path

    import armpath
    from arms import UR5_DH
    from independent_dh import dh_pose

    cell = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
    home = [0, -90, 90, -90, -90, 0]
    placed = armpath.load_arm(scene=cell)
    assert placed.name == "ur5" and np.allclose(np.degrees(placed.home), home)
    tip = armpath.forward_kinematics(placed, home)["tip"]
    T = dh_pose(*UR5_DH, np.radians(home))
    expected = (T @ [0.0, 0.0, 120.0, 1.0])[:3] + np.array([-150.0, 0.0, 250.0])
    np.testing.assert_allclose(tip, expected, atol=1e-6)
    # the same model named, placed the same; without a scene, where its own base puts it
    named = armpath.load_arm("ur5", scene=cell)
    np.testing.assert_allclose(armpath.forward_kinematics(named, home)["tip"], expected, atol=1e-6)
    alone = armpath.forward_kinematics(armpath.load_arm("ur5"), home)["tip"]
    assert not np.allclose(alone, expected)


def test_the_scenes_own_model_given_unplaced_is_pointed_out():
    """A UR5 loaded alone and given with the UR5 cell planned with its base at the origin and
    its own tool, not where the cell stands its UR5, silently unless it collided. It now warns
    (an ArmpathWarning naming the cell's base and load_arm(scene=...)); the arm as the cell
    places it, and another model, are not warned about."""
    import warnings
    from pathlib import Path

    import armpath
    from armpath.api import arm_and_scene
    from armpath.errors import ArmpathWarning

    cell = armpath.load_scene(Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml")

    def said(arm):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            arm_and_scene(arm, cell)
        return [str(w.message) for w in caught if issubclass(w.category, ArmpathWarning)]

    (note,) = said(armpath.load_arm("ur5"))
    assert note.startswith(
        "the arm given ('ur5') stands where its own base puts it and carries another tool, not "
        "as scene 'UR5 welding cell' places its 'ur5' (base at (-150, 0, 250) mm, the scene's "
        "tool)"
    )
    assert "armpath.load_arm(scene=...)" in note
    assert said(armpath.load_arm(scene=cell)) == []
    assert said(armpath.load_arm("puma560")) == []


def test_a_scenes_reach_tolerance_is_the_calls_default():
    """armpath.reach with tolerance_mm=None takes the scene's [tasks.reach] tolerance_mm (the
    seed scene's box at 20 mm: 61 commands, as `armpath reach 20 -200 120 --tolerance 20`);
    a tolerance given to the call wins; the fingertip's error, replayed on the independent seed
    kinematics, is within the one used."""
    import armpath

    scene = armpath.load_scene(
        {"name": "box", "tasks": {"reach": {"target_mm": [20, -200, 120], "tolerance_mm": 20}}}
    )
    counts = []
    for given, used in ((None, 20.0), (0.05, 0.05)):
        doc = armpath.reach("seed", [20, -200, 120], scene=scene, tolerance_mm=given).doc
        assert doc["tolerance_mm"] == used
        final = independent.replay(doc["initial_deg"], doc["commands"])[-1]
        tip = independent.points(final)[-1]  # E, the fingertip
        assert np.linalg.norm(tip - [20.0, -200.0, 120.0]) <= used
        counts.append(doc["n_commands"])
    assert counts == [61, 63]
