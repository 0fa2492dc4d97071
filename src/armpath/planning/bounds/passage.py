"""Where the tool point must pass on its way to a site: into a hollow obstacle through one of
its openings (see the package).

The tool point may touch an obstacle but never enter it (its bare tip keeps a clearance of
zero or more), so a motion from outside a hollow obstacle's *hull* (the solid with its inside
filled) to a point inside it brings the tool point across the hull's boundary, and the only
part of that boundary it can cross is an opening: the disc inside the rim of an open end
(:meth:`HollowFrustum.openings`). At that instant the arm is a member of the family at a point
of the disc, and it keeps the clearance rule. A leg from the start to such a site therefore
takes at least the least distance from the start to a clear member at the disc plus from that
member to the site's member: a second relaxation, never below the direct one, that the bound
takes wherever it is larger.

The disc is covered by a square grid: every point of it lies within half a cell's diagonal
of a grid point, so sampling the family at the grid points with that as the tolerance covers
every member at the disc, as far as the package's sampling errors hold.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.geometry.primitives import HollowFrustum, Opening
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import tool_position
from armpath.model.serial_arm import SerialArm
from armpath.planning.bounds.metric import PredecessorTree
from armpath.planning.bounds.sampling import FamilySampler, Layer

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Spacing of the square grid over an opening (mm): every point of the disc lies within half
#: a cell's diagonal (11.3 mm) of a grid point. Seed Task 3: 109 grid points, 254,032 samples
#: that may be clear, its bound 103 -> 108 commands.
PASSAGE_SPACING_MM = 16.0
#: Samples whose way through a passage :meth:`PassageSamples.to` remembers at most (a few
#: hundred bytes each); past it, it forgets them all and starts again.
PASSAGE_MEMO_LIMIT = 400_000
#: Tool directions sampled at each grid point (about 6.4 deg apart).
PASSAGE_DIRECTIONS = 1000
#: Most grid points of all the openings of a scene together (a finer grid is coarsened).
MAX_PASSAGE_POINTS = 400


@dataclass(frozen=True)
class Passage:
    """A hollow ``obstacle``'s openings as the grid ``points`` ``(G, 3)`` (model units) over
    their discs, every point of a disc within ``radius`` (model units) of one; the start's tool
    point lies outside the obstacle's hull."""

    obstacle: HollowFrustum
    points: FloatArray
    radius: float

    def entered(self, sites: FloatArray, tolerance: float) -> BoolArray:
        """Per site ``(K, 3)`` (model units): whether a leg from the start to a point within
        ``tolerance`` of it takes this passage (every such point inside the hull)."""
        return np.asarray(self.obstacle.hull_side(sites, tolerance) == 1, dtype=bool)


def disc_grid(opening: Opening, spacing: float) -> FloatArray:
    """Centres ``(G, 3)`` of the square cells of side ``spacing`` (in the disc's plane) that
    meet the disc: every point of the disc lies within ``spacing / sqrt(2)`` of one."""
    xy, points = opening.square_grid(spacing)
    # the nearest point of each cell to the disc's centre
    gap = np.hypot(*np.maximum(np.abs(xy) - spacing / 2.0, 0.0).T)
    return np.asarray(points[gap <= opening.radius], dtype=np.float64)


def _tool_point_checked(
    arm: SerialArm, world: CollisionWorld, q: FloatArray, tool: FloatArray
) -> bool:
    """Whether the tool point (``tool`` at ``q``) is the end of a part the world keeps out of
    every obstacle (a clearance of zero or more), so that it never enters one."""
    parts = world.parts(arm)
    if not parts:
        return False
    _, ends = world.part_segments(arm, q)
    if np.linalg.norm(ends[-1] - tool) > 1e-9 * max(1.0, float(np.abs(tool).max())):
        return False
    last = parts[-1].name
    kept = [p.required for p in world.pairs(arm) if not p.is_self and p.part == last]
    return len(kept) == len(world.obstacles) and min(kept, default=0.0) >= 0.0


def passages(
    arm: SerialArm,
    world: CollisionWorld,
    q_start: FloatArray,
    sites: FloatArray,
    tolerance: float,
    spacing_mm: float = PASSAGE_SPACING_MM,
) -> list[Passage]:
    """The passages of ``world``'s hollow obstacles that a leg from ``q_start`` (rad) to one
    of ``sites`` ``(K, 3)`` (model units, each within ``tolerance`` model units) must take;
    none when the tool point is not checked against the obstacles. The grids have
    ``spacing_mm``, coarser where all of them together would pass :data:`MAX_PASSAGE_POINTS`
    (and with a great many obstacles, only the first ones' passages up to that many points)."""
    q_start = np.asarray(q_start, dtype=np.float64)
    hollow = [o for o in world.obstacles if isinstance(o, HollowFrustum) and o.openings()]
    start_point = tool_position(arm, q_start)
    if not hollow or not _tool_point_checked(arm, world, q_start, start_point):
        return []
    sites = np.asarray(sites, dtype=np.float64).reshape(-1, 3)
    hollow = [
        o
        for o in hollow
        if o.hull_side(start_point, 0.0) == -1 and np.any(o.hull_side(sites, tolerance) == 1)
    ]
    spacing = spacing_mm / arm.mm_per_unit

    def count(spacing: float) -> int:
        return sum(disc_grid(h, spacing).shape[0] for o in hollow for h in o.openings())

    if count(spacing) > MAX_PASSAGE_POINTS:
        # the cells go as the square of the spacing, a few more where they meet the rims:
        # widen until they fit (each step 5 % wider, so a few steps), or until one cell spans
        # the widest opening (many obstacles: a cell or a few each)
        widest = max(h.radius for o in hollow for h in o.openings())
        spacing *= float(np.sqrt(count(spacing) / MAX_PASSAGE_POINTS))
        while count(spacing) > MAX_PASSAGE_POINTS and spacing < 2.0 * widest:
            spacing *= 1.05
    out: list[Passage] = []
    held = 0
    for o in hollow:
        grid = np.vstack([disc_grid(h, spacing) for h in o.openings()])
        held += grid.shape[0]
        if out and held > MAX_PASSAGE_POINTS:
            break  # the rest are left out: a weaker bound, still a bound
        out.append(Passage(o, grid, spacing / np.sqrt(2)))
    return out


@dataclass(frozen=True)
class PassageSamples:
    """A passage as the bounds use it: the family sampled at its grid points
    (:data:`PASSAGE_DIRECTIONS` tool directions, its radius the tolerance; the members that
    may be clear) with the least distance from the start to each sample (commands), and the
    same for the samples that are clear themselves, taken as exact. :meth:`to` remembers the
    way to each sample it was asked about (by its command units and errors: the way depends on
    nothing else), so a search's next round computes only its new samples and those whose
    errors changed."""

    passage: Passage
    layer: Layer
    start: FloatArray
    exact: Layer
    exact_start: FloatArray
    _memo: dict[tuple[FamilySampler, bool], dict[bytes, float]] = field(
        default_factory=dict, compare=False, repr=False
    )
    _trees: dict[tuple[FamilySampler, bool], PredecessorTree] = field(
        default_factory=dict, compare=False, repr=False
    )

    @staticmethod
    def sampled(
        sampler: FamilySampler, passage: Passage, q_start: FloatArray, with_errors: bool = True
    ) -> PassageSamples:
        """The samples of ``passage`` in ``sampler``'s metric (``with_errors=False``: taken as
        exact, a diagnostic)."""
        fam = sampler.fam
        # one coarse sampling at many points: its singular cells are only loose, and finding
        # them at every point would cost more than the passage's whole sampling
        at = FamilySampler(
            fam,
            passage.radius * fam.arm.mm_per_unit,
            PASSAGE_DIRECTIONS,
            q_start=q_start,
            blow_ups=False,
        )
        layers = []
        for point in passage.points:
            check_time("bounding the commands")
            layers.append(at.layer(point, at.base, levels=0))
        layer = Layer.joined(layers)
        if not with_errors:
            layer = layer.without_errors()
        exact = layer.subset(np.asarray(layer.clear)).without_errors()
        return PassageSamples(
            passage,
            layer,
            sampler.distance_from(q_start, layer),
            exact,
            sampler.distance_from(q_start, exact),
        )

    def to(
        self, sampler: FamilySampler, layer: Layer, whole: bool, exact: bool = False
    ) -> FloatArray:
        """Least commands from the start through the passage to each sample of ``layer``
        (rounded up to whole commands when ``whole``; ``exact``: through the samples that are
        clear themselves)."""
        if layer.size == 0:
            return np.zeros(0)
        check_time("bounding the commands")
        through, start = (self.exact, self.exact_start) if exact else (self.layer, self.start)
        memo = self._memo.setdefault((sampler, exact), {})  # the sampler kept: its metric
        rows = np.ascontiguousarray(np.hstack([layer.u, layer.err]), dtype=np.float64)
        keys = [row.tobytes() for row in rows]
        via = np.array([memo.get(k, np.nan) for k in keys], dtype=np.float64)
        todo = np.flatnonzero(np.isnan(via))
        if todo.size:
            key = (sampler, exact)  # the same samples and costs for every layer: one tree
            if key not in self._trees:
                self._trees[key] = sampler.predecessor_tree(through, start)
            via[todo] = sampler.advance(through, start, layer.subset(todo), tree=self._trees[key])[
                0
            ]
            if len(memo) + todo.size > PASSAGE_MEMO_LIMIT:
                memo.clear()
            memo.update(zip((keys[i] for i in todo), via[todo].tolist(), strict=True))
        return np.asarray(np.ceil(via - 1e-9) if whole else via, dtype=np.float64)


def sampled_passages(
    sampler: FamilySampler,
    q_start: FloatArray,
    sites: FloatArray,
    with_errors: bool = True,
    through_openings: bool = True,
    say: Callable[[str], None] | None = None,
) -> list[PassageSamples]:
    """The passages a leg from ``q_start`` (rad) to ``sites`` ``(K, 3)`` (model units, within
    ``sampler``'s tolerance) must take (:func:`passages`), each sampled
    (:meth:`PassageSamples.sampled`; ``say`` told before, where there are any); none without
    ``through_openings``."""
    if not through_openings:
        return []
    fam = sampler.fam
    found = passages(fam.arm, fam.world, q_start, sites, sampler.tol)
    if found and say is not None:
        say("sampling the family in the openings the tool point must pass")
    return [PassageSamples.sampled(sampler, p, q_start, with_errors) for p in found]


def passage_method(samples: Sequence[PassageSamples], leg: str) -> str:
    """What a bound's method adds for the passages it charged ``leg`` ("a leg from the start",
    say) with: empty without any."""
    if not samples:
        return ""
    names = ", ".join(s.passage.obstacle.name for s in samples)
    return (
        f"; {leg} into a hollow obstacle at least its way through the obstacle's opening (the "
        f"family sampled over the opening's disc, the members that may be clear: {names})"
    )


def passage_sampling(samples: Sequence[PassageSamples]) -> dict[str, float]:
    """What a bound's sampling adds for its passages: their samples (none without any)."""
    return {"opening_samples": float(sum(s.layer.size for s in samples))} if samples else {}
