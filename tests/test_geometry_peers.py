"""Segment distances of every primitive against independent libraries (coal, python-fcl).

A segment (one link of the arm) is a capsule of radius 0 to the peers. For every shape, several
hundred seeded random segments are compared:

* segments clear of the solid: our value equals coal's ``distance`` (GJK on the exact convex
  primitive) to a tight tolerance; for the hollow workpiece, which coal only has as a triangle
  mesh, within the mesh's discretisation error (see :func:`_mesh_error_bound`);
* all segments: our value is ``<= 0`` exactly when coal's ``collide`` reports a collision, except
  within a small band around 0 where either verdict is legitimate.

python-fcl cross-checks a few cases of the shapes it has. It is never called with a plane or
half-space (its distance query segfaults on those, DESIGN.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

coal = pytest.importorskip("coal")

from armpath.geometry import (  # noqa: E402
    Box,
    Capsule,
    HalfSpace,
    Obstacle,
    Sphere,
    cone_frustum,
    cylinder,
)
from armpath.scenes import seed_scene  # noqa: E402

#: Random segments per shape.
N_SEGMENTS = 400
#: GJK tolerance requested from coal (relative; its default 1e-6 leaves ~1e-6 relative errors).
#: Not tighter: at 1e-10 coal 3.0.3 reports distance 0 and a collision for the cone's random
#: segment #152 of seed 1004 at extent 120 ((-77.25, 67.79, 26.87) -> (-118.62, 104.56, 72.10),
#: truly 1.146 mm away).
GJK_TOLERANCE = 1e-9
#: Allowed |ours - coal| / (1 + distance) for exact primitives (coal's GJK gives ~3e-9).
PRIMITIVE_RTOL = 1e-8
#: Half-width of the band around 0 where the two collision verdicts may differ (mm).
SIGN_BAND = 1e-6
#: Sections around the axis of the workpiece mesh (8 triangles per section).
MESH_SECTIONS = 512
#: python-fcl's capsule needs a positive radius; its distance is added back.
FCL_SEGMENT_RADIUS = 1e-6
#: python-fcl (libccd GJK, default tolerances) is less precise than coal (seen: 8e-6 mm).
FCL_ATOL = 1e-4


def _rotation_z_to(direction: np.ndarray) -> np.ndarray:
    """A rotation whose third column is ``direction`` (normalised)."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, d)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(d, x), d])


def _segment_pose(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation, centre and length of the z-centred capsule frame on ``p0 -> p1``."""
    d = p1 - p0
    return _rotation_z_to(d), (p0 + p1) / 2, float(np.linalg.norm(d))


@dataclass
class Peer:
    """One of our obstacles with its coal twin (geometry and pose)."""

    ours: Obstacle
    geometry: object
    pose: object
    center: np.ndarray
    extent: float  # segments are sampled in a cube of this half-width about ``center``


def _coal_pose(rotation: np.ndarray, translation: np.ndarray) -> object:
    return coal.Transform3s(np.asarray(rotation, float), np.asarray(translation, float))


def _peers() -> dict[str, Peer]:
    rng = np.random.default_rng(7)
    R_box = Rotation.random(random_state=rng).as_matrix()
    axis_cyl = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    axis_cone = np.array([-0.6, 0.2, 0.4]) / np.linalg.norm([-0.6, 0.2, 0.4])
    cap_a, cap_b = np.array([-40.0, 10.0, 5.0]), np.array([60.0, -30.0, 80.0])
    base_cyl, base_cone = np.array([20.0, -10.0, 30.0]), np.array([-15.0, 25.0, -20.0])
    out = {
        "sphere": Peer(
            Sphere("s", (10.0, -20.0, 30.0), 50.0),
            coal.Sphere(50.0),
            _coal_pose(np.eye(3), np.array([10.0, -20.0, 30.0])),
            np.array([10.0, -20.0, 30.0]),
            100.0,
        ),
        "capsule": Peer(
            Capsule("c", cap_a, cap_b, 25.0),
            coal.Capsule(25.0, float(np.linalg.norm(cap_b - cap_a))),
            _coal_pose(_rotation_z_to(cap_b - cap_a), (cap_a + cap_b) / 2),
            (cap_a + cap_b) / 2,
            80.0,
        ),
        "box": Peer(
            Box("b", (5.0, 15.0, -10.0), (60.0, 25.0, 40.0), R_box),
            coal.Box(120.0, 50.0, 80.0),
            _coal_pose(R_box, np.array([5.0, 15.0, -10.0])),
            np.array([5.0, 15.0, -10.0]),
            100.0,
        ),
        "cylinder": Peer(
            cylinder("y", base_cyl, axis_cyl, 40.0, 150.0),
            coal.Cylinder(40.0, 150.0),
            _coal_pose(_rotation_z_to(axis_cyl), base_cyl + 75.0 * axis_cyl),
            base_cyl + 75.0 * axis_cyl,
            100.0,
        ),
        # coal.Cone(radius, lz): base disc at z = -lz/2, apex at z = +lz/2 of its frame
        "cone": Peer(
            cone_frustum("k", base_cone, axis_cone, 70.0, 0.0, 120.0),
            coal.Cone(70.0, 120.0),
            _coal_pose(_rotation_z_to(axis_cone), base_cone + 60.0 * axis_cone),
            base_cone + 60.0 * axis_cone,
            100.0,
        ),
    }
    return out


def _random_segments(
    rng: np.random.Generator, center: np.ndarray, extent: float, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` segments: start uniform in the cube, direction uniform, length 0.1 .. 1.2 extent."""
    p0 = center + rng.uniform(-extent, extent, size=(n, 3))
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    length = rng.uniform(0.1, 1.2 * extent, size=(n, 1))
    return p0, p0 + length * u


def _coal_queries(geometry, pose, p0, p1) -> tuple[np.ndarray, np.ndarray]:
    """coal's distance and collision verdict of radius-0 capsules on the segments."""
    dreq = coal.DistanceRequest()
    dreq.gjk_tolerance = GJK_TOLERANCE
    creq = coal.CollisionRequest()
    creq.gjk_tolerance = GJK_TOLERANCE
    dist = np.empty(len(p0))
    hit = np.empty(len(p0), dtype=bool)
    for k, (a, b) in enumerate(zip(p0, p1, strict=True)):
        R, t, length = _segment_pose(a, b)
        seg, seg_pose = coal.Capsule(0.0, length), _coal_pose(R, t)
        dist[k] = coal.distance(seg, seg_pose, geometry, pose, dreq, coal.DistanceResult())
        hit[k] = coal.collide(seg, seg_pose, geometry, pose, creq, coal.CollisionResult()) > 0
    return dist, hit


PEER_NAMES = ["sphere", "capsule", "box", "cylinder", "cone"]


@pytest.fixture(scope="module")
def peers() -> dict[str, Peer]:
    return _peers()


@pytest.mark.parametrize("name", PEER_NAMES)
def test_segment_distance_matches_coal(peers: dict[str, Peer], name: str) -> None:
    peer = peers[name]
    rng = np.random.default_rng(1000 + PEER_NAMES.index(name))
    p0, p1 = _random_segments(rng, peer.center, peer.extent, N_SEGMENTS)
    ours = peer.ours.segment_distance(p0, p1)
    dist, hit = _coal_queries(peer.geometry, peer.pose, p0, p1)

    clear = ours > SIGN_BAND
    assert clear.sum() >= N_SEGMENTS // 4, "too few disjoint segments to compare"
    assert (~clear).sum() >= N_SEGMENTS // 10, "too few intersecting segments to compare"
    err = np.abs(ours[clear] - dist[clear])
    worst = int(np.flatnonzero(clear)[np.argmax(err)])
    assert np.all(err <= PRIMITIVE_RTOL * (1.0 + ours[clear])), (
        f"{name}: max |ours - coal| = {err.max():.3g} at segment {p0[worst]} -> {p1[worst]}"
    )
    decided = np.abs(ours) > SIGN_BAND
    disagree = np.flatnonzero(decided & ((ours <= 0) != hit))
    assert disagree.size == 0, (
        f"{name}: collision verdicts differ for {disagree.size} segments, e.g. "
        f"{p0[disagree[0]]} -> {p1[disagree[0]]}: ours {ours[disagree[0]]}, coal {hit[disagree[0]]}"
    )


@pytest.mark.parametrize("name", PEER_NAMES)
def test_near_surface_segments_match_coal(peers: dict[str, Peer], name: str) -> None:
    """Segments grazing the surface (0 .. 2 mm off a tangent plane, slightly tilted)."""
    peer = peers[name]
    rng = np.random.default_rng(2000 + PEER_NAMES.index(name))
    # points on the surface: pull random points onto it along the distance gradient
    x = peer.center + rng.uniform(-peer.extent, peer.extent, size=(4 * N_SEGMENTS, 3))
    for _ in range(3):
        grad = _gradient(peer.ours, x)
        x = x - peer.ours.signed_distance(x)[:, None] * grad
    x = x[np.abs(peer.ours.signed_distance(x)) < 1e-6][:N_SEGMENTS]
    normal = _gradient(peer.ours, x)
    u = rng.normal(size=x.shape)
    u -= np.sum(u * normal, axis=1, keepdims=True) * normal
    u += rng.normal(0.0, 0.05, size=(len(x), 1)) * normal
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    mid = x + rng.uniform(0.0, 2.0, size=(len(x), 1)) * normal
    half = rng.uniform(0.5, 30.0, size=(len(x), 1)) * u
    p0, p1 = mid - half, mid + half
    ours = peer.ours.segment_distance(p0, p1)
    dist, hit = _coal_queries(peer.geometry, peer.pose, p0, p1)
    clear = ours > SIGN_BAND
    assert len(x) >= N_SEGMENTS // 2
    assert clear.sum() >= len(x) // 5
    assert (~clear).sum() >= len(x) // 20
    err = np.abs(ours[clear] - dist[clear])
    worst = int(np.flatnonzero(clear)[np.argmax(err)])
    assert np.all(err <= PRIMITIVE_RTOL * (1.0 + ours[clear])), (
        f"{name}: max |ours - coal| = {err.max():.3g} at segment {p0[worst]} -> {p1[worst]}"
    )
    decided = np.abs(ours) > SIGN_BAND
    assert not np.any(decided & ((ours <= 0) != hit))


def test_cone_segment_where_tight_gjk_tolerance_fails(peers: dict[str, Peer]) -> None:
    """Pins the case that set GJK_TOLERANCE: coal at 1e-10 calls this 1.146 mm gap a collision."""
    a = np.array([-77.25287918759159, 67.79050488603295, 26.873347576519386])
    b = np.array([-118.62361036266537, 104.56310899768917, 72.10152287032193])
    peer = peers["cone"]
    ours = float(peer.ours.segment_distance(a, b))
    t = np.linspace(0.0, 1.0, 20001)
    dense = peer.ours.signed_distance(a + t[:, None] * (b - a)).min()
    assert ours == pytest.approx(1.146229543477902, abs=1e-9)
    assert ours <= dense + 1e-12
    dist, hit = _coal_queries(peer.geometry, peer.pose, a[None], b[None])
    assert dist[0] == pytest.approx(ours, rel=PRIMITIVE_RTOL)
    assert not hit[0]


def _gradient(obstacle: Obstacle, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Unit gradient of the signed distance by central differences."""
    g = np.stack(
        [
            (obstacle.signed_distance(x + h * e) - obstacle.signed_distance(x - h * e)) / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )
    return np.asarray(g / np.linalg.norm(g, axis=-1, keepdims=True))


# --- the hollow workpiece as a triangle mesh ---------------------------------------------------


def _mesh_error_bound(profile: np.ndarray, sections: int) -> float:
    """Hausdorff distance between the revolved solid and its ``sections``-gon mesh.

    The mesh's horizontal slice at height ``z`` is the true annulus with both circles replaced
    by inscribed regular polygons (vertices on the circles, at the same angles at every height,
    so the mesh quads are planar trapezoids). A point of either solid is therefore within the
    largest chord sagitta ``r_max (1 - cos(pi / n))`` of the other, and the distances of any
    point (or segment) outside both differ by at most that much.
    """
    return float(profile[:, 0].max() * (1.0 - math.cos(math.pi / sections)))


@pytest.fixture(scope="module")
def workpiece_mesh():
    trimesh = pytest.importorskip("trimesh")
    wp = next(o for o in seed_scene().world.obstacles if not isinstance(o, HalfSpace))
    assert np.allclose(wp.axis, [0.0, 0.0, 1.0])
    mesh = trimesh.creation.revolve(wp.profile, sections=MESH_SECTIONS)
    assert mesh.is_watertight and mesh.is_volume
    mesh.apply_translation(wp.origin)
    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(len(mesh.faces), len(mesh.vertices))
    bvh.addVertices(np.asarray(mesh.vertices, dtype=np.float64))
    bvh.addTriangles(np.asarray(mesh.faces, dtype=np.int64))
    bvh.endModel()
    return wp, bvh, _mesh_error_bound(wp.profile, MESH_SECTIONS)


def _workpiece_segments(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Half anywhere around the vessel, a quarter in its cavity, a quarter about its rim."""
    base = np.array([210.0, 0.0, 0.0])
    k = n // 4
    p0a, p1a = _random_segments(rng, base + np.array([0.0, 0.0, 90.0]), 260.0, n - 2 * k)
    ang, rad = rng.uniform(0, 2 * np.pi, (2, k)), rng.uniform(0, 110.0, (2, k))
    z = rng.uniform(10.0, 240.0, (2, k))
    cav = base + np.stack([rad * np.cos(ang), rad * np.sin(ang), z], axis=-1)
    ang = rng.uniform(0, 2 * np.pi, k)
    rim = base + np.stack([92.0 * np.cos(ang), 92.0 * np.sin(ang), np.full(k, 180.0)], axis=-1)
    u = rng.normal(size=(k, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    rim0 = rim + rng.uniform(-15.0, 15.0, (k, 3))
    rim1 = rim0 + rng.uniform(1.0, 60.0, (k, 1)) * u
    return np.concatenate([p0a, cav[0], rim0]), np.concatenate([p1a, cav[1], rim1])


def test_workpiece_matches_coal_mesh(workpiece_mesh) -> None:
    wp, bvh, bound = workpiece_mesh
    rng = np.random.default_rng(3000)
    p0, p1 = _workpiece_segments(rng, 2 * N_SEGMENTS)
    ours = wp.segment_distance(p0, p1)
    dist, hit = _coal_queries(bvh, coal.Transform3s(), p0, p1)
    clear = ours > bound
    assert clear.sum() >= N_SEGMENTS // 2
    err = np.abs(ours[clear] - dist[clear])
    worst = int(np.flatnonzero(clear)[np.argmax(err)])
    assert err.max() <= bound + 1e-6, (
        f"workpiece: |ours - mesh| = {err.max():.4g} > bound {bound:.4g} at segment "
        f"{p0[worst]} -> {p1[worst]}"
    )
    # a mesh in coal is its surface: a segment buried in the wall does not collide with it
    t = np.linspace(0.0, 1.0, 400)
    along = wp.signed_distance(p0[:, None, :] + t[:, None] * (p1 - p0)[:, None, :])
    buried = along.max(axis=1) < 0.0
    decided = (np.abs(ours) > bound) & ~buried
    disagree = np.flatnonzero(decided & ((ours <= 0) != hit))
    assert disagree.size == 0, (
        f"workpiece: collision verdicts differ for {disagree.size} segments, e.g. "
        f"{p0[disagree[0]]} -> {p1[disagree[0]]}: ours {ours[disagree[0]]}, coal {hit[disagree[0]]}"
    )
    assert not np.any(hit[buried])


# --- python-fcl: a few cases of the shapes it has (never a plane or half-space) ---------------


def test_python_fcl_agrees_on_a_few_cases(peers: dict[str, Peer]) -> None:
    fcl = pytest.importorskip("fcl")
    twins = {
        "sphere": lambda: fcl.Sphere(50.0),
        "capsule": lambda: fcl.Capsule(25.0, float(peers["capsule"].geometry.halfLength * 2)),
        "box": lambda: fcl.Box(120.0, 50.0, 80.0),
        "cylinder": lambda: fcl.Cylinder(40.0, 150.0),
    }
    rng = np.random.default_rng(4000)
    for name, make in twins.items():
        peer = peers[name]
        pose = peer.pose
        obj = fcl.CollisionObject(make(), fcl.Transform(pose.getRotation(), pose.getTranslation()))
        p0, p1 = _random_segments(rng, peer.center, peer.extent, 40)
        ours = peer.ours.segment_distance(p0, p1)
        keep = ours > 1e-3
        assert keep.sum() >= 10
        for a, b, d in zip(p0[keep], p1[keep], ours[keep], strict=True):
            R, t, length = _segment_pose(a, b)
            seg = fcl.CollisionObject(fcl.Capsule(FCL_SEGMENT_RADIUS, length), fcl.Transform(R, t))
            got = fcl.distance(seg, obj, fcl.DistanceRequest(), fcl.DistanceResult())
            got += FCL_SEGMENT_RADIUS
            assert got == pytest.approx(d, abs=FCL_ATOL), f"fcl {name}: {a} -> {b}"
