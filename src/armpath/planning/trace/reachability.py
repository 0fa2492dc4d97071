"""Which parts of a curve the tool point can be on, and why the others are out of bounds.

Reachability of a point is decided by the *score* ``max over the family of min(slacks)`` (see
:mod:`armpath.planning.trace.family`). The curve is scanned at ``scan_step_mm``; every change of
verdict is then bisected to ``resolution_mm`` with the family searched on a finer grid (and
polished where the arm allows), so the ends of unreachable arcs are located to that resolution.

The reason an arc is unreachable comes from relaxations at points inside it: *out of reach* (no
real solution at all), *joint limits* (unreachable even with the clearances ignored, except that
the tool must still come from outside the surface it works on), *collision with* an obstacle
(unreachable with that obstacle alone, limits ignored), or both together.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_size, check_time
from armpath.errors import InvalidInputError
from armpath.geometry.curves import Curve
from armpath.geometry.world import CollisionWorld
from armpath.model.serial_arm import SerialArm
from armpath.planning.trace.family import AxisRule, CurveFamily, Verdict, curve_family

FloatArray = NDArray[np.float64]

#: Most scan points of one reachability analysis: a 100 m curve at the default 4 mm step,
#: about 80 s at some 3 ms a point (100,000 let a 398 m line scan for over 5 min).
MAX_SCAN_POINTS = 25_000
#: What an unreachable arc's reason adds for an arm whose family the tool directions do not
#: span (:attr:`CurveFamily.unspanned_because` fills it in): its verdict is over the members
#: found.
SELF_MOTION_CAVEAT = " (among the members found: {}, so clear ones may have been missed)"
#: Scan points between the scan's progress messages.
SCAN_PROGRESS_EVERY = 1000


@dataclass(frozen=True)
class CurveArc:
    """The arc from arc length ``start_mm`` to ``end_mm`` (``end_mm`` may exceed the length of a
    closed curve: the arc then runs on past its start)."""

    start_mm: float
    end_mm: float

    @property
    def length_mm(self) -> float:
        return self.end_mm - self.start_mm


def merged_arcs(
    arcs: Iterable[CurveArc], length_mm: float, closed: bool
) -> list[tuple[float, float]]:
    """The arcs' union as sorted disjoint intervals of arc length within the curve (a closed
    curve's arcs taken round it: an arc running on past the start continues from 0)."""
    pieces: list[tuple[float, float]] = []
    for arc in arcs:
        a, b = sorted((arc.start_mm, arc.end_mm))
        if not closed:
            pieces.append((max(a, 0.0), min(b, length_mm)))
            continue
        if b - a >= length_mm:
            return [(0.0, length_mm)]
        a0 = a % length_mm
        b0 = a0 + (b - a)
        pieces.append((a0, min(b0, length_mm)))
        if b0 > length_mm:
            pieces.append((0.0, b0 - length_mm))
    out: list[tuple[float, float]] = []
    for a, b in sorted(p for p in pieces if p[1] > p[0]):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def common_mm(first: list[tuple[float, float]], second: list[tuple[float, float]]) -> float:
    """Length of the intersection of two unions of sorted disjoint intervals
    (:func:`merged_arcs`)."""
    total, i, j = 0.0, 0, 0
    while i < len(first) and j < len(second):
        lo = max(first[i][0], second[j][0])
        hi = min(first[i][1], second[j][1])
        total += max(hi - lo, 0.0)
        if first[i][1] < second[j][1]:
            i += 1
        else:
            j += 1
    return total


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


def curve_reachability(
    arm: SerialArm,
    world: CollisionWorld,
    curve: Curve,
    scan_step_mm: float = 4.0,
    resolution_mm: float = 0.05,
    on_progress: Callable[[str], None] | None = None,
    rule: AxisRule | None = None,
    start_q: FloatArray | None = None,
) -> CurveReachability:
    """Reachable and unreachable arcs of ``curve`` (ends located to ``resolution_mm``) for
    ``arm`` in ``world``; ``rule`` narrows the tool's directions (:class:`AxisRule`);
    ``start_q``: where the arm starts (rad), if known (see :func:`curve_family`)."""
    if not (np.isfinite(scan_step_mm) and scan_step_mm > 0):
        raise InvalidInputError(f"scan step must be a finite length > 0 mm, got {scan_step_mm}")
    if not (np.isfinite(resolution_mm) and resolution_mm >= 1e-6):
        raise InvalidInputError(f"resolution must be >= 1e-6 mm, got {resolution_mm}")
    fam = curve_family(arm, world, curve, rule, start_q)
    say = on_progress or (lambda _m: None)
    L = curve.length
    check_size(
        L / scan_step_mm,
        MAX_SCAN_POINTS,
        f"scanning the {L:.4g} mm curve {curve.name!r} every {scan_step_mm:g} mm",
        "the curve (shorter) or the scan step (larger: trace --scan-step; scan_step_mm in Python)",
    )
    n = max(int(np.ceil(L / scan_step_mm)), 4)
    s_scan = np.linspace(0.0, L, n + 1)
    if curve.closed:
        s_scan = s_scan[:-1]
    say(f"reachability: scanning {s_scan.size} points of {curve.name!r}")
    scores = np.empty(s_scan.size)
    for i, s in enumerate(s_scan):
        check_time("scanning the curve for reachable points")
        if i and i % SCAN_PROGRESS_EVERY == 0:
            say(f"reachability: scanned {i} of {s_scan.size} points of {curve.name!r}")
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
            if fam.rule is not None:  # only the directions the rule allows were searched
                tag += f" with the tool axis {fam.rule.words()}"
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
        reason = blocked[0]
    else:
        where = {
            b: [f"{100 * f:.0f} %" for f, t in zip(fractions, tags, strict=True) if t == b]
            for b in blocked
        }
        reason = "; ".join(f"{b} (at {', '.join(where[b])} of the arc)" for b in blocked)
    if not fam.directions_span and blocked != ["out of reach"]:
        # certain only where the tool point itself would lie inside an obstacle
        inside = [
            min((float(o.signed_distance(fam.frame(s)[0])) for o in fam.world.obstacles),
                default=np.inf) < 0.0
            for s in s_inside
        ]  # fmt: skip
        if not all(inside):
            reason += SELF_MOTION_CAVEAT.format(fam.unspanned_because)
    return reason, tuple(blocked)
