"""Curves for tracing: the safe expression parser, arc length and closest points, the seed crack."""

import numpy as np
import pytest

import independent
from armpath.errors import ArmpathWarning, InvalidInputError
from armpath.geometry.curves import CircularArc, ParametricCurve, Polyline, seed_crack
from armpath.geometry.expressions import parse_expression
from armpath.scenes import seed_scene

WORKPIECE = seed_scene().world.obstacles[1]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("210 + 150*cos(t)", lambda t: 210 + 150 * np.cos(t)),
        ("-t**2 / 3 + sqrt(abs(t))", lambda t: -(t**2) / 3 + np.sqrt(np.abs(t))),
        ("atan2(sin(t), cos(t)) + pi - tau/2", lambda t: np.arctan2(np.sin(t), np.cos(t))),
        ("max(t, 0.5) * exp(-t) + 2e-3", lambda t: np.maximum(t, 0.5) * np.exp(-t) + 2e-3),
        ("7", lambda t: np.full_like(t, 7.0)),
    ],
)
def test_expressions_match_numpy(text, expected):
    t = np.linspace(-2, 2, 101)
    np.testing.assert_allclose(parse_expression(text)(t), expected(t), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("__import__('os').system('echo hi')", "unknown function"),
        ("t.__class__", "Attribute"),
        ("(lambda: 1)()", "unknown function"),
        ("[t for t in range(3)]", "ListComp"),
        ("x + 1", "unknown name 'x'"),
        ("sin(t, 2)", "takes 1"),
        ("sin(x=t)", "takes 1"),
        ("t[0]", "Subscript"),
        ("'abc'", "numbers"),
        ("2 +", "not valid arithmetic"),
        ("t if t > 0 else 0", "IfExp"),
        ("", "non-empty"),
        ("300+" + "-" * 1990 + "t", "nests deeper than 400"),  # was a RecursionError
        ("+".join(["t"] * 500), "nests deeper than 400"),
    ],
)
def test_expressions_refuse_everything_else(text, message):
    with pytest.raises(InvalidInputError, match=message):
        parse_expression(text)


def test_an_expression_nested_up_to_the_limit_evaluates():
    """400 levels (the limit) parse and evaluate: a sum of 401 terms and 400 unary minuses."""
    np.testing.assert_allclose(parse_expression("+".join(["t"] * 401))([0.5, 2.0]), [200.5, 802])
    np.testing.assert_allclose(parse_expression("-" * 400 + "t")([3.0]), [3.0])


def test_seed_crack_lies_on_the_outer_wall_and_the_plane():
    crack = seed_crack(WORKPIECE)
    assert crack.closed
    p = crack.sample(4001)
    np.testing.assert_allclose(p[:, 0], 2 * p[:, 2], atol=1e-9)
    # independent: on the outer cone r = 168 - 0.4 z around (210, 0), between z = 0 and 180
    r = np.hypot(p[:, 0] - 210, p[:, 1])
    np.testing.assert_allclose(r, 168 - 0.4 * p[:, 2], atol=1e-9)
    # the SPEC's end points of the curve in the plane y = 0
    d, _ = crack.closest([[52.5, 0, 26.25], [315, 0, 157.5]])
    np.testing.assert_allclose(d, 0, atol=1e-8)
    assert p[:, 2].min() == pytest.approx(26.25) and p[:, 2].max() == pytest.approx(157.5)
    # length against an independent parametrization: by z, y = +-sqrt(R(z)^2 - (2z - 210)^2)
    z = 26.25 + (157.5 - 26.25) * (0.5 - 0.5 * np.cos(np.linspace(0, np.pi, 400_001)))
    y = np.sqrt(np.maximum((168 - 0.4 * z) ** 2 - (2 * z - 210) ** 2, 0))
    half = np.stack([2 * z, y, z], axis=-1)
    length = 2 * np.linalg.norm(np.diff(half, axis=0), axis=-1).sum()
    assert crack.length == pytest.approx(length, rel=1e-7)
    # the workpiece's own distance puts the crack on its surface
    assert np.abs(independent.Workpiece("normal").distance(p)).max() < 1e-9


def test_arc_length_and_closest_points_on_a_helix():
    r, pitch, turns = 40.0, 25.0, 3.0
    helix = ParametricCurve(
        "helix", f"{r}*cos(t)", f"{r}*sin(t)", f"{pitch}*t/(2*pi)", 0, 2 * np.pi * turns
    )
    exact = turns * np.hypot(2 * np.pi * r, pitch)
    assert helix.length == pytest.approx(exact, rel=1e-7) and not helix.closed
    pts = helix.sample(301)
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=-1)
    assert steps.max() / steps.min() < 1 + 1e-4  # equal arc-length spacing
    # points pushed off the curve along the (horizontal) principal normal: distance = push
    t = np.linspace(0.3, 2 * np.pi * turns - 0.3, 50)
    on = np.stack([r * np.cos(t), r * np.sin(t), pitch * t / (2 * np.pi)], axis=-1)
    out = on + 5.0 * np.stack([np.cos(t), np.sin(t), 0 * t], axis=-1)
    d, s = helix.closest(out)
    np.testing.assert_allclose(d, 5.0, atol=1e-6)
    np.testing.assert_allclose(s, t * np.hypot(r, pitch / (2 * np.pi)), atol=1e-3)


def test_polyline():
    square = Polyline("square", [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]], closed=True)
    assert square.length == pytest.approx(40.0)
    d, s = square.closest([[5, -3, 0], [12, 5, 4], [-1, -1, 0]])
    np.testing.assert_allclose(d, [3, np.hypot(2, 4), np.sqrt(2)], atol=1e-9)
    np.testing.assert_allclose(s[:2], [5, 15], atol=1e-6)
    np.testing.assert_allclose(
        square.at_arc_length([0, 25, 40]), [[0, 0, 0], [5, 10, 0], [0, 0, 0]], atol=1e-9
    )
    with pytest.raises(InvalidInputError, match="all its 3 points are the same point"):
        Polyline("bad", [[1, 0, 0], [1, 0, 0], [1, 0, 0]])
    # each refusal says what is wrong ("need (V >= 2, 3) finite vertices" for all three)
    with pytest.raises(InvalidInputError, match="a curve needs at least 2 points, got 1"):
        Polyline("one", [[330, 60, 260]])
    with pytest.raises(InvalidInputError, match=r"3 coordinates \(x, y, z\), got .* \(2, 2\)"):
        Polyline("flat", [[0, 0], [1, 0]])
    with pytest.raises(InvalidInputError, match="a coordinate is not a finite number"):
        Polyline("nan", [[0, 0, 0], [1, np.nan, 0]])


def test_a_curve_shorter_than_the_least_length_is_refused():
    """0.1 mm is traced; 0.01 mm found no lattice state near it and failed with a message
    repeated for every scan point."""
    assert Polyline("ok", [[300, 0, 260], [300, 0.1, 260]]).length == pytest.approx(0.1)
    with pytest.raises(InvalidInputError, match=r"0\.01 mm long; a curve must be at least 0\.1"):
        _ = Polyline("tiny", [[300, 0, 260], [300, 0.01, 260]]).length


def test_the_tangent_of_a_curve_that_barely_moves_is_still_a_unit_vector():
    """x = 300 + t**1e6 stands still until the last table sample, where it moves 1 mm along x:
    the tangent, by differences 1e-3 mm apart, was 0/0 (a warning, then a failed trace with an
    empty reason); the step now widens until the curve moves."""
    import warnings

    from armpath.model.seed_arm import seed_arm
    from armpath.planning.trace.family import curve_family

    curve = ParametricCurve("plateau", "300 + t**1e6", "0", "260", 0.0, 1.0)
    assert curve.length == pytest.approx(1.0)
    fam = curve_family(seed_arm(), seed_scene().world, curve)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for s in (0.0, 0.5, 1.0):
            _, t, _ = fam.frame(s)
            np.testing.assert_allclose(t, [1.0, 0.0, 0.0], atol=1e-9)


def test_a_closed_polyline_may_repeat_its_first_vertex_and_repeated_points_are_dropped():
    """Closed by its own last vertex (as a drawing program writes it), a closed polyline is the
    same curve (the square's 40 mm); a point written twice in a row (a measured seam's log) is
    dropped with a warning naming it, where it was refused: the curve is the same set of
    points; a closed polyline of two vertices (there and back) is refused."""
    square = [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]]
    a = Polyline("a", square, closed=True)
    b = Polyline("b", [*square, square[0]], closed=True)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert abs(b.length - 40.0) < 1e-9
    with pytest.warns(ArmpathWarning, match=r"2 point\(s\) the same as the one before dropped "):
        c = Polyline("c", [[0, 0, 0], [1, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0, 0]])
    np.testing.assert_array_equal(c.vertices, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    assert abs(c.length - 2.0) < 1e-12
    with pytest.warns(ArmpathWarning, match=r"\(points 5, counted from 1\)"):
        d = Polyline("d", [*square, square[-1], square[0]])
    assert d.closed and abs(d.length - 40.0) < 1e-9  # the repeat, then the closing point
    with pytest.raises(InvalidInputError, match="3 or more vertices"):
        Polyline("e", [[0, 0, 0], [1, 0, 0]], closed=True)
    # coinciding points named by their places among the points given (a repeat dropped
    # before them, the last within rounding of the first closing the curve onto it)
    with (
        pytest.warns(ArmpathWarning),
        pytest.raises(InvalidInputError, match=r"points 5 and 1 \(counted from 1\) are the same"),
    ):
        Polyline("f", [[0, 0, 0], [0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [0, 0, 4e-7]])


def test_points_whose_last_is_their_first_are_a_closed_curve():
    """A points table that writes its first point again at its end (a circle exported point by
    point) was an open curve from that point round to itself: a pass could begin only at that
    end, and the SO-100 tracing such a circle at 0.3 mm left its first 0.05 mm untraced. It is
    closed now, as a parametric curve whose ends meet is: the same vertices and length as
    when closed is asked, and a closest point just before the end is found just before the
    start. Three points there and back stay open (a closed curve needs three vertices)."""
    square = [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]]
    asked = Polyline("asked", square, closed=True)
    for end in ([0.0, 0.0, 0.0], [0.0, 0.0, 4e-7]):  # exactly, or within rounding
        written = Polyline("written", [*square, end])
        assert written.closed and abs(written.length - 40.0) < 1e-6
        np.testing.assert_array_equal(written.vertices, asked.vertices)
        assert abs(float(written.wrap(41.0)) - 1.0) < 1e-9
    assert not Polyline("near", [*square, [0.0, 0.0, 0.01]]).closed  # 10 um apart: open
    assert not Polyline("back", [[0, 0, 0], [10, 0, 0], [0, 0, 0]]).closed


def test_the_table_follows_a_curve_that_turns_fast_or_refuses_it():
    """The arc-length table doubles its points until the curve measured through the midpoints
    of its intervals is no longer (to 1e-4): a helix of 1,000 turns gets its length to 1e-4 of
    the closed form (the first 20,001 points were 0.4 % short); a polyline's table has every
    vertex, so its length is its pieces' sum exactly; a circle wound 160,000 times over t in
    [0, 1e6] (its length was 0.5 % of the true one) is refused, naming what to change."""
    from armpath.geometry.curves import TABLE_SAMPLES

    helix = ParametricCurve(
        "helix", "300 + 50*cos(t)", "50*sin(t)", "200 + t/10", 0.0, 2000 * np.pi
    )
    assert helix.length == pytest.approx(1000 * np.hypot(100 * np.pi, np.pi / 5), rel=1e-4)
    lifted = helix.points(np.array([0.123456, 0.654321])) + np.array([0.0, 0.0, 0.05])
    d, _ = helix.closest(lifted)
    np.testing.assert_allclose(d, 0.05 * np.cos(np.arctan2(0.1, 50.0)), rtol=1e-4)
    circle = ParametricCurve("circle", "300 + 50*cos(t)", "50*sin(t)", "200", 0.0, 2 * np.pi)
    assert circle._table[0].size == TABLE_SAMPLES  # a curve the first table follows keeps it
    walk = np.cumsum(np.random.default_rng(0).normal(size=(3000, 3)), axis=0) * 5.0
    poly = Polyline("walk", walk)
    assert poly.length == pytest.approx(np.linalg.norm(np.diff(walk, axis=0), axis=1).sum(), 1e-12)
    wound = ParametricCurve("wound", "300 + 50*cos(t)", "50*sin(t)", "200", 0.0, 1e6)
    with pytest.raises(InvalidInputError, match="turns faster than 320,001 points along it"):
        _ = wound.length


def test_a_polyline_of_more_vertices_than_the_limit_is_refused():
    """Its table holds every vertex: 2,000,000 vertices took 429 MB; the limit is 1,000,000."""
    many = np.zeros((1_000_001, 3))
    many[:, 0] = np.arange(1_000_001) * 0.01
    with pytest.raises(InvalidInputError, match=r"1,000,001 \(the limit is 1,000,000\)"):
        Polyline("many", many)


def test_too_deeply_nested_parentheses_are_one_short_error():
    """Python's parser takes at most 200 levels of parentheses: 300 were refused as "too many
    nested parentheses" with the whole 600-character expression repeated; now the limit is
    named and the expression shortened. 150 levels parse and evaluate."""
    from armpath.errors import InvalidInputError
    from armpath.geometry.expressions import parse_expression

    with pytest.raises(InvalidInputError) as err:
        parse_expression("(" * 300 + "t" + ")" * 300)
    said = str(err.value)
    assert "at most 200 levels of parentheses" in said and len(said) < 200
    assert float(parse_expression("(" * 150 + "t" + ")" * 150)(np.array([2.0]))[0]) == 2.0


def test_a_circle_and_its_arcs_lie_where_a_rotation_about_the_normal_puts_them():
    """A circle given by centre, radius and normal (a tilted one, from a start direction not in
    its plane): every point lies at the radius in the plane, the length is 2 pi r, and the point
    a quarter of the way round is the start rotated 90 deg about the normal (scipy's rotation);
    an arc of 90 deg is open, pi r / 2 long, and ends there."""
    from scipy.spatial.transform import Rotation

    c, n = np.array([400.0, -50.0, 250.0]), np.array([1.0, 2.0, 2.0]) / 3.0
    circle = CircularArc("ring", c, 30.0, 3.0 * n, start_direction=np.array([0.0, 0.0, 1.0]))
    p = circle.sample(721)
    np.testing.assert_allclose(np.linalg.norm(p - c, axis=1), 30.0, atol=1e-9)
    np.testing.assert_allclose((p - c) @ n, 0.0, atol=1e-9)
    assert circle.closed and circle.length == pytest.approx(2 * np.pi * 30.0, rel=1e-6)
    z = np.array([0.0, 0.0, 1.0])
    start = c + 30.0 * (z - (z @ n) * n) / np.linalg.norm(z - (z @ n) * n)
    quarter = c + Rotation.from_rotvec(np.pi / 2 * n).apply(start - c)
    np.testing.assert_allclose(circle.points(np.array([0.0, 0.25])), [start, quarter], atol=1e-9)
    arc = CircularArc("arc", c, 30.0, n, start_direction=np.array([0.0, 0.0, 1.0]), sweep_deg=90)
    assert not arc.closed and arc.length == pytest.approx(np.pi * 30.0 / 2, rel=1e-6)
    np.testing.assert_allclose(arc.at_arc_length(np.array([arc.length])), [quarter], atol=1e-6)
    d, s = arc.closest(np.array([quarter + 0.1 * n]))
    assert d[0] == pytest.approx(0.1, abs=1e-6) and s[0] == pytest.approx(arc.length, abs=1e-3)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"radius": 0.0}, "the radius must be above 0"),
        ({"radius": float("nan")}, "the radius must be above 0"),
        ({"normal": np.zeros(3)}, "the normal has no direction"),
        ({"sweep_deg": 400.0}, "the sweep must be above 0 and at most 360 deg, got 400"),
        ({"start_direction": np.array([0.0, 0.0, -2.0])}, "the start direction lies along"),
    ],
)
def test_a_circle_that_is_no_circle_is_refused(kwargs, message):
    given = {"radius": 10.0, "normal": np.array([0.0, 0.0, 1.0]), **kwargs}
    with pytest.raises(InvalidInputError, match=message):
        CircularArc("c", np.zeros(3), **given)


def test_a_polylines_corners_are_its_turning_vertices():
    """``corners_mm``: the arc lengths of the vertices where a polyline turns (on a closed one
    also its first, at 0 mm); a vertex on a straight run is none, nor is an open one's end;
    smooth curves have none."""
    square = Polyline(
        "sq", np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]]), closed=True
    )
    np.testing.assert_allclose(square.corners_mm, [0.0, 10.0, 20.0, 30.0])
    bent = Polyline("bent", np.array([[0.0, 0, 0], [3, 0, 0], [5, 0, 0], [5, 4, 0]]))
    np.testing.assert_allclose(bent.corners_mm, [5.0])
    straight = Polyline("line", np.array([[0.0, 0, 0], [1, 1, 1], [2, 2, 2]]))
    assert straight.corners_mm.size == 0
    assert CircularArc("c", [0.0, 0, 0], 5.0).corners_mm.size == 0
