"""A generic independent replay of armpath's results, for the stress suite.

It shares no code with armpath: numpy, scipy and shapely, plus the other independent checkers
(``independent.points``: the seed arm's forward kinematics from SPEC section 1;
``independent_dh``: the textbook D-H matrices). Everything here is written from the SPEC, the
README's description of the scene files and the textbook formulas.

What it checks
--------------
* **Commands** (:func:`replay_result`): integers in [-20, 20] ticks, six per command; the start
  state on the 0.1 deg lattice; every state computed exactly in integer ticks; the joint limits
  at every state (a command moves the joints linearly, so the states bound the whole motion);
  ``final_deg`` and ``n_commands`` agree with the commands.
* **Clearance along the continuous motion.** Every command is sampled at instants so close that
  no point of the arm moves more than ``time_step_mm`` (0.5 mm) between two of them: a command
  moving the joints by ``dq`` (rad) moves any arm point at most ``sum_i |dq_i| R_i``, with
  ``R_i`` the distance from joint ``i``'s axis of any point of the links after it (crudely, the
  sum of those link lengths). At every instant each link is sampled every ``link_step_mm`` (at
  most 1 mm) and the signed distance of every sample to every obstacle is computed by the
  formulas below; the link's capsule radius and the required clearance are subtracted.
  The last ``tool_tip_exempt_mm`` of the last link is the tool tip: a bare segment (no radius,
  README: "a bare segment that may touch the surface it works on") that must not penetrate
  (clearance >= 0); the rest of that link keeps its radius plus the margin. Non-adjacent links
  keep ``self_margin_mm`` beyond both radii (a sample of one link against the other link's
  segment).

  *The allowance.* Every sample is a real point of the continuous motion, so a sample below the
  required clearance is a real violation: the result is rejected when the sampled minimum is
  below the requirement by more than a rounding allowance (``1e-6 mm`` plus ``1e-13`` of the
  largest coordinate in the scene), *not* by half the sample spacing. The sampling can only miss
  a violation, never invent one. How much it can miss: any point of the continuous motion lies
  within ``time_step_mm / 2`` (half a time step) plus ``link_step_mm / 2`` (half a link
  spacing) of a sample, and a signed distance is 1-Lipschitz, so a violation deeper than
  ``(time_step_mm + link_step_mm) / 2`` (0.75 mm; for two moving links ``time_step_mm +
  link_step_mm / 2``) cannot hide between samples. To see shallower ones, the worst samples of
  each pair are resampled 20 times finer around them. The same bound is reported as
  ``certified_lower_bound`` (sampled minimum less the resolution of the coarsest level used).
  Sampling starts coarse (5 mm both ways) and goes to the fine level only for commands whose
  coarse samples do not already prove the pair clear by that bound; this changes nothing in
  the verdict: a skipped command provably has no sample below the requirement.
* **Fingertip**: the error to the target (reach, plan ``--to-xyz``, every spot weld at its
  state), the goal state (plan ``--to``), and the reported error and tip.
* **Curves** (traces): the deviation of the *continuous* fingertip path from the curve during
  each pass (sampled so that the tip moves at most ``tip_step_mm`` = 0.02 mm between samples,
  then resampled finer around the worst ones); the distance is measured to a dense polyline of
  the true curve when the caller gives one (:class:`DenseCurve`), otherwise to the result's own
  2001 ``curve.points_mm`` with an allowance for the chords (a quarter of the largest second
  difference). The result's curve is compared with the true one both ways (Hausdorff), and each
  pass's claimed arc must be swept: every curve point in it lies within the tolerance (plus the
  sampling) of the pass's sampled tip path.
* **Reported certificates**: the reported lower bound of the clearance must not exceed the
  sampled minimum (samples are real values), nor the reported deviation bound the sampled
  deviation.

Obstacles (signed distance, negative inside): half-space (the normal points out of the solid),
sphere, capsule, oriented box (``rotation_deg`` a rotation vector whose matrix's columns are the
box axes), cylinder, cone frustum and hollow frustum through their profile in the ``(r, z)``
half-plane about the axis (distance to the profile's edges, the edges lying on the axis
excluded, and shapely's point-in-polygon for the sign), and convex meshes (OBJ or ASCII STL;
``x = R(rotation_deg) (scale x_file) + translation``; outside: distance to the triangles,
inside: the largest face-plane distance). The hollow frustum is read from the README and SPEC:
outer radius ``r_bottom -> r_top`` over ``height``, the inner face ``dh`` inside the outer one
(``dh = wall * sqrt(1 + slope^2)`` measured normal, ``wall`` horizontally), closed ends are
plates ``wall`` thick along the axis, an open end is cut perpendicular to the axis.

Kinematics: the seed arm (A, B, C, D, E, SPEC section 1) and any D-H / modified D-H robot file
(``check_fk`` / ``check_ik``: tool pose by the textbook product, joint points on their axes,
IK solutions verified by forward kinematics).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

import independent
import independent_dh

TICKS_PER_DEG = 10
MAX_TICKS = 20
SEED_LENGTHS = (independent.AB, independent.BC, independent.CD, independent.DE)
#: The seed arm's joint ranges (deg), SPEC section 1; None = unlimited.
SEED_LIMITS_DEG: tuple[float | None, ...] = (None, 125.0, 138.0, None, 133.5, None)

#: Defaults of the sampling (mm): see the module docstring.
TIME_STEP_MM = 0.5
LINK_STEP_MM = 1.0
TIP_STEP_MM = 0.02
COARSE_MM = 5.0
REFINE_FACTOR = 20
#: Longest stretch of a claimed arc (in tolerances) a pass may skip at a corner.
GAP_TOLERANCES = 10.0


# ---------------------------------------------------------------------------------------------
# The seed arm
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SeedArm:
    """The seed arm (SPEC section 1) with its joint limits (deg) and link radius (mm)."""

    limits_deg: tuple[tuple[float, float], ...] = tuple(
        (-math.inf, math.inf) if r is None else (-r, r) for r in SEED_LIMITS_DEG
    )
    link_radius: float = 0.0
    #: landmark indices of the links: AB (fixed column, not checked), BC, CD, DE
    links: tuple[tuple[int, int], ...] = ((0, 1), (1, 2), (2, 3), (3, 4))
    checked: tuple[bool, ...] = (False, True, True, True)
    link_names: tuple[str, ...] = ("AB", "BC", "CD", "DE")
    #: landmark index of the fingertip
    tip_index: int = 4

    @property
    def radii(self) -> tuple[float, ...]:
        return (self.link_radius,) * len(self.links)

    @staticmethod
    def points(theta_deg: np.ndarray) -> np.ndarray:
        """A, B, C, D, E ``(..., 5, 3)`` for joint angles in degrees."""
        return independent.points(theta_deg)

    @property
    def reach_per_joint(self) -> np.ndarray:
        """``R_i`` (mm): no arm point is farther than this from joint ``i``'s axis."""
        _, bc, cd, de = SEED_LENGTHS
        return np.array([bc + cd + de, bc + cd + de, cd + de, de, de, 0.0])

    @property
    def tick_limits(self) -> tuple[np.ndarray, np.ndarray]:
        return _tick_limits(self.limits_deg)

    @property
    def self_pairs(self) -> list[tuple[int, int]]:
        """Links that share no landmark, at least one of them checked."""
        out = []
        for i, a in enumerate(self.links):
            for j in range(i + 1, len(self.links)):
                b = self.links[j]
                if set(a) & set(b) or not (self.checked[i] or self.checked[j]):
                    continue
                out.append((i, j))
        return out

    @classmethod
    def from_model(cls, model: Mapping[str, Any]) -> SeedArm:
        """From a result's ``model``: refuses other arms or other link lengths (the CLI plans
        with the SPEC's seed arm only)."""
        if model.get("name") != "seed":
            raise ValueError(f"the replay handles the seed arm only, got {model.get('name')!r}")
        params = model.get("parameters", {})
        lengths = tuple(
            float(params.get(k, math.nan)) for k in ("AB_mm", "BC_mm", "CD_mm", "DE_mm")
        )
        if not np.allclose(lengths, SEED_LENGTHS):
            raise ValueError(f"seed arm with other link lengths {lengths}")
        limits = []
        for lim in model.get("joint_limits_deg", [None] * 6):
            limits.append((-math.inf, math.inf) if lim is None else (float(lim[0]), float(lim[1])))
        return cls(tuple(limits), float(params.get("link_radius_mm", 0.0)))


def _tick_limits(limits_deg: Sequence[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    lo = np.array([lo for lo, _ in limits_deg]) * TICKS_PER_DEG
    hi = np.array([hi for _, hi in limits_deg]) * TICKS_PER_DEG
    return np.ceil(lo - 1e-9), np.floor(hi + 1e-9)


@dataclass(frozen=True)
class CapsuleArm:
    """Any arm on the 0.1 deg / 20 tick lattice, described by the caller: ``landmarks(deg)``
    gives points ``(..., K, 3)`` (mm) from joint angles in degrees (the caller's own forward
    kinematics), ``links`` are capsules between landmarks with their radii, ``self_pairs`` the
    link pairs checked against each other, ``reach_per_joint`` (mm) bounds every landmark's
    (and link point's) distance from each joint's axis, ``tip_index`` is the tool point."""

    landmarks: Callable[[np.ndarray], np.ndarray]
    links: tuple[tuple[int, int], ...]
    radii: tuple[float, ...]
    checked: tuple[bool, ...]
    link_names: tuple[str, ...]
    self_pairs: tuple[tuple[int, int], ...]
    reach_per_joint: np.ndarray
    limits_deg: tuple[tuple[float, float], ...]
    tip_index: int

    def points(self, theta_deg: np.ndarray) -> np.ndarray:
        return self.landmarks(np.asarray(theta_deg, dtype=float))

    @property
    def tick_limits(self) -> tuple[np.ndarray, np.ndarray]:
        return _tick_limits(self.limits_deg)


# ---------------------------------------------------------------------------------------------
# D-H robot files
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DHRobot:
    """A robot file's D-H table in mm and rad (``q`` of prismatic joints in mm)."""

    modified: bool
    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    offset: np.ndarray
    theta: np.ndarray
    prismatic: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    base: np.ndarray
    tool: np.ndarray

    @property
    def n(self) -> int:
        return len(self.a)

    @classmethod
    def from_file(cls, doc: Mapping[str, Any]) -> DHRobot:
        """Read the JSON robot-file shape of the README (lengths mm or m, angles deg or rad)."""
        units = doc.get("units", {})
        L = {"mm": 1.0, "m": 1000.0}[units.get("length", "mm")]
        A = {"deg": math.pi / 180.0, "rad": 1.0}[units.get("angle", "deg")]
        rows = doc["links"]
        pris = np.array([r.get("type", "revolute") == "prismatic" for r in rows])
        qs = np.where(pris, L, A)

        def col(key: str, scale: float | np.ndarray) -> np.ndarray:
            return np.array([float(r.get(key, 0.0)) for r in rows]) * scale

        lims = [r.get("limits") or [None, None] for r in rows]  # null: unlimited
        lower = np.array([-math.inf if lo is None else float(lo) for lo, _ in lims]) * qs
        upper = np.array([math.inf if hi is None else float(hi) for _, hi in lims]) * qs

        def transform(key: str) -> np.ndarray:
            if key not in doc:
                return np.eye(4)
            T = np.array(doc[key], dtype=float).reshape(4, 4)
            T[:3, 3] *= L
            return T

        return cls(
            modified=doc.get("convention", "standard") == "modified",
            a=col("a", L),
            alpha=col("alpha", A),
            d=col("d", L),
            offset=col("offset", qs),
            theta=col("theta", A),
            prismatic=pris,
            lower=lower,
            upper=upper,
            base=transform("base"),
            tool=transform("tool"),
        )

    def _row(self, i: int, q: float) -> tuple[np.ndarray, np.ndarray]:
        """(the part of row ``i`` before its joint axis, the rest including the motion)."""
        rz, rx, tz, tx = (
            independent_dh._rz,
            independent_dh._rx,
            independent_dh._tz,
            independent_dh._tx,
        )
        if self.prismatic[i]:
            th, dist = self.theta[i], self.d[i] + self.offset[i] + q
        else:
            th, dist = q + self.offset[i], self.d[i]
        if self.modified:
            return rx(self.alpha[i]) @ tx(self.a[i]), rz(th) @ tz(dist)
        return np.eye(4), rz(th) @ tz(dist) @ tx(self.a[i]) @ rx(self.alpha[i])

    def pose(self, q: Sequence[float]) -> np.ndarray:
        """Tool pose: ``base * prod(row_i) * tool`` (textbook product)."""
        T = self.base.copy()
        for i in range(self.n):
            pre, rest = self._row(i, float(q[i]))
            T = T @ pre @ rest
        return T @ self.tool

    def axes(self, q: Sequence[float]) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each joint's axis line in the world: (a point on it, unit direction)."""
        T = self.base.copy()
        out = []
        for i in range(self.n):
            pre, rest = self._row(i, float(q[i]))
            T = T @ pre
            out.append((T[:3, 3].copy(), T[:3, 2].copy()))
            T = T @ rest
        return out

    def within_limits(self, q: np.ndarray, slack: float = 1e-9) -> bool:
        return bool(np.all((q >= self.lower - slack) & (q <= self.upper + slack)))

    def pose_jacobian(self, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
        """Jacobian of (position in m, rotation-matrix entries) by central differences, per
        joint (rad, or m for a prismatic joint): unitless, for judging conditioning."""
        cols = []
        for i in range(self.n):
            e = np.zeros(self.n)
            e[i] = h
            Tp, Tm = self.pose(q + e), self.pose(q - e)
            col = np.r_[(Tp[:3, 3] - Tm[:3, 3]) / 1000.0, (Tp[:3, :3] - Tm[:3, :3]).ravel()]
            cols.append(col * (1000.0 if self.prismatic[i] else 1.0))
        return np.array(cols).T / (2 * h)


def check_fk(robot: DHRobot | None, q: Sequence[float], doc: Mapping[str, Any]) -> list[str]:
    """Problems of an fk result ``{"points": {name: xyz}, "pose": 4x4}`` at joint values ``q``
    (rad / mm); ``robot`` None means the seed arm (``q`` in deg; points A..E)."""
    problems: list[str] = []
    if robot is None:
        P = SeedArm.points(np.asarray(q, dtype=float))
        for name, p in zip("ABCDE", P, strict=True):
            got = np.asarray(doc["points"].get(name, [np.nan] * 3), dtype=float)
            if not np.allclose(got, p, atol=1e-7):
                problems.append(f"point {name} is {got.tolist()}, independent {p.tolist()}")
        return problems
    T = robot.pose(q)
    scale = 1.0 + float(np.abs(T[:3, 3]).max()) + float(np.abs(robot.base[:3, 3]).max())
    tol = 1e-9 * scale + 1e-7
    pose = np.asarray(doc["pose"], dtype=float)
    if not np.allclose(pose[:3, 3], T[:3, 3], atol=tol) or not np.allclose(
        pose[:3, :3], T[:3, :3], atol=1e-9
    ):
        problems.append(
            f"tool pose differs from the textbook product by {np.abs(pose - T).max():.3g}"
        )
    names = list(doc["points"])
    pts = {k: np.asarray(v, dtype=float) for k, v in doc["points"].items()}
    frames = ["base", *(f"J{i + 1}" for i in range(robot.n)), "tool"]
    if names[: robot.n + 2] != frames:
        problems.append(f"points {names} do not start with {frames}")
        return problems
    if not np.allclose(pts["base"], robot.base[:3, 3], atol=tol):
        problems.append("point base is not the base origin")
    if not np.allclose(pts["tool"], T[:3, 3], atol=tol):
        problems.append("point tool is not the tool origin")
    lines = [*robot.axes(q), (T[:3, 3], T[:3, 2])]  # joint axes, then the tool's z axis
    for name in names:
        # joint i's frame origin lies on its axis; a corner named after frame k lies on the
        # axis of joint k (the tool's z axis for the tool)
        frame = name[:-1] if name.endswith("'") else name
        if frame == "base" or frame not in frames:
            continue
        c, u = lines[frames.index(frame) - 1]
        v = pts[name] - c
        off = float(np.linalg.norm(v - (v @ u) * u))
        if off > tol * 10:
            problems.append(f"point {name} is {off:.3g} mm off the axis of {frame}")
    return problems


def _angle_close(a: np.ndarray, b: np.ndarray, prismatic: np.ndarray, tol: float) -> bool:
    diff = np.where(prismatic, a - b, (a - b + np.pi) % (2 * np.pi) - np.pi)
    return bool(np.all(np.abs(diff) <= tol))


def check_ik(
    robot: DHRobot,
    target: np.ndarray,
    doc: Mapping[str, Any],
    generating_q: np.ndarray | None = None,
    position_only: bool = False,
) -> tuple[list[str], dict[str, Any]]:
    """Problems of an ik result (``solutions`` in rad / mm, ``within_limits``) for ``target``
    (a 4x4 pose, or a point with ``position_only``), and facts: whether the generating joint
    vector was found and how well conditioned it is."""
    problems: list[str] = []
    sols = np.asarray(doc["solutions"], dtype=float).reshape(-1, robot.n)
    scale = 1.0 + float(np.abs(np.asarray(target, dtype=float)).max())
    pos_tol = 1e-4 + 1e-9 * scale
    worst_pos, worst_rot = 0.0, 0.0
    for k, q in enumerate(sols):
        if not np.all(np.isfinite(q)):
            problems.append(f"solution {k + 1} is not finite: {q.tolist()}")
            continue
        T = robot.pose(q)
        if position_only:
            pos, rot = float(np.linalg.norm(T[:3, 3] - target)), 0.0
        else:
            pos = float(np.linalg.norm(T[:3, 3] - target[:3, 3]))
            R = T[:3, :3].T @ target[:3, :3]
            rot = float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
        worst_pos, worst_rot = max(worst_pos, pos), max(worst_rot, rot)
        if pos > pos_tol or rot > 1e-6:
            problems.append(
                f"solution {k + 1} {np.round(q, 6).tolist()} misses the target by {pos:.3g} mm, "
                f"{math.degrees(rot):.3g} deg (textbook forward kinematics)"
            )
        flags = doc.get("within_limits")
        if flags is not None and len(flags) == len(sols):
            inside = robot.within_limits(q)
            if bool(flags[k]) != inside:
                problems.append(f"solution {k + 1}: within_limits says {flags[k]}, it is {inside}")
    facts: dict[str, Any] = {
        "count": len(sols),
        "worst_position_mm": worst_pos,
        "worst_rotation_rad": worst_rot,
    }
    if generating_q is not None and len(generating_q):
        found = any(_angle_close(s, generating_q, robot.prismatic, 1e-4) for s in sols)
        sv = np.linalg.svd(robot.pose_jacobian(np.asarray(generating_q, float)), compute_uv=False)
        facts["found_generating"] = found
        facts["generating_sigma_min"] = float(sv[-1]) if sv.size else 0.0
    return problems, facts


# ---------------------------------------------------------------------------------------------
# Obstacles: signed distances (mm), negative inside
# ---------------------------------------------------------------------------------------------


def _unit(v: Sequence[float], what: str) -> np.ndarray:
    u = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(u))
    if not (np.isfinite(n) and n > 0):
        raise ValueError(f"{what} has no direction: {list(v)}")
    return u / n


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points ``(N, k)`` to the segment ``a -> b`` (any dimension k)."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * ab, axis=1)


@dataclass
class Obstacle:
    """A solid: ``sdf(points (N, 3)) -> (N,)`` and an enclosing ball (None: unbounded)."""

    name: str
    kind: str
    sdf: Callable[[np.ndarray], np.ndarray]
    ball: tuple[np.ndarray, float] | None
    scale: float


def _half_space(name: str, point: Sequence[float], normal: Sequence[float]) -> Obstacle:
    p0, n = np.asarray(point, float), _unit(normal, f"{name} normal")
    return Obstacle(name, "half_space", lambda p: (p - p0) @ n, None, float(np.abs(p0).max()))


def _sphere(name: str, center: Sequence[float], radius: float) -> Obstacle:
    c = np.asarray(center, float)
    r = float(radius)
    return Obstacle(
        name,
        "sphere",
        lambda p: np.linalg.norm(p - c, axis=1) - r,
        (c, r),
        float(np.abs(c).max() + r),
    )


def _capsule(name: str, start: Sequence[float], end: Sequence[float], radius: float) -> Obstacle:
    a, b, r = np.asarray(start, float), np.asarray(end, float), float(radius)
    mid = (a + b) / 2
    return Obstacle(
        name,
        "capsule",
        lambda p: _segment_distance(p, a, b) - r,
        (mid, float(np.linalg.norm(b - a)) / 2 + r),
        float(max(np.abs(a).max(), np.abs(b).max()) + r),
    )


def _box(name: str, center: Sequence[float], half: Sequence[float], R: np.ndarray) -> Obstacle:
    c, h = np.asarray(center, float), np.asarray(half, float)

    def sdf(p: np.ndarray) -> np.ndarray:
        local = (p - c) @ R  # coordinates along the box axes (the columns of R)
        q = np.abs(local) - h
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        return outside + np.minimum(q.max(axis=1), 0.0)

    return Obstacle(
        name, "box", sdf, (c, float(np.linalg.norm(h))), float(np.abs(c).max() + h.max())
    )


def _revolution(
    name: str, kind: str, origin: Sequence[float], axis: Sequence[float], profile: np.ndarray
) -> Obstacle:
    """A polygon ``(r, z)`` (r >= 0) revolved about the axis through ``origin``."""
    o, a = np.asarray(origin, float), _unit(axis, f"{name} axis")
    pts = [tuple(v) for v in np.asarray(profile, float)]
    pts = [v for i, v in enumerate(pts) if v != pts[i - 1]]
    poly = shapely.Polygon(pts)
    if not poly.is_valid or poly.area <= 0:
        raise ValueError(f"{name}: the profile {pts} is not a simple polygon")
    shapely.prepare(poly)
    V = np.array(pts)
    edges = [
        (V[i], V[(i + 1) % len(V)])
        for i in range(len(V))
        if not (V[i][0] == 0 and V[(i + 1) % len(V)][0] == 0)  # edges on the axis: inside
    ]

    def sdf(p: np.ndarray) -> np.ndarray:
        rel = p - o
        z = rel @ a
        r = np.linalg.norm(rel - z[:, None] * a, axis=1)
        rz = np.column_stack([r, z])
        d = np.min([_segment_distance(rz, e0, e1) for e0, e1 in edges], axis=0)
        # on the boundary the distance is 0 except on the axis, which is inside the solid
        inside = shapely.intersects_xy(poly, r, z)
        return np.where(inside, -d, d)

    rmax = float(V[:, 0].max())
    zlo, zhi = float(V[:, 1].min()), float(V[:, 1].max())
    center = o + a * (zlo + zhi) / 2
    return Obstacle(
        name,
        kind,
        sdf,
        (center, math.hypot(rmax, (zhi - zlo) / 2)),
        float(np.abs(o).max() + math.hypot(rmax, max(abs(zlo), abs(zhi)))),
    )


def hollow_frustum_profile(
    height: float,
    r_bottom: float,
    r_top: float,
    wall: float,
    wall_thickness: str = "normal",
    open_top: bool = True,
    closed_bottom: bool = True,
) -> np.ndarray:
    """The ``(r, z)`` profile of a hollow truncated cone (see the module docstring)."""
    h, rb, rt, w = float(height), float(r_bottom), float(r_top), float(wall)
    slope = (rb - rt) / h
    dh = w * math.sqrt(1 + slope**2) if wall_thickness == "normal" else w

    def r_in(z: float) -> float:
        return rb - slope * z - dh

    if dh >= min(rb, rt) or (w >= h) or (closed_bottom and not open_top and 2 * w >= h):
        raise ValueError("hollow frustum: the wall leaves no hollow inside")
    lo = w if closed_bottom else 0.0
    hi = h if open_top else h - w
    ring = [(rb, 0.0), (rt, h)]
    ring += [(r_in(h), h)] if open_top else [(0.0, h), (0.0, hi), (r_in(hi), hi)]
    ring += [(r_in(lo), lo), (0.0, lo), (0.0, 0.0)] if closed_bottom else [(r_in(0.0), 0.0)]
    return np.array(ring)


def hollow_frustum_inner_point(
    base_center: Sequence[float],
    height: float,
    r_bottom: float,
    r_top: float,
    wall: float,
    wall_thickness: str,
    x: float,
    y: float,
) -> np.ndarray | None:
    """The point of the inner face (vertical axis) above ``(x, y)``, or None if there is none
    within the height."""
    h, rb, rt, w = float(height), float(r_bottom), float(r_top), float(wall)
    slope = (rb - rt) / h
    dh = w * math.sqrt(1 + slope**2) if wall_thickness == "normal" else w
    rho = math.hypot(x - base_center[0], y - base_center[1])
    if slope == 0:
        return None
    z = (rb - dh - rho) / slope
    if not 0 <= z <= h:
        return None
    return np.array([x, y, base_center[2] + z])


def _read_convex_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of an OBJ (``v``/``f`` lines) or ASCII STL file."""
    text = path.read_text()
    if path.suffix.lower() == ".obj":
        V, F = [], []
        for line in text.splitlines():
            parts = line.split()
            if parts and parts[0] == "v":
                V.append([float(x) for x in parts[1:4]])
            elif parts and parts[0] == "f":
                idx = [int(s.split("/")[0]) - 1 for s in parts[1:]]
                F += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
        return np.array(V), np.array(F)
    verts = [
        [float(x) for x in line.split()[1:4]]
        for line in text.splitlines()
        if line.strip().startswith("vertex")
    ]
    V = np.array(verts)
    return V, np.arange(len(V)).reshape(-1, 3)


def _point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance of points ``(N, 3)`` to triangles ``(T, 3, 3)``: ``(N, T)``."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ap = p[:, None, :] - a[None]
    h = np.einsum("ntk,tk->nt", ap, n)
    foot = p[:, None, :] - h[..., None] * n[None]
    # barycentric test of the foot of the perpendicular
    inside = np.ones(h.shape, bool)
    for u, v in ((a, b), (b, c), (c, a)):
        side = np.einsum("ntk,tk->nt", np.cross(v - u, foot - u[None]), n)
        inside &= side >= 0
    d = np.where(inside, np.abs(h), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        uv = v - u
        t = np.clip(np.einsum("ntk,tk->nt", p[:, None] - u[None], uv) / (uv * uv).sum(1), 0, 1)
        d = np.minimum(d, np.linalg.norm(p[:, None] - u[None] - t[..., None] * uv[None], axis=2))
    return d


def _convex_mesh(name: str, V: np.ndarray, F: np.ndarray) -> Obstacle:
    tri = V[F]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    centroid = V.mean(axis=0)
    if np.any(np.einsum("tk,tk->t", tri[:, 0] - centroid, n) < 0):
        n = -n  # inward winding: turn the normals out
    off = np.einsum("tk,tk->t", tri[:, 0], n)

    def sdf(p: np.ndarray) -> np.ndarray:
        plane = p @ n.T - off  # (N, T), <= 0 on the inner side of every face
        worst = plane.max(axis=1)
        out = np.zeros(len(p))
        outside = worst > 0
        if np.any(outside):
            out[outside] = _point_triangle_distance(p[outside], tri).min(axis=1)
        return np.where(outside, out, worst)

    radius = float(np.linalg.norm(V - centroid, axis=1).max())
    return Obstacle(name, "mesh", sdf, (centroid, radius), float(np.abs(V).max()))


def _rotation_deg(v: Sequence[float]) -> np.ndarray:
    return Rotation.from_rotvec(np.radians(np.asarray(v, dtype=float))).as_matrix()


def obstacle_from_spec(o: Mapping[str, Any], base_dir: Path | None = None) -> Obstacle:
    """One obstacle of a scene file (or of a result's ``scene.obstacles``)."""
    t, name = o["type"], str(o.get("name", o["type"]))
    if t == "half_space":
        return _half_space(name, o["point"], o["normal"])
    if t == "sphere":
        return _sphere(name, o["center"], o["radius"])
    if t == "capsule":
        return _capsule(name, o["start"], o["end"], o["radius"])
    if t == "box":
        if "half_extents" in o:  # a result's description
            return _box(name, o["center"], o["half_extents"], np.asarray(o["rotation"], float))
        R = _rotation_deg(o.get("rotation_deg", (0.0, 0.0, 0.0)))
        return _box(name, o["center"], np.asarray(o["size"], float) / 2, R)
    axis = o.get("axis", (0.0, 0.0, 1.0))
    if t == "cylinder":
        r, h = float(o["radius"]), float(o["height"])
        return _revolution(
            name, t, o["base_center"], axis, np.array([(0, 0), (r, 0), (r, h), (0, h)])
        )
    if t == "cone_frustum":
        rb, rt, h = float(o["r_bottom"]), float(o["r_top"]), float(o["height"])
        return _revolution(
            name, t, o["base_center"], axis, np.array([(0, 0), (rb, 0), (rt, h), (0, h)])
        )
    if t == "hollow_frustum":
        prof = hollow_frustum_profile(
            o["height"],
            o["r_bottom"],
            o["r_top"],
            o["wall"],
            str(o.get("wall_thickness", "normal")),
            bool(o.get("open_top", True)),
            bool(o.get("closed_bottom", True)),
        )
        return _revolution(name, t, o["base_center"], axis, prof)
    if t == "solid_of_revolution":  # a result's description of a cylinder or cone
        return _revolution(name, t, o["origin"], o["axis"], np.asarray(o["profile_rz"], float))
    if t == "mesh":
        if "file" not in o:
            raise ValueError(f"mesh {name}: the replay needs the scene file's mesh entry")
        path = Path(o["file"])
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        V, F = _read_convex_mesh(path)
        R = _rotation_deg(o.get("rotation_deg", (0.0, 0.0, 0.0)))
        V = (float(o.get("scale", 1.0)) * V) @ R.T + np.asarray(o.get("translation", (0, 0, 0)))
        return _convex_mesh(name, V, F)
    raise ValueError(f"unknown obstacle type {t!r}")


@dataclass
class Scene:
    """Obstacles and the clearance rule (mm)."""

    obstacles: list[Obstacle]
    margin: float = 1.0
    tip_exempt: float = 5.0
    self_margin: float = 1.0

    @property
    def allowance(self) -> float:
        """Rounding allowance of a clearance (mm): 1e-6 plus 1e-13 of the largest coordinate."""
        scale = max([o.scale for o in self.obstacles] + [1000.0])
        return 1e-6 + 1e-13 * scale

    @classmethod
    def from_spec(cls, spec: Mapping[str, Any], base_dir: Path | None = None) -> Scene:
        """From a scene file's contents (``clearance``, ``obstacles``)."""
        c = spec.get("clearance", {})
        return cls(
            [obstacle_from_spec(o, base_dir) for o in spec.get("obstacles", [])],
            float(c.get("margin_mm", 1.0)),
            float(c.get("tool_tip_exempt_mm", 5.0)),
            float(c.get("self_margin_mm", 1.0)),
        )

    @classmethod
    def from_result(cls, doc: Mapping[str, Any]) -> Scene:
        """From a result's own ``scene`` description (when the scene file is not at hand)."""
        s = doc["scene"]
        return cls(
            [obstacle_from_spec(o) for o in s.get("obstacles", [])],
            float(s["clearance_margin_mm"]),
            float(s["tool_tip_exempt_mm"]),
            float(s["self_collision_margin_mm"]),
        )

    def sdf(self, p: np.ndarray) -> np.ndarray:
        """Signed distance of points ``(N, 3)`` to every obstacle: ``(N, O)``."""
        p = np.asarray(p, float).reshape(-1, 3)
        if not self.obstacles:
            return np.zeros((len(p), 0))
        return np.column_stack([o.sdf(p) for o in self.obstacles])


# ---------------------------------------------------------------------------------------------
# The clearance rule along a continuous motion
# ---------------------------------------------------------------------------------------------


@dataclass
class _Pair:
    """One clearance the rule constrains: ``(part, obstacle)`` or ``(link, link)``."""

    label: str
    link: int  # index into arm.links of the sampled link
    tip_cut: float  # > 0: the part is cut at this distance (mm) from the link's end
    is_tip: bool
    required: float  # what the rule requires of the clearance (margin, 0 or self margin)
    radii: float  # capsule radii subtracted from the distance
    obstacle: Obstacle | None = None
    other: int | None = None  # the other link of a self pair

    def values(self, arm: SeedArm | CapsuleArm, P: np.ndarray, step: float) -> np.ndarray:
        """``clearance - required`` at samples every ``step`` mm along the part: ``(C, S)``."""
        i0, i1 = arm.links[self.link]
        a, b = P[:, i0], P[:, i1]
        L = float(np.linalg.norm(b[0] - a[0]))
        lo, hi = 0.0, 1.0
        if self.tip_cut > 0:
            cut = max(0.0, 1.0 - self.tip_cut / L) if L > 0 else 0.0
            lo, hi = (cut, 1.0) if self.is_tip else (0.0, cut)
        n = max(2, math.ceil((hi - lo) * L / step) + 1)
        s = np.linspace(lo, hi, n)
        X = a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]
        flat = X.reshape(-1, 3)
        if self.obstacle is not None:
            d = self.obstacle.sdf(flat)
        else:
            j0, j1 = arm.links[self.other]  # type: ignore[index]
            A = np.repeat(P[:, j0], n, axis=0)
            B = np.repeat(P[:, j1], n, axis=0)
            ab = B - A
            den = np.einsum("ij,ij->i", ab, ab)
            with np.errstate(invalid="ignore", divide="ignore"):
                t = np.where(den > 0, np.einsum("ij,ij->i", flat - A, ab) / den, 0.0)
            t = np.clip(t, 0.0, 1.0)
            d = np.linalg.norm(flat - A - t[:, None] * ab, axis=1)
        return d.reshape(len(P), n) - self.radii - self.required


def _pairs(arm: SeedArm | CapsuleArm, scene: Scene) -> list[_Pair]:
    names, r = arm.link_names, arm.radii
    checked = [k for k in range(len(arm.links)) if arm.checked[k]]
    out = []
    for k in checked:
        last = k == checked[-1]
        for o in scene.obstacles:
            if last and scene.tip_exempt > 0:
                cut = scene.tip_exempt
                out.append(
                    _Pair(f"{names[k]} body - {o.name}", k, cut, False, scene.margin, r[k], o)
                )
                # the tool tip is a bare segment: no radius, it may touch but not enter
                out.append(_Pair(f"{names[k]} tip - {o.name}", k, cut, True, 0.0, 0.0, o))
            else:
                out.append(_Pair(f"{names[k]} - {o.name}", k, 0.0, False, scene.margin, r[k], o))
    for i, j in arm.self_pairs:
        out.append(
            _Pair(
                f"{names[i]} - {names[j]}", i, 0.0, False, scene.self_margin, r[i] + r[j], None, j
            )
        )
    return out


def _instants(
    states_deg: np.ndarray, cmds: np.ndarray, n_sub: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Joint states at ``n_sub[k] + 1`` evenly spaced instants of every command ``k``
    (end points included): ``(sum(n_sub + 1), 6)`` and each row's command."""
    owner = np.repeat(np.arange(len(cmds)), n_sub + 1)
    frac = np.concatenate([np.linspace(0.0, 1.0, m + 1) for m in n_sub])
    return states_deg[owner] + frac[:, None] * cmds[owner], owner


@dataclass
class PairResult:
    label: str
    required: float  # what the rule requires (mm)
    is_self: bool
    sampled_min: float  # smallest sampled clearance - required (mm)
    certified_lower_bound: float  # of clearance - required, from the sampling resolution
    where: tuple[int, float] = (-1, 0.0)  # (command index, fraction of it)
    allowance: float = 1e-6  # rounding allowance (mm): 1e-6 plus 1e-13 of the coordinates


def motion_clearance(
    arm: SeedArm | CapsuleArm,
    scene: Scene,
    states_ticks: np.ndarray,
    time_step_mm: float = TIME_STEP_MM,
    link_step_mm: float = LINK_STEP_MM,
    coarse_mm: float = COARSE_MM,
) -> list[PairResult]:
    """Sampled clearance (less the requirement) of every pair along the continuous motion
    through ``states_ticks`` ``(N + 1, 6)`` (a single state: that configuration alone)."""
    states_deg = np.asarray(states_ticks, dtype=float) / TICKS_PER_DEG
    pairs = _pairs(arm, scene)
    if len(states_deg) == 1:
        P = arm.points(states_deg)
        return [
            PairResult(
                p.label,
                p.required,
                p.obstacle is None,
                float(v.min()),
                float(v.min()) - link_step_mm * 0.025,
                (0, 0.0),
                _allowance(p),
            )
            for p in pairs
            for v in [p.values(arm, P, link_step_mm * 0.05)]
        ]
    cmds = np.diff(states_deg, axis=0)
    move = np.abs(np.radians(cmds)) @ arm.reach_per_joint  # bound on any point's motion (mm)
    out = []
    for pair in pairs:
        mult = 1.0 if pair.obstacle is not None else 2.0  # both links move in a self pair
        best_v, best_where = math.inf, (-1, 0.0)
        lower = np.full(len(cmds), math.inf)
        todo = np.arange(len(cmds))
        for dt, ds in ((coarse_mm, coarse_mm), (time_step_mm, link_step_mm)):
            if todo.size == 0:
                break
            n_sub = np.maximum(1, np.ceil(move[todo] / dt)).astype(int)
            for chunk in np.array_split(np.arange(todo.size), max(1, int(n_sub.sum()) // 4000)):
                if chunk.size == 0:
                    continue
                q, owner = _instants(states_deg[todo[chunk]], cmds[todo[chunk]], n_sub[chunk])
                vals = pair.values(arm, arm.points(q), ds).min(axis=1)
                k = int(np.argmin(vals))
                if vals[k] < best_v:
                    frac_k = _frac_of(owner, k, n_sub[chunk])
                    best_v, best_where = float(vals[k]), (int(todo[chunk][owner[k]]), frac_k)
                per_cmd = np.full(chunk.size, math.inf)
                np.minimum.at(per_cmd, owner, vals)
                res = mult * (move[todo[chunk]] / n_sub[chunk]) / 2 + ds / 2
                lower[todo[chunk]] = per_cmd - res
            todo = todo[lower[todo] < 0]
        if best_where[0] >= 0:
            best_v = min(
                best_v,
                _refine(arm, pair, states_deg, cmds, move, best_where, time_step_mm, link_step_mm),
            )
        out.append(
            PairResult(
                pair.label,
                pair.required,
                pair.obstacle is None,
                best_v,
                float(lower.min()),
                best_where,
                _allowance(pair),
            )
        )
    return out


def _allowance(pair: _Pair) -> float:
    scale = pair.obstacle.scale if pair.obstacle is not None else 0.0
    return 1e-6 + 1e-13 * max(scale, 1000.0)


def _frac_of(owner: np.ndarray, k: int, n_sub: np.ndarray) -> float:
    """The fraction of its command at which row ``k`` of :func:`_instants` lies."""
    first = int(np.searchsorted(owner, owner[k]))
    return (k - first) / n_sub[owner[k]]


def _refine(
    arm: SeedArm | CapsuleArm,
    pair: _Pair,
    states_deg: np.ndarray,
    cmds: np.ndarray,
    move: np.ndarray,
    where: tuple[int, float],
    time_step_mm: float,
    link_step_mm: float,
) -> float:
    """Resample a neighbourhood of the worst sample ``REFINE_FACTOR`` times finer."""
    c, f = where
    n_sub = max(1, math.ceil(move[c] / time_step_mm))
    lo, hi = max(0.0, f - 1.0 / n_sub), min(1.0, f + 1.0 / n_sub)
    frac = np.linspace(lo, hi, 2 * REFINE_FACTOR + 1)
    q = states_deg[c] + frac[:, None] * cmds[c]
    return float(pair.values(arm, arm.points(q), link_step_mm / REFINE_FACTOR).min())


# ---------------------------------------------------------------------------------------------
# Curves
# ---------------------------------------------------------------------------------------------


@dataclass
class DenseCurve:
    """A curve as a dense polyline ``(M, 3)`` (closed: the last point joins the first)."""

    points: np.ndarray
    closed: bool = False
    allowance: float = 0.0  # how far the polyline may be from the true curve (mm)
    _tree: cKDTree = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.points = np.asarray(self.points, dtype=float)
        self._tree = cKDTree(self.points)

    @classmethod
    def from_result(cls, doc: Mapping[str, Any]) -> DenseCurve:
        """The result's own 2001 points; the chord error bounded by a quarter of the largest
        second difference (a parabola between samples sags by an eighth of it)."""
        P = np.asarray(doc["curve"]["points_mm"], dtype=float)
        closed = bool(doc["curve"].get("closed", False))
        second = np.linalg.norm(P[2:] - 2 * P[1:-1] + P[:-2], axis=1)
        return cls(P, closed, 0.25 * float(second.max(initial=0.0)))

    @property
    def spacing(self) -> float:
        """Longest segment (mm)."""
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).max(initial=0.0))

    def distance(self, X: np.ndarray, k: int = 8) -> np.ndarray:
        """Distance of points ``(N, 3)`` to the polyline (its segments at the ``k`` nearest
        vertices)."""
        X = np.asarray(X, dtype=float).reshape(-1, 3)
        M = len(self.points)
        kk = min(k, M)
        _, idx = self._tree.query(X, k=kk)
        idx = idx.reshape(len(X), kk)
        best = np.full(len(X), np.inf)
        for step in (-1, 0):
            i0 = idx + step
            if self.closed:
                i0 %= M
                i1 = (i0 + 1) % M
            else:
                i0 = np.clip(i0, 0, M - 2)
                i1 = i0 + 1
            A, B = self.points[i0], self.points[i1]
            AB = B - A
            den = np.einsum("nkj,nkj->nk", AB, AB)
            with np.errstate(invalid="ignore", divide="ignore"):
                t = np.where(den > 0, np.einsum("nkj,nkj->nk", X[:, None] - A, AB) / den, 0.0)
            t = np.clip(t, 0.0, 1.0)
            d = np.linalg.norm(X[:, None] - A - t[..., None] * AB, axis=2)
            best = np.minimum(best, d.min(axis=1))
        return best


def curve_hausdorff(a: DenseCurve, b: DenseCurve) -> float:
    """Largest distance from a vertex of either polyline to the other polyline."""
    return float(max(b.distance(a.points).max(), a.distance(b.points).max()))


# ---------------------------------------------------------------------------------------------
# Replaying a result document
# ---------------------------------------------------------------------------------------------


@dataclass
class Truth:
    """What the caller asked for, independently of the result (every field optional).

    ``start_deg``: the start state; ``target``: the fingertip target (mm); ``goal_deg``: a joint
    goal; ``targets``: spot-weld points (mm, in the scene's order); ``curve``: the true curve;
    ``tolerance``: the tolerance asked for.
    """

    start_deg: Sequence[float] | None = None
    target: Sequence[float] | None = None
    goal_deg: Sequence[float] | None = None
    targets: np.ndarray | None = None
    curve: DenseCurve | None = None
    tolerance: float | None = None
    return_to_start: bool | None = None


@dataclass
class Replay:
    problems: list[str] = field(default_factory=list)
    states_ticks: np.ndarray | None = None
    clearance: list[PairResult] = field(default_factory=list)
    facts: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.problems


def replay_states(
    doc: Mapping[str, Any], arm: SeedArm | CapsuleArm, problems: list[str]
) -> np.ndarray:
    """Exact integer replay of ``initial_deg`` and ``commands``: states ``(N + 1, 6)``."""
    raw = np.asarray(doc.get("commands", []), dtype=object)
    flat = [v for row in doc.get("commands", []) for v in row]
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in flat):
        problems.append("a command increment is not an integer")
    try:
        cmds = np.array(doc.get("commands", []), dtype=float).reshape(-1, 6)
    except ValueError:
        problems.append(f"commands are not rows of 6 increments (shape {raw.shape})")
        cmds = np.zeros((0, 6))
    if not np.all(cmds == np.rint(cmds)):
        problems.append("a command increment is not a whole number of ticks")
    cmds = np.rint(cmds).astype(np.int64)
    if np.abs(cmds).max(initial=0) > MAX_TICKS:
        k = int(np.argmax(np.abs(cmds).max(axis=1)))
        problems.append(f"command {k + 1} {cmds[k].tolist()} has an increment beyond 20 ticks")
    if doc.get("n_commands", len(cmds)) != len(cmds):
        problems.append(f"n_commands {doc.get('n_commands')} but {len(cmds)} commands")
    init = np.asarray(doc["initial_deg"], dtype=float) * TICKS_PER_DEG
    if init.shape != (6,) or not np.allclose(init, np.rint(init), atol=1e-6):
        problems.append(f"initial_deg {doc['initial_deg']} is not on the 0.1 deg lattice")
    start = np.rint(init).astype(np.int64)
    states = np.vstack([start, start + np.cumsum(cmds, axis=0)])
    lo, hi = arm.tick_limits
    bad = np.argwhere((states < lo) | (states > hi))
    if bad.size:
        k, j = bad[0]
        problems.append(
            f"state {k} has joint {j + 1} at {states[k, j] / 10:g} deg, outside its limits "
            f"{arm.limits_deg[j]}"
        )
    if "final_deg" in doc and not np.allclose(
        np.asarray(doc["final_deg"], float) * TICKS_PER_DEG, states[-1], atol=1e-6
    ):
        problems.append("final_deg does not match the replayed commands")
    return states


def replay_result(
    doc: Mapping[str, Any],
    scene: Scene | None = None,
    truth: Truth | None = None,
    time_step_mm: float = TIME_STEP_MM,
    link_step_mm: float = LINK_STEP_MM,
    tip_step_mm: float = TIP_STEP_MM,
    arm: SeedArm | CapsuleArm | None = None,
) -> Replay:
    """Replay a result document (reach, plan, spotweld, trace) independently.

    ``scene``: the scene as the caller wrote it (default: the result's own description);
    ``truth``: what was asked for; ``arm``: the arm asked for (default: the SPEC's seed arm
    with the result's link radius; the result's joint limits must be the SPEC's; any other arm
    is a :class:`CapsuleArm` with the caller's own kinematics). Returns the problems found
    (empty: accepted) and facts.
    """
    truth = truth or Truth()
    rep = Replay()
    P = rep.problems
    claimed: SeedArm | None = None
    try:
        if not isinstance(arm, CapsuleArm):
            claimed = SeedArm.from_model(doc["model"])
        scene = scene or Scene.from_result(doc)
    except (KeyError, ValueError) as exc:
        P.append(f"cannot replay: {exc}")
        return rep
    if arm is None:
        assert claimed is not None
        arm = SeedArm(link_radius=claimed.link_radius)
    states = replay_states(doc, arm, P)
    rep.states_ticks = states
    if truth.start_deg is not None and not np.array_equal(
        states[0], np.rint(np.asarray(truth.start_deg, float) * TICKS_PER_DEG).astype(np.int64)
    ):
        P.append(f"starts at {(states[0] / 10).tolist()}, asked {list(truth.start_deg)}")
    if P:
        return rep  # the motion itself is not legal: nothing more to judge
    if claimed is not None and isinstance(arm, SeedArm):
        _check_claimed_seed_arm(doc, claimed, arm, P)
    # clearance along the continuous motion
    rep.clearance = motion_clearance(arm, scene, states, time_step_mm, link_step_mm)
    eps = scene.allowance
    worst = min(rep.clearance, key=lambda c: c.sampled_min, default=None)
    # each pair's allowance covers rounding at its obstacle's coordinates; every sample is a
    # real point of the motion, so nothing is allowed for the sampling (module docstring)
    if worst is not None:
        rep.facts["min_slack_mm"] = worst.sampled_min
        rep.facts["min_slack_pair"] = worst.label
    for c in rep.clearance:
        if c.sampled_min < -c.allowance:
            P.append(
                f"clearance broken: {c.label} is {-c.sampled_min:.4g} mm short of its "
                f"requirement during command {c.where[0] + 1} (at {c.where[1]:.3f} of it)"
            )
    reported = doc.get("clearance", {}).get("min_clearance_lower_bound_mm")
    if reported is not None and rep.clearance:
        # the reported bound is of the smallest clearance to an obstacle (tool tip included,
        # radii subtracted): no sample of it may be smaller
        sampled = min(
            (c.sampled_min + c.required for c in rep.clearance if not c.is_self), default=math.inf
        )
        rep.facts["min_clearance_sampled_mm"] = sampled
        if float(reported) > sampled + 1e-6 + eps:
            P.append(
                f"reported clearance lower bound {reported:.6g} mm exceeds a sampled clearance "
                f"{sampled:.6g} mm"
            )
    tips = arm.points(states / TICKS_PER_DEG)[:, arm.tip_index]
    tol = truth.tolerance if truth.tolerance is not None else doc.get("tolerance_mm")
    task = doc.get("task")
    if "tip" in doc and not np.allclose(doc["tip"], tips[-1], atol=1e-6):
        P.append(f"reported tip {doc['tip']} but the final state puts it at {tips[-1].tolist()}")
    target = truth.target if truth.target is not None else doc.get("target")
    if task in ("reach", "plan") and target is not None:
        err = float(np.linalg.norm(tips[-1] - np.asarray(target, float)))
        rep.facts["error_mm"] = err
        if tol is not None and err > float(tol) + 1e-9:
            P.append(f"fingertip error {err:.6g} mm exceeds the tolerance {tol} mm")
        if "error_mm" in doc and abs(float(doc["error_mm"]) - err) > 1e-6:
            P.append(f"reported error {doc['error_mm']:.6g} mm, replayed {err:.6g} mm")
        if (
            truth.target is not None
            and "target" in doc
            and not np.allclose(doc["target"], truth.target, atol=1e-9)
        ):
            P.append(f"target {doc['target']} is not the one asked {list(truth.target)}")
    if task == "reach" or (task == "plan" and truth.goal_deg is not None):
        need = int(np.ceil(np.abs(states[-1] - states[0]).max(initial=0) / MAX_TICKS))
        if task == "plan" and truth.goal_deg is not None:
            goal = np.rint(np.asarray(truth.goal_deg, float) * TICKS_PER_DEG).astype(np.int64)
            if not np.array_equal(states[-1], goal):
                P.append(f"ends at {(states[-1] / 10).tolist()}, goal {list(truth.goal_deg)}")
        if len(states) - 1 < need:
            P.append("fewer commands than the joint changes need (impossible)")
    lb = doc.get("lower_bound_commands")
    if lb is not None and task in ("reach", "trace", "spotweld") and len(states) - 1 < int(lb):
        P.append(f"{len(states) - 1} commands beat the claimed lower bound {lb}")
    if task == "spotweld":
        _check_spotweld(doc, truth, tips, states, tol, P, rep.facts)
    if task == "trace":
        _check_trace(doc, truth, arm, states, tol, tip_step_mm, P, rep.facts)
    return rep


def _check_claimed_seed_arm(
    doc: Mapping[str, Any], claimed: SeedArm, arm: SeedArm, P: list[str]
) -> None:
    """The result must describe the arm asked for (the motion is judged with that arm anyway)."""
    radii = [
        float(link["radius"])
        for link in doc["model"].get("definition", {}).get("links", [])
        if "radius" in link
    ]
    if not np.allclose(claimed.limits_deg, arm.limits_deg, rtol=0, atol=1e-9):
        P.append(f"the result's joint limits {claimed.limits_deg} are not {arm.limits_deg}")
    for what, r in [("model.parameters.link_radius_mm", claimed.link_radius)] + [
        ("a link radius of model.definition", r) for r in radii
    ]:
        if not math.isclose(r, arm.link_radius, abs_tol=1e-9):
            P.append(f"{what} is {r:g} mm, the arm asked for has {arm.link_radius:g} mm")
            break


def _check_spotweld(
    doc: Mapping[str, Any],
    truth: Truth,
    tips: np.ndarray,
    states: np.ndarray,
    tol: float | None,
    P: list[str],
    facts: dict[str, Any],
) -> None:
    targets = np.asarray(doc.get("targets", []), dtype=float)
    if truth.targets is not None and (
        targets.shape != np.shape(truth.targets)
        or not np.allclose(targets, truth.targets, atol=1e-6)
    ):
        P.append(
            f"targets {targets.tolist()} are not the independent ones "
            f"{np.asarray(truth.targets).tolist()}"
        )
        return
    seen = []
    worst = 0.0
    for v in doc.get("visits", []):
        k = int(v["after_command"])
        if not 0 <= k < len(states):
            P.append(f"visit after command {k} is outside the sequence")
            continue
        t = np.asarray(v["target"], dtype=float)
        match = [i for i, g in enumerate(targets) if np.allclose(g, t, atol=1e-9)]
        if not match:
            P.append(f"visit of {t.tolist()}, which is not a target")
            continue
        seen.append(match[0])
        err = float(np.linalg.norm(tips[k] - t))
        worst = max(worst, err)
        if tol is not None and err > float(tol) + 1e-9:
            P.append(f"weld {t.tolist()} missed by {err:.6g} mm (tolerance {tol})")
        if abs(float(v.get("error_mm", err)) - err) > 1e-6:
            P.append(f"weld {t.tolist()}: reported error {v['error_mm']}, replayed {err}")
    facts["error_mm"] = worst
    if sorted(seen) != list(range(len(targets))):
        P.append(f"targets visited {sorted(seen)} instead of each of {len(targets)} once")
    afters = [int(v["after_command"]) for v in doc.get("visits", [])]
    if afters != sorted(afters):
        P.append("visits are not in the order of the commands")
    back = (
        truth.return_to_start if truth.return_to_start is not None else doc.get("returns_to_start")
    )
    if back and not np.array_equal(states[-1], states[0]):
        P.append("asked to return to the start, it does not")


def _check_trace(
    doc: Mapping[str, Any],
    truth: Truth,
    arm: SeedArm | CapsuleArm,
    states: np.ndarray,
    tol: float | None,
    tip_step_mm: float,
    P: list[str],
    facts: dict[str, Any],
) -> None:
    own = DenseCurve.from_result(doc)
    curve = truth.curve or own
    if truth.curve is not None:
        gap = curve_hausdorff(own, truth.curve)
        facts["curve_hausdorff_mm"] = gap
        # the result's points are on the curve; its chords may cut a corner by half a chord
        if gap > 1e-3 + own.allowance + own.spacing / 2:
            P.append(f"the result's curve is {gap:.4g} mm from the curve asked for")
            return
    tol = float(tol if tol is not None else doc["tolerance_mm"])
    allowance = curve.allowance + 1e-9
    deg = states.astype(float) / TICKS_PER_DEG
    cmds = np.diff(deg, axis=0)
    R = arm.reach_per_joint
    devs = []
    for i, j in doc.get("passes", []):
        if not (0 <= i < j <= len(states) - 1):
            what = "has no commands" if i == j else "is not a range of states"
            P.append(f"pass {[i, j]} {what} (states 0..{len(states) - 1})")
            continue
        move = np.abs(np.radians(cmds[i:j])) @ R
        n_sub = np.maximum(1, np.ceil(move / tip_step_mm)).astype(int)
        q, owner = _instants(deg[i:j], cmds[i:j], n_sub)
        E = arm.points(q)[:, arm.tip_index]
        d = curve.distance(E)
        k = int(np.argmax(d))
        dev = float(d[k])
        # resample around the worst instant
        c = i + int(owner[k])
        f = _frac_of(owner, k, n_sub)
        step = 1.0 / n_sub[owner[k]]
        fr = np.linspace(max(0.0, f - step), min(1.0, f + step), 2 * REFINE_FACTOR + 1)
        dev = max(
            dev,
            float(
                curve.distance(arm.points(deg[c] + fr[:, None] * cmds[c])[:, arm.tip_index]).max()
            ),
        )
        devs.append(dev)
        if dev > tol + allowance:
            P.append(
                f"pass {[i, j]}: the fingertip leaves the curve by {dev:.6g} mm "
                f"(tolerance {tol}) during command {c + 1}"
            )
        _check_swept(doc, own, [i, j], E, tol, tip_step_mm + allowance, P)
    facts["max_deviation_mm"] = max(devs, default=0.0)
    bound = doc.get("max_deviation_bound_mm")
    if devs and bound is not None and max(devs) > float(bound) + allowance + 1e-6:
        P.append(f"sampled deviation {max(devs):.6g} mm exceeds the reported bound {bound:.6g}")


def _check_swept(
    doc: Mapping[str, Any],
    own: DenseCurve,
    states: list[int],
    E: np.ndarray,
    tol: float,
    slack: float,
    P: list[str],
) -> None:
    """The pass's claimed arc is swept: the arc-length positions of the curve points nearest to
    the tip (at samples within the tolerance) leave no gap longer than ``GAP_TOLERANCES``
    tolerances inside it. (A path may cut a corner of the curve within the tolerance band: the
    nearest points then jump across the corner, by about twice the tolerance over the tangent
    of half the corner angle; a longer gap means part of the arc was not followed.)"""
    detail = [p for p in doc.get("pass_details", []) if list(p["states"]) == states]
    if not detail:
        return
    s0, s1 = float(detail[0]["start_mm"]), float(detail[0]["end_mm"])
    s = np.asarray(doc["curve"]["arc_length_mm"], dtype=float)
    L = float(doc["curve"]["length_mm"])
    lo, hi = min(s0, s1), max(s0, s1)
    _, idx = own._tree.query(E)
    near = own.distance(E) <= tol + slack
    pos = s[idx[near]]
    if own.closed:
        pos = lo + np.mod(pos - lo, L)
    pos = np.sort(np.r_[pos, pos - L, pos + L] if own.closed else pos)
    allowed = GAP_TOLERANCES * tol + 2 * L / max(len(s) - 1, 1)
    inside = pos[(pos >= lo) & (pos <= hi)]
    edges = np.r_[lo, inside, hi] if inside.size else np.array([lo, hi])
    gaps = np.diff(edges)
    if gaps.size and gaps.max() > allowed:
        k = int(np.argmax(gaps))
        P.append(
            f"pass {states} claims {s0:.2f}..{s1:.2f} mm but its tip follows no part of "
            f"{edges[k]:.2f}..{edges[k + 1]:.2f} mm of it (within the tolerance {tol})"
        )


# ---------------------------------------------------------------------------------------------
# True curves
# ---------------------------------------------------------------------------------------------


def frustum_section_curve(
    base_center: Sequence[float],
    axis: Sequence[float],
    height: float,
    r_bottom: float,
    r_top: float,
    plane_point: Sequence[float],
    plane_normal: Sequence[float],
    samples: int = 200_001,
) -> DenseCurve:
    """Where a plane cuts the outer face of a frustum (outer radius ``r_bottom -> r_top`` over
    ``height`` along ``axis``): around the axis at angle ``phi`` the face point at height ``z``
    is ``o + r(z) (cos phi e1 + sin phi e2) + z a`` with ``r`` linear in ``z``, and the plane
    equation is linear in ``z``. Raises ValueError when the section leaves the face."""
    o = np.asarray(base_center, float)
    a = _unit(axis, "axis")
    n = _unit(plane_normal, "plane normal")
    e1 = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    k = (float(r_top) - float(r_bottom)) / float(height)
    phi = np.linspace(0.0, 2 * np.pi, samples)[:-1]
    radial = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
    c = radial @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        z = -(n @ (o - np.asarray(plane_point, float)) + float(r_bottom) * c) / (k * c + n @ a)
    if not np.all(np.isfinite(z)) or z.min() < -1e-9 or z.max() > float(height) + 1e-9:
        raise ValueError("the plane does not cut the outer face in one closed curve")
    pts = o + (float(r_bottom) + k * z)[:, None] * radial + z[:, None] * a
    return DenseCurve(pts, closed=True)


def polyline_curve(vertices: Sequence[Sequence[float]], closed: bool = False) -> DenseCurve:
    """A polyline is its own dense form (segments exact)."""
    V = np.asarray(vertices, dtype=float)
    # split long segments so that the nearest-vertex search always sees the right segment
    pts = [V[0]]
    ring = np.vstack([V, V[:1]]) if closed else V
    for p, q in itertools.pairwise(ring):
        m = max(1, math.ceil(float(np.linalg.norm(q - p)) / 0.5))
        pts += [p + (q - p) * (i / m) for i in range(1, m + 1)]
    P = np.array(pts[:-1] if closed else pts)
    return DenseCurve(P, closed=closed)


def sampled_curve(
    f: Callable[[np.ndarray], np.ndarray], t0: float, t1: float, spacing_mm: float = 0.002
) -> DenseCurve:
    """A parametric curve ``f(t) -> (N, 3)`` sampled so that consecutive points are at most about
    ``spacing_mm`` apart (closed when its ends meet)."""
    t = np.linspace(t0, t1, 20_001)
    P = f(t)
    length = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
    n = int(min(2_000_001, max(20_001, length / spacing_mm)))
    t = np.linspace(t0, t1, n)
    P = f(t)
    closed = bool(np.linalg.norm(P[-1] - P[0]) < 1e-9)
    return DenseCurve(P[:-1] if closed else P, closed=closed)


def config_slack(
    arm: SeedArm | CapsuleArm, scene: Scene, theta_deg: np.ndarray, link_step_mm: float = 1.0
) -> np.ndarray:
    """Smallest sampled ``clearance - required`` over every pair, per configuration ``(K,)``
    (links sampled every ``link_step_mm``; inf without pairs)."""
    P = arm.points(np.atleast_2d(np.asarray(theta_deg, dtype=float)))
    out = np.full(len(P), np.inf)
    for pair in _pairs(arm, scene):
        out = np.minimum(out, pair.values(arm, P, link_step_mm).min(axis=1))
    return out
