"""Which parts of a curve the fingertip can be on, and why the others are out of bounds.

A point of the curve is *reachable* when some configuration puts the fingertip exactly on it with
every joint within its limits and the clearance rule kept (links keep the margin from every
obstacle and each other; the tool tip may touch but not penetrate). The fingertip depends on
joints 1-5 only, so each point has a two-dimensional family of solutions: the wrist point D on the
sphere of radius DE around the point, four geometric branches (arm side x elbow; the wrist flip
gives the same links and the same limit slack). For a curve that lies on an obstacle's surface
(the *surface*, e.g. the weld seam on the workpiece) the tool must come from outside, so only
directions with ``(E - D) . n <= 0`` (``n`` the outward normal) are searched.

Reachability of a point is decided by the *score* ``max over the family of min(slacks)``, where a
slack is a pair's clearance less what it needs (mm) or a joint's distance to its limit (deg,
counted 1:1 with mm — only the sign decides). The curve is scanned at ``scan_step_mm``; every
change of verdict is then bisected to ``resolution_mm`` with the family searched on a finer grid and
polished by Nelder-Mead, so the ends of unreachable arcs are located to that resolution.

The reason an arc is unreachable comes from relaxations at points inside it: *out of reach* (no
real solution at all), *joint limits* (unreachable even with the clearances ignored, except that
the tool must still come from outside the surface it works on), *collision with* an obstacle
(unreachable with that obstacle alone, limits ignored), or both together.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from armpath.budget import check_size, check_time
from armpath.errors import InvalidInputError
from armpath.geometry.curves import Curve
from armpath.geometry.primitives import Obstacle, orthonormal_frame
from armpath.geometry.world import CollisionWorld
from armpath.ik.seed_position import family_from_wrist
from armpath.kinematics import landmark_positions
from armpath.model.seed_arm import SeedArmGeometry, seed_geometry_of
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]

#: A fingertip this close to the surface (or inside by at most this much) touches it (mm).
TOUCH_MM = 1e-6
#: Tool directions this far past tangent to the surface are still searched (cosine).
_PAST_TANGENT = 0.02
#: Branches of :func:`family_from_wrist` that differ geometrically (wrist flip dropped).
_BRANCHES = (0, 2, 4, 6)
#: Most scan points of one reachability analysis (a 400 m curve at the default 4 mm step).
MAX_SCAN_POINTS = 100_000


def fibonacci_directions(count: int) -> FloatArray:
    """``count`` nearly uniform unit vectors ``(count, 3)`` (Fibonacci sphere)."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = np.pi * (1.0 + np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


@dataclass(frozen=True)
class Verdict:
    """The best configuration the family search found for one curve point.

    ``score`` is the smallest slack there (>= 0: reachable); ``q`` joints (rad, 6) or NaN when the
    point has no real solution; ``limiting`` names the constraints at the smallest slack (see
    :meth:`CurveFamily.limiting`).
    """

    s_mm: float
    score: float
    q: FloatArray
    limiting: tuple[str, ...]

    @property
    def reachable(self) -> bool:
        return bool(self.score >= 0.0)

    @property
    def out_of_reach(self) -> bool:
        """No configuration at all puts the fingertip there."""
        return not bool(np.all(np.isfinite(self.q)))


@dataclass(frozen=True)
class CurveArc:
    """The arc from arc length ``start_mm`` to ``end_mm`` (``end_mm`` may exceed the length of a
    closed curve: the arc then runs on past its start)."""

    start_mm: float
    end_mm: float

    @property
    def length_mm(self) -> float:
        return self.end_mm - self.start_mm


@dataclass(frozen=True)
class UnreachableArc(CurveArc):
    """An arc no configuration reaches. ``reason`` says why in words, ``blocked_by`` lists the
    constraint groups that block it (``"out of reach"``, ``"joint limits"``, ``"collision with
    NAME"``, ``"joint limits and collisions together"``); ``limiting_at_start`` and
    ``limiting_at_end`` the constraints active in the last reachable configuration next to each
    end (empty when the arc reaches the end of an open curve)."""

    reason: str = ""
    blocked_by: tuple[str, ...] = ()
    limiting_at_start: tuple[str, ...] = ()
    limiting_at_end: tuple[str, ...] = ()


@dataclass(frozen=True)
class CurveReachability:
    """Reachable and unreachable arcs of a curve, with the scan they came from and the solution
    family searched."""

    curve: Curve
    surface: str | None
    reachable: tuple[CurveArc, ...]
    unreachable: tuple[UnreachableArc, ...]
    resolution_mm: float
    scan_s_mm: FloatArray
    scan_score: FloatArray
    family: CurveFamily = field(repr=False)

    @property
    def reachable_mm(self) -> float:
        return float(sum(a.length_mm for a in self.reachable))


@dataclass
class CurveFamily:
    """The solution family of the fingertip on a curve, for one arm and scene.

    ``surface`` is the obstacle the curve lies on (found automatically: the one whose surface is
    within :data:`TOUCH_MM` of every sampled curve point), or None for a curve in free space.
    """

    arm: SerialArm
    world: CollisionWorld
    curve: Curve
    geometry: SeedArmGeometry = field(init=False)
    surface: Obstacle | None = field(init=False)

    def __post_init__(self) -> None:
        self.geometry = seed_geometry_of(self.arm)
        pts = self.curve.sample(257)
        self.surface = None
        for o in self.world.obstacles:
            if np.max(np.abs(o.signed_distance(pts))) <= 1e-6:
                self.surface = o
        pairs = self.world.pairs(self.arm)
        self._required = self.world.required(self.arm)
        touching = np.array(
            [p.is_tip and self.surface is not None and p.other == self.surface.name for p in pairs]
        )
        self._touch_cols = touching
        self._labels = [p.label for p in pairs]
        self._others = [p.other for p in pairs]
        self._is_self = np.array([p.is_self for p in pairs], dtype=bool)
        #: joints without limits (turning by whole turns gives the same links)
        self.unlimited = ~(np.isfinite(self.arm.lower) | np.isfinite(self.arm.upper))
        self._lo = np.where(np.isfinite(self.arm.lower), self.arm.lower, -np.inf)
        self._hi = np.where(np.isfinite(self.arm.upper), self.arm.upper, np.inf)

    # -- geometry of the curve -------------------------------------------------------------
    def frame(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Point, unit tangent and outward normal (zero without a surface) at arc length ``s``
        (mm; brought onto the curve by :meth:`Curve.wrap`)."""
        h = 1e-3
        c, before, after = self.curve.at_arc_length(np.array([s, s - h, s + h]))
        t = after - before
        t = t / np.linalg.norm(t)
        if self.surface is None:
            return c, t, np.zeros(3)
        n = self.surface.outward_normal(c)
        n = n - (n @ t) * t
        return c, t, n / np.linalg.norm(n)

    @cached_property
    def coarse_dirs(self) -> FloatArray:
        """Tool directions of the scan (2000, about 4.5 deg apart)."""
        return fibonacci_directions(2000)

    @cached_property
    def fine_dirs(self) -> FloatArray:
        """Tool directions of the refined search (8000, about 2.3 deg apart)."""
        return fibonacci_directions(8000)

    # -- the family at one point -------------------------------------------------------------
    def configs(self, s: float, dirs: FloatArray) -> FloatArray:
        """Family members ``(M, 6)`` rad with the fingertip on the curve at ``s`` (E - D along
        ``dirs``, every geometric branch; members without a real solution dropped)."""
        c, _, n = self.frame(s)
        if self.surface is not None:
            dirs = dirs[dirs @ n <= _PAST_TANGENT]
        return self.configs_at(c, dirs)

    def configs_at(self, E: FloatArray, dirs: FloatArray) -> FloatArray:
        wrist = E - self.geometry.de_mm * dirs
        sol = family_from_wrist(self.geometry, E, wrist)[:, _BRANCHES, :]
        q = np.concatenate([sol, np.zeros((*sol.shape[:-1], 1))], axis=-1).reshape(-1, 6)
        return q[np.all(np.isfinite(q), axis=-1)]

    def slacks(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Per configuration: joint slacks ``(M, n)`` deg, pair slacks ``(M, K)`` mm (the tool
        tip against the surface excluded: NaN) and whether the tool tip stays out of the surface.
        """
        with np.errstate(invalid="ignore"):
            joint = np.degrees(np.minimum(self._hi - q, q - self._lo))
        values, _ = self.world.pair_clearances(self.arm, q)
        pair = values - self._required
        tip_ok = np.all(pair[:, self._touch_cols] >= -TOUCH_MM, axis=-1)
        pair[:, self._touch_cols] = np.nan
        return joint, pair, tip_ok

    def score(
        self, q: FloatArray, limits: bool = True, obstacles: tuple[str, ...] | None = None
    ) -> FloatArray:
        """Smallest slack per configuration (-inf when the tool tip enters the surface).

        ``limits=False`` ignores joint limits; ``obstacles`` keeps only the pairs against those
        obstacles (None: every pair, link pairs included; ``()``: no pair).
        """
        joint, pair, tip_ok = self.slacks(q)
        parts = []
        if limits:
            parts.append(np.min(joint, axis=-1))
        keep = self._columns(obstacles)
        if np.any(keep):
            parts.append(np.nanmin(np.where(keep, pair, np.nan), axis=-1, initial=np.inf))
        out = np.minimum.reduce(parts) if parts else np.full(q.shape[0], np.inf)
        return np.where(tip_ok, out, -np.inf)

    def _columns(self, obstacles: tuple[str, ...] | None) -> NDArray[np.bool_]:
        cols = ~self._touch_cols
        if obstacles is None:
            return cols
        chosen = np.array([o in obstacles for o in self._others], dtype=bool)
        return np.asarray(cols & chosen & ~self._is_self, dtype=bool)

    def limiting(
        self,
        q: FloatArray,
        limits: bool = True,
        obstacles: tuple[str, ...] | None = None,
        within: float = 0.01,
    ) -> tuple[str, ...]:
        """Constraints within ``within`` of the smallest slack at one configuration ``(6,)``
        (among those :meth:`score` counts with the same ``limits`` and ``obstacles``)."""
        joint, pair, _ = self.slacks(q[None])
        joint = joint[0] if limits else np.full(joint.shape[1], np.inf)
        pair = np.where(self._columns(obstacles), pair[0], np.nan)
        lowest = min(float(np.min(joint)), float(np.nanmin(pair, initial=np.inf)))
        out = []
        for j in np.flatnonzero(joint <= lowest + within):
            which = "upper" if self._hi[j] - q[j] < q[j] - self._lo[j] else "lower"
            limit = self._hi[j] if which == "upper" else self._lo[j]
            out.append(f"joint {j + 1} at its {which} limit {np.degrees(limit):g} deg")
        for k in np.flatnonzero(np.nan_to_num(pair, nan=np.inf) <= lowest + within):
            need = self._required[k]
            out.append(f"{self._labels[k]} clearance {pair[k] + need:.3f} mm (needs {need:g})")
        return tuple(out)

    def best(
        self,
        s: float,
        fine: bool = False,
        limits: bool = True,
        obstacles: tuple[str, ...] | None = None,
    ) -> Verdict:
        """The family member with the largest score at ``s``: grid, then (``fine``) a finer grid
        polished by Nelder-Mead over the tool direction."""
        dirs = self.fine_dirs if fine else self.coarse_dirs
        q = self.configs(s, dirs)
        if q.shape[0] == 0:
            return Verdict(s, -np.inf, np.full(6, np.nan), ("out of reach",))
        sc = self.score(q, limits, obstacles)
        k = int(np.argmax(sc))
        best_q, best_sc = q[k], float(sc[k])
        if fine:
            best_q, best_sc = self._polish(s, q, sc, limits, obstacles, best_q, best_sc)
        lim = self.limiting(best_q, limits, obstacles) if best_sc > -np.inf else ()
        return Verdict(s, best_sc, best_q, lim)

    def _polish(
        self,
        s: float,
        q: FloatArray,
        sc: FloatArray,
        limits: bool,
        obstacles: tuple[str, ...] | None,
        best_q: FloatArray,
        best_sc: float,
    ) -> tuple[FloatArray, float]:
        c, _, n = self.frame(s)
        axis = -n if self.surface is not None else np.array([0.0, 0.0, 1.0])
        e1, e2 = orthonormal_frame(axis)
        # the direction E - D of each candidate, as polar angles about ``axis``
        pts_d = self._wrist_dirs(q, c)

        def member(x: FloatArray, branch: int) -> FloatArray:
            """The family member of ``branch`` whose tool direction has polar angles ``x``."""
            u = np.cos(x[0]) * axis + np.sin(x[0]) * (np.cos(x[1]) * e1 + np.sin(x[1]) * e2)
            sol = family_from_wrist(self.geometry, c, (c - self.geometry.de_mm * u)[None])
            return np.asarray(np.r_[sol[0, _BRANCHES[branch]], 0.0], dtype=np.float64)

        for k in np.argsort(-sc)[:3]:
            if not np.isfinite(sc[k]):
                break
            d = pts_d[k]
            x0 = np.array([np.arccos(np.clip(d @ axis, -1, 1)), np.arctan2(d @ e2, d @ e1)])
            branch = self._branch_of(q[k], c, d)

            def objective(x: FloatArray, branch: int = branch) -> float:
                cand = member(x, branch)
                if not np.all(np.isfinite(cand)):
                    return 1e6
                return -float(self.score(cand[None], limits, obstacles)[0])

            res = minimize(
                objective,
                x0,
                method="Nelder-Mead",
                options={"xatol": 1e-4, "fatol": 1e-5, "maxfev": 250},
            )
            if -res.fun > best_sc:
                best_q, best_sc = member(res.x, branch), float(-res.fun)
        return best_q, best_sc

    def _wrist_dirs(self, q: FloatArray, E: FloatArray) -> FloatArray:
        D = landmark_positions(self.arm, q)[:, -2, :]
        u = E - D
        return np.asarray(u / np.linalg.norm(u, axis=-1, keepdims=True), dtype=np.float64)

    def _branch_of(self, q: FloatArray, E: FloatArray, d: FloatArray) -> int:
        sols = family_from_wrist(self.geometry, E, (E - self.geometry.de_mm * d)[None])[
            0, _BRANCHES
        ]
        err = np.nan_to_num(np.abs(sols - q[:5]).max(axis=-1), nan=np.inf)
        return int(np.argmin(err))


def curve_reachability(
    arm: SerialArm,
    world: CollisionWorld,
    curve: Curve,
    scan_step_mm: float = 4.0,
    resolution_mm: float = 0.05,
    on_progress: Callable[[str], None] | None = None,
) -> CurveReachability:
    """Reachable and unreachable arcs of ``curve`` (ends located to ``resolution_mm``)."""
    if not (np.isfinite(scan_step_mm) and scan_step_mm > 0):
        raise InvalidInputError(f"scan step must be > 0 mm, got {scan_step_mm}")
    if not (np.isfinite(resolution_mm) and resolution_mm >= 1e-6):
        raise InvalidInputError(f"resolution must be >= 1e-6 mm, got {resolution_mm}")
    fam = CurveFamily(arm, world, curve)
    say = on_progress or (lambda _m: None)
    L = curve.length
    check_size(
        L / scan_step_mm,
        MAX_SCAN_POINTS,
        f"scanning the {L:.4g} mm curve {curve.name!r} every {scan_step_mm:g} mm",
        "the curve (shorter) or the scan step (larger)",
    )
    n = max(int(np.ceil(L / scan_step_mm)), 4)
    s_scan = np.linspace(0.0, L, n + 1)
    if curve.closed:
        s_scan = s_scan[:-1]
    say(f"reachability: scanning {s_scan.size} points of {curve.name!r}")
    scores = np.empty(s_scan.size)
    for i, s in enumerate(s_scan):
        check_time("scanning the curve for reachable points")
        scores[i] = fam.best(float(s)).score
    ok = scores >= 0.0
    # a coarse "no" might be a fine "yes": re-check the scan points next to a change
    for i in range(s_scan.size):
        if not ok[i]:
            check_time("scanning the curve for reachable points")
            nb = [i - 1, i + 1] if curve.closed else [j for j in (i - 1, i + 1) if 0 <= j < n + 1]
            if any(ok[j % s_scan.size] for j in nb) or scores[i] > -0.5:
                v = fam.best(float(s_scan[i]), fine=True)
                scores[i], ok[i] = v.score, v.reachable
    say("reachability: locating the ends of the unreachable arcs")

    def boundary(s_in: float, s_out: float) -> tuple[float, Verdict]:
        """Bisect between a reachable and an unreachable arc length (the gap halves each step,
        so at most ``log2(gap / resolution)`` steps)."""
        last = fam.best(s_in, fine=True)
        steps = int(np.ceil(np.log2(max(abs(s_out - s_in), resolution_mm) / resolution_mm))) + 1
        for _ in range(steps):
            if abs(s_out - s_in) <= resolution_mm:
                break
            check_time("locating the ends of the unreachable arcs")
            mid = 0.5 * (s_in + s_out)
            v = fam.best(mid)  # a coarse witness proves reachability; only "no" is refined
            if not v.reachable:
                v = fam.best(mid, fine=True)
            if v.reachable:
                s_in, last = mid, v
            else:
                s_out = mid
        return s_in, last

    if np.all(ok):
        arcs = [CurveArc(0.0, L)]
        return CurveReachability(
            curve, _name(fam), tuple(arcs), (), resolution_mm, s_scan, scores, fam
        )
    if not np.any(ok):
        bad = UnreachableArc(0.0, L, *_reason(fam, 0.0, L))
        return CurveReachability(curve, _name(fam), (), (bad,), resolution_mm, s_scan, scores, fam)
    # every change of verdict between neighbouring scan points, bisected
    edges: list[tuple[float, bool, tuple[str, ...]]] = []  # (s, enters reachable, limiting)
    m = s_scan.size
    for a in range(m if curve.closed else m - 1):
        b = (a + 1) % m
        if ok[a] == ok[b]:
            continue
        sa, sb = float(s_scan[a]), float(s_scan[b] + (L if b < a else 0.0))
        if ok[a]:
            s_edge, v = boundary(sa, sb)
            edges.append((s_edge, False, v.limiting))
        else:
            s_edge, v = boundary(sb, sa)
            edges.append((s_edge, True, v.limiting))
    reach_arcs: list[CurveArc] = []
    bad_arcs: list[UnreachableArc] = []
    if curve.closed:
        # start at an edge entering the reachable part; edges alternate enter / leave
        k0 = next(i for i, e in enumerate(edges) if e[1])
        ring = edges[k0:] + [(e[0] + L, e[1], e[2]) for e in edges[:k0]]
        for i in range(0, len(ring), 2):
            enter, leave = ring[i], ring[i + 1]
            nxt = ring[(i + 2) % len(ring)]
            nxt_s = nxt[0] + (L if i + 2 >= len(ring) else 0.0)
            reach_arcs.append(CurveArc(enter[0], leave[0]))
            bad_arcs.append(_bad(fam, leave[0], nxt_s, leave[2], nxt[2]))
    else:
        cursor: float | None = 0.0 if ok[0] else None
        bad_from: tuple[float, tuple[str, ...]] | None = None if ok[0] else (0.0, ())
        for s_edge, enters, lim in edges:
            if enters:
                assert bad_from is not None
                bad_arcs.append(_bad(fam, bad_from[0], s_edge, bad_from[1], lim))
                cursor, bad_from = s_edge, None
            else:
                assert cursor is not None
                reach_arcs.append(CurveArc(cursor, s_edge))
                cursor, bad_from = None, (s_edge, lim)
        if cursor is not None:
            reach_arcs.append(CurveArc(cursor, L))
        if bad_from is not None:
            bad_arcs.append(_bad(fam, bad_from[0], L, bad_from[1], ()))
    return CurveReachability(
        curve,
        _name(fam),
        tuple(sorted((_normalized(a, L, curve.closed) for a in reach_arcs), key=_start)),
        tuple(sorted((_normalized(a, L, curve.closed) for a in bad_arcs), key=_start)),
        resolution_mm,
        s_scan,
        scores,
        fam,
    )


def _start(arc: CurveArc) -> float:
    return arc.start_mm


_Arc = TypeVar("_Arc", bound=CurveArc)


def _name(fam: CurveFamily) -> str | None:
    return fam.surface.name if fam.surface is not None else None


def _normalized(arc: _Arc, L: float, closed: bool) -> _Arc:
    """Shift a closed curve's arc so it starts in ``[0, L)``."""
    if not closed or 0.0 <= arc.start_mm < L:
        return arc
    shift = np.floor(arc.start_mm / L) * L
    return replace(arc, start_mm=arc.start_mm - shift, end_mm=arc.end_mm - shift)


def _bad(
    fam: CurveFamily, a: float, b: float, lim_a: tuple[str, ...], lim_b: tuple[str, ...]
) -> UnreachableArc:
    reason, blocked = _reason(fam, a, b)
    return UnreachableArc(a, b, reason, blocked, lim_a, lim_b)


def _reason(fam: CurveFamily, a: float, b: float) -> tuple[str, tuple[str, ...]]:
    """Why the arc ``a``..``b`` is unreachable: the constraint groups that block points at 10,
    30, 50, 70 and 90 % of it, and where each one does."""
    names = [o.name for o in fam.world.obstacles]
    fractions = (0.1, 0.3, 0.5, 0.7, 0.9)
    s_inside = [a + (b - a) * f for f in fractions]
    tags: list[str] = []

    def verdict(s: float, limits: bool, obstacles: tuple[str, ...]) -> Verdict:
        v = fam.best(s, limits=limits, obstacles=obstacles)
        return v if v.score < -0.5 or v.score >= 0 else fam.best(s, True, limits, obstacles)

    for s in map(float, s_inside):
        check_time("finding why an arc is unreachable")
        v = verdict(s, True, ())
        if v.out_of_reach:
            tag = "out of reach"
        elif not v.reachable:
            joints = [x.split(" at ")[0] for x in v.limiting if x.startswith("joint")]
            tag = "joint limits" + (f" ({', '.join(joints)})" if joints else "")
            if fam.surface is not None:  # the tool must come from outside what it works on
                tag += f" for every tool direction from outside the {fam.surface.name}"
        else:
            alone = [o for o in names if not verdict(s, False, (o,)).reachable]
            if alone:
                tag = "collision with " + " and ".join(alone)
            else:
                tag = "joint limits and collisions together"
        tags.append(tag)
    blocked = list(dict.fromkeys(tags))
    if len(blocked) == 1:
        return blocked[0], tuple(blocked)
    where = {
        b: [f"{100 * f:.0f} %" for f, t in zip(fractions, tags, strict=True) if t == b]
        for b in blocked
    }
    reason = "; ".join(f"{b} (at {', '.join(where[b])} of the arc)" for b in blocked)
    return reason, tuple(blocked)
