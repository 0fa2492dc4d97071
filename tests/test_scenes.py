"""Scene files: the built-in seed scene and validation of user files."""

import re
from pathlib import Path

import numpy as np
import pytest

from armpath.errors import SceneError
from armpath.geometry import HollowFrustum, WallThickness
from armpath.scenes import load_scene, seed_scene


def test_seed_scene_is_spec_section_3():
    scene = seed_scene()
    assert scene.reach_target_mm == (20.0, -200.0, 120.0)
    assert scene.world.margin == 1.0 and scene.world.tip_exempt == 5.0
    (wp,) = scene.workpieces
    assert isinstance(wp, HollowFrustum)
    assert (wp.height, wp.r_bottom, wp.r_top, wp.wall) == (180, 168, 96, 8)
    np.testing.assert_allclose(wp.origin, [210, 0, 0])
    assert wp.open_top and wp.closed_bottom
    assert scene.wall_thickness is WallThickness.NORMAL
    horizontal = scene.with_wall_thickness("horizontal")
    assert horizontal.wall_thickness is WallThickness.HORIZONTAL
    assert horizontal.workpieces[0].horizontal_wall == 8.0
    assert scene.describe()["wall_thickness"] == "normal"


GOOD = """
name = "mine"
[[obstacles]]
type = "half_space"
name = "floor"
point = [0, 0, -10]
normal = [0, 0, 1]
[tasks.reach]
target_mm = [100, 200, 300]
"""


def test_user_scene_file(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(GOOD)
    scene = load_scene(f)
    assert scene.name == "mine" and scene.reach_target_mm == (100, 200, 300)
    assert scene.world.obstacles[0].signed_distance(np.array([0, 0, 0.0])) == 10


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("name = ", "not valid TOML"),
        ('description = "x"', "name: Field required"),
        (GOOD.replace('type = "half_space"', 'type = "torus"'), "obstacles.0"),
        (  # a short list: the value missing is named, not pydantic's "normal.2: Field required"
            GOOD.replace("[0, 0, 1]", "[0, 0]"),
            "obstacles.0.half_space.normal: too few values \\(value 3 is missing\\)$",
        ),
        (  # a number where an expression goes: "Input should be a valid string" was jargon
            GOOD + '[tasks.trace]\ncurve = { type = "parametric", x = 300, y = "0", z = "0" }\n',
            "tasks.trace.curve.parametric.x: must be text in quotes, got 300$",
        ),
        (GOOD.replace("[0, 0, 1]", "[0, 0, 0]"), "normal must be non-zero"),
        (
            "speed = 3\n" + GOOD,
            "the top level: unknown key 'speed' \\(the top level takes arm, clearance, "
            "description, name, obstacles, tasks\\)$",
        ),
        (  # a key written after a table's header belongs to that table
            GOOD + "\nspeed = 3\n",
            "tasks.reach: unknown key 'speed' \\(tasks.reach takes target_mm, tolerance_mm\\)$",
        ),
        (  # a misspelt key is named, not the required key it leaves missing
            GOOD.replace("point = ", "point_mm = "),
            "obstacles.0.half_space: unknown key 'point_mm' \\(obstacles.0.half_space takes "
            "name, normal, point, type\\)$",
        ),
        (
            GOOD.replace("[tasks.reach]\ntarget_mm", "[tasks.spotweld]\nwelds"),
            "tasks.spotweld: unknown key 'welds' \\(tasks.spotweld takes points_mm, "
            "points_xy_mm, surface, tolerance_mm, workpiece\\)$",
        ),
        (
            GOOD + '[arm]\nmodel = "ur5"\n[arm.tool]\npositon_mm = [0, 0, 1]\n',
            "arm.tool: unknown key 'positon_mm' \\(arm.tool takes approach_axis, position_mm, "
            "radius_mm, rotation_deg\\)$",
        ),
        (GOOD.replace("[100, 200, 300]", '[100, "a", 300]'), "tasks.reach.target_mm"),
        (
            'name = "w"\n[[obstacles]]\ntype = "hollow_frustum"\nname = "w"\n'
            "base_center = [0, 0, 0]\nheight = 10\nr_bottom = 5\nr_top = 5\nwall = -1\n",
            "wall: Input should be greater than 0",
        ),
    ],
)
def test_bad_scene_files_name_the_problem(tmp_path, text, message):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match=message):
        load_scene(f)


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "nope.toml")


@pytest.mark.parametrize(
    ("arm", "message"),
    [
        ("tick = -0.1", r"ticks must be finite and > 0 \(deg, mm for a prismatic joint\), got "
         r"\[-0.1, -0.1, -0.1, -0.1, -0.1, -0.1\]$"),
        ("max_ticks = 1000000000000", r"max ticks per command must be in \[1, 1,000,000\]"),
        ("steps_per_tick = 100000000000000", r"steps per tick must be whole numbers in "
         r"\[1, 1,000,000\]"),
    ],
)  # fmt: skip
def test_an_arms_lattice_is_refused_in_the_units_and_limits_written(tmp_path, arm, message):
    """A negative tick was shown in rad ([-0.0017453292519943296, ...]); a count of ticks or
    steps above 1e9 was refused as 'beyond the largest coordinate or size a scene may use
    (1e+09 mm)', where the lattice's own limit is a million."""
    from armpath.errors import InvalidInputError
    from armpath.scenes.arm import scene_arm

    f = tmp_path / "arm.toml"
    f.write_text(f'name = "a"\n[arm]\nmodel = "ur5"\n{arm}\n')
    with pytest.raises(InvalidInputError, match=message):
        scene_arm(load_scene(f))


def test_a_scenes_tool_is_carried_from_the_flange_of_a_dh_table_and_of_a_urdf(tmp_path):
    """A scene's ``[arm] tool`` replaced everything after the last joint frame: a D-H table's
    last a and alpha (a KUKA-like alpha6 = 180 deg turned the tool back into the forearm) and
    a URDF's fixed joints up to its tip link (a 60 mm flange lost). It is now carried from the
    flange, as the README says: the tool point at home is the textbook D-H product (and the
    URDF chain multiplied out here) times the tool, in the scene's base placement."""
    import json

    from armpath.kinematics import tool_pose
    from armpath.scenes.arm import scene_arm
    from independent_dh import _rx, _rz, _tx, _tz, dh_pose

    D = np.pi / 180
    a, alpha, d = [260, 680, -35, 0, 0, 12], [-90, 0, 90, -90, 90, 180], [675, 0, 0, 670, 0, 158]
    (tmp_path / "kr.json").write_text(json.dumps({
        "name": "kr", "convention": "standard", "units": {"length": "mm", "angle": "deg"},
        "links": [{"a": x, "alpha": y, "d": z} for x, y, z in zip(a, alpha, d, strict=True)],
    }))  # fmt: skip
    tool = _tx(5.0) @ _tz(100.0) @ _rx(30 * D)
    base = _tz(400.0) @ _rz(90 * D)
    (tmp_path / "kr.toml").write_text(
        'name = "kr"\n[arm]\nmodel = "kr.json"\n'
        "base = { position_mm = [0, 0, 400], rotation_deg = [0, 0, 90] }\n"
        "tool = { position_mm = [5, 0, 100], rotation_deg = [30, 0, 0] }\n"
    )
    arm = scene_arm(load_scene(tmp_path / "kr.toml"))
    q = np.array([10.0, -30.0, 20.0, 40.0, -50.0, 60.0]) * D
    truth = base @ dh_pose(a, np.array(alpha) * D, d, q) @ tool
    np.testing.assert_allclose(tool_pose(arm, q), truth, atol=1e-9)

    (tmp_path / "bot.urdf").write_text(
        '<robot name="bot"><link name="b"/><link name="l1"/><link name="l2"/><link name="f"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="l1"/>'
        '<origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
        '<origin xyz="0.4 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        '<joint name="flange" type="fixed"><parent link="l2"/><child link="f"/>'
        '<origin xyz="0.06 0 0" rpy="0 -0.5235987755982988 0"/></joint></robot>'
    )
    (tmp_path / "bot.toml").write_text(
        'name = "bot"\n[arm]\nmodel = "bot.urdf"\ntip_link = "f"\n'
        "tool = { position_mm = [0, 0, 100] }\n"
    )
    arm = scene_arm(load_scene(tmp_path / "bot.toml"))
    q = np.array([0.4, -0.7])
    ry = np.array([[np.cos(-np.pi / 6), 0, np.sin(-np.pi / 6), 0], [0, 1, 0, 0],
                   [-np.sin(-np.pi / 6), 0, np.cos(-np.pi / 6), 0], [0, 0, 0, 1.0]])  # fmt: skip
    truth = _tz(300.0) @ _rz(q[0]) @ _tx(400.0) @ _rx(np.pi / 2) @ _rz(q[1])
    truth = truth @ _tx(60.0) @ ry @ _tz(100.0)
    np.testing.assert_allclose(tool_pose(arm, q), truth, atol=1e-9)


def test_a_home_off_the_lattice_or_in_collision_is_named_where_it_is_written(tmp_path):
    """A scene's home_deg off the 0.1 deg lattice was refused as "the arm's home pose", naming
    neither the scene nor the key; a home in collision was "start state is in collision",
    and a trace scanned its curve for seconds before saying so. Both now say where to look,
    before any planning."""
    from cli_in_process import run_in_process

    head = 'name = "h"\n[[obstacles]]\ntype = "half_space"\nname = "table"\n'
    head += "point = [0, 0, 0]\nnormal = [0, 0, 1]\n"
    curve = '[tasks.trace.curve]\ntype = "polyline"\nname = "l"\n'
    curve += "points_mm = [[300, 0, 100], [300, 20, 100]]\n"
    (tmp_path / "off.toml").write_text(head + "[arm]\nhome_deg = [0, -90, 0, 0, -90.05, 0]\n")
    (tmp_path / "down.toml").write_text(head + "[arm]\nhome_deg = [0, 120, 0, 0, 0, 0]\n" + curve)
    r = run_in_process(["reach", "300", "100", "200", "--scene", "off.toml"], tmp_path)
    assert r.returncode == 1
    assert "scene off.toml: arm: arm.home_deg: joint 5 is not a whole number" in r.stderr
    r = run_in_process(["trace", "--scene", "down.toml", "--no-bound"], tmp_path)
    assert r.returncode == 1 and "reachability" not in r.stderr
    assert "start state is in collision" in r.stderr and "the arm's home pose" in r.stderr
    assert "[arm] home_deg" in r.stderr and "random poses" not in r.stderr


def test_an_arm_whose_base_stands_too_near_an_obstacle_is_told_to_move_the_base(tmp_path):
    """The PUMA 560's D-H base frame is its shoulder: set on the UR5 cell's pedestal top (z =
    250 mm) its upper arm's capsule (radius 80 mm) holds the shoulder, which lies on the
    pedestal's face, so it reaches 80 mm into the pedestal at every pose. The start was refused
    with the advice to move the home, which no home can mend; it now says to move the base.
    The advice mends it: raised by the trunk's height, the arm stands on the pedestal."""
    from armpath.model.catalog import PUMA560_LINK_RADII_MM, PUMA560_PEDESTAL_MM
    from cli_in_process import run_in_process

    cell = (Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml").read_text()
    puma = re.sub(r"\nhome_deg = .*\n", "\n", cell.replace('model = "ur5"', 'model = "puma560"'))
    (tmp_path / "puma.toml").write_text(puma)
    r = run_in_process(["spotweld", "--scene", "puma.toml"], tmp_path)
    assert r.returncode == 1 and r.stderr.count("error:") == 1
    depth = PUMA560_LINK_RADII_MM[2]  # the shoulder on the face: the capsule's whole radius
    assert f"L2a is {-depth:.3f} mm from pedestal" in r.stderr
    assert "every one of 64 random poses" in r.stderr and "[arm] base" in r.stderr
    assert "home_deg" not in r.stderr
    # the advice mends it: raised by the trunk's height, the arm stands on the pedestal
    raised = puma.replace("[-150, 0, 250]", f"[-150, 0, {250 + PUMA560_PEDESTAL_MM}]")
    (tmp_path / "raised.toml").write_text(raised)
    r = run_in_process(["reach", "450", "-150", "250", "--scene", "raised.toml"], tmp_path)
    assert r.returncode == 0, r.stderr


def test_links_too_thick_for_any_pose_are_named_not_the_base(tmp_path):
    """``--link-radius 1e6`` put every link into the seed scene's table at every pose, and the
    refusal told the user to move the arm's base. Where the link's radius is more than its
    capsule lacks at the best of the random poses (a bare segment would clear), the refusal
    names the radius; the PUMA on the pedestal above still hears of its base."""
    from cli_in_process import run_in_process

    r = run_in_process(["reach", "300", "100", "200", "--link-radius", "1e6"], tmp_path)
    assert r.returncode == 1 and r.stderr.count("error:") == 1
    assert "every one of 64 random poses" in r.stderr and "DE is 1e+06 mm thick" in r.stderr
    assert "--link-radius" in r.stderr and "move the base" not in r.stderr
    r = run_in_process(["reach", "300", "100", "200", "--link-radius", "2"], tmp_path)
    assert r.returncode == 0, r.stderr


def test_a_key_written_twice_true_for_a_number_and_a_device_for_a_mesh_are_refused(tmp_path):
    """YAML kept the last of a key written twice (TOML refuses it), ``radius = true`` was a
    sphere of 1 mm, and a mesh file that is a device was said not to exist. Each is refused by
    name; true and false where the field takes them (``open_top``) still load."""
    from armpath.errors import InvalidInputError

    twice = tmp_path / "twice.yaml"
    twice.write_text("name: x\nname: y\n")
    with pytest.raises(SceneError, match=r"key 'name' written twice"):
        load_scene(twice)
    truth = tmp_path / "truth.toml"
    truth.write_text(
        'name = "t"\n[[obstacles]]\ntype = "sphere"\nname = "b"\ncenter = [0, 500, 0]\n'
        "radius = true\n"
    )
    with pytest.raises(SceneError, match=r"radius: must be a number, not true"):
        load_scene(truth)
    truth.write_text(
        'name = "t"\n[[obstacles]]\ntype = "box"\nname = "b"\ncenter = [0, 500, false]\n'
        "size = [1, 1, 1]\n"
    )
    with pytest.raises(SceneError, match=r"center: must be a number, not false"):
        load_scene(truth)
    fine = tmp_path / "fine.toml"
    fine.write_text(
        'name = "f"\n[[obstacles]]\ntype = "hollow_frustum"\nname = "w"\n'
        "base_center = [300, 0, 0]\nheight = 100\nr_bottom = 80\nr_top = 60\nwall = 5\n"
        "open_top = false\n"
    )
    # a YAML merge key ('<<: *anchor') is no key written twice, and may be overridden
    merged = tmp_path / "merged.yaml"
    merged.write_text(
        "name: m\nobstacles:\n  - &s {type: sphere, name: a, center: [500, 0, 100], radius: 10}\n"
        "  - {<<: *s, name: b, radius: 20}\n"
    )
    first, b = load_scene(merged).world.obstacles
    assert (
        first.name == "a"
        and b.name == "b"
        and b.signed_distance(np.array([500.0, 0.0, 100.0])) == -20.0
    )
    # true where text goes is not 'a number'
    truth.write_text('name = "t"\n[[obstacles]]\ntype = "sphere"\nname = true\n'
                     "center = [0, 500, 0]\nradius = 1\n")  # fmt: skip
    with pytest.raises(SceneError) as text_error:
        load_scene(truth)
    assert "must be a number" not in str(text_error.value)
    (w,) = load_scene(fine).world.obstacles
    assert isinstance(w, HollowFrustum) and w.signed_distance(np.array([300.0, 0.0, 99.0])) < 0
    device = tmp_path / "device.toml"
    device.write_text('name = "d"\n[[obstacles]]\ntype = "mesh"\nname = "z"\nfile = "/dev/null"\n')
    with pytest.raises((SceneError, InvalidInputError), match=r"'/dev/null' is not a regular file"):
        load_scene(device)


def test_a_scene_circle_is_the_parametric_circle_written_out(tmp_path):
    """``type = "circle"`` in a scene: the same points as the parametric circle a user would
    otherwise write (x = cx + r cos t, y = cy + r sin t), closed, its definition in the result;
    an arc of it (``sweep_deg``) is open and ends where the parametric one does."""
    from armpath.geometry.curves import ParametricCurve

    f = tmp_path / "c.toml"
    for sweep, t1 in ((None, "6.283185307179586"), (120, "2.0943951023931953")):
        extra = "" if sweep is None else f", sweep_deg = {sweep}"
        f.write_text(
            GOOD + '[tasks.trace]\ncurve = { type = "circle", name = "ring", '
            f"center_mm = [330, 60, 260], radius_mm = 25{extra} }}\n"
        )
        curve = load_scene(f).trace_curve()
        written = ParametricCurve("p", "330 + 25*cos(t)", "60 + 25*sin(t)", "260", 0.0, float(t1))
        u = np.linspace(0.0, 1.0, 97)
        np.testing.assert_allclose(curve.points(u), written.points(u), atol=1e-9)
        assert curve.closed == (sweep is None) == written.closed
        assert curve.length == pytest.approx(written.length, rel=1e-9)
        assert curve.describe()["radius_mm"] == 25.0 and curve.describe()["type"] == "circle"


def test_a_scene_circle_with_no_radius_names_it(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text(GOOD + '[tasks.trace]\ncurve = { type = "circle", center_mm = [0, 0, 0] }\n')
    with pytest.raises(SceneError, match=r"tasks\.trace\.curve\.circle\.radius_mm: Field required"):
        load_scene(f)


def test_the_eight_weld_example_is_the_seed_scene_with_four_more_welds_on_its_inner_wall():
    """``examples/seed_eight_welds.toml`` (the README's eight-weld tour): the seed scene's
    obstacles and clearance, Task 3's four welds first, and four more, each on the workpiece's
    surface (its signed distance 0 at the weld) inside its inner radius at that height."""
    folder = Path(__file__).resolve().parents[1] / "examples"
    example = load_scene(folder / "seed_eight_welds.toml")
    seed = seed_scene()
    welds = example.spotweld_targets_mm()
    assert welds.shape == (8, 3)
    np.testing.assert_allclose(welds[:4], seed.spotweld_targets_mm())
    assert example.definition["obstacles"] == seed.definition["obstacles"]
    assert example.definition["clearance"] == seed.definition["clearance"]
    piece = next(o for o in example.world.obstacles if o.name == "workpiece")
    np.testing.assert_allclose(piece.signed_distance(welds), 0.0, atol=1e-9)
    radius = np.hypot(welds[:, 0] - 210.0, welds[:, 1])
    np.testing.assert_allclose(radius, piece.inner_radius(welds[:, 2]), atol=1e-9)
