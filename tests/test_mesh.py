"""Mesh obstacles and enclosing proxies against independent truth.

Truth comes from analytic solids that bracket the mesh (an inscribed polyhedron lies between
the balls/cylinders of its inradius and circumradius), trimesh's brute-force closest point,
python-fcl's segment distance, dense sampling along segments, and optimality conditions or
scipy optimisation for the proxies.
"""

import json
import pickle

import fcl
import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize, nnls
from scipy.spatial.transform import Rotation

from armpath.errors import InvalidInputError
from armpath.geometry.mesh import MeshObstacle, load_mesh
from armpath.geometry.primitives import Sphere
from armpath.geometry.proxies import (
    enclosing_cylinder,
    enclosing_frustum,
    enclosing_proxies,
    enclosing_sphere,
)

R_BALL = 10.0
BOX = np.array([8.0, 12.0, 6.0])  # full extents
R_CYL, H_CYL, N_CYL = 5.0, 20.0, 64


def _ball_mesh() -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=2, radius=R_BALL)


def _box_mesh() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=BOX)


def _cylinder_mesh() -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=R_CYL, height=H_CYL, sections=N_CYL)


def _torus_mesh() -> trimesh.Trimesh:
    return trimesh.creation.torus(
        major_radius=10, minor_radius=3, major_sections=24, minor_sections=12
    )


MESHES = {
    "ball": _ball_mesh(),
    "box": _box_mesh(),
    "cylinder": _cylinder_mesh(),
    "torus": _torus_mesh(),
}
OBSTACLES = {k: MeshObstacle.from_trimesh(m, k) for k, m in MESHES.items()}


# ------------------------------------------------------------------------------------------
# independent analytic distances
# ------------------------------------------------------------------------------------------


def box_sd(x, extents=BOX):
    q = np.abs(x) - extents / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    return outside + np.minimum(q.max(axis=-1), 0.0)


def cylinder_sd(x, radius, height):
    dr = np.hypot(x[..., 0], x[..., 1]) - radius
    dz = np.abs(x[..., 2]) - height / 2
    outside = np.hypot(np.maximum(dr, 0.0), np.maximum(dz, 0.0))
    return outside + np.minimum(np.maximum(dr, dz), 0.0)


def ball_inradius(mesh):
    """Distance from the centre to the nearest face plane (the inscribed ball's radius)."""
    n = mesh.face_normals
    return float(np.min(np.abs(np.einsum("fi,fi->f", n, mesh.triangles[:, 0]))))


# ------------------------------------------------------------------------------------------
# (a) point signed distances
# ------------------------------------------------------------------------------------------


def test_box_signed_distance_is_exact():
    rng = np.random.default_rng(1)
    x = rng.uniform(-12, 12, (3000, 3))
    np.testing.assert_allclose(OBSTACLES["box"].signed_distance(x), box_sd(x), atol=1e-9)


def test_ball_signed_distance_within_discretisation():
    mesh = MESHES["ball"]
    r_in = ball_inradius(mesh)
    rng = np.random.default_rng(2)
    x = rng.normal(size=(1500, 3))
    x *= rng.uniform(0, 2 * R_BALL, (1500, 1)) / np.linalg.norm(x, axis=-1, keepdims=True)
    d = OBSTACLES["ball"].signed_distance(x)
    r = np.linalg.norm(x, axis=-1)
    # ball(r_in) ⊆ mesh ⊆ ball(R): the signed distance lies between theirs
    assert np.all(d >= r - R_BALL - 1e-9)
    assert np.all(d <= r - r_in + 1e-9)
    assert np.all(d[r < r_in] < 0) and np.all(d[r > R_BALL] > 0)
    # magnitude = trimesh's brute-force distance to the nearest triangle
    _, ref, _ = trimesh.proximity.closest_point_naive(mesh, x)
    np.testing.assert_allclose(np.abs(d), ref, atol=1e-9)


def test_cylinder_signed_distance_within_discretisation():
    rng = np.random.default_rng(3)
    x = np.column_stack(
        [rng.uniform(-9, 9, 3000), rng.uniform(-9, 9, 3000), rng.uniform(-14, 14, 3000)]
    )
    d = OBSTACLES["cylinder"].signed_distance(x)
    r_in = R_CYL * np.cos(np.pi / N_CYL)  # inradius of the inscribed regular polygon
    assert np.all(d >= cylinder_sd(x, R_CYL, H_CYL) - 1e-9)
    assert np.all(d <= cylinder_sd(x, r_in, H_CYL) + 1e-9)


def test_torus_signs_match_the_analytic_torus():
    mesh = MESHES["torus"]
    rng = np.random.default_rng(4)
    x = rng.uniform(-15, 15, (1500, 3))
    x[:, 2] /= 3
    analytic = np.hypot(np.hypot(x[:, 0], x[:, 1]) - 10, x[:, 2]) - 3
    d = OBSTACLES["torus"].signed_distance(x)
    clear = np.abs(analytic) > 0.5  # far beyond the facets' deviation from the torus
    assert np.all(np.sign(d[clear]) == np.sign(analytic[clear]))
    _, ref, _ = trimesh.proximity.closest_point_naive(mesh, x)
    np.testing.assert_allclose(np.abs(d), ref, atol=1e-9)


def test_shapes_broadcast_and_contains():
    obs = OBSTACLES["box"]
    x = np.zeros((2, 5, 3))
    x[1] = 100
    assert obs.signed_distance(x).shape == (2, 5)
    assert obs.contains(x).tolist() == [[True] * 5, [False] * 5]
    assert obs.signed_distance(np.zeros(3)).shape == ()


@settings(max_examples=25, deadline=None)
@given(
    rotvec=st.lists(st.floats(-3, 3), min_size=3, max_size=3),
    shift=st.lists(st.floats(-50, 50), min_size=3, max_size=3),
    seed=st.integers(0, 2**32 - 1),
)
def test_posed_box_matches_analytic(rotvec, shift, seed):
    rot = Rotation.from_rotvec(rotvec).as_matrix()
    box = _box_mesh()
    obs = MeshObstacle("posed", box.vertices @ rot.T + shift, box.faces)
    local = np.random.default_rng(seed).uniform(-10, 10, (200, 3))
    np.testing.assert_allclose(obs.signed_distance(local @ rot.T + shift), box_sd(local), atol=1e-9)


def test_inward_wound_mesh_is_flipped():
    box = _box_mesh()
    flipped = MeshObstacle("flipped", box.vertices, box.faces[:, ::-1])
    x = np.random.default_rng(5).uniform(-10, 10, (500, 3))
    np.testing.assert_allclose(flipped.signed_distance(x), box_sd(x), atol=1e-9)


def test_invalid_meshes_are_rejected():
    box = _box_mesh()
    with pytest.raises(InvalidInputError, match="watertight"):
        MeshObstacle("open", box.vertices, box.faces[1:])
    bad = box.faces.copy()
    bad[0] = bad[0, ::-1]
    with pytest.raises(InvalidInputError, match="consistently wound"):
        MeshObstacle("twisted", box.vertices, bad)
    with pytest.raises(InvalidInputError, match="empty"):
        MeshObstacle("empty", np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
    with pytest.raises(InvalidInputError, match="indices"):
        MeshObstacle("indices", box.vertices, box.faces + 100)
    with pytest.raises(InvalidInputError, match=r"trimesh\.Trimesh"):
        MeshObstacle.from_trimesh(box.vertices, "array")


# ------------------------------------------------------------------------------------------
# (b) segment distances
# ------------------------------------------------------------------------------------------


def _random_segments(rng, n, spread, length):
    a = rng.uniform(-spread, spread, (n, 3))
    return a, a + rng.normal(size=(n, 3)) * length


def _sampled_min(obs, a, b, n=2000):
    t = np.linspace(0.0, 1.0, n)
    pts = a[:, None, :] + t[:, None] * (b - a)[:, None, :]
    return obs.signed_distance(pts).min(axis=-1)


@pytest.mark.parametrize("name", ["ball", "box", "cylinder", "torus"])
def test_segment_distance_against_sampling(name):
    obs = OBSTACLES[name]
    rng = np.random.default_rng(11)
    a, b = _random_segments(rng, 12, 16.0, 6.0)
    # and segments starting near the surface, many of them entering the solid
    a2 = trimesh.sample.sample_surface(MESHES[name], 12, seed=5)[0] + rng.normal(size=(12, 3))
    a, b = np.vstack([a, a2]), np.vstack([b, a2 + rng.normal(size=(12, 3)) * 6.0])
    value, lower = obs.segment_distance_bounds(a, b)
    sampled = _sampled_min(obs, a, b)
    half_step = np.linalg.norm(b - a, axis=-1) / 1999 / 2
    assert np.all(lower <= value)
    assert np.all(lower <= sampled + 1e-9)  # a proven lower bound of the true minimum
    clear = value > 0
    assert clear.sum() >= 4 and (~clear).sum() >= 4  # both kinds are exercised
    # clear segments: exact minimum, below every sample, within the sampling's Lipschitz slack
    assert np.all(value[clear] <= sampled[clear] + 1e-9)
    assert np.all(sampled[clear] - value[clear] <= half_step[clear] + 1e-9)
    assert np.all(value[clear] - lower[clear] <= 1e-6)
    # touching or entering the solid: a negative value the segment attains, so not below the
    # true minimum, itself at most half a sample step below the sampled one; no lower bound
    assert np.all(value[~clear] <= 0)
    assert np.all(value[~clear] >= sampled[~clear] - half_step[~clear] - 1e-9)
    assert np.all(lower[~clear] == -np.inf)
    # asked to certify, the generic sampling gives a proven bound and refines the value
    value_c, lower_c = obs.segment_distance_bounds(a, b, certify=0.5)
    assert np.all(value_c <= value) and np.all(lower_c <= value_c)
    assert np.all(lower_c <= sampled + 1e-9) and np.all(lower_c[~clear] > -np.inf)
    assert np.all(value_c[~clear] >= sampled[~clear] - half_step[~clear] - 1e-9)
    np.testing.assert_array_equal(value_c[clear], value[clear])
    if name != "torus":  # convex: the refined samples find the minimum
        assert np.all(value_c[~clear] <= sampled[~clear] + 1e-6)


def _fcl_segment_distance(mesh, a, b):
    model = fcl.BVHModel()
    model.beginModel(len(mesh.vertices), len(mesh.faces))
    model.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int32))
    model.endModel()
    target = fcl.CollisionObject(model, fcl.Transform())
    out = []
    for p, q in zip(a, b, strict=True):
        d = q - p
        length = np.linalg.norm(d)
        rot = Rotation.align_vectors([d / length], [[0.0, 0.0, 1.0]])[0].as_matrix()
        seg = fcl.CollisionObject(fcl.Capsule(0.0, length), fcl.Transform(rot, (p + q) / 2))
        out.append(fcl.distance(seg, target, fcl.DistanceRequest(), fcl.DistanceResult()))
    return np.array(out)


@pytest.mark.parametrize("name", ["ball", "cylinder", "torus"])
def test_clear_segment_distance_matches_fcl(name):
    obs = OBSTACLES[name]
    rng = np.random.default_rng(12)
    a, b = _random_segments(rng, 60, 25.0, 8.0)
    value, _ = obs.segment_distance_bounds(a, b)
    clear = value > 0.05
    assert clear.sum() > 20
    ref = _fcl_segment_distance(MESHES[name], a[clear], b[clear])
    np.testing.assert_allclose(value[clear], ref, atol=1e-8)


def test_segment_inside_the_solid():
    obs = OBSTACLES["box"]
    a = np.array([[-3.0, -5.0, -2.0], [0.0, 0.0, 0.0]])
    b = np.array([[3.0, 4.0, 1.0], [0.0, 0.0, 0.0]])  # the second is a point at the centre
    value, lower = obs.segment_distance_bounds(a, b)
    assert np.all(value < 0) and np.all(lower == -np.inf)
    value, lower = obs.segment_distance_bounds(a, b, certify=0.0)
    # the segment passes (1, 1, 0) at t = 2/3, where the box's signed distance is -3, its least
    assert box_sd(a[0] + 2 / 3 * (b[0] - a[0])) == pytest.approx(-3.0)
    assert value[0] == pytest.approx(-3.0, abs=1e-6)
    assert value[1] == pytest.approx(-3.0, abs=1e-9)
    assert np.all(lower <= value) and np.all(lower >= value - 0.01)


def test_zero_length_segment_and_broadcasting():
    obs = OBSTACLES["ball"]
    p = np.array([[30.0, 1.0, 2.0], [0.0, 25.0, 0.0]])
    np.testing.assert_allclose(obs.segment_distance(p, p), obs.signed_distance(p), atol=1e-9)
    p0 = np.random.default_rng(13).uniform(-20, 20, (5, 1, 3))
    p1 = np.random.default_rng(14).uniform(-20, 20, (4, 3))
    value, lower = obs.segment_distance_bounds(p0, p1)
    assert value.shape == lower.shape == (5, 4)
    flat, _ = obs.segment_distance_bounds(
        np.broadcast_to(p0, (5, 4, 3)).reshape(-1, 3), np.broadcast_to(p1, (5, 4, 3)).reshape(-1, 3)
    )
    np.testing.assert_allclose(value.reshape(-1), flat)


def test_small_and_large_batches_agree():
    obs = OBSTACLES["torus"]
    rng = np.random.default_rng(15)
    a, b = _random_segments(rng, 40, 25.0, 8.0)
    b[3] = a[3]  # a point
    b[4] = a[4] + [5.0, 0.01, 0.0]  # nearly along x
    big, _ = obs.segment_distance_bounds(a, b)
    small = np.concatenate(
        [obs.segment_distance_bounds(a[i : i + 4], b[i : i + 4])[0] for i in range(0, 40, 4)]
    )
    np.testing.assert_allclose(big, small, atol=1e-9)


def test_broad_phase_bounds_are_honest():
    mesh = _cylinder_mesh()
    exact_obs = MeshObstacle.from_trimesh(mesh, "exact")
    fast = MeshObstacle.from_trimesh(mesh, "fast", broad_phase_cutoff=2.0)
    rng = np.random.default_rng(16)
    a, b = _random_segments(rng, 80, 30.0, 5.0)
    exact, _ = exact_obs.segment_distance_bounds(a, b)
    value, lower = fast.segment_distance_bounds(a, b)
    sphere = fast.bounding_sphere
    proxy = sphere.segment_distance(a, b)
    far = proxy > 2.0
    assert 10 < far.sum() < 80
    np.testing.assert_allclose(lower[far], proxy[far])
    assert np.all(lower[far] <= exact[far] + 1e-9)
    assert np.all(value[far] >= exact[far] - 1e-9)  # attained, so never below the minimum
    np.testing.assert_allclose(value[~far], exact[~far], atol=1e-12)
    # a requested certification above the proxy bound forces the exact distance
    value_c, _ = fast.segment_distance_bounds(a, b, certify=proxy + 1.0)
    np.testing.assert_allclose(value_c, exact, atol=1e-12)


def test_pickle_round_trip():
    obs = OBSTACLES["torus"]
    again = pickle.loads(pickle.dumps(obs))
    a, b = _random_segments(np.random.default_rng(17), 10, 20.0, 5.0)
    np.testing.assert_array_equal(again.segment_distance(a, b), obs.segment_distance(a, b))


def test_describe_is_plain_json():
    info = OBSTACLES["ball"].describe()
    assert json.loads(json.dumps(info)) == info
    assert info["type"] == "mesh" and info["source"] is None
    assert info["faces"] == 320 and info["vertices"] == 162
    assert info["bounding_sphere"]["radius"] == pytest.approx(R_BALL)


# ------------------------------------------------------------------------------------------
# (c) proxies
# ------------------------------------------------------------------------------------------


def _assert_contains(proxy, points, scale):
    assert np.all(proxy.signed_distance(points) <= 1e-9 * scale)


@pytest.mark.parametrize("name", ["ball", "box", "cylinder", "torus"])
def test_mesh_proxies_contain_the_mesh(name):
    obs = OBSTACLES[name]
    proxies = obs.proxies()
    scale = float(np.ptp(obs.vertices, axis=0).max())
    for proxy in (proxies.sphere, proxies.cylinder, proxies.frustum):
        _assert_contains(proxy, obs.vertices, scale)
        # the mesh is inside the proxy, so the proxy's distance is a lower bound
        x = np.random.default_rng(18).uniform(-25, 25, (400, 3))
        assert np.all(proxy.signed_distance(x) <= obs.signed_distance(x) + 1e-9)
    assert proxies.frustum.profile[:, 0].min() >= 0


def _minimax_radius(points):
    """Smallest enclosing radius by scipy (epigraph form: min t s.t. |p - c|^2 <= t)."""
    c0 = points.mean(axis=0)
    t0 = float(np.max(np.sum((points - c0) ** 2, axis=-1)))
    res = minimize(
        lambda z: z[3],
        np.r_[c0, t0],
        jac=lambda z: np.r_[0.0, 0.0, 0.0, 1.0],
        constraints=[{"type": "ineq", "fun": lambda z: z[3] - np.sum((points - z[:3]) ** 2, -1)}],
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 500},
    )
    return float(np.sqrt(np.max(np.sum((points - res.x[:3]) ** 2, axis=-1))))


def _assert_minimal_sphere(points, center, radius):
    d = np.linalg.norm(points - center, axis=-1)
    assert np.all(d <= radius * (1 + 1e-12))
    # optimality: the centre is a convex combination of the points on the sphere
    support = points[d >= radius * (1 - 1e-9)]
    assert len(support) >= 2 or radius == 0
    matrix = np.vstack([support.T, np.ones(len(support))])
    _, residual = nnls(matrix, np.r_[center, 1.0])
    assert residual <= 1e-7 * max(radius, 1.0)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 60),
    stretch=st.lists(st.floats(0.01, 10.0), min_size=3, max_size=3),
)
def test_enclosing_sphere_is_minimal(seed, n, stretch):
    pts = np.random.default_rng(seed).normal(size=(n, 3)) * stretch
    center, radius = enclosing_sphere(pts)
    _assert_minimal_sphere(pts, center, radius)
    if n >= 2:
        assert radius <= _minimax_radius(pts) * (1 + 1e-6)


def test_enclosing_sphere_known_cases():
    c, r = enclosing_sphere([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(c, [1, 2, 3])
    assert r == 0
    c, r = enclosing_sphere([[0.0, 0, 0], [4.0, 0, 0], [1.0, 0.5, 0]])  # obtuse: a diameter
    np.testing.assert_allclose(c, [2, 0, 0], atol=1e-12)
    assert r == pytest.approx(2.0)
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    c, r = enclosing_sphere(tet)
    np.testing.assert_allclose(c, 0, atol=1e-12)
    assert r == pytest.approx(np.sqrt(3))
    # trimesh's furthest-site Voronoi estimate is an upper bound of the minimum
    pts = np.random.default_rng(19).normal(size=(300, 3)) * [1, 2, 5]
    _, r_trimesh = trimesh.nsphere.minimum_nsphere(pts)
    assert enclosing_sphere(pts).radius <= r_trimesh + 1e-12
    with pytest.raises(InvalidInputError):
        enclosing_sphere(np.zeros((0, 3)))
    with pytest.raises(InvalidInputError):
        enclosing_sphere([[np.nan, 0, 0]])


def test_enclosing_cylinder_of_a_cylinder():
    fit = enclosing_cylinder(MESHES["cylinder"].vertices)
    assert abs(fit.axis @ [0, 0, 1]) == pytest.approx(1.0, abs=1e-6)
    assert fit.radius == pytest.approx(R_CYL, rel=1e-5)
    assert fit.height == pytest.approx(H_CYL, rel=1e-5)
    assert np.linalg.norm(fit.axis) == pytest.approx(1.0)
    top = fit.origin + fit.height * fit.axis
    assert {round(float(fit.origin[2])), round(float(top[2]))} == {-10, 10}


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(5, 80))
def test_cylinder_and_frustum_contain_random_points(seed, n):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) * rng.uniform(0.1, 5, 3)
    scale = float(np.ptp(pts, axis=0).max())
    cyl = enclosing_cylinder(pts)
    _assert_contains(cyl.solid("c"), pts, scale)
    # the radius about the fitted axis is the smallest enclosing circle's (not more than trimesh)
    ref = trimesh.bounds.minimum_cylinder(pts)
    assert cyl.volume <= np.pi * ref["radius"] ** 2 * ref["height"] * (1 + 1e-9)
    fr = enclosing_frustum(pts, cyl.axis)
    assert fr.r_bottom >= 0 and fr.r_top >= 0
    _assert_contains(fr.solid("f"), pts, scale)
    assert fr.volume <= cyl.volume * (1 + 1e-9)  # the cylinder is one of the candidate frustums
    assert fr.volume <= _frustum_volume_by_scipy(pts, fr.origin, fr.axis, fr.height) * (1 + 1e-6)


def _frustum_volume_by_scipy(pts, origin, axis, height):
    rel = pts - origin
    h = rel @ axis
    r = np.linalg.norm(rel - h[:, None] * axis, axis=-1)
    s = h / height
    res = minimize(
        lambda x: x[0] ** 2 + x[0] * x[1] + x[1] ** 2,
        [r.max() * 1.01, r.max() * 1.01],
        constraints=[
            {"type": "ineq", "fun": lambda x: x[0] * (1 - s) + x[1] * s - r},
            {"type": "ineq", "fun": lambda x: x},
        ],
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 500},
    )
    r0, r1 = res.x
    return np.pi / 3 * height * (r0 * r0 + r0 * r1 + r1 * r1)


def test_frustum_of_a_cone_is_the_cone():
    cone = trimesh.creation.cone(radius=4.0, height=8.0, sections=32)
    fr = enclosing_frustum(cone.vertices, axis=[0, 0, 2.0])
    np.testing.assert_allclose(fr.axis, [0, 0, 1])
    assert fr.r_bottom == pytest.approx(4.0, abs=1e-9)
    assert fr.r_top == pytest.approx(0.0, abs=1e-9)
    assert fr.height == pytest.approx(8.0)
    down = enclosing_frustum(cone.vertices, axis=[0, 0, -1.0])
    assert down.r_bottom == pytest.approx(0.0, abs=1e-9)
    assert down.r_top == pytest.approx(4.0, abs=1e-9)
    _assert_contains(down.solid("down"), cone.vertices, 8.0)
    with pytest.raises(InvalidInputError, match="axis"):
        enclosing_frustum(cone.vertices, axis=[0, 0, 0])
    with pytest.raises(InvalidInputError, match="coplanar"):
        enclosing_cylinder([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])


def test_proxy_obstacles():
    proxies = enclosing_proxies(MESHES["box"].vertices, "box")
    assert isinstance(proxies.sphere, Sphere)
    assert proxies.sphere.radius == pytest.approx(np.linalg.norm(BOX) / 2)
    assert proxies.frustum.name == "box frustum"
    for proxy in (proxies.sphere, proxies.cylinder, proxies.frustum):
        info = proxy.describe()
        assert json.loads(json.dumps(info)) == info
    s = proxies.sphere
    a, b = np.array([[20.0, -5, 0]]), np.array([[20.0, 5, 0]])
    v, lo = s.segment_distance_bounds(a, b)
    assert v[0] == pytest.approx(20 - s.radius, abs=1e-12) and lo[0] <= v[0]
    with pytest.raises(InvalidInputError):
        enclosing_sphere([[1.0, 2.0, 3.0]]).solid("a point")  # radius 0 is no obstacle


# ------------------------------------------------------------------------------------------
# (d) files
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", ["stl", "obj"])
def test_load_mesh_round_trip(tmp_path, suffix):
    mesh = MESHES["torus"]
    path = tmp_path / f"part.{suffix}"
    mesh.export(path)
    obs = load_mesh(path, "part")
    assert obs.faces.shape == mesh.faces.shape
    assert obs.vertices.shape == mesh.vertices.shape
    assert obs.describe()["source"] == str(path)
    x = np.random.default_rng(20).uniform(-15, 15, (300, 3))
    np.testing.assert_allclose(
        obs.signed_distance(x), OBSTACLES["torus"].signed_distance(x), atol=1e-5
    )  # OBJ keeps ~8 digits
    # scaled (file in another unit) and posed
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec([0.3, -0.2, 1.0]).as_matrix()
    pose[:3, 3] = [100.0, -20.0, 5.0]
    posed = load_mesh(path, "posed", scale=10.0, transform=pose)
    y = x * 10.0 @ pose[:3, :3].T + pose[:3, 3]
    np.testing.assert_allclose(
        posed.signed_distance(y), 10.0 * OBSTACLES["torus"].signed_distance(x), atol=1e-4
    )


def test_load_mesh_rejects_bad_files(tmp_path):
    with pytest.raises(InvalidInputError, match="does not exist"):
        load_mesh(tmp_path / "missing.stl", "m")
    step = tmp_path / "part.step"
    step.write_text("ISO-10303-21;")
    with pytest.raises(InvalidInputError, match=r"unsupported file type '.step'.*\.stl"):
        load_mesh(step, "m")
    for name, content in [
        ("empty.stl", b""),
        ("junk.stl", b"\x00\x01 not a mesh" * 5),
        ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
        ("bad.obj", b"v a b c\nf 1 2 3\n"),
    ]:
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(InvalidInputError, match=r"no triangles|could not read"):
            load_mesh(path, "m")
    open_box = _box_mesh()
    open_box.update_faces(np.arange(len(open_box.faces)) != 0)
    holey = tmp_path / "open.stl"
    open_box.export(holey)
    with pytest.raises(InvalidInputError, match=r"not watertight.*closed"):
        load_mesh(holey, "m")
    box = tmp_path / "box.stl"
    _box_mesh().export(box)
    with pytest.raises(InvalidInputError, match="scale"):
        load_mesh(box, "m", scale=0.0)
    with pytest.raises(InvalidInputError, match="transform"):
        load_mesh(box, "m", transform=np.zeros((4, 4)))


def test_mesh_distances_stop_at_the_time_limit():
    """A long batch of segments against a mesh honours the time limit in force (stress suite:
    a plan in a scene of meshes ran to twice its --time-limit)."""
    import time

    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    obs = OBSTACLES["ball"]
    rng = np.random.default_rng(7)
    a, b = _random_segments(rng, 600, 25.0, 8.0)
    with time_limit(0.001), pytest.raises(TimeLimitError, match="distances to a mesh"):
        time.sleep(0.01)
        obs.segment_distance_bounds(a, b)
    value, _ = obs.segment_distance_bounds(a, b)  # no limit: the whole batch
    assert value.shape == (600,)
