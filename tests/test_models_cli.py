"""``armpath model show|convert`` (issue 19, item 5): a model written as URDF loads back with the
same forward kinematics (checked with yourdfpy's own kinematics, not armpath's) and as
armpath's JSON model document loads back with --model."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from armpath.kinematics import tool_pose
from armpath.model.catalog import BUILTIN_MODELS
from armpath.model.serial_arm import SerialArm
from armpath.model.urdf import arm_from_urdf
from armpath.model.urdf_export import arm_to_urdf


def _random_q(arm: SerialArm, count: int, seed: int) -> np.ndarray:
    lo = np.where(np.isfinite(arm.lower), arm.lower, -np.pi)
    hi = np.where(np.isfinite(arm.upper), arm.upper, np.pi)
    return np.random.default_rng(seed).uniform(lo, hi, (count, arm.n_joints))


def _placed_ur5() -> SerialArm:
    from pathlib import Path

    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm

    cell = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
    return scene_arm(load_scene(cell))  # on its pedestal, with a 120 mm torch


@pytest.mark.parametrize("name", [*BUILTIN_MODELS, "ur5 in the cell"])
def test_urdf_export_has_the_same_kinematics(name, tmp_path):
    import yourdfpy

    arm = _placed_ur5() if name == "ur5 in the cell" else BUILTIN_MODELS[name]()
    path = tmp_path / "arm.urdf"
    path.write_text(arm_to_urdf(arm), encoding="utf-8")
    q = _random_q(arm, 40, seed=len(name))
    want = tool_pose(arm, q)
    # armpath reads it back
    back = arm_from_urdf(path, "tool")
    got = tool_pose(back, q)
    assert np.abs(got[:, :3, 3] - want[:, :3, 3]).max() <= 1e-9
    assert np.abs(got[:, :3, :3] - want[:, :3, :3]).max() <= 1e-12
    # yourdfpy's own forward kinematics (metres) agrees
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False)
    names = [j.name for j in arm.joints]
    to_urdf = np.where([j.kind.value == "prismatic" for j in arm.joints], 1e-3, 1.0)  # mm -> m
    for row, T in zip(q[:8], want[:8], strict=True):
        urdf.update_cfg(dict(zip(names, row * to_urdf, strict=True)))
        peer = urdf.get_transform("tool", "world")
        assert np.abs(peer[:3, 3] * 1000.0 - T[:3, 3]).max() <= 1e-9
        assert np.abs(peer[:3, :3] - T[:3, :3]).max() <= 1e-12


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armpath", *args], capture_output=True, text=True, cwd=cwd
    )


def test_cli_convert_to_json_loads_back_with_model(tmp_path):
    out = tmp_path / "painter.json"
    r = _cli("model", "convert", "painter004", "--to", "json", "--out", str(out))
    assert r.returncode == 0, r.stderr
    q = ["10", "20", "30", "40", "50", "60"]
    a = json.loads(_cli("fk", *q, "--model", "painter004", "--json").stdout)
    b = json.loads(_cli("fk", *q, "--model", str(out), "--json").stdout)
    np.testing.assert_allclose(a["pose"], b["pose"], atol=1e-9)
    shown = _cli("model", "show", str(out))
    assert shown.returncode == 0 and "painter004: 6 joints" in shown.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--to", "urdf", "--out", "x.json"], "--out must end in .urdf"),
    ],
)
def test_cli_convert_refuses_bad_requests(args, message, tmp_path):
    r = _cli("model", "convert", "ur5", *args, cwd=tmp_path)
    assert r.returncode == 1 and r.stderr.startswith("error:") and message in r.stderr
    assert list(tmp_path.iterdir()) == []


def _dh_product(doc: dict, q: np.ndarray) -> np.ndarray:
    """The tool pose of a D-H robot file by the textbook product (tests/independent_dh.py)."""
    from independent_dh import dh_pose

    rows = doc["links"]
    prismatic = np.array([r.get("type") == "prismatic" for r in rows])
    offsets = [0.0 if p else r.get("offset", 0.0) for r, p in zip(rows, prismatic, strict=True)]
    assert all(r.get("theta", 0.0) == 0.0 for r in rows if r.get("type") != "prismatic")
    T = dh_pose(
        [r["a"] for r in rows],
        [r["alpha"] for r in rows],
        [r["d"] for r in rows],
        q,
        modified=doc["convention"] == "modified",
        prismatic=prismatic,
        offset=offsets,
    )
    return np.asarray(doc["base"]) @ T @ np.asarray(doc["tool"])


def _public_panda() -> SerialArm:
    from test_public_urdf import PANDA, robot_file

    return arm_from_urdf(robot_file(PANDA), "panda_hand")


@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("name", [*BUILTIN_MODELS, "ur5 in the cell", "panda file"])
def test_dh_tables_reproduce_every_tool_pose(name, convention):
    """The D-H table of any chain (built-in, placed in a cell, a public URDF): read back as a
    robot file and by the textbook D-H product, the same tool pose to 1e-9 mm."""
    from armpath.model.dh import robot_from_dict
    from armpath.model.dh_export import dh_document

    if name == "ur5 in the cell":
        arm = _placed_ur5()
    elif name == "panda file":
        arm = _public_panda()
    else:
        arm = BUILTIN_MODELS[name]()
    doc = json.loads(json.dumps(dh_document(arm, convention)))  # as a file holds it
    assert doc["convention"] == convention and len(doc["links"]) == arm.n_joints
    q = _random_q(arm, 60, seed=7)
    want = tool_pose(arm, q)
    back = tool_pose(robot_from_dict(doc), q)
    assert np.abs(back[:, :3, 3] - want[:, :3, 3]).max() <= 1e-9
    assert np.abs(back[:, :3, :3] - want[:, :3, :3]).max() <= 1e-12
    for row, T in zip(q[:10], want[:10], strict=True):
        peer = _dh_product(doc, row)
        assert np.abs(peer[:3, 3] - T[:3, 3]).max() <= 1e-9


def test_cli_convert_to_mdh_loads_back_with_model(tmp_path):
    out = tmp_path / "puma_mdh.json"
    r = _cli("model", "convert", "puma560", "--to", "mdh", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert json.loads(out.read_text())["convention"] == "modified"
    q = ["10", "-20", "30", "-40", "50", "-60"]
    a = json.loads(_cli("fk", *q, "--model", "puma560", "--json").stdout)
    b = json.loads(_cli("fk", *q, "--model", str(out), "--json").stdout)
    np.testing.assert_allclose(a["pose"], b["pose"], atol=1e-9)


@pytest.mark.parametrize("name", ["seed", "iiwa14", "welder003"])
def test_cli_show_gives_home_and_limits_in_display_units(name, tmp_path):
    """The home pose and limits shown are the model document's (rad, mm) in deg and mm: the
    home was once shown as ticks (the seed's -90 deg as -0.15708)."""
    from cli_in_process import run_in_process

    doc = json.loads(run_in_process(["model", "show", name, "--json"], tmp_path).stdout)
    kinds = [j["kind"] for j in doc["joints"]]
    home = [
        v if k == "prismatic" else np.degrees(v) for v, k in zip(doc["home"], kinds, strict=True)
    ]
    shown = run_in_process(["model", "show", name], tmp_path).stdout
    line = next(t for t in shown.splitlines() if "; home " in t)
    values = [float(v) for v in line.split("; home ")[1].split(" (")[0].split()]
    np.testing.assert_allclose(values, home, atol=1e-4)
    if name == "seed":  # the seed arm's home, from its statement
        assert values == [0, -90, 0, 0, -90, 0]
        assert "-125 … 125 deg" in shown and "-138 … 138 deg" in shown


def test_cli_show_says_how_high_a_base_column_stands(tmp_path):
    """The PUMA 560's D-H base frame is its shoulder, 26.45 in (671.83 mm) above its foot:
    a scene's base placed at a pedestal's top buried the upper arm at every pose. Show says how
    high the base frame stands; an arm without a column says nothing of it."""
    from cli_in_process import run_in_process

    shown = " ".join(run_in_process(["model", "show", "puma560"], tmp_path).stdout.split())
    assert f"the base frame stands {26.45 * 25.4:g} mm above the arm's foot" in shown
    assert "above the arm's foot" not in run_in_process(["model", "show", "ur5"], tmp_path).stdout


def test_cli_show_of_a_scene_shows_its_arm_as_the_tasks_take_it(tmp_path):
    """``model show --scene`` shows the scene's [arm] as built: the UR5 cell's pedestal base and
    120 mm torch, in the model document whose tool pose equals the cell's arm's (the base and
    tool applied by hand to the bare UR5 here); with a model, that model on the cell's base;
    neither a model nor a scene is one error line."""
    from pathlib import Path

    from cli_in_process import run_in_process

    cell = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
    shown = " ".join(
        run_in_process(["model", "show", "--scene", str(cell)], tmp_path).stdout.split()
    )
    assert "tool: 0 0 120 mm from the flange" in shown and "base at -150 0 250 mm" in shown
    doc = json.loads(
        run_in_process(["model", "show", "--scene", str(cell), "--json"], tmp_path).stdout
    )
    from armpath.model.catalog import resolve_model
    from armpath.model.serialize import arm_from_dict

    q = _random_q(resolve_model("ur5"), 5, 3)
    bare = tool_pose(resolve_model("ur5"), q)
    by_hand = bare.copy()
    by_hand[:, :3, 3] += bare[:, :3, :3] @ np.array([0.0, 0.0, 120.0]) + [-150.0, 0.0, 250.0]
    np.testing.assert_allclose(tool_pose(arm_from_dict(doc), q), by_hand, atol=1e-9)
    puma = " ".join(
        run_in_process(["model", "show", "puma560", "--scene", str(cell)], tmp_path).stdout.split()
    )
    assert "puma560" in puma and "base at -150 0 250 mm" in puma
    r = run_in_process(["model", "show"], tmp_path)
    assert r.returncode == 1 and r.stderr == (
        "error: give a model (a built-in name or a robot file) or --scene\n"
    )


def test_an_empty_model_is_a_usage_error_and_a_folder_an_unknown_model(tmp_path):
    """--model "" was read as the robot file '.' that "does not exist": now every option given
    an empty value is a usage error; the folder '.' is no model."""
    from cli_in_process import run_in_process

    r = run_in_process(["fk", "0", "0", "0", "0", "0", "0", "--model", ""], tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("error: --model was given an empty value")
    r = run_in_process(["fk", "0", "0", "0", "0", "0", "0", "--model", "."], tmp_path)
    assert r.returncode == 1 and r.stderr.startswith("error: unknown model '.': use one of")


def test_a_broken_urdf_gets_one_line_saying_what_is_wrong(tmp_path):
    """A truncated URDF made yourdfpy print its XML parser's complaint, retry with a forgiving
    parser and fail on the rest ("expected one root link"); an element without its name said
    "'name'". Each now gets one error line naming what is wrong and where."""
    from cli_in_process import run_in_process

    good = arm_to_urdf(BUILTIN_MODELS["ur5"]())
    lines = good.splitlines(keepends=True)
    cases = {
        "cut.urdf": ("".join(lines[:40]) + lines[40][:12], "is not well-formed XML: line 41"),
        "empty.urdf": ("", "is not well-formed XML: line 1, column 1 (no element found)"),
        "root.urdf": ('<?xml version="1.0"?><robt name="x"/>', "the root element is <robt>"),
        "noname.urdf": (
            good.replace('<link name="', '<link x="', 1),
            "an element lacks its 'name' attribute",
        ),
        "notype.urdf": (good.replace(' type="revolute"', "", 1), "has no type"),
        # a joint whose parent is no link: the chain began there, silently two joints short
        "parent.urdf": (
            good.replace('<parent link="link_2" />', '<parent link="link_2x" />', 1),
            "joint 'q3' names parent link 'link_2x', which is not a link of the file",
        ),
        # a mimic joint was taken as a joint of its own
        "mimic.urdf": (
            good.replace(
                '<child link="link_3" />',
                '<child link="link_3" /><mimic joint="q2" multiplier="0.5" />',
                1,
            ),
            "joint 'q3' mimics joint 'q2'",
        ),
    }
    for name, (text, needle) in cases.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
        r = run_in_process(["fk", "0", "0", "0", "0", "0", "0", "--model", name], tmp_path)
        assert r.returncode == 1 and r.stdout == "", (name, r.stdout)
        assert r.stderr.count("\n") == 1 and r.stderr.startswith(f"error: URDF {name!r}"), r.stderr
        assert needle in r.stderr, r.stderr


def test_a_robot_files_mistake_names_the_file(tmp_path):
    """A D-H robot file's mistakes were reported as "robot file: links[0]: ...", which file
    not said."""
    from cli_in_process import run_in_process

    (tmp_path / "typo.json").write_text('{"links": [{"a": 100, "alpah": 90}]}')
    r = run_in_process(["fk", "0", "--model", "typo.json"], tmp_path)
    assert r.returncode == 1
    assert "error: robot file 'typo.json': links[0]: unknown key(s) ['alpah']" in r.stderr


def test_limits_of_more_than_two_turns_are_refused_as_a_unit_slip(tmp_path):
    """Limits of +-185 in a robot file in rad, or of +-170 in a URDF (radians by its
    standard), made joints of +-10,600 deg and nonsense plans; both are refused."""
    from cli_in_process import run_in_process

    (tmp_path / "rad.json").write_text(
        '{"units": {"angle": "rad"}, "links": [{"a": 100, "limits": [-185, 185]}]}'
    )
    (tmp_path / "deg.urdf").write_text(
        '<robot name="d"><link name="b"/><link name="f"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="f"/>'
        '<origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-170" upper="170" effort="1" velocity="1"/></joint></robot>'
    )
    for name, needle in (
        ("rad.json", "links[0].limits: -185 rad is more than two turns (720 deg)"),
        ("deg.urdf", "joint 'j1' limits: -170 rad is more than two turns"),
    ):
        r = run_in_process(["model", "show", name], tmp_path)
        assert r.returncode == 1 and needle in r.stderr, r.stderr


def test_a_dh_table_of_axes_that_nearly_meet_reproduces_the_tool_pose(tmp_path):
    """A URDF whose pitch is 1.5707963268 (pi/2 to ten digits) has two axes that meet but for
    rounding (1.8e-9 mm apart): the table took the common normal along that rounding, 9e-6
    rad off, and its tool pose was 0.007 mm off the URDF's. Now to 1e-9 mm, by the textbook
    D-H product too."""
    from armpath.model.dh import load_robot_file, robot_from_dict
    from armpath.model.dh_export import dh_document

    def joint(name, parent, child, xyz, rpy, axis):
        return (
            f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        )

    links = "".join(f'<link name="l{i}"/>' for i in range(6))
    (tmp_path / "near.urdf").write_text(
        f'<robot name="near">{links}'
        + joint("j1", "l0", "l1", "0 0 0.25", "0 0 0", "0 0 1")
        + joint("j2", "l1", "l2", "0.05 0 0.1", "0 0 0", "0 1 0")
        + joint("j3", "l2", "l3", "0 0 0.4", "0 0 0", "0 1 0")
        + joint("j4", "l3", "l4", "0.35 0 0", "0 1.5707963268 0", "0 0 1")
        + joint("j5", "l4", "l5", "0 0 0.08", "0 0 0", "0 1 0")
        + "</robot>"
    )
    arm = load_robot_file(tmp_path / "near.urdf")
    doc = json.loads(json.dumps(dh_document(arm, "standard")))
    q = _random_q(arm, 60, seed=3)
    want = tool_pose(arm, q)
    assert np.abs(tool_pose(robot_from_dict(doc), q) - want).max() <= 1e-9
    for row, T in zip(q[:10], want[:10], strict=True):
        assert np.abs(_dh_product(doc, row)[:3, 3] - T[:3, 3]).max() <= 1e-9


def _one_error_line(args: list[str], cwd) -> str:
    """The one ``error:`` line (exit 1, nothing on stdout) of a CLI run in process, any warning
    raised as an error (a RuntimeWarning printed before the line is a defect too)."""
    import warnings

    from cli_in_process import run_in_process

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = run_in_process(args, cwd)
    assert r.returncode == 1 and r.stdout == "", (args, r.stdout, r.stderr)
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("error: "), (args, r.stderr)
    return r.stderr.strip()


def _fk_tip(args: list[str], cwd) -> list[float]:
    from cli_in_process import run_in_process

    r = run_in_process(["fk", *args, "--json"], cwd)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    return json.loads(r.stdout)["tip"]


def _urdf(origin: str, name2: str = "j2", kind: str = "revolute", limit: str = "-1 1") -> str:
    lower, upper = limit.split()
    return (
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
        f'<joint name="j1" type="revolute"><parent link="a"/><child link="b"/>'
        f'<origin xyz="{origin}"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        f'<joint name="{name2}" type="{kind}"><parent link="b"/><child link="c"/>'
        '<origin xyz="0.1 0 0"/><axis xyz="1 0 0"/>'
        f'<limit lower="{lower}" upper="{upper}" effort="1" velocity="1"/></joint></robot>'
    )


def test_lengths_of_a_robot_file_beyond_the_coordinate_limit_are_refused_naming_where(tmp_path):
    """A D-H link of a = 1e308 mm made ``workspace`` raise OverflowError, ``fk`` print a tip of
    1e308 after RuntimeWarnings and ``reach`` a traceback; a URDF origin of 1e300 m the same.
    Every length of a robot file (a, d, a prismatic offset and limits, home, radii, base and
    tool translations; URDF origins and prismatic limits; a model document's translations) is
    now refused beyond the 1e9 mm every scene coordinate and target is held to, naming where
    in the file. Files within it still work."""
    limit = "is beyond the largest length a model may use (1e+09 mm, as for scenes and targets)"
    eye = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    far = [[1, 0, 0, 5e9], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    files = {
        "huge.json": ({"links": [{"a": 1e308}, {"a": 100}]}, "links[0].a: 1e+308 mm"),
        "d.json": (
            {"units": {"length": "m"}, "links": [{"a": 0.1}, {"d": 2e6}]},
            "links[1].d: 2e+06 m",
        ),
        "slide.json": (
            {"links": [{"a": 10}, {"type": "prismatic", "limits": [0, 2e9]}]},
            "links[1].limits[1]: 2e+09 mm",
        ),
        "offset.json": (
            {"links": [{"a": 10}, {"type": "prismatic", "offset": -3e9}]},
            "links[1].offset: -3e+09 mm",
        ),
        "base.json": ({"links": [{"a": 10}, {"a": 10}], "base": far}, "base: translation x"),
        "tool.json": ({"links": [{"a": 10}, {"a": 10}], "base": eye, "tool": far}, "tool: transl"),
        # an integer beyond any float (JSON has no limit) is no finite number either
        "int.json": ({"links": [{"a": 10**400}, {"a": 10}]}, "links[0].a must be finite"),
    }
    for name, (doc, where) in files.items():
        (tmp_path / name).write_text(json.dumps(doc))
        line = _one_error_line(["fk", "0", "0", "--model", name, "--json"], tmp_path)
        assert line.startswith(f"error: robot file {name!r}: {where}"), line
        if name != "int.json":
            assert limit in line, line
    line = "error: robot file 'huge.json': links[0].a: 1e+308 mm " + limit
    for args in (
        ["workspace", "--model", "huge.json", "--samples", "1000"],
        ["reach", "100", "0", "0", "--model", "huge.json"],
    ):
        assert _one_error_line(args, tmp_path) == line
    (tmp_path / "huge.urdf").write_text(_urdf("1e300 0 0"))
    (tmp_path / "slide.urdf").write_text(_urdf("0 0 0", kind="prismatic", limit="0 1e7"))
    assert _one_error_line(["reach", "100", "0", "0", "--model", "huge.urdf"], tmp_path) == (
        f"error: URDF 'huge.urdf': joint 'j1' origin xyz (x): 1e+300 m {limit}"
    )
    assert _one_error_line(["fk", "0", "0", "--model", "slide.urdf"], tmp_path) == (
        f"error: URDF 'slide.urdf': joint 'j2' limit upper: 1e+10 mm {limit}"
    )
    # armpath's own model document: a translation changed to 1e300 mm
    (tmp_path / "ok.urdf").write_text(_urdf("0.2 0 0.3"))
    from cli_in_process import run_in_process

    r = run_in_process(["model", "convert", "ok.urdf", "--to", "json", "--out", "m.json"], tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "m.json").read_text())
    doc["joints"][1]["T_parent_joint"][1][3] = 1e300
    (tmp_path / "m_far.json").write_text(json.dumps(doc))
    line = _one_error_line(["fk", "0", "0", "--model", "m_far.json"], tmp_path)
    assert line == (
        "error: robot file 'm_far.json': malformed arm: joint 2: T_parent_joint translation y: "
        f"1e+300 mm {limit}"
    ), line
    # within the limit: the tool point where the lengths put it
    (tmp_path / "long.json").write_text(json.dumps({"links": [{"a": 1e9}, {"a": 250, "d": 40}]}))
    assert _fk_tip(["0", "0", "--model", "long.json"], tmp_path) == [1e9 + 250, 0.0, 40.0]
    assert _fk_tip(["0", "0", "--model", "ok.urdf"], tmp_path) == [300.0, 0.0, 300.0]
    assert _fk_tip(["0", "0", "--model", "m.json"], tmp_path) == [300.0, 0.0, 300.0]


def test_a_scene_placing_a_far_base_beyond_the_coordinate_limit_is_refused(tmp_path):
    """A scene's base placement and a robot file's base each within 1e9 mm but 1.8e9 mm
    together gave a result whose saved base could not be loaded back; now the scene is refused,
    naming the composed base and the limit. The robot file alone still works, its tool point
    where its base puts it (the D-H product by hand: a base at x = 9e8, two 100 mm links)."""
    limit = "is beyond the largest length a model may use (1e+09 mm, as for scenes and targets)"
    base = [[1, 0, 0, 9e8], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    doc = {"links": [{"a": 100}, {"a": 100}], "base": base}
    (tmp_path / "far.json").write_text(json.dumps(doc))
    (tmp_path / "far.toml").write_text(
        'name = "far"\n[arm]\nmodel = "far.json"\nbase = { position_mm = [9e8, 0, 0] }\n'
    )
    line = _one_error_line(["reach", "100", "50", "0", "--scene", "far.toml"], tmp_path)
    assert line == (
        "error: scene far.toml: arm: the arm's base (its placement after its own base): "
        f"1.8e+09 mm {limit}"
    ), line
    assert _fk_tip(["0", "0", "--model", "far.json"], tmp_path) == [9e8 + 200, 0.0, 0.0]


def test_the_base_and_tool_of_a_robot_file_must_be_rigid_transforms(tmp_path):
    """A robot file's base of diag(2, 2, 2, 1) doubled every distance silently and an all-zero
    rotation block put every point at the base; neither is a placement. The base and the tool
    are now refused unless rigid (rotation block orthonormal with determinant +1 to 1e-6, last
    row 0 0 0 1), naming the field and the file; a rotation written to six digits is one."""
    rows = [{"a": 100}, {"a": 100}]

    def matrix(r, t=(0, 0, 0), last=(0, 0, 0, 1)):
        return [[*r[0], t[0]], [*r[1], t[1]], [*r[2], t[2]], list(last)]

    scale = matrix([[2, 0, 0], [0, 2, 0], [0, 0, 2]])
    zero = matrix([[0, 0, 0], [0, 0, 0], [0, 0, 0]])
    mirror = matrix([[1, 0, 0], [0, 1, 0], [0, 0, -1]])
    skew = matrix([[1, 0, 0], [0, 1, 0], [0, 0, 1]], last=(0, 0, 0.5, 1))
    not_rigid = "is not a rigid transform: "
    cases = {
        "scale.json": ({"base": scale}, f"base {not_rigid}its rotation block (the upper-left"),
        "zero.json": ({"tool": zero}, f"tool {not_rigid}its rotation block"),
        "mirror.json": ({"base": mirror}, f"base {not_rigid}its rotation block is a reflection"),
        "skew.json": ({"tool": skew}, f"tool {not_rigid}its last row must be 0 0 0 1, got 0 0 0.5"),
    }
    for name, (extra, message) in cases.items():
        (tmp_path / name).write_text(json.dumps({"links": rows, **extra}))
        line = _one_error_line(["fk", "0", "0", "--model", name], tmp_path)
        assert line.startswith(f"error: robot file {name!r}: {message}"), line
    # a model document's base: named by its key
    from cli_in_process import run_in_process

    (tmp_path / "ok.json").write_text(json.dumps({"links": rows}))
    r = run_in_process(["model", "convert", "ok.json", "--to", "json", "--out", "m.json"], tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "m.json").read_text())
    doc["T_world_base"] = scale
    (tmp_path / "m_scaled.json").write_text(json.dumps(doc))
    line = _one_error_line(["fk", "0", "0", "--model", "m_scaled.json"], tmp_path)
    assert line.startswith(
        f"error: robot file 'm_scaled.json': malformed arm: the document: base (T_world_base) "
        f"{not_rigid}"
    ), line
    # rigid ones still place the arm: 30 deg about z written to six digits, then 10 mm up
    turn = matrix([[0.866025, -0.5, 0], [0.5, 0.866025, 0], [0, 0, 1]], t=(0, 0, 10))
    (tmp_path / "turned.json").write_text(json.dumps({"links": rows, "base": turn}))
    tip = _fk_tip(["0", "0", "--model", "turned.json"], tmp_path)
    np.testing.assert_allclose(tip, [173.205, 100.0, 10.0], atol=1e-6)


def test_a_urdf_with_two_joints_of_one_name_is_refused(tmp_path):
    """A URDF whose two joints were both named j1 was read as an arm of two j1 joints
    (``model show`` listed both); a name says which joint a limit, a tip link or a message
    means, so a second one is refused, naming it. Two links of one name the same."""
    (tmp_path / "twice.urdf").write_text(_urdf("0.1 0 0", name2="j1"))
    line = _one_error_line(["model", "show", "twice.urdf"], tmp_path)
    assert line == (
        "error: URDF 'twice.urdf': more than one joint is named 'j1'; each joint needs a name "
        "of its own"
    )
    (tmp_path / "links.urdf").write_text(_urdf("0.1 0 0").replace('"c"', '"b"'))
    line = _one_error_line(["model", "show", "links.urdf"], tmp_path)
    assert "more than one link is named 'b'" in line, line
    (tmp_path / "ok.urdf").write_text(_urdf("0.1 0 0"))
    assert _fk_tip(["0", "0", "--model", "ok.urdf"], tmp_path) == [200.0, 0.0, 0.0]


_TWO_JOINTS = """<robot name="r">
  <link name="base"/><link name="a"/><link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="0 0 {z}"/><axis xyz="0 0 1"/>{limit1}</joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="{x} 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""
_LIMIT = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'


@pytest.mark.parametrize(
    ("z", "x", "limit1", "words"),
    [
        # a 290 mm and a 400 mm link written in mm: 690 m of arm
        ("290", "400", _LIMIT, "add up to 690 m, more than the 100 m"),
        # ROS's parser refuses a revolute joint without <limit>; it was taken as unlimited
        ("0.29", "0.4", "", "joint 'j1' is revolute but has no <limit>"),
        # ROS reads a <limit> without lower and upper as 0 and 0; it was taken as unlimited
        ("0.29", "0.4", '<limit effort="1" velocity="1"/>', "gives no lower or upper"),
        # one side only: ROS reads the other as 0; it was taken as unlimited
        ("0.29", "0.4", '<limit upper="1" effort="1" velocity="1"/>', "gives its upper only"),
        # reversed limits were refused without the file's name or their unit
        (
            "0.29",
            "0.4",
            '<limit lower="3" upper="-3" effort="1" velocity="1"/>',
            "URDF 'r.urdf': joint 'j1' limits: lower 3 rad is above upper -3 rad",
        ),
    ],
)
def test_a_urdf_in_mm_or_without_a_joints_range_is_refused(tmp_path, z, x, limit1, words):
    path = tmp_path / "r.urdf"
    path.write_text(_TWO_JOINTS.format(z=z, x=x, limit1=limit1), encoding="utf-8")
    r = _cli("fk", "--model", str(path), "0", "0", cwd=tmp_path)
    assert r.returncode == 1 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0]
    # in metres, with its limits, the same file loads: the tool 290 mm up, 400 mm out
    path.write_text(_TWO_JOINTS.format(z="0.29", x="0.4", limit1=_LIMIT), encoding="utf-8")
    np.testing.assert_allclose(tool_pose(arm_from_urdf(path), [0.0, 0.0])[:3, 3], [400, 0, 290])


def test_a_robot_placed_far_off_in_its_urdf_world_is_not_taken_for_mm(tmp_path):
    """Fixed joints before the first moving one place the robot in its world: 106 m off is
    not an arm written in mm (only the arm's own chain is held to 100 m)."""
    world = _TWO_JOINTS.format(z="0.29", x="0.4", limit1=_LIMIT).replace(
        '<link name="base"/>',
        '<link name="world"/><link name="base"/><joint name="place" type="fixed">'
        '<parent link="world"/><child link="base"/><origin xyz="80 70 0"/></joint>',
    )
    path = tmp_path / "placed.urdf"
    path.write_text(world, encoding="utf-8")
    tip = tool_pose(arm_from_urdf(path), [0.0, 0.0])[:3, 3]
    np.testing.assert_allclose(tip, [80_400.0, 70_000.0, 290.0], atol=1e-6)
