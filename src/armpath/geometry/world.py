"""Clearance of an arm's links (capsules) to a set of obstacles and to each other.

Each link of the arm is a capsule: the segment between two landmarks with the link's radius. The
last ``tip_exempt`` length of the last link is the *tool tip*: it may touch the surface it works
on (clearance >= 0) while every other part must keep ``margin`` (SPEC section 3). Links that are
not neighbours in the chain must also keep ``self_margin`` from each other (self-collision).

Every clearance the rule constrains is one *pair* (:class:`ClearancePair`): a part against an
obstacle, or two links. Batched evaluation returns one column per pair.

Which links are checked is decided once per arm (:func:`link_analysis`) from the arm's
geometry, on a fixed sample of configurations within the joint limits (landmark positions are
analytic in the joints, so what holds on the sample holds at every configuration):

* landmarks that coincide at every configuration are one point; a link whose two ends are one
  point has zero length and is dropped (no obstacle part, no self pair);
* two links are not checked against each other when

  1. both are part of the fixed base (``Link.checked`` False);
  2. they share an end point (neighbours, also through coincident landmarks);
  3. they are joined by a chain of links of fixed length whose total is shorter than their radii
     plus ``self_margin``: their end points are then closer than that at every configuration,
     so the pair breaks the rule everywhere and says nothing (a chain of zero-length links, the
     typical case, is rule 2); so too two links that only a prismatic joint's slide moves
     apart (one rigid body while it holds still) and that the slide, retracted, brings that
     close: the links either side of a SCARA's quill, which retracts to nothing, are
     neighbours rather than in collision wherever it is retracted;
  4. they belong to one rigid body (their end points keep their distances at every
     configuration): motion cannot change their clearance.

The seed arm has no zero-length link and its pairs are AB-CD, AB-DE and BC-DE.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError
from armpath.geometry.compiled_world import (
    ObstacleTable,
    configurations_slacks,
    obstacle_table,
    segments_clear,
)
from armpath.geometry.kernels import indexed_segment_distances, segments_to_point
from armpath.geometry.primitives import HollowFrustum, Obstacle, Opening
from armpath.jit import in_slices
from armpath.kinematics import (
    compiled_chain,
    displacement_bounds,
    forward_frames,
    landmark_positions,
)
from armpath.model.serial_arm import JointKind, Link, SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class Part:
    """A capsule of the arm checked against obstacles: a piece of link ``link`` (name)."""

    name: str
    link: str
    radius: float
    is_tip: bool


@dataclass(frozen=True)
class ClearancePair:
    """One clearance the rule constrains: ``part`` against ``other`` (an obstacle or a link).

    ``required`` is the clearance it must keep (length unit, capsule radii already subtracted
    from the clearance), ``is_tip`` marks the tool tip, ``is_self`` a link-link pair.
    """

    part: str
    other: str
    required: float
    is_tip: bool
    is_self: bool

    @property
    def label(self) -> str:
        return f"{self.part} - {self.other}"


#: Step of the scan of a joint for the self-collision ranges it cannot cross (rad, 0.05 deg).
_BAND_STEP_RAD = float(np.radians(0.05))


def _carrying_frames(
    arm: SerialArm, frame: int, offset: tuple[float, float, float]
) -> tuple[int, int]:
    """The frames (0 base, i after joint i) that carry the point ``offset`` of frame ``frame``
    (n + 1: the tool) rigidly, first and last: a point on a revolute joint's axis is carried by
    the frames on both sides of that joint."""
    n = arm.n_joints
    p = np.array([*offset, 1.0])
    if frame == n + 1:
        p, frame = arm.T_flange_tool @ p, n

    def on_axis(point: FloatArray, k: int) -> bool:  # point in the frame of joint k (0-based)
        joint = arm.joints[k]
        scale = max(float(np.linalg.norm(point[:3])), 1.0)
        turns = joint.kind is JointKind.REVOLUTE
        return turns and float(np.linalg.norm(np.cross(point[:3], joint.axis))) <= 1e-9 * scale

    first, down = frame, p
    while first >= 1 and on_axis(down, first - 1):
        down, first = arm.joints[first - 1].T_parent_joint @ down, first - 1
    last, up = frame, p
    while last < n:
        nxt = np.linalg.solve(arm.joints[last].T_parent_joint, up)
        if not on_axis(nxt, last):
            break
        up, last = nxt, last + 1
    return first, last


def into_windows(
    q: FloatArray, windows: Sequence[tuple[int, float, float]]
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Configurations ``(M, n)`` rad with each windowed joint turned by whole turns into its
    window (:meth:`CollisionWorld.joint_windows`; else to the copy nearest it), and whether
    every such joint fits."""
    out = np.array(q, dtype=np.float64, copy=True)
    inside = np.ones(out.shape[0], dtype=bool)
    for k, lo, hi in windows:
        above = lo + (out[:, k] - lo) % (2.0 * np.pi)  # the lowest copy at or above lo
        below = above - 2.0 * np.pi
        fits = above <= hi
        out[:, k] = np.where(fits | (above - hi <= lo - below), above, below)
        inside &= fits
    return out, inside


@dataclass(frozen=True, eq=False)
class LinkAnalysis:
    """What the clearance rule needs to know about an arm's links (see the module docstring).

    ``point_of`` gives each landmark's point (landmarks coinciding at every configuration share
    one); ``degenerate`` marks zero-length links; ``length`` is each link's length where it is
    the same at every configuration (``inf`` where a prismatic joint changes it); ``chain`` is
    the shortest chain of fixed-length links between two points (``inf`` if none); ``rigid``
    marks link pairs in one rigid body. ``slide_chain`` is the shortest chain with each leg a
    prismatic joint slides at its shortest, and ``rigid_but_slides`` marks link pairs in one
    rigid body while the prismatic joints hold still (only a slide moves them apart).
    ``fixed`` marks landmarks no joint moves and ``fixed_at`` gives their positions (every
    landmark's at the first analysis configuration); ``at_tool`` marks landmarks at the tool
    point at every configuration.
    """

    point_of: NDArray[np.int64]
    degenerate: NDArray[np.bool_]
    length: FloatArray
    chain: FloatArray
    rigid: NDArray[np.bool_]
    slide_chain: FloatArray
    rigid_but_slides: NDArray[np.bool_]
    fixed: NDArray[np.bool_]
    fixed_at: FloatArray
    at_tool: NDArray[np.bool_]

    def ends(self, link: Link) -> tuple[int, int]:
        return int(self.point_of[link.start]), int(self.point_of[link.end])


#: Configurations sampled to analyse an arm's links, and the random seed that draws them.
_ANALYSIS_SAMPLES = 32
_ANALYSIS_SEED = 20240517


def _analysis_configurations(arm: SerialArm) -> FloatArray:
    """Joint vectors spread over the joint limits (:func:`_analysis_bounds`); a fixed sample,
    so the analysis is deterministic."""
    lo_f, hi_f = np.array(_analysis_bounds(arm)).T
    u = np.random.default_rng(_ANALYSIS_SEED).uniform(0.0, 1.0, (_ANALYSIS_SAMPLES, arm.n_joints))
    return np.asarray(lo_f + u * (hi_f - lo_f), dtype=np.float64)


def _analysis_bounds(arm: SerialArm) -> list[tuple[float, float]]:
    """Each joint's range for the analysis: its limits, or where it has none a turn
    (revolute) or 2,000 length units (prismatic: two metres of a model in mm)."""
    bounds = []
    for joint in arm.joints:
        lo, hi = joint.limits
        span = 2.0 * np.pi if joint.kind is JointKind.REVOLUTE else 2000.0
        if np.isfinite(lo) and np.isfinite(hi):
            bounds.append((lo, hi))
        elif np.isfinite(lo):
            bounds.append((lo, lo + span))
        elif np.isfinite(hi):
            bounds.append((hi - span, hi))
        else:
            bounds.append((-span / 2, span / 2))
    return bounds


def _shortest_lengths(
    arm: SerialArm, base: FloatArray, length: FloatArray, tol: float
) -> FloatArray:
    """Each link's shortest length over the joint limits: its fixed ``length``, or for a leg
    a prismatic joint slides (its length ``|c + q|`` over ``q`` in the joint's range, found from
    the two ends of the range with the other joints held) the least of that; ``inf`` for any
    other link of varying length. A leg the joint can shrink to nothing joins the links on
    either side at one point (a SCARA's quill fully retracted); the chain rule then counts
    them as neighbours rather than in collision at every such configuration. ``base`` is the
    configuration the other joints hold."""
    out = np.array(length, dtype=np.float64, copy=True)
    links = arm.links
    for j, (lo, hi) in enumerate(_analysis_bounds(arm)):
        if arm.joints[j].kind is not JointKind.PRISMATIC:
            continue
        ends = np.stack([base, base])
        ends[0, j], ends[1, j] = lo, hi
        pts = landmark_positions(arm, ends)  # (2, L, 3)
        for k, lk in enumerate(links):
            if np.isfinite(length[k]):
                continue
            at_lo, at_hi = np.linalg.norm(pts[:, lk.end] - pts[:, lk.start], axis=-1)
            if abs(at_hi - at_lo) <= tol:
                continue  # not this joint's leg
            out[k] = min(out[k], max(0.0, 0.5 * (at_lo + at_hi - (hi - lo))))
    return out


def _chains(
    links: Sequence[Link], point_of: NDArray[np.int64], length: FloatArray, n_points: int
) -> FloatArray:
    """The shortest chain of links (each of ``length``, ``inf`` for none) between every two
    points (Floyd-Warshall over the few points)."""
    chain = np.full((n_points, n_points), np.inf)
    np.fill_diagonal(chain, 0.0)
    for k, lk in enumerate(links):
        a, b = point_of[lk.start], point_of[lk.end]
        chain[a, b] = chain[b, a] = min(chain[a, b], length[k])
    for m in range(n_points):
        chain = np.minimum(chain, chain[:, m : m + 1] + chain[m : m + 1, :])
    return chain


def _rigid_pairs(links: Sequence[Link], gap: FloatArray, tol: float) -> NDArray[np.bool_]:
    """Link pairs whose end points keep their distances (``gap`` ``(K, L, L)`` over sampled
    configurations) to ``tol``."""
    spread = gap.max(axis=0) - gap.min(axis=0)  # how much each landmark distance varies
    n = len(links)
    rigid = np.zeros((n, n), dtype=bool)
    for i in range(n):
        for j in range(n):
            ends = [links[i].start, links[i].end, links[j].start, links[j].end]
            rigid[i, j] = bool(spread[np.ix_(ends, ends)].max() <= tol)
    return rigid


def link_analysis(arm: SerialArm) -> LinkAnalysis:
    """Points, zero-length links, fixed lengths, chains and rigid pairs of ``arm``'s links
    (computed once per arm and kept on it)."""
    cached = arm.__dict__.get("_link_analysis")
    if isinstance(cached, LinkAnalysis):
        return cached
    configurations = _analysis_configurations(arm)
    pts = landmark_positions(arm, configurations)  # (K, L, 3)
    scale = max(1.0, float(np.abs(pts).max()))
    tol = 1e-9 * scale
    n_lm = len(arm.landmarks)
    gap = np.linalg.norm(pts[:, :, None, :] - pts[:, None, :, :], axis=-1)  # (K, L, L)
    same = gap.max(axis=0) <= tol
    point_of = np.array([int(np.argmax(same[i])) for i in range(n_lm)], dtype=np.int64)
    links = arm.links
    n = len(links)
    degenerate = np.array([point_of[lk.start] == point_of[lk.end] for lk in links], dtype=bool)
    seg = np.array([gap[:, lk.start, lk.end] for lk in links]).reshape(n, gap.shape[0])
    length = np.where(np.ptp(seg, axis=1) <= tol, seg.mean(axis=1), np.inf)
    chain = _chains(links, point_of, length, n_lm)
    rigid = _rigid_pairs(links, gap, tol)
    slides = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints], dtype=bool)
    if np.any(slides):
        shortest = _shortest_lengths(arm, configurations[0], length, tol)
        slide_chain = _chains(links, point_of, shortest, n_lm)
        held = configurations.copy()
        held[:, slides] = held[0, slides]  # the prismatic joints hold still
        held_pts = landmark_positions(arm, held)
        held_gap = np.linalg.norm(held_pts[:, :, None, :] - held_pts[:, None, :, :], axis=-1)
        rigid_but_slides = _rigid_pairs(links, held_gap, tol)
    else:  # no slide: the chains and rigid bodies are the ones above
        slide_chain, rigid_but_slides = chain, rigid
    fixed = np.ptp(pts, axis=0).max(axis=-1) <= tol
    tool = forward_frames(arm, configurations)[..., -1, :3, 3]  # (K, 3)
    at_tool = np.linalg.norm(pts - tool[:, None, :], axis=-1).max(axis=0) <= tol
    out = LinkAnalysis(
        point_of,
        degenerate,
        length,
        chain,
        rigid,
        slide_chain,
        rigid_but_slides,
        fixed,
        pts[0],
        at_tool,
    )
    arm.__dict__["_link_analysis"] = out
    return out


#: Fewest configurations whose smallest slacks (:meth:`CollisionWorld.smallest_slacks`, compiled)
#: are split between threads, one slice per core, where a core is free.
SLACK_THREAD_BATCH = 1_000
#: Most configurations :meth:`CollisionWorld.segments_satisfied` checks in one call of
#: :meth:`CollisionWorld.satisfied` (worlds with a mesh).
SATISFIED_CHUNK = 50_000


class SlackGroup(NamedTuple):
    """One minimum :meth:`CollisionWorld.smallest_slacks` takes: over the pairs ``columns``
    (a mask over the world's pairs), at most ``ceiling``, exact above ``floor`` (each a
    scalar or one value per configuration)."""

    columns: NDArray[np.bool_]
    ceiling: FloatArray | float = np.inf
    floor: FloatArray | float = -np.inf


@dataclass(frozen=True, eq=False)
class _ArmBinding:
    """What a :class:`CollisionWorld` computes once per arm: its parts and pairs, what each
    pair requires, each part's link (an index into the checked links: the last one's body and
    tip share it), the landmark indices of the parts' and self pairs' segments, and how far a
    point can move per unit of each joint (:func:`displacement_bounds`)."""

    parts: tuple[Part, ...]
    pairs: tuple[ClearancePair, ...]
    required: FloatArray
    part_radius: FloatArray
    part_link: IntArray
    link_start: IntArray
    link_end: IntArray
    tip_split: bool
    self_a0: IntArray
    self_a1: IntArray
    self_b0: IntArray
    self_b1: IntArray
    self_radii: FloatArray
    reach: FloatArray


@dataclass(frozen=True)
class CollisionWorld:
    """Obstacles plus the clearance rule.

    Parameters
    ----------
    obstacles:
        The solids to keep clear of.
    margin:
        Clearance every part of the arm except the tool tip must keep (length unit, default 1).
    tip_exempt:
        Length at the end of the last link that only must not penetrate (default 5).
    self_margin:
        Clearance between links that are not neighbours in the chain (default 1, like the
        margin: the seed arm's links have zero radius, so a margin is what keeps them apart).
    """

    obstacles: tuple[Obstacle, ...]
    margin: float = 1.0
    tip_exempt: float = 5.0
    self_margin: float = 1.0
    #: what the world computed once for each arm it met (:meth:`_bound`)
    _bindings: dict[int, tuple[SerialArm, _ArmBinding]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        for what, v in (
            ("clearance margin", self.margin),
            ("tool-tip exempt length", self.tip_exempt),
            ("self-collision margin", self.self_margin),
        ):
            if not (np.isfinite(v) and v >= 0):
                raise InvalidInputError(f"{what} must be >= 0, got {v}")
        names = [o.name for o in self.obstacles]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"obstacle names must be unique, got {names}")

    @property
    def obstacle_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.obstacles)

    def openings(self) -> tuple[Opening, ...]:
        """The discs through which the hollow obstacles' insides are entered
        (:meth:`HollowFrustum.openings`)."""
        return tuple(
            hole for o in self.obstacles if isinstance(o, HollowFrustum) for hole in o.openings()
        )

    @staticmethod
    def _checked_links(arm: SerialArm) -> list[Link]:
        """Links checked against obstacles: not part of the fixed base, not of zero length."""
        degenerate = link_analysis(arm).degenerate
        return [lk for lk, z in zip(arm.links, degenerate, strict=True) if lk.checked and not z]

    def _bound(self, arm: SerialArm) -> _ArmBinding:
        """Parts, pairs, requirements and index arrays for ``arm``: computed on the first call
        with that arm, then reused (the planners ask thousands of times)."""
        entry = self._bindings.get(id(arm))
        if entry is not None and entry[0] is arm:
            return entry[1]
        parts = self._parts(arm)
        checked = self._checked_links(arm)
        sp = self.self_pairs(arm)
        pairs = [
            ClearancePair(p.name, o.name, 0.0 if p.is_tip else self.margin, p.is_tip, False)
            for p in parts
            for o in self.obstacles
        ]
        pairs += [
            ClearancePair(arm.links[i].name, arm.links[j].name, self.self_margin, False, True)
            for i, j in sp
        ]
        links = arm.links
        binding = _ArmBinding(
            parts=parts,
            pairs=tuple(pairs),
            required=np.array([p.required for p in pairs], dtype=np.float64),
            part_radius=np.array([p.radius for p in parts], dtype=np.float64),
            part_link=np.array(
                [[lk.name for lk in checked].index(p.link) for p in parts], dtype=np.intp
            ),
            link_start=np.array([lk.start for lk in checked], dtype=np.intp),
            link_end=np.array([lk.end for lk in checked], dtype=np.intp),
            tip_split=bool(checked) and self.tip_exempt > 0,
            self_a0=np.array([links[i].start for i, _ in sp], dtype=np.intp),
            self_a1=np.array([links[i].end for i, _ in sp], dtype=np.intp),
            self_b0=np.array([links[j].start for _, j in sp], dtype=np.intp),
            self_b1=np.array([links[j].end for _, j in sp], dtype=np.intp),
            self_radii=np.array(
                [links[i].radius + links[j].radius for i, j in sp], dtype=np.float64
            ),
            reach=displacement_bounds(arm),
        )
        self._bindings[id(arm)] = (arm, binding)
        return binding

    def parts(self, arm: SerialArm) -> tuple[Part, ...]:
        """The capsules checked against obstacles: every checked link of non-zero length, the
        last one split into body and tip. The tip is the bare segment (radius 0): the tool
        point itself may touch a surface; the body keeps its radius (so a tool of radius ``r``
        can meet a surface head-on only when ``r + margin <= tip_exempt``)."""
        return self._bound(arm).parts

    def _parts(self, arm: SerialArm) -> tuple[Part, ...]:
        checked = self._checked_links(arm)
        out: list[Part] = []
        for k, link in enumerate(checked):
            last = k == len(checked) - 1
            out.append(Part(link.name, link.name, link.radius, False))
            if last and self.tip_exempt > 0:
                out.append(Part(f"{link.name} tip", link.name, 0.0, True))
        return tuple(out)

    def touch_blocker(self, arm: SerialArm) -> str | None:
        """Why ``arm``'s tool cannot touch a surface at all, or None when it can: its body
        (the last link's capsule) must keep the margin, so unless the bare tip is longer than
        the body's radius plus the margin, the body meets the surface before the tip does."""
        parts = self.parts(arm)
        if not parts:
            return None
        body = [p for p in parts if not p.is_tip][-1]
        need = body.radius + self.margin
        if self.tip_exempt > need:
            return None
        unit = arm.length_unit
        return (
            f"the tool cannot touch a surface: its body ({body.name}, radius {body.radius:g} "
            f"{unit}) keeps the {self.margin:g} {unit} margin and only its last "
            f"{self.tip_exempt:g} {unit} are bare (the scene's clearance.tool_tip_exempt_mm); "
            f"make that longer than {need:g} {unit} (radius plus margin) or the tool thinner"
        )

    def fixed_link_blocker(self, arm: SerialArm, point: ArrayLike, tolerance: float) -> str | None:
        """Why no configuration putting ``arm``'s tool point within ``tolerance`` of ``point``
        keeps the rule between the links, or None where this test finds no reason: a link no
        joint moves (the base column) pairs with a link ending at the tool point, and
        ``point`` lies so near the fixed one that the other, ending within ``tolerance`` of
        it, comes nearer than their radii plus ``self_margin``. A proof, so a target inside
        the base is refused at once rather than after a search."""
        p = np.asarray(point, dtype=np.float64).reshape(3)
        info = link_analysis(arm)
        fixed, at_tool, pts = info.fixed, info.at_tool, info.fixed_at
        tol = 1e-9 * max(1.0, float(np.abs(pts).max()))
        links = arm.links
        for i, j in self.self_pairs(arm):
            for still, moving in ((links[i], links[j]), (links[j], links[i])):
                if not (fixed[still.start] and fixed[still.end]):
                    continue
                if not (at_tool[moving.start] or at_tool[moving.end]):
                    continue
                a, b = pts[still.start], pts[still.end]
                d_exact = float(segments_to_point(a[None], b[None], p[None])[0])
                need = still.radius + moving.radius + self.self_margin
                if d_exact + tolerance < need - tol:
                    unit = arm.length_unit
                    d = round(d_exact, 6)  # 0, not 7e-15, on the link's axis
                    return (
                        f"the point lies {d:.4g} {unit} from link {still.name}, which no joint "
                        f"moves, so link {moving.name}, which ends at the tool point, would come "
                        f"within {d + tolerance:.4g} {unit} of it (with the {tolerance:g} {unit} "
                        f"tolerance), where the two must keep {need:g} {unit} apart (their radii "
                        f"and the {self.self_margin:g} {unit} between links)"
                    )
        return None

    def self_pairs(self, arm: SerialArm) -> tuple[tuple[int, int], ...]:
        """Indices into ``arm.links`` of link pairs checked for self-collision.

        Zero-length links take no part; pairs are skipped by the four rules of the module
        docstring (both fixed base, a shared end point, a chain shorter than their radii plus
        ``self_margin``, one rigid body). Computed once per arm and margin.
        """
        cache: dict[float, tuple[tuple[int, int], ...]] = arm.__dict__.setdefault("_self_pairs", {})
        if self.self_margin in cache:
            return cache[self.self_margin]
        info = link_analysis(arm)
        links = arm.links
        out = []
        for i in range(len(links)):
            for j in range(i + 1, len(links)):
                a, b = links[i], links[j]
                if info.degenerate[i] or info.degenerate[j] or not (a.checked or b.checked):
                    continue
                ends_a, ends_b = info.ends(a), info.ends(b)
                if set(ends_a) & set(ends_b) or info.rigid[i, j]:
                    continue
                near = a.radius + b.radius + self.self_margin
                if min(info.chain[p, r] for p in ends_a for r in ends_b) < near:
                    continue
                if info.rigid_but_slides[i, j] and (
                    min(info.slide_chain[p, r] for p in ends_a for r in ends_b) < near
                ):
                    continue  # only a slide parts them, and retracted it joins them
                out.append((i, j))
        cache[self.self_margin] = tuple(out)
        return cache[self.self_margin]

    def pairs(self, arm: SerialArm) -> tuple[ClearancePair, ...]:
        """Every constrained clearance: each part against each obstacle, then link pairs."""
        return self._bound(arm).pairs

    def part_segments(self, arm: SerialArm, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """End points of every part, each ``(..., P, 3)``, in the order of :meth:`parts`."""
        return self._segments(arm, landmark_positions(arm, q))

    def _segments(self, arm: SerialArm, pts: FloatArray) -> tuple[FloatArray, FloatArray]:
        bound = self._bound(arm)
        starts = pts[..., bound.link_start, :]
        ends = pts[..., bound.link_end, :]
        if not bound.tip_split:
            return starts, ends
        # the last link: its body up to the cut, then the bare tip from the cut
        a, b = starts[..., -1, :], ends[..., -1, :]
        length = np.linalg.norm(b - a, axis=-1, keepdims=True)
        frac = np.clip(self.tip_exempt / np.where(length > 0, length, 1.0), 0.0, 1.0)
        cut = (b - frac * (b - a))[..., None, :]
        return (
            np.concatenate([starts, cut], axis=-2),
            np.concatenate([ends[..., :-1, :], cut, ends[..., -1:, :]], axis=-2),
        )

    def required(self, arm: SerialArm) -> FloatArray:
        """Clearance each pair must keep, ``(K,)`` in the order of :meth:`pairs`."""
        return self._bound(arm).required.copy()

    def pair_clearances(self, arm: SerialArm, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Clearance of every pair ``(..., K)`` and a proven lower bound of it.

        Capsule radii are subtracted. For analytic obstacles the two differ only by a rounding
        allowance; obstacles without a closed form (meshes) give a certified lower bound.
        """
        pts = landmark_positions(arm, q)
        batch = pts.shape[:-2]
        p0, p1 = self._segments(arm, pts)
        radii = self._bound(arm).part_radius
        values, lowers = [], []
        for o in self.obstacles:
            v, lo = o.segment_distance_bounds(p0, p1)
            values.append(v - radii)
            lowers.append(lo - radii)
        width = p0.shape[-2] * len(values)  # (not -1: no configurations, an empty batch)
        cols_v = [np.stack(values, axis=-1).reshape(*batch, width)] if values else []
        cols_l = [np.stack(lowers, axis=-1).reshape(*batch, width)] if lowers else []
        if self.self_pairs(arm):
            d = self._self_clearances(arm, pts)
            cols_v.append(d)
            cols_l.append(d - 1e-7)
        if not cols_v:
            return np.zeros((*batch, 0)), np.zeros((*batch, 0))
        return np.concatenate(cols_v, axis=-1), np.concatenate(cols_l, axis=-1)

    def smallest_slacks(
        self,
        arm: SerialArm,
        q: ArrayLike,
        groups: Sequence[SlackGroup | tuple[NDArray[np.bool_], FloatArray | float]],
    ) -> list[FloatArray]:
        """For each group ``(columns, ceiling[, floor])`` of ``groups``: per configuration of
        ``q (M, n)``, ``min(ceiling, smallest clearance - required over the pairs in
        columns)``, where ``columns`` is a mask over :meth:`pairs` and ``ceiling`` a scalar or
        ``(M,)``.

        Equal to the same minimum of :meth:`pair_clearances` (the same kernels on the same
        segments), but a pair is measured exactly only where its broad-phase lower bound
        (:meth:`Obstacle.broad_phase`) is below the smallest slack known so far: first each
        configuration's pair of lowest bound, then the pairs still below. Where every obstacle
        has a closed form this runs as one compiled loop (:func:`configurations_slacks`: the
        same values wherever they are exact; below a floor the two may stop at different ones).
        The minimum a caller takes with its own slacks (joint limits) is the natural ceiling.

        A ``floor`` (scalar or ``(M,)``, default -inf) says which values the caller needs: a
        configuration whose value is above its floor gets it exactly; one at or below gets a
        value between the true one and the floor (measuring stops once the smallest slack known
        is at the floor). A search for the largest value passes the best value it has.
        """
        q = np.asarray(q, dtype=np.float64)
        if q.ndim != 2:
            raise InvalidInputError(f"configurations must have shape (M, n), got {q.shape}")
        bound = self._bound(arm)
        table = self._table
        if table is not None and groups:
            return self._compiled_slacks(arm, q, groups, table)
        pts = landmark_positions(arm, q)
        p0, p1 = self._segments(arm, pts)
        m_count, n_parts = p0.shape[0], p0.shape[1]
        n_obs = len(self.obstacles)
        n_obs_cols = n_parts * n_obs
        a = np.ascontiguousarray(p0.reshape(-1, 3))
        b = np.ascontiguousarray(p1.reshape(-1, 3))
        # broad-phase lower bound of every obstacle pair's slack, (M, P * O) in pairs' order
        by_obstacle = np.full((m_count, n_parts, n_obs), -np.inf)
        for o, obstacle in enumerate(self.obstacles):
            by_obstacle[:, :, o] = obstacle.broad_phase(a, b).reshape(m_count, n_parts)
        lower = by_obstacle.reshape(m_count, n_obs_cols)
        # (less a rounding allowance, so a bound never passes the exact value it bounds)
        lower -= np.repeat(bound.part_radius, n_obs) + bound.required[:n_obs_cols] + 1e-9
        self_slack = None

        def measure(result: FloatArray, m_idx: IntArray, k: IntArray) -> None:
            """Lower ``result`` by the exact slacks of configurations ``m_idx``, pairs ``k``."""
            part, obs = np.divmod(k, n_obs)
            slack = np.empty(m_idx.size)
            for o in np.unique(obs):
                sel = np.flatnonzero(obs == o)
                seg = m_idx[sel] * n_parts + part[sel]
                v, _ = self.obstacles[o].segment_distance_bounds(a[seg], b[seg])
                slack[sel] = v - bound.part_radius[part[sel]] - bound.required[k[sel]]
            np.minimum.at(result, m_idx, slack)

        out = []
        for group in groups:
            columns, ceiling, floor = SlackGroup(*group)
            result = np.array(np.broadcast_to(ceiling, (m_count,)), dtype=np.float64)
            floors = np.broadcast_to(np.asarray(floor, dtype=np.float64), (m_count,))
            cols = np.asarray(columns, dtype=bool)
            if np.any(cols[n_obs_cols:]):
                if self_slack is None:
                    self_slack = self._self_clearances(arm, pts) - bound.required[n_obs_cols:]
                result = np.minimum(
                    result, self_slack[:, cols[n_obs_cols:]].min(axis=-1, initial=np.inf)
                )
            obstacle_cols = np.flatnonzero(cols[:n_obs_cols])
            if obstacle_cols.size:
                lb = lower[:, obstacle_cols]

                # each configuration's pair of lowest bound first: it sets the bar the other
                # pairs' bounds must pass to be measured
                first = np.argmin(lb, axis=1)
                rows = np.flatnonzero((lb[np.arange(m_count), first] < result) & (result > floors))
                measure(result, rows, obstacle_cols[first[rows]])
                below = (lb < result[:, None]) & (result > floors)[:, None]
                below[rows, first[rows]] = False
                m_idx, c_idx = np.nonzero(below)
                measure(result, m_idx, obstacle_cols[c_idx])
            out.append(result)
        return out

    def _kernel_args(
        self, arm: SerialArm, need: FloatArray, table: ObstacleTable
    ) -> tuple[Any, ...]:
        """The arguments the compiled loops share, in their order: the arm's chain, its parts,
        what each pair needs (``need``, in :meth:`pairs` order), the obstacle table and the
        link pairs."""
        bound = self._bound(arm)
        return (
            *compiled_chain(arm),
            bound.link_start.astype(np.int64),
            bound.link_end.astype(np.int64),
            float(self.tip_exempt),
            bound.tip_split,
            bound.part_radius,
            need,
            table.kinds,
            table.params,
            table.balls,
            table.profiles,
            table.boundary,
            table.n_vertices,
            bound.self_a0.astype(np.int64),
            bound.self_a1.astype(np.int64),
            bound.self_b0.astype(np.int64),
            bound.self_b1.astype(np.int64),
            bound.self_radii,
        )

    def _compiled_slacks(
        self,
        arm: SerialArm,
        q: FloatArray,
        groups: Sequence[SlackGroup | tuple[NDArray[np.bool_], FloatArray | float]],
        table: ObstacleTable,
    ) -> list[FloatArray]:
        """:meth:`smallest_slacks` by :func:`configurations_slacks` (the same values above the
        floors)."""
        bound = self._bound(arm)
        m_count = q.shape[0]
        columns, ceilings, floors = [], [], []
        for group in groups:
            cols, ceiling, floor = SlackGroup(*group)
            columns.append(np.asarray(cols, dtype=bool))
            ceilings.append(np.broadcast_to(np.asarray(ceiling, dtype=np.float64), (m_count,)))
            floors.append(np.broadcast_to(np.asarray(floor, dtype=np.float64), (m_count,)))
        cols = np.ascontiguousarray(np.array(columns, dtype=np.bool_).reshape(len(groups), -1))
        ceiling_rows = np.array(ceilings).reshape(len(groups), m_count)
        floor_rows = np.array(floors).reshape(len(groups), m_count)
        args = self._kernel_args(arm, bound.required, table)

        def part(a: int, b: int) -> FloatArray:
            return np.asarray(
                configurations_slacks(
                    np.ascontiguousarray(q[a:b]),
                    cols,
                    np.ascontiguousarray(ceiling_rows[:, a:b]),
                    np.ascontiguousarray(floor_rows[:, a:b]),
                    *args,
                )
            )

        # each configuration's values are its own, and the loop releases the GIL
        out = np.concatenate(in_slices(part, m_count, SLACK_THREAD_BATCH), axis=1)
        return [np.array(row) for row in out]

    def satisfied(
        self, arm: SerialArm, q: ArrayLike, extra: ArrayLike | float = 0.0
    ) -> NDArray[np.bool_]:
        """Per configuration ``(...)``, whether every pair keeps ``required + extra`` (``extra``
        a scalar or one value per pair, length unit).

        The fast verdict for planners: a part whose distance to an obstacle's enclosing ball
        (then, for meshes, to the enclosing cone frustum) already exceeds what the pair needs
        skips the exact distance (broad phase); the verdict equals
        ``all(pair_clearances >= required + extra)``.
        """
        pts = landmark_positions(arm, q)
        batch = pts.shape[:-2]
        bound = self._bound(arm)
        need = bound.required + np.broadcast_to(
            np.asarray(extra, dtype=np.float64), bound.required.shape
        )
        p0, p1 = self._segments(arm, pts)
        n_parts = p0.shape[-2]
        a = np.ascontiguousarray(p0.reshape(-1, 3))
        b = np.ascontiguousarray(p1.reshape(-1, 3))
        ok = np.ones(a.shape[0] // max(n_parts, 1), dtype=bool)
        radii = np.tile(bound.part_radius, ok.size)
        owner = np.repeat(np.arange(ok.size), n_parts)
        part_of = np.tile(np.arange(n_parts), ok.size)
        for k, o in enumerate(self.obstacles):
            col_need = need[k :: len(self.obstacles)][:n_parts][part_of] + radii
            ball = o.enclosing_ball()
            todo = np.arange(a.shape[0])
            if ball is not None:
                center, radius = ball
                c = np.ascontiguousarray(np.broadcast_to(center, a.shape))
                lower = segments_to_point(a, b, c) - radius
                todo = np.flatnonzero(lower < col_need)
            todo = todo[ok[owner[todo]]]
            proxy = o.enclosing_solid()
            if proxy is not None and todo.size:
                d_proxy, _ = proxy.segment_distance_bounds(a[todo], b[todo])
                todo = todo[d_proxy < col_need[todo]]
            if todo.size:
                d, _ = o.segment_distance_bounds(a[todo], b[todo])
                bad = d < col_need[todo]
                ok[owner[todo[bad]]] = False
        n_self = len(bound.self_radii)
        if n_self and np.any(ok):
            live = np.flatnonzero(ok)
            d = self._self_clearances(arm, pts.reshape(-1, *pts.shape[-2:])[live])
            ok[live] = np.all(d >= need[-n_self:], axis=-1)
        return ok.reshape(batch)

    @cached_property
    def _table(self) -> ObstacleTable | None:
        return obstacle_table(self.obstacles)

    def segments_satisfied(
        self,
        arm: SerialArm,
        a: FloatArray,
        b: FloatArray,
        counts: IntArray,
        extra: ArrayLike | float = 0.0,
        strides: tuple[int, ...] = (1,),
    ) -> NDArray[np.bool_]:
        """Per joint-space segment ``a[e] -> b[e]`` (each ``(M, n)``), whether all its
        ``counts[e] >= 2`` evenly spaced configurations (both ends included) keep every pair's
        ``required + extra`` (the verdict of :meth:`satisfied` at each).

        Samples on the coarsest of ``strides`` (and the last) are checked first, then finer
        ones, and a segment stops at its first failing sample: most segments a planner tries
        are blocked, usually where the coarse samples see it. With obstacles of closed form
        only (not meshes) it is one compiled loop; otherwise :meth:`satisfied` per batch.
        """
        a = np.ascontiguousarray(a, dtype=np.float64)
        b = np.ascontiguousarray(b, dtype=np.float64)
        counts = np.ascontiguousarray(counts, dtype=np.int64)
        if a.shape != b.shape or a.ndim != 2 or counts.shape != a.shape[:1]:
            raise InvalidInputError(
                f"segments need (M, n) ends and (M,) counts, got {a.shape}, {b.shape}, "
                f"{counts.shape}"
            )
        if np.any(counts < 2):
            raise InvalidInputError("every segment needs at least 2 samples (its ends)")
        return self.segment_checker(arm, extra, strides)(a, b, counts)

    def segment_checker(
        self, arm: SerialArm, extra: ArrayLike | float = 0.0, strides: tuple[int, ...] = (1,)
    ) -> Callable[[FloatArray, FloatArray, IntArray], NDArray[np.bool_]]:
        """:meth:`segments_satisfied` for ``arm``, ``extra`` and ``strides`` fixed, as a
        function of ``(a, b, counts)`` (contiguous float64 ``(M, n)`` ends and int64 ``(M,)``
        counts >= 2, not checked again): for planners that call it thousands of times."""
        bound = self._bound(arm)
        need = np.ascontiguousarray(
            bound.required
            + np.broadcast_to(np.asarray(extra, dtype=np.float64), bound.required.shape)
        )
        table = self._table
        if not bound.pairs:
            return lambda a, b, counts: np.ones(a.shape[0], dtype=bool)
        if table is None:
            return lambda a, b, counts: self._segments_satisfied_batched(
                arm, a, b, counts, extra, strides
            )
        arm_args = (
            np.array(strides, dtype=np.int64),
            *self._kernel_args(arm, need, table),
            bound.reach,
        )

        def check(a: FloatArray, b: FloatArray, counts: IntArray) -> NDArray[np.bool_]:
            return np.asarray(segments_clear(a, b, counts, *arm_args), dtype=bool)

        return check

    def _segments_satisfied_batched(
        self,
        arm: SerialArm,
        a: FloatArray,
        b: FloatArray,
        counts: IntArray,
        extra: ArrayLike | float,
        strides: tuple[int, ...],
    ) -> NDArray[np.bool_]:
        """:meth:`segments_satisfied` by :meth:`satisfied` on batches of samples (meshes)."""
        owner = np.repeat(np.arange(a.shape[0]), counts)
        start = np.cumsum(counts) - counts
        local = np.arange(owner.size) - start[owner]
        frac = local / (counts[owner] - 1)
        last = local == counts[owner] - 1
        level = np.full(owner.size, len(strides) - 1)
        for k in range(len(strides) - 1, -1, -1):
            level[(local % strides[k] == 0) | last] = k
        ok = np.ones(a.shape[0], dtype=bool)
        for k in range(len(strides)):
            rows = np.flatnonzero((level == k) & ok[owner])
            for s in range(0, rows.size, SATISFIED_CHUNK):
                sel = rows[s : s + SATISFIED_CHUNK]
                sel = sel[ok[owner[sel]]]
                if sel.size == 0:
                    continue
                q = a[owner[sel]] + frac[sel, None] * (b - a)[owner[sel]]
                bad = ~self.satisfied(arm, q, extra)
                ok[owner[sel[bad]]] = False
            if not np.any(ok):
                break
        return ok

    def joint_bands(self, arm: SerialArm) -> dict[int, tuple[tuple[float, float], ...]]:
        """Ranges of single joints where the self-collision rule fails whatever the others are.

        A pair of links whose four end points are carried by the frames on either side of one
        revolute joint ``k`` (a point on a joint's axis counts as carried by the frames on both
        sides of it: the joint turns it about itself) keeps a clearance that depends on joint ``k``
        alone. Each such joint is scanned over its limits every :data:`_BAND_STEP_RAD`;
        between two samples whose slacks are both below minus half a step times the fastest
        the pair's distance can change (the farthest of its points from the axis, per rad),
        every value fails. Returns joint index (0-based) -> the failing ranges (rad), merged,
        within the joint's limits and two turns about zero (the ranges repeat every turn); the
        arm cannot move that joint across them. Computed once per arm and margins.
        """
        key = (self.self_margin, self.margin)
        cache: dict[Any, dict[int, tuple[tuple[float, float], ...]]] = arm.__dict__.setdefault(
            "_joint_bands", {}
        )
        if key not in cache:
            cache[key] = self._joint_bands(arm)
        return cache[key]

    def joint_windows(
        self, arm: SerialArm, q_start: ArrayLike
    ) -> tuple[tuple[int, float, float], ...]:
        """Per joint with self-collision ranges (:meth:`joint_bands`), the values it can reach
        from ``q_start`` (rad): ``(joint, low, high)`` between the nearest ranges (or their
        whole-turn copies) on either side, within its limits. A joint whose start lies inside
        one of its ranges is left out."""
        start = np.asarray(q_start, dtype=np.float64)
        out = []
        for k, ranges in self.joint_bands(arm).items():
            x, lo, hi = float(start[k]), float(arm.lower[k]), float(arm.upper[k])
            near = round(x / (2.0 * np.pi))  # the ranges repeat every turn
            copies = [
                (a + 2.0 * np.pi * m, b + 2.0 * np.pi * m)
                for a, b in ranges
                for m in range(near - 2, near + 3)
            ]
            if any(a < x < b for a, b in copies):
                continue
            lo = max([lo, *(b for a, b in copies if b <= x)])
            hi = min([hi, *(a for a, b in copies if a >= x)])
            if np.isfinite(lo) and np.isfinite(hi):
                out.append((k, lo, hi))
        return tuple(out)

    def _joint_bands(self, arm: SerialArm) -> dict[int, tuple[tuple[float, float], ...]]:
        bound = self._bound(arm)
        if len(bound.self_radii) == 0:
            return {}
        n = arm.n_joints
        # the frames that carry each point rigidly, first and last
        carried = np.array([_carrying_frames(arm, lm.frame, lm.offset) for lm in arm.landmarks])
        first, own = carried[:, 0], carried[:, 1]
        # a link is carried by the frames that carry both its ends; the pair's distance depends
        # on the joints between the frames carrying the one and the other
        a_lo = np.maximum(first[bound.self_a0], first[bound.self_a1])
        a_hi = np.minimum(own[bound.self_a0], own[bound.self_a1])
        b_lo = np.maximum(first[bound.self_b0], first[bound.self_b1])
        b_hi = np.minimum(own[bound.self_b0], own[bound.self_b1])
        ends = np.stack([bound.self_a0, bound.self_a1, bound.self_b0, bound.self_b1], axis=1)
        # joint k (frame k + 1) alone: one link carried up to frame k, the other from k + 1
        below = np.where(a_hi < b_lo, a_hi, b_hi)
        above = np.where(a_hi < b_lo, b_lo, a_lo)
        required = self.required(arm)[-len(bound.self_radii) :]
        q0 = np.clip(np.zeros(n), arm.lower, arm.upper)
        bands: dict[int, tuple[tuple[float, float], ...]] = {}
        for k in range(n):
            joint = arm.joints[k]
            pairs = np.flatnonzero((below == k) & (above == k + 1))
            if joint.kind is not JointKind.REVOLUTE or pairs.size == 0:
                continue
            # the ranges repeat every turn: two turns hold every one an unlimited joint meets
            lo, hi = max(float(arm.lower[k]), -2.0 * np.pi), min(float(arm.upper[k]), 2.0 * np.pi)
            count = int(np.ceil((hi - lo) / _BAND_STEP_RAD)) + 1
            angles = np.linspace(lo, hi, count)
            q = np.repeat(q0[None, :], count, axis=0)
            q[:, k] = angles
            pts = landmark_positions(arm, q)
            slack = (self._self_clearances(arm, pts, pairs) - required[pairs]).min(axis=1)
            axis_origin = forward_frames(arm, q0)[k + 1, :3, 3]
            used = np.unique(ends[pairs])
            rate = float(np.linalg.norm(pts[0, used] - axis_origin, axis=-1).max())
            step = float(angles[1] - angles[0]) if count > 1 else 0.0
            fails = np.maximum(slack[:-1], slack[1:]) + rate * step / 2.0 < 0.0
            ranges: list[tuple[float, float]] = []
            for i in np.flatnonzero(fails):
                a, b = float(angles[i]), float(angles[i + 1])
                if ranges and ranges[-1][1] >= a:
                    ranges[-1] = (ranges[-1][0], b)
                else:
                    ranges.append((a, b))
            if ranges:
                bands[k] = tuple(ranges)
        return bands

    def _self_clearances(
        self, arm: SerialArm, pts: FloatArray, which: IntArray | None = None
    ) -> FloatArray:
        """Distances between the self-collision link pairs (those of index ``which``, all by
        default) less their radii, ``(..., S)``."""
        bound = self._bound(arm)
        ends: tuple[IntArray, ...] = (bound.self_a0, bound.self_a1, bound.self_b0, bound.self_b1)
        radii = bound.self_radii
        if which is not None:  # a few pairs (the joint bands): only theirs measured
            ends = tuple(np.ascontiguousarray(e[which]) for e in ends)
            radii = radii[which]
        flat = np.ascontiguousarray(pts.reshape(-1, *pts.shape[-2:]), dtype=np.float64)
        d = indexed_segment_distances(flat, *ends).reshape(*pts.shape[:-2], len(radii))
        return np.asarray(d - radii)

    def clearances(self, arm: SerialArm, q: ArrayLike) -> FloatArray:
        """Clearance of every part to every obstacle, ``(..., P, O)``; capsule radii subtracted."""
        values, _ = self.pair_clearances(arm, q)
        n_parts, n_obs = len(self._bound(arm).parts), len(self.obstacles)
        return values[..., : n_parts * n_obs].reshape(*values.shape[:-1], n_parts, n_obs)

    def slack(self, arm: SerialArm, q: ArrayLike, ceiling: float = np.inf) -> FloatArray:
        """Per configuration, the smallest ``clearance - required`` over all pairs, at most
        ``ceiling`` (a caller that needs only the negative values passes 0: the pairs whose
        broad phase is above it are not measured).

        Non-negative exactly when the configuration satisfies the clearance rule. Measured
        with the broad phase of :meth:`smallest_slacks` (the same values).
        """
        q = np.asarray(q, dtype=np.float64)
        flat = q.reshape(-1, q.shape[-1])
        every = np.ones(len(self._bound(arm).pairs), dtype=bool)
        (lowest,) = self.smallest_slacks(arm, flat, [(every, ceiling)])
        return lowest.reshape(q.shape[:-1])

    def may_be_clear_within(self, arm: SerialArm, q: ArrayLike, moved: ArrayLike) -> BoolArray:
        """Per configuration of ``q (M, n)``, whether a configuration that moves no point of
        the arm farther than ``moved`` (length unit) from it may keep the clearance rule.

        ``moved`` is a scalar or ``(M,)`` (any point of the arm), or ``(M, L)``: how far each
        of the arm's landmarks (:func:`~armpath.kinematics.landmark_positions`) moves. A part
        is the segment between two landmarks (the last link's body and tip both lie on the
        last link's), so none of its points moves farther than the farther of its ends; a
        part's slack to an obstacle below minus that, or a link pair's below minus both
        links' together, rules the configuration out (as :meth:`slack` measures them). Pairs
        are measured only as far as that decides (:meth:`smallest_slacks` with those
        allowances as ceilings and floors just under them)."""
        q = np.asarray(q, dtype=np.float64)
        bound = self._bound(arm)
        moved = np.asarray(moved, dtype=np.float64)
        m_count = q.shape[0]
        n_obs = len(self.obstacles)
        n_parts, n_pairs = len(bound.parts), len(bound.pairs)
        masks: list[BoolArray] = []
        allowed: list[FloatArray] = []
        if moved.ndim == 2:  # one group per part and one per link pair
            # each part's allowance: the farther of its ends (the tip's: the last link's)
            ends = (bound.link_start[bound.part_link], bound.link_end[bound.part_link])
            part_moved = np.maximum(moved[:, ends[0]], moved[:, ends[1]])
            self_moved = np.maximum(moved[:, bound.self_a0], moved[:, bound.self_a1])
            self_moved += np.maximum(moved[:, bound.self_b0], moved[:, bound.self_b1])
            for first, count, allow in (
                *((p * n_obs, n_obs, part_moved[:, p]) for p in range(n_parts)),
                *((n_parts * n_obs + j, 1, self_moved[:, j]) for j in range(self_moved.shape[1])),
            ):
                masks.append(np.zeros(n_pairs, dtype=bool))
                masks[-1][first : first + count] = True
                allowed.append(-allow)
        else:  # every part alike, every link pair alike (both links move)
            reach = np.broadcast_to(moved, (m_count,))
            is_self = np.array([p.is_self for p in bound.pairs], dtype=bool)
            masks, allowed = [~is_self, is_self], [-reach, -2.0 * reach]
        # each group's measuring stops once a pair is below its allowance (the floor just
        # under it); a value left at the ceiling says no pair is below
        groups = [
            SlackGroup(mask, allow, np.nextafter(allow, -np.inf))
            for mask, allow in zip(masks, allowed, strict=True)
            if mask.any()
        ]
        keep = np.ones(m_count, dtype=bool)
        for group, lowest in zip(groups, self.smallest_slacks(arm, q, groups), strict=True):
            keep &= lowest >= group.ceiling
        return keep

    def describe(self) -> dict[str, object]:
        return {
            "obstacles": [o.describe() for o in self.obstacles],
            "clearance_margin_mm": self.margin,
            "tool_tip_exempt_mm": self.tip_exempt,
            "self_collision_margin_mm": self.self_margin,
        }
