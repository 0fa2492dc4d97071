"""The solution family sampled over tool directions, with sampling errors (see the package)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.geometry.primitives import Obstacle
from armpath.geometry.world import CollisionWorld, into_windows
from armpath.ik.family import GenericFamily
from armpath.ik.solve import complete_solver
from armpath.ik.target import ToolTarget
from armpath.jit import njit
from armpath.kinematics import (
    displacement_bounds,
    landmark_positions,
    position_jacobian,
    tool_pose,
)
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.bounds.chart import (
    BlowUp,
    caps_about,
    outside_holes,
    real_within,
    ring,
    ring_of,
    singular_directions,
    snapped,
    to_real,
)
from armpath.planning.bounds.metric import PredecessorTree, _wrapped, advance, predecessor_tree
from armpath.planning.trace.family import (
    CurveFamily,
    fibonacci_directions,
    solve_frames,
    tool_frames,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Largest joint change (commands) between members of neighbouring directions that are taken
#: for one branch of the family (farther: the branch ends between them).
BRANCH_GAP = 30.0
#: Slack (model units) a sample may lack beyond what its error box allows and still be kept.
CLEAR_MARGIN = 1e-6
#: Finest direction spacing of a refinement (rad, about 0.05 deg).
MIN_SPACING = float(np.radians(0.05))
#: Samples :meth:`FamilySampler._filtered` checks for clearance at first when it checks them
#: by rank (each batch after twice the one before).
_RANKED_BATCH = 64
#: Most directions of one layer (refinement stops before it would pass this).
MAX_LAYER_DIRECTIONS = 200_000
#: Directions a layer's singular directions are searched from (about 8 deg apart), whatever
#: its own sampling.
_DETECT_DIRECTIONS = fibonacci_directions(600)
_DETECT_SPACING = float(np.sqrt(4.0 * np.pi / _DETECT_DIRECTIONS.shape[0]))
#: Sampling error standing for "no neighbour has a member" (commands).
_MISSING = 1e6
#: Random starts from which members are drawn at each audited point of an arm with no
#: all-solutions IK (:meth:`FamilySampler.audit`).
AUDIT_STARTS = 200
#: Random tool frames at whose every IK solution members are drawn at each audited point of an
#: arm with an all-solutions IK (:meth:`FamilySampler.audit`).
AUDIT_FRAMES = 3000
#: Rounds of random approach directions drawn to find :data:`AUDIT_FRAMES` ones the rule at a
#: point allows (fewer frames are audited where it allows less than 1 / 50 of the sphere).
_FRAME_ROUNDS = 50
#: Most points of one bound that are audited (evenly spread among its sites).
AUDIT_SITES = 6
#: Times an audited site whose drawn members lie outside every sample's error box is refined
#: about them and audited again (:meth:`FamilySampler.audit_sites`).
AUDIT_REFINES = 3
#: Farthest outside every box (commands) the members an audit finds may lie for the site to be
#: refined about them: the seed line's edge of reach missed by 0.051 and was refined to none;
#: a UR5 tool 50 mm off its last axis, its turns about the tool axis sampled, missed 2,777 of
#: 20,396 by up to 10 commands, and splitting about them grew the layer from 106,980 samples
#: to 1,246,999 in two rounds (100 s) with more missed each round.
AUDIT_REFINE_WORST = 1.0
#: Most direction cells one refinement of an audited site splits (each adds up to six
#: directions, each with its turns), those nearest the members farthest out first.
AUDIT_REFINE_CELLS = 256
#: Commands by which a drawn member may lie outside every sample's error box before the audit
#: counts it missed (rounding of the units).
AUDIT_SLACK = 1e-6
#: Smallest singular value, relative to the largest, of the tip joints' Jacobian of the tool
#: point at which a member of a family of three tip joints or fewer is taken as isolated.
_ISOLATED_RANK = 1e-9


@dataclass(frozen=True)
class Layer:
    """Samples of the family at one point: command units ``u (M, J)`` of the tip joints, their
    errors ``err (M, J)`` (commands), the configurations ``q (M, n)`` rad and the tool
    direction of each ``dirs (M, 3)``; ``direction (M,)`` the index of each sample's direction
    among those the layer was sampled along, ``clear (M,)`` whether the sample itself keeps the
    clearance rule (not only may a member near it: see :meth:`FamilySampler.layer`). Both
    default to -1 and False (layers built by hand)."""

    u: FloatArray
    err: FloatArray
    q: FloatArray
    dirs: FloatArray
    direction: IntArray | None = None
    clear: BoolArray | None = None

    def __post_init__(self) -> None:
        if self.direction is None:
            object.__setattr__(self, "direction", np.full(self.size, -1, dtype=np.int64))
        if self.clear is None:
            object.__setattr__(self, "clear", np.zeros(self.size, dtype=bool))

    @property
    def size(self) -> int:
        return int(self.u.shape[0])

    def without_errors(self) -> Layer:
        """The same samples taken as exact (no sampling error): not a bound any more, the
        shortest path through the samples themselves."""
        return Layer(self.u, np.zeros_like(self.err), self.q, self.dirs, self.direction, self.clear)

    @staticmethod
    def joined(layers: list[Layer]) -> Layer:
        """The samples of ``layers`` (at least one) as one layer."""
        return Layer(
            *(
                np.concatenate([getattr(lay, name) for lay in layers])
                for name in ("u", "err", "q", "dirs", "direction", "clear")
            )
        )

    def subset(self, keep: BoolArray | IntArray) -> Layer:
        """The samples ``keep`` (a mask or indices)."""
        assert self.direction is not None and self.clear is not None
        return Layer(
            self.u[keep],
            self.err[keep],
            self.q[keep],
            self.dirs[keep],
            self.direction[keep],
            self.clear[keep],
        )


def _delaunay_neighbours(
    dirs: FloatArray, caps: tuple[BlowUp, ...] = ()
) -> tuple[IntArray, IntArray, IntArray]:
    """Neighbours of each (virtual) direction in the spherical Delaunay triangulation (the
    convex hull of the unit vectors), as CSR ``(pointer, index)``, and the triangles
    ``(T, 3)``; without the triangles across a blown-up direction's hole (all three corners on
    its circle: the chart has no directions there)."""
    from scipy.spatial import ConvexHull

    tri = ConvexHull(dirs).simplices
    if caps:
        on = ring_of(dirs, caps)[tri]
        tri = tri[~((on[:, 0] >= 0) & (on[:, 0] == on[:, 1]) & (on[:, 0] == on[:, 2]))]
    a = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2], tri[:, 1], tri[:, 2], tri[:, 0]])
    b = np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0], tri[:, 0], tri[:, 1], tri[:, 2]])
    a, b = a.astype(np.int64), b.astype(np.int64)  # n * n overflows qhull's int32
    pairs = np.unique(a * dirs.shape[0] + b)
    src, dst = pairs // dirs.shape[0], pairs % dirs.shape[0]
    ptr = np.searchsorted(src, np.arange(dirs.shape[0] + 1))
    return ptr.astype(np.int64), dst.astype(np.int64), tri.astype(np.int64)


@dataclass(frozen=True)
class _Samples:
    """A layer's samples before the clearance filter: every direction tried ``dirs (D, 3)``
    (virtual: in the chart with the blow-ups ``caps``, :mod:`.chart`) and, per member, its
    configuration, direction index, command units, the arm's points, the tolerance's joint
    change (commands), its slack (model units; 0 where it is not negative, the only values
    the filter needs) and whether it is isolated: the tip joints' Jacobian of the tool point
    has full column rank there (three tip joints or fewer, as a SCARA's), so the members
    near it are itself alone and it has no sampling error."""

    dirs: FloatArray
    q: FloatArray
    index: IntArray
    u: FloatArray
    points: FloatArray
    tol_err: FloatArray
    slack: FloatArray
    isolated: BoolArray
    #: per member, whether it lies within the joint limits (those outside are kept for their
    #: neighbours' errors: the family goes on past the limits)
    inside: BoolArray
    #: per direction, the family's real solutions there, the joint limits ignored (-1: not
    #: known; see :meth:`CurveFamily.solutions`)
    solution_counts: IntArray
    caps: tuple[BlowUp, ...] = ()

    @staticmethod
    def empty(arm: SerialArm, n_tip: int, caps: tuple[BlowUp, ...] = ()) -> _Samples:
        none = np.zeros((0, arm.n_joints))
        return _Samples(
            dirs=np.zeros((0, 3)),
            q=none,
            index=np.zeros(0, dtype=np.int64),
            u=np.zeros((0, n_tip)),
            points=landmark_positions(arm, none),
            tol_err=np.zeros((0, n_tip)),
            slack=np.zeros(0),
            isolated=np.zeros(0, dtype=bool),
            inside=np.zeros(0, dtype=bool),
            solution_counts=np.zeros(0, dtype=np.int64),
            caps=caps,
        )


def _midpoints(
    dirs: FloatArray, triangles: IntArray, refine: BoolArray, caps: tuple[BlowUp, ...] = ()
) -> FloatArray:
    """The midpoints (on the sphere) of the edges of every triangle with a vertex to
    ``refine``: each such triangle is split in four, which halves its directions' cells. A
    midpoint in a blown-up direction's hole (of two points of its circle) is moved out onto
    the circle."""
    tri = triangles[np.any(refine[triangles], axis=1)]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    mid = dirs[edges[:, 0]] + dirs[edges[:, 1]]
    return snapped(mid / np.linalg.norm(mid, axis=-1, keepdims=True), caps)


def _distinct(new: FloatArray, old: FloatArray) -> FloatArray:
    """The directions of ``new`` not already in ``old`` or earlier in ``new`` (qhull needs
    distinct points)."""
    key = np.round(np.vstack([old, new]) * 1e9).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    first = np.sort(first[first >= old.shape[0]])
    return np.asarray(new[first - old.shape[0]], dtype=np.float64)


def pseudo_inverse(J: FloatArray) -> FloatArray:
    """The Moore-Penrose pseudo-inverse ``(M, k, r)`` of each matrix of ``J (M, r, k)``, singular
    values below 1e-9 of the largest cut (as ``np.linalg.pinv(J, rcond=1e-9)``): through the
    smaller Gram matrix's inverse where it is well conditioned (its least eigenvalue above
    1e-12 of its largest: the singular values' above 1e-6), about three times faster than
    the singular value decomposition, which the others take."""
    Jt = np.swapaxes(J, -1, -2)
    wide = J.shape[-2] <= J.shape[-1]
    gram = J @ Jt if wide else Jt @ J
    out = np.empty(Jt.shape)
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvalsh(gram)
        good = eig[:, 0] > 1e-12 * eig[:, -1]
        inverse = np.linalg.inv(np.where(good[:, None, None], gram, np.eye(gram.shape[-1])))
        out[good] = (Jt[good] @ inverse[good]) if wide else (inverse[good] @ Jt[good])
        if not np.all(good):
            out[~good] = np.linalg.pinv(J[~good], rcond=1e-9)
    return out


@njit(cache=True)
def nearest_row(
    x: FloatArray, v: FloatArray, lo: int, hi: int, skip: int, period: FloatArray
) -> tuple[int, float]:  # pragma: no cover - compiled
    """The row of ``v[lo:hi]`` (but row ``skip``) nearest ``x`` in the largest joint change
    (command units, joints with a ``period`` the shorter way round) and its distance; ``(-1,
    inf)`` if none."""
    best, arg = np.inf, -1
    for k in range(lo, hi):
        if k == skip:
            continue
        worst = 0.0
        for c in range(x.size):
            d = _wrapped(v[k, c] - x[c], period[c])
            if d > worst:
                worst = d
                if worst >= best:
                    break
        if worst < best:
            best, arg = worst, k
    return arg, best


@njit(cache=True)
def _direction_neighbours(
    u: FloatArray,
    node_dir: IntArray,
    dir_ptr: IntArray,
    nb_ptr: IntArray,
    nb: IntArray,
    period: FloatArray,
    branch_gap: float,
    own: bool,
) -> IntArray:  # pragma: no cover - compiled
    """Per sample, the nearest sample (largest-joint distance, command units ``u (M, J)``) of
    each neighbouring direction that has one within ``branch_gap`` commands (a member farther
    is on another branch); -1 pads the rows. Samples are sorted by direction; ``dir_ptr``
    points at each direction's first. ``own``: the other samples of a sample's own direction
    are neighbours too (a family sampled at several turns about each direction)."""
    m = u.shape[0]
    width = 1
    for d in range(nb_ptr.size - 1):
        width = max(width, nb_ptr[d + 1] - nb_ptr[d] + 1)
    out = np.full((m, width), -1, dtype=np.int64)
    for i in range(m):
        d = node_dir[i]
        count = 0
        for p in range(nb_ptr[d] - (1 if own else 0), nb_ptr[d + 1]):
            e = nb[p] if p >= nb_ptr[d] else d
            arg, best = nearest_row(u[i], u, dir_ptr[e], dir_ptr[e + 1], i, period)
            if arg >= 0 and best <= branch_gap:
                out[i, count] = arg
                count += 1
    return out


@njit(cache=True)
def _sampling_errors(
    u: FloatArray,
    points: FloatArray,
    node_dir: IntArray,
    dir_ptr: IntArray,
    nb_ptr: IntArray,
    nb: IntArray,
    period: FloatArray,
    missing: float,
    branch_gap: float,
    own: bool,
    solution_counts: IntArray,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Per sample and joint, the largest difference to its neighbours
    (:func:`_direction_neighbours`: the nearest sample of each neighbouring direction within
    ``branch_gap`` commands; ``missing`` where it has none); and per sample how far each of
    the arm's ``points`` ``(M, P, 3)`` moves to them at most, ``(M, P)`` (inf where none).

    A sample lies by a fold when a neighbouring direction has fewer real solutions than its
    own (``solution_counts`` per direction, the joint limits ignored; -1: not known) and no
    member near it: two branches meet between them and end. The nearest other sample of its
    own direction that ends there too is taken for the branch it meets, to first order
    midway between them (they part as the square root of the distance to the fold), and half
    its difference to that sibling, in each joint and each point, is added to the sample's
    error and its points' motion: the members between it and the fold. Only where one
    sample is drawn per direction (not ``own``: several turns about each direction have no
    such pairs)."""
    m, j = u.shape
    near = _direction_neighbours(u, node_dir, dir_ptr, nb_ptr, nb, period, branch_gap, own)
    err = np.zeros((m, j))
    moved = np.zeros((m, points.shape[1]))
    for i in range(m):
        if near[i, 0] < 0:
            err[i, :] = missing
            moved[i, :] = np.inf
            continue
        for w in range(near.shape[1]):
            arg = near[i, w]
            if arg < 0:
                break
            for c in range(j):
                x = _wrapped(u[arg, c] - u[i, c], period[c])
                if x > err[i, c]:
                    err[i, c] = x
            for t in range(points.shape[1]):
                x = 0.0
                for c in range(3):
                    x += (points[arg, t, c] - points[i, t, c]) ** 2
                moved[i, t] = max(moved[i, t], np.sqrt(x))
    if own:
        return err, moved
    # the samples by a fold: a neighbouring direction with fewer real solutions, none near
    ends = np.zeros(m, dtype=np.bool_)
    for i in range(m):
        d = node_dir[i]
        for p in range(nb_ptr[d], nb_ptr[d + 1]):
            e = nb[p]
            if not 0 <= solution_counts[e] < solution_counts[d]:
                continue
            found = False
            for w in range(near.shape[1]):
                if near[i, w] < 0:
                    break
                if node_dir[near[i, w]] == e:
                    found = True
            ends[i] = ends[i] or not found
    for i in range(m):
        if not ends[i] or err[i, 0] >= missing:
            continue
        d = node_dir[i]
        sib, gap = -1, np.inf
        for k in range(dir_ptr[d], dir_ptr[d + 1]):
            if k == i or not ends[k]:
                continue
            x = 0.0
            for c in range(j):
                x = max(x, _wrapped(u[k, c] - u[i, c], period[c]))
            if x < gap:
                sib, gap = k, x
        if sib < 0:
            continue
        for c in range(j):
            err[i, c] += 0.5 * _wrapped(u[sib, c] - u[i, c], period[c])
        for t in range(points.shape[1]):
            x = 0.0
            for c in range(3):
                x += (points[sib, t, c] - points[i, t, c]) ** 2
            moved[i, t] += 0.5 * np.sqrt(x)
    return err, moved


@njit(cache=True)
def _beyond_boxes(
    x: FloatArray, u: FloatArray, err: FloatArray, period: FloatArray
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled
    """Per row of ``x``, the least over the samples ``u`` of how far it lies outside the
    sample's box ``err`` in the largest joint, and the sample attaining it (-1 where there is
    none; see :meth:`FamilySampler.beyond_boxes`)."""
    out = np.full(x.shape[0], np.inf)
    nearest = np.full(x.shape[0], -1, dtype=np.int64)
    for i in range(x.shape[0]):
        best = np.inf
        for k in range(u.shape[0]):
            worst = -np.inf
            for c in range(x.shape[1]):
                d = _wrapped(u[k, c] - x[i, c], period[c]) - err[k, c]
                if d > worst:
                    worst = d
                    if worst >= best:
                        break
            if worst < best:
                best = worst
                nearest[i] = k
                if best <= 0.0:
                    break
        out[i] = best
    return out, nearest


@dataclass(frozen=True)
class ToolBody:
    """Where the body of the arm's last link ends and its bare tip begins (the *cut*, the
    tip's length from the tool point), with what the body must keep from each obstacle: the
    facts :meth:`FamilySampler._filtered` drops whole cells of tool directions by.

    With the tool point within ``tol`` of a point ``E`` and the last link along the tool
    direction, the cut of a member whose direction lies within ``angle`` of a sample's is
    within ``tol + tip * angle`` of the sample's cut (``tip``: the cut's distance from the tool
    point). The body's clearance to an obstacle is at most the cut's signed distance less the
    body's radius, and signed distance is 1-Lipschitz; so where the sample's cut lies closer to
    an obstacle than the body's radius, its required clearance and that lever together, no
    member of the cell keeps the clearance rule. The arm's points moving to the neighbouring
    directions' members (the general rule) allow far more: the wrist end of the last link
    swings by its whole length times the angle (the seed arm's tool near tangent to the
    workpiece at the ends of the crack's reachable arc: slack -1.0 mm, kept by a 65 mm lever,
    dropped by the 5 mm one)."""

    obstacles: tuple[Obstacle, ...]
    #: clearance the body keeps from each obstacle, its capsule radius added (model units)
    needs: FloatArray
    #: index of the body among the world's parts (:meth:`CollisionWorld.parts`)
    part: int

    @staticmethod
    def of(world: CollisionWorld, arm: SerialArm) -> ToolBody | None:
        """The last link's body of ``arm`` in ``world``; None without obstacles or a bare tip."""
        parts = world.parts(arm)
        if not world.obstacles or len(parts) < 2 or not parts[-1].is_tip:
            return None
        body = parts[-2]
        kept = {p.other: p.required for p in world.pairs(arm) if p.part == body.name}
        needs = np.array(  # an obstacle the body need not keep clear of blocks nothing
            [body.radius + kept[o.name] if o.name in kept else -np.inf for o in world.obstacles]
        )
        return ToolBody(world.obstacles, needs, len(parts) - 2)

    def blocked(
        self,
        world: CollisionWorld,
        arm: SerialArm,
        q: FloatArray,
        dirs: FloatArray,
        angle: FloatArray,
        tol: float,
    ) -> BoolArray:
        """Which members ``q (M, n)`` rad (tool directions ``dirs (M, 3)``, real) stand for a
        cell of directions within ``angle (M,)`` rad in which no member with the tool point
        within ``tol`` of theirs keeps the body's clearance (see the class). Members whose last
        link does not lie along their tool direction are never blocked here."""
        if q.shape[0] == 0:
            return np.zeros(0, dtype=bool)
        _, ends = world.part_segments(arm, q)
        cut, point = ends[:, self.part], ends[:, -1]
        tip = np.linalg.norm(point - cut, axis=-1)
        along = np.linalg.norm(point - cut - tip[:, None] * dirs, axis=-1) <= 1e-9 * (1.0 + tip)
        lever = tol + tip * angle
        out = np.zeros(q.shape[0], dtype=bool)
        for obstacle, need in zip(self.obstacles, self.needs, strict=True):
            out |= obstacle.signed_distance(cut) + lever < need
        return np.asarray(out & along, dtype=bool)


class FamilySampler:
    """Samples the family of one arm at points, with sampling errors (see the module)."""

    def __init__(
        self,
        fam: CurveFamily,
        tolerance_mm: float,
        directions: int | None = None,
        q_start: FloatArray | None = None,
        blow_ups: bool = True,
        blow_up_cache: dict[bytes, tuple[BlowUp, ...]] | None = None,
    ) -> None:
        arm = fam.arm
        #: whether the family's singular directions are blown up (:mod:`.chart`)
        self.blow_ups = blow_ups
        #: the blow-ups found at each tool point (by its bytes), shared by the samplers of
        #: one family given the same dict (they depend on the point and on the directions
        #: allowed there alone: whoever passes the dict gives each point one ``allowed``);
        #: None: found again at each call
        self.blow_up_cache = blow_up_cache
        self.fam = fam
        self.tip = np.asarray(fam.tip_joints, dtype=bool)
        grid = arm.lattice
        step = (np.asarray(grid.tick, dtype=np.float64) * grid.max_ticks)[self.tip]
        self.step = step
        # a revolute joint whose range spans a whole turn is measured the shorter way round:
        # the family's samples take one of its turns, a plan may take the other
        span = (arm.upper - arm.lower)[self.tip]
        revolute = np.array([j.kind is JointKind.REVOLUTE for j in arm.joints])[self.tip]
        turns = revolute & ~(span < 2.0 * np.pi)
        #: the tip joints that can turn whole turns (a revolute joint whose range spans one)
        self.whole_turns = turns
        self.period = np.where(turns, 2.0 * np.pi / step, 0.0)
        #: the tip joints that a self-collision range they cannot cross confines
        #: (:meth:`CollisionWorld.joint_windows` from ``q_start``): rad, by joint index; such a
        #: joint is measured within its range, not round the turn
        self.joint_windows = tuple(
            w
            for w in (fam.world.joint_windows(arm, q_start) if q_start is not None else ())
            if self.tip[w[0]]
        )
        #: the same ranges in command units, by index among the tip joints
        self.windows: list[tuple[int, float, float]] = []
        tip_index = np.cumsum(self.tip) - 1
        for k, lo, hi in self.joint_windows:
            j = int(tip_index[k])
            self.windows.append((j, lo / step[j], hi / step[j]))
            self.period[j] = 0.0
        self.tol = tolerance_mm / arm.mm_per_unit
        base = fam.coarse_dirs if directions is None else fibonacci_directions(directions)
        self.base = np.asarray(base, dtype=np.float64)
        self.base_spacing = float(np.sqrt(4.0 * np.pi / self.base.shape[0]))
        #: how far any point of the arm moves per unit of each tip joint (model units per rad)
        self.reach = displacement_bounds(arm)[self.tip]
        #: tool frames sampled about each direction (several: the family has a third dimension)
        self.turns = fam.turns_per_direction
        self.required = fam.world.required(arm)
        #: the last link's body, by which whole cells of directions are dropped (see
        #: :meth:`_filtered`)
        self.body = ToolBody.of(fam.world, arm)
        #: how many parts a pair's slack may close by at most: two where the world checks the
        #: arm against itself (both links of a pair move), else one (only the arm's part)
        self.movers = 2.0 if any(p.is_self for p in fam.world.pairs(arm)) else 1.0
        #: why the sampled directions and turns do not span the family ("" where they do:
        #: :attr:`CurveFamily.unspanned_because`; a redundant arm's self-motion)
        self.unspanned_because = fam.unspanned_because
        #: per audited point (:meth:`audit`), the clear members drawn there, how many of them
        #: lie outside every sample's error box, and how far the farthest does (commands)
        self.audits: list[tuple[int, int, float]] = []
        #: the all-solutions IK the audit draws members with (None: from random starts)
        self.audit_solver = complete_solver(arm)
        #: audits drawn again after a layer was refined (:meth:`audit`'s ``again``), and the
        #: members the last audit drew (command units)
        self._redraws = 0
        self._drawn = np.zeros((0, self.step.size))

    @property
    def covers_family(self) -> bool:
        """Whether the samples cover the family, as the bounds take them to (see
        :meth:`unproven_because`)."""
        return not self.unproven_because()

    def unproven_because(self, with_errors: bool = True) -> str:
        """Why a bound over the samples is not proven, in words ("" where it is): without the
        sampling errors (``with_errors`` False) it is none; or the samples are not taken to
        cover the family (:attr:`CurveFamily.unspanned_because`: a redundant arm's
        self-motion, a five-joint family the tool directions do not chart); or members drawn
        by :meth:`audit` lay outside every sample's error box."""
        if not with_errors:
            return "the sampling errors are left out"
        if self.unspanned_because:
            return f"the samples do not cover the arm's family ({self.unspanned_because})"
        missed = sum(m for _, m, _ in self.audits)
        if not missed:
            return ""
        drawn = sum(d for d, _, _ in self.audits)
        worst = max(w for _, _, w in self.audits)
        how_far = (
            f"by up to {worst:.3g} commands"
            if np.isfinite(worst)
            else "at a point where no sample was kept"
        )
        how_drawn = (
            f"every IK solution at {AUDIT_FRAMES} random tool frames"
            if self.audit_solver is not None
            else "random starts"
        )
        return (
            f"of {drawn} clear members drawn from {how_drawn} at {len(self.audits)} points, "
            f"{missed} lie outside every sample's error box, {how_far} (the family varies "
            "faster between the samples than their errors allow)"
        )

    def audit_sites(
        self,
        points: list[FloatArray],
        layers: list[Layer],
        allowed: list[Callable[[FloatArray], BoolArray] | None] | None = None,
        refine: Callable[[int, FloatArray], Layer | None] | None = None,
    ) -> None:
        """:meth:`audit` at up to :data:`AUDIT_SITES` of the sites ``points`` (with their
        ``layers`` and the directions ``allowed`` at each), evenly spread. ``refine(k,
        missed)``: site ``k``'s layer refined about the members an audit found outside every
        box (command units), or None where it cannot be; the site is then audited again, the
        members drawn before and a new draw (:meth:`audit`'s ``again``), at most
        :data:`AUDIT_REFINES` times and while none lies farther out than
        :data:`AUDIT_REFINE_WORST` (a site at the edge of the reach, where the family narrows
        faster than its coarse sampling shows, is sampled finely where the audit looks; one
        whose error model misses by whole commands is left an estimate)."""
        if not points:
            return
        picked = np.unique(np.linspace(0, len(points) - 1, min(len(points), AUDIT_SITES)).round())
        for k in picked.astype(int).tolist():
            check_time("bounding the commands")
            rule = None if allowed is None else allowed[k]
            missed = self.audit(points[k], layers[k], rule)
            for _ in range(AUDIT_REFINES if refine is not None else 0):
                assert refine is not None
                near = missed.shape[0] > 0 and self.audits[-1][2] <= AUDIT_REFINE_WORST
                layer = refine(k, missed) if near else None
                if layer is None:
                    break
                missed = self.audit(points[k], layer, rule, again=True)

    def audit(
        self,
        E: FloatArray,
        layer: Layer,
        allowed: Callable[[FloatArray], BoolArray] | None,
        again: bool = False,
    ) -> FloatArray:
        """Check ``layer`` (the samples at tool point ``E``) against members drawn another way:
        for an arm with an all-solutions IK (:func:`complete_solver`), every solution at
        :data:`AUDIT_FRAMES` random tool frames at ``E`` whose approach axis points along a
        direction ``allowed``; otherwise Levenberg-Marquardt on the point alone from
        :data:`AUDIT_STARTS` random starts. Those within the limits, clear and inside the
        joints' ranges to keep should each lie within some sample's error box (the bounds'
        assumption); the count of those that do not is recorded (:attr:`audits`), and one
        makes :attr:`covers_family` False; they are returned (command units of the tip joints,
        ``(M, J)``). A test that can fail, not a proof: where the error model fails (near the
        edge of reach, where the family folds or narrows), members fall between the samples'
        error boxes.

        ``again``: the last audit was of this point, its layer since refined: the members
        drawn then are checked again with a new draw (the refined samples' errors may be
        smaller), and the record replaces the last one, counting the members of both draws."""
        if self.unspanned_because:
            return np.zeros((0, self.step.size))  # nothing is claimed
        arm = self.fam.arm
        E = np.asarray(E, dtype=np.float64)
        if again:
            self._redraws += 1
            rng = np.random.default_rng([len(self.audits), self._redraws])
        else:
            rng = np.random.default_rng(len(self.audits))
        if self.audit_solver is not None:
            R = _random_frames(np.asarray(arm.approach_axis), allowed, AUDIT_FRAMES, rng)
            q, _ = solve_frames(arm, self.audit_solver, E, R)
            q = q[arm.within_limits(q)] if q.shape[0] else q
        else:
            family = GenericFamily(arm, ToolTarget(E))
            lo, hi = arm.sampling_box()
            q = family.refine(rng.uniform(lo, hi, (AUDIT_STARTS, arm.n_joints)), iterations=80)
            q = q[family.exact(q)]
        if q.shape[0]:  # clear to rounding: a tool tip on a surface is at 0 +- 1e-13
            q = q[self.fam.world.satisfied(arm, q, extra=-CLEAR_MARGIN)]
        if allowed is not None and q.shape[0]:
            q = q[allowed(tool_pose(arm, q)[:, :3, :3] @ np.asarray(arm.approach_axis))]
        u = self.units(q)
        inside = np.ones(u.shape[0], dtype=bool)
        for j, w_lo, w_hi in self.windows:
            inside &= (u[:, j] >= w_lo - AUDIT_SLACK) & (u[:, j] <= w_hi + AUDIT_SLACK)
        u = u[inside]
        if again:
            self.audits.pop()
            u = np.vstack([u, self._drawn])
        self._drawn = u
        beyond = self.beyond_boxes(layer, u)
        missed = beyond > AUDIT_SLACK
        worst = float(beyond[missed].max()) if missed.any() else 0.0
        self.audits.append((int(u.shape[0]), int(missed.sum()), worst))
        return np.asarray(u[missed])

    def beyond_boxes(self, layer: Layer, u: FloatArray) -> FloatArray:
        """How far each point ``u`` (command units ``(K, J)`` of the tip joints) lies outside
        the nearest of ``layer``'s error boxes (commands, in the largest joint; at most 0
        inside one, where the search stops; inf where the layer is empty), a whole turn's
        joint the shorter way."""
        return self.nearest_boxes(layer, u)[0]

    def nearest_boxes(self, layer: Layer, u: FloatArray) -> tuple[FloatArray, IntArray]:
        """:meth:`beyond_boxes`, and per point the sample of ``layer`` whose box it lies
        nearest (-1 where the layer is empty)."""
        check_time("bounding the commands")
        return _beyond_boxes(
            np.ascontiguousarray(u, dtype=np.float64),
            np.ascontiguousarray(layer.u, dtype=np.float64),
            np.ascontiguousarray(layer.err, dtype=np.float64),
            self.period,
        )

    def within_windows(self, q: FloatArray) -> FloatArray:
        """Configurations ``(..., n)`` rad with each joint that has a range to keep
        (:attr:`joint_windows`) at the copy of its value (whole turns) nearest it
        (:func:`into_windows`): on the start's side of its self-collision ranges."""
        q = np.asarray(q, dtype=np.float64)
        if not self.joint_windows:
            return q
        flat = into_windows(q.reshape(-1, q.shape[-1]), self.joint_windows)[0]
        return np.asarray(flat.reshape(q.shape), dtype=np.float64)

    def units(self, q: FloatArray) -> FloatArray:
        """Command units of the tip joints of configurations ``(..., n)`` rad, each joint with a
        range to keep measured on the start's side of it (:meth:`within_windows`)."""
        return np.asarray(self.within_windows(q)[..., self.tip] / self.step, dtype=np.float64)

    def outside_windows(self, u: FloatArray, err: FloatArray) -> BoolArray:
        """Samples (command units ``(M, J)``, errors ``(M, J)``) whose every nearby member lies
        outside a joint's range to keep: farther out than the sample's error."""
        out = np.zeros(u.shape[0], dtype=bool)
        for j, lo, hi in self.windows:
            gap = np.maximum(np.maximum(lo - u[:, j], u[:, j] - hi), 0.0)
            out |= gap > err[:, j] + 1e-9
        return out

    def outside_limits(self, u: FloatArray, err: FloatArray) -> BoolArray:
        """Samples (command units ``(M, J)`` of the tip joints, errors ``(M, J)``) whose every
        nearby member lies past a tip joint's limit: farther than the sample's error (a joint
        that turns whole turns has none)."""
        arm = self.fam.arm
        lo = arm.lower[self.tip] / self.step
        hi = arm.upper[self.tip] / self.step
        with np.errstate(invalid="ignore"):
            gap = np.maximum(np.maximum(lo - u, u - hi), 0.0)
        gap = np.where(self.whole_turns, 0.0, np.nan_to_num(gap, nan=0.0))
        return np.asarray(np.any(gap > err + 1e-9, axis=1))

    def layer(
        self,
        E: FloatArray,
        dirs: FloatArray,
        allowed: Callable[[FloatArray], BoolArray] | None = None,
        *,
        levels: int,
    ) -> Layer:
        """The family at tool point ``E`` sampled along ``dirs`` (those ``allowed``: a mask of
        any directions). A sample that is not clear itself is kept when a member near it may be
        (see :meth:`_filtered`); ``levels`` times, the triangles of directions about such
        samples are split in four, which shrinks what their neighbours allow and so drops the
        samples whose whole cell collides."""
        return self.sampled(E, dirs, allowed, levels=levels)[1][0]

    def sampled(
        self,
        E: FloatArray,
        dirs: FloatArray,
        allowed: Callable[[FloatArray], BoolArray] | None = None,
        *,
        levels: int,
    ) -> tuple[_Samples, tuple[Layer, IntArray, FloatArray, IntArray]]:
        """What :meth:`layer` samples: every member (:class:`_Samples`) and what
        :meth:`_filtered` makes of them."""
        caps = self._blow_ups(E, allowed)
        if caps:  # the directions in the chart: none in the holes, the circles instead
            dirs = np.vstack([dirs[outside_holes(dirs, caps)], *(ring(c) for c in caps)])
        empty = _Samples.empty(self.fam.arm, int(self.tip.sum()), caps)
        acc = self._grown(empty, E, dirs, allowed)
        for level in range(levels + 1):
            check_time("bounding the commands")
            filtered = self._filtered(acc)
            _, unsure, spacing, triangles = filtered
            refine = np.zeros(acc.dirs.shape[0], dtype=bool)
            refine[unsure] = spacing[unsure] / 2.0 >= MIN_SPACING
            if level == levels or not np.any(refine):
                break
            new = _distinct(_midpoints(acc.dirs, triangles, refine, acc.caps), acc.dirs)
            if acc.dirs.shape[0] + new.shape[0] > MAX_LAYER_DIRECTIONS:
                break
            acc = self._grown(acc, E, new, allowed)
        return acc, filtered

    def _blow_ups(
        self, E: FloatArray, allowed: Callable[[FloatArray], BoolArray] | None
    ) -> tuple[BlowUp, ...]:
        """The blow-ups of the family's singular directions at ``E`` among those allowed
        (:mod:`.chart`, found from :data:`_DETECT_DIRECTIONS`; none when :attr:`blow_ups` is
        off or the family is not two-dimensional: several turns sampled about each
        direction)."""
        if not self.blow_ups or self.turns != 1:
            return ()
        if self.blow_up_cache is None:
            return self._found_blow_ups(E, allowed)
        key = np.asarray(E, dtype=np.float64).tobytes()
        if key not in self.blow_up_cache:
            self.blow_up_cache[key] = self._found_blow_ups(E, allowed)
        return self.blow_up_cache[key]

    def _found_blow_ups(
        self, E: FloatArray, allowed: Callable[[FloatArray], BoolArray] | None
    ) -> tuple[BlowUp, ...]:
        """What :meth:`_blow_ups` finds at ``E``, found now."""
        centers = singular_directions(
            self.fam.arm,
            self.tip,
            lambda d: self.fam.members(E, d),
            _DETECT_DIRECTIONS,
            _DETECT_SPACING,
        )
        if allowed is not None and centers:
            centers = [c for c, ok in zip(centers, allowed(np.array(centers)), strict=True) if ok]
        return caps_about(centers)

    def split(
        self,
        acc: _Samples,
        E: FloatArray,
        refine: BoolArray,
        triangles: IntArray,
        allowed: Callable[[FloatArray], BoolArray] | None,
    ) -> _Samples:
        """``acc`` with the members along the new directions of the triangles about ``refine``
        split in four (``acc`` itself when there are none)."""
        new = _distinct(_midpoints(acc.dirs, triangles, refine, acc.caps), acc.dirs)
        return acc if new.shape[0] == 0 else self._grown(acc, E, new, allowed)

    def _grown(
        self,
        acc: _Samples,
        E: FloatArray,
        dirs: FloatArray,
        allowed: Callable[[FloatArray], BoolArray] | None,
    ) -> _Samples:
        """``acc`` with the members along ``dirs`` added (configurations, command units, the
        arm's points, the tolerance's joint change, the slack)."""
        real = to_real(dirs, acc.caps)
        pick = np.flatnonzero(allowed(real)) if allowed is not None else np.arange(dirs.shape[0])
        q, index = self.fam.solutions(E, real[pick])
        counts = np.full(dirs.shape[0], -1, dtype=np.int64)
        if self.fam.solves_completely:
            counts[pick] = np.bincount(index, minlength=pick.shape[0])
        inside = self.fam.arm.within_limits(q) if q.shape[0] else np.zeros(0, dtype=bool)
        index = pick[index] + acc.dirs.shape[0]
        tol_err = np.zeros((q.shape[0], acc.u.shape[1]))
        slack = np.zeros(q.shape[0])
        isolated = np.zeros(q.shape[0], dtype=bool)
        if q.shape[0]:
            J = position_jacobian(self.fam.arm, q)[:, :, self.tip]
            tol_err = self.tol * np.abs(pseudo_inverse(J)).sum(axis=-1) / self.step
            tol_err = np.where(np.isfinite(tol_err), tol_err, _MISSING)
            if J.shape[-1] <= 3:
                sv = np.linalg.svd(J, compute_uv=False)
                isolated = sv[:, -1] > _ISOLATED_RANK * np.maximum(sv[:, 0], 1e-300)
            # only a negative slack matters (see _filtered): the broad phase skips the pairs
            # that cannot be below zero, and every sample at or above it reads 0; a member
            # past the limits is dropped whatever its slack
            if inside.any():
                slack[inside] = self.fam.world.slack(self.fam.arm, q[inside], ceiling=0.0)
        return _Samples(
            dirs=np.vstack([acc.dirs, dirs]),
            q=np.vstack([acc.q, q]),
            index=np.concatenate([acc.index, index]),
            u=np.vstack([acc.u, self.units(q)]),
            points=np.concatenate([acc.points, landmark_positions(self.fam.arm, q)]),
            tol_err=np.vstack([acc.tol_err, tol_err]),
            slack=np.concatenate([acc.slack, slack]),
            isolated=np.concatenate([acc.isolated, isolated]),
            inside=np.concatenate([acc.inside, inside]),
            solution_counts=np.concatenate([acc.solution_counts, counts]),
            caps=acc.caps,
        )

    def _filtered(
        self,
        acc: _Samples,
        ranked: tuple[Callable[[FloatArray, FloatArray], FloatArray], float] | None = None,
    ) -> tuple[Layer, IntArray, FloatArray, IntArray]:
        """The layer of the samples in ``acc`` with their errors; the samples kept only for
        what their neighbours allow (indices into ``acc.dirs``); each direction's spacing (the
        widest angle to its Delaunay neighbours, rad); the Delaunay triangles. ``ranked``:
        for a caller to whom only the samples of least rank matter (the rank of each given its
        command units and errors, and a margin), the samples are checked for clearance in
        order of rank until the next lies more than the margin above the least kept; the
        others are kept as if a member near them may be clear, unchecked by the tool's body
        too (a relaxation); None: all are checked.

        A sample is kept when each link's slack is no worse than the farther of the link's ends
        moves to its neighbours' members (and within the tolerance; a link pair's, both links'
        together): a member nearby may then be clear where the sample is not. Links are
        straight between those points, so none of a link's points moves farther. Such a
        sample is dropped after all when its last link's body is too close to an obstacle for
        any member of its cell (:class:`ToolBody`: the body's end moves far less than the
        link's other end)."""
        order = np.argsort(acc.index, kind="stable")
        q, index, u = acc.q[order], acc.index[order], acc.u[order]
        n_dirs = acc.dirs.shape[0]
        nb_ptr, nb, triangles = _delaunay_neighbours(acc.dirs, acc.caps)
        src = np.repeat(np.arange(n_dirs), np.diff(nb_ptr))
        cosines = np.einsum("ij,ij->i", acc.dirs[src], acc.dirs[nb])
        spacing = np.zeros(n_dirs)
        np.maximum.at(spacing, src, np.arccos(np.clip(cosines, -1.0, 1.0)))
        dir_ptr = np.searchsorted(index, np.arange(n_dirs + 1)).astype(np.int64)
        err, moved = _sampling_errors(
            u, acc.points[order], index, dir_ptr, nb_ptr, nb, self.period, _MISSING,
            BRANCH_GAP, self.turns > 1, acc.solution_counts,
        )  # fmt: skip
        # an isolated member (see _Samples) is the only one near it, wherever the others lie
        isolated = acc.isolated[order]
        err[isolated], moved[isolated] = 0.0, 0.0
        alone = err[:, 0] >= _MISSING
        if np.any(alone) and not np.all(alone):
            # no neighbouring direction has a member (a sliver of the family inside the joint
            # limits): the layer's median error stands in for the unknown one
            err[alone] = np.median(err[~alone], axis=0)
            moved[alone] = np.median(moved[~alone], axis=0)
        tol_err, slack = acc.tol_err[order], acc.slack[order]
        err = err + tol_err
        # how far the arm's points may move within the cell beyond the neighbours' members
        # (the tolerance's joint change), each landmark's own way and any point at most
        extra = (tol_err * self.step) @ self.reach + CLEAR_MARGIN
        # a member past the joint limits counts in its neighbours' errors (the family goes on
        # past a limit) and is then dropped: the layer's samples are configurations plans and
        # guides may take; its cells are split like unsure ones
        inside = acc.inside[order]
        edge = ~inside & ~self.outside_limits(u, err)
        keep = inside & ~self.outside_windows(u, err)
        at = np.flatnonzero(keep)
        moved = moved + extra[:, None]
        checked = np.zeros_like(keep)  # the samples whose clearance is checked
        if ranked is None:
            keep[at] &= self.may_be_clear(q[at], slack[at], moved[at])
            checked[at] = True
        else:  # nearest first, until the next lies beyond the nearest kept by the margin
            key, margin = ranked
            rank = key(u[at], err[at])
            at, rank = at[np.argsort(rank, kind="stable")], np.sort(rank, kind="stable")
            done, batch, best = 0, _RANKED_BATCH, math.inf
            while done < at.shape[0] and not rank[done] > best + margin:
                take = at[done : done + batch]
                ok = self.may_be_clear(q[take], slack[take], moved[take])
                keep[take], checked[take] = ok, True
                best = min(best, float(rank[done : done + batch][ok].min(initial=math.inf)))
                done, batch = done + batch, 2 * batch
        if self.body is not None:
            # a sample not clear itself whose cell the body cannot keep clear anywhere
            # (:class:`ToolBody`), where the chart is the identity out to its spacing (those
            # whose clearance is not checked are kept as they are)
            angle = spacing[index]
            check = keep & checked & (slack < 0.0)
            check &= real_within(acc.dirs, acc.caps, spacing)[index]
            at = np.flatnonzero(check)
            real = to_real(acc.dirs[index[at]], acc.caps)
            keep[at] &= ~self.body.blocked(
                self.fam.world, self.fam.arm, q[at], real, angle[at], self.tol
            )
        unsure = np.unique(np.concatenate([index[keep & (slack < 0.0)], index[edge]]))
        clear = (slack >= 0.0) & inside & ~self.outside_windows(u, np.zeros_like(err))
        real = to_real(acc.dirs[index[keep]], acc.caps)
        layer = Layer(u[keep], err[keep], q[keep], real, index[keep], clear[keep])
        return layer, unsure, spacing, triangles

    def may_be_clear(self, q: FloatArray, slack: FloatArray, moved: FloatArray) -> BoolArray:
        """Which configurations ``q (M, n)`` rad (their slack ``(M,)``, model units) may have
        a member within ``moved (M, L)`` of each landmark that keeps the clearance rule: what
        :meth:`CollisionWorld.may_be_clear_within` says, asked only where the slack is negative
        and no further than a first cut by the farthest landmark allows (a link pair's slack
        closes by both links' motion: twice that where the world checks the arm against
        itself). A part moves no farther than the farther of its ends, so a link far inside an
        obstacle whose ends move little is not cleared by the wrist's swing."""
        farthest = moved.max(axis=1, initial=0.0)
        keep = slack >= -self.movers * farthest
        at = np.flatnonzero(keep & (slack < 0.0))
        keep[at] = self.fam.world.may_be_clear_within(self.fam.arm, q[at], moved[at])
        return np.asarray(keep, dtype=bool)

    def distance_from(self, q_start: FloatArray, layer: Layer, whole: bool = False) -> FloatArray:
        """Least commands from ``q_start`` (rad) to each sample's error box (rounded up to
        whole commands when ``whole``)."""
        return self.box_distance(q_start, layer.u, layer.err, whole)

    def box_distance(
        self, q_start: FloatArray, u: FloatArray, err: FloatArray, whole: bool = False
    ) -> FloatArray:
        """Least commands from ``q_start`` (rad) to each box about ``u (M, J)`` (command units
        of the tip joints) reaching ``err (M, J)`` either way (rounded up to whole commands
        when ``whole``), a whole turn's joint the shorter way."""
        d = self.units(q_start)[None, :] - u
        period = np.where(self.period > 0, self.period, 1.0)
        d = np.where(self.period > 0, d - period * np.floor(d / period + 0.5), d)
        out = np.maximum(np.abs(d) - err, 0.0).max(axis=-1, initial=0.0)
        return np.asarray(np.ceil(out - 1e-9) if whole else out, dtype=np.float64)

    def advance(
        self,
        prev: Layer,
        cost: FloatArray,
        nxt: Layer,
        whole: bool = False,
        tree: PredecessorTree | None = None,
    ) -> tuple[FloatArray, IntArray]:
        """Shortest-path costs at ``nxt`` from ``cost`` at ``prev`` (and the predecessors);
        ``whole``: each step a whole number of commands (a leg between targets); ``tree``:
        :meth:`predecessor_tree` of ``prev`` and ``cost``, for several steps from them."""
        return advance(prev.u, prev.err, cost, nxt.u, nxt.err, self.period, whole, tree)

    def predecessor_tree(self, prev: Layer, cost: FloatArray) -> PredecessorTree:
        """What :meth:`advance` searches for the steps from ``cost`` at ``prev``."""
        return predecessor_tree(prev.u, prev.err, cost, self.period)


def _random_frames(
    approach_tool: FloatArray,
    allowed: Callable[[FloatArray], BoolArray] | None,
    count: int,
    rng: np.random.Generator,
) -> FloatArray:
    """Up to ``count`` random tool rotations ``(K, 3, 3)``: the approach axis
    ``approach_tool`` (tool frame) taken to a random direction ``allowed`` (uniform over them;
    every one when None), turned about it by a uniform angle. Fewer where the directions
    allowed are too rare to find ``count`` of in :data:`_FRAME_ROUNDS` rounds of ``count``."""
    found: list[FloatArray] = []
    kept = 0
    for _ in range(_FRAME_ROUNDS):
        d = rng.normal(size=(count, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        if allowed is not None:
            d = d[allowed(d)]
        found.append(d)
        kept += d.shape[0]
        if kept >= count:
            break
    dirs = np.concatenate(found)[:count]
    return tool_frames(dirs, rng.uniform(0.0, 2.0 * np.pi, (dirs.shape[0], 1)), approach_tool)


def _allowed_at(fam: CurveFamily, s: float) -> Callable[[FloatArray], BoolArray]:
    """The tool directions the family allows at arc length ``s`` mm."""
    return lambda dirs: fam.allowed_mask(s, dirs)
