"""Tours through pools of goal states: a lazy shortest path whose legs are planned on demand.

The guided tour (:mod:`~armpath.planning.tour_guide`) commits to one clear member of the family
per target before it plans a single leg; where a leg must go round an obstacle (through a
hollow workpiece's opening, say) the member it committed to may be a poor place to arrive. Here
many goal states per target stay open until the legs between them are known:

1. The family at every target is sampled finer next to the obstacles (the triangles of tool
   directions about members that may be clear split :data:`POOL_LEVELS` times); the members
   that may be goal states are kept (links keep the margin plus
   :data:`POOL_BODY_BUFFER_MM`: :func:`pool_guide`; at most
   :data:`MAX_POOL_LAYER` per target).
2. For each visiting order, the shortest path from the start through one member per target
   (whole commands per leg, obstacles between the targets ignored) is found forwards (by prefix,
   shared between orders) and backwards; the :data:`POOL_ORDERS` orders whose paths are
   shortest are pooled, and at each target the members on some path within
   :data:`POOL_SLACK` commands of its order's shortest (at most :data:`POOL_MEMBERS` per order
   and target, the shortest paths first).
3. One lazy search over the pooled orders (:func:`lazy_search`): the cheapest path from the
   start through one member per target, in which a planned leg costs its planned commands and
   an unplanned one its direct-motion commands plus the median of what the planned legs between
   the same two targets needed beyond theirs (once :data:`EXCESS_AFTER` are planned; a leg
   that failed counts as endless). The path's members are first turned into lattice goal
   states (the clear state nearest each, which keeps the buffer:
   :func:`~armpath.planning.reach_generic.generic_goal_states`; a member without one, or with
   another member's, drops out), then its legs are planned in turn from where the one before
   ends (:func:`~armpath.planning.motion.plan_motion` through the openings' waypoints where no
   direct motion is clear, a searched leg merged and its states placed for fewer commands
   where certified: :func:`~armpath.planning.motion.merged_certified`; a joint whose limits
   span more than a turn may end at a whole-turn copy of its goal, so legs are counted between
   states up to whole turns), and the path is
   found again, until the cheapest path is planned whole, its estimate reaches the plan to beat,
   or :data:`POOL_LEG_PLANS` legs are planned in all.

A searched leg that goes round an obstacle often comes down to its direct count once its
states are placed (:mod:`~armpath.planning.tighten`), so the cheapest path stays cheap: the UR5
cell's welds were 115 commands when the pools' legs were kept as searched (the estimate passed
the plan to beat after 29 leg plans) and are 107 since, every leg at its direct count and the
tour at its lower bound.

Without the median every leg into a hollow workpiece would look a few commands cheaper than it
is and each would be planned in turn (a search for 122 commands of the seed's Task 3 took 200
leg plans); with it, ten. Without it the search would be exact (no leg needs fewer than its
direct commands, so the first path planned whole is the cheapest through the pools); the
median makes it an estimate that chooses what to plan, and the tour's bound
(:func:`~armpath.planning.bounds.tour_bound`) is what proves how close the plan is.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import ArmpathError, PlanningError
from armpath.geometry.world import into_windows
from armpath.ik.family import shift_into_limits
from armpath.ik.target import ToolTarget
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import MotionOptions, MotionPlan, plan_motion, whole_turn_ticks
from armpath.planning.passages import passage_source
from armpath.planning.reach_generic import generic_goal_states, goal_links_rule
from armpath.planning.tour_guide import TourGuide
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Times the tool directions about members that may be clear are split at each target.
POOL_LEVELS = 2
#: Room (length unit) the links of a pool's members and goal states keep beyond the margin.
#: Less than a single goal's (:data:`~armpath.planning.reach.GOAL_BODY_BUFFER_MM`, 1.5): the
#: searched legs between them have their states placed (:mod:`~armpath.planning.tighten`), so
#: goal states nearer the obstacles, and nearer each other, pay. The seed's Task 3: 122
#: commands with 1.5, 121 with 0.5 or 0.2; the UR5 cell's welds 107 with either.
POOL_BODY_BUFFER_MM = 0.5
#: Most members kept at a target for the paths through them (evenly over those that may be goal
#: states; the seed's Task 3 has 3,800-19,000).
MAX_POOL_LAYER = 25_000
#: Orders pooled: those whose shortest paths through clear members are shortest.
POOL_ORDERS = 5
#: Members kept at a target: on a path within this many commands of its order's shortest.
POOL_SLACK = 3.0
#: Most members kept per order and target (those on the shortest paths first).
POOL_MEMBERS = 200
#: Most lattice goal states per target.
POOL_GOALS = 400
#: The least largest-joint difference (deg) between the members the goal states start from.
POOL_SPREAD_DEG = 0.3
#: Legs planned between two targets before their median excess over direct motion is used.
EXCESS_AFTER = 3
#: Most legs planned in all (each a motion plan: direct, through a waypoint, or searched).
POOL_LEG_PLANS = 40

_START = -1


@dataclass(frozen=True)
class PooledTour:
    """The best tour planned through the pools: its order and legs (None when none was planned
    whole), and how many legs were planned."""

    order: tuple[int, ...] | None
    legs: list[MotionPlan] | None
    leg_plans: int
    orders_pooled: tuple[tuple[int, ...], ...]


def pool_guide(
    fam: CurveFamily, targets: FloatArray, tolerance_mm: float, q_start: FloatArray
) -> TourGuide:
    """The members of the family at each target that may be goal states (links keep the margin
    plus :data:`POOL_BODY_BUFFER_MM`: :func:`goal_links_rule`),
    sampled finer next to the obstacles (:data:`POOL_LEVELS`)."""
    guide = TourGuide.build(fam, targets, tolerance_mm, 0.0, q_start, levels=POOL_LEVELS)
    keep = []
    for p, lay in zip(targets, guide.layers, strict=True):
        goal_clear = goal_links_rule(guide.arm, guide.world, p, POOL_BODY_BUFFER_MM)
        ok = goal_clear(guide.with_start(lay.q, q_start), tolerance_mm)
        index = np.flatnonzero(ok)
        if index.size > MAX_POOL_LAYER:  # evenly over them: the paths' time and memory bounded
            index = index[np.linspace(0, index.size - 1, MAX_POOL_LAYER).round().astype(np.int64)]
        mask = np.zeros(lay.size, dtype=bool)
        mask[index] = True
        keep.append(mask)
    return guide.subset(keep)


class _MemberPaths:
    """Shortest paths from the start through one member per target (whole commands per leg,
    obstacles between the targets ignored), forwards by prefix of the order (kept: orders
    share their prefixes) and backwards for the orders asked about."""

    def __init__(self, guide: TourGuide, q_start: FloatArray, back: bool) -> None:
        self.guide, self.q_start, self.back = guide, q_start, back
        self.forward: dict[tuple[int, ...], FloatArray] = {}

    def to(self, prefix: tuple[int, ...]) -> FloatArray:
        """The shortest path's length to each member of the last target of ``prefix``."""
        if prefix not in self.forward:
            check_time("pooling the tour's goal states")
            s, layers = self.guide.sampler, self.guide.layers
            if len(prefix) == 1:
                cost = s.distance_from(self.q_start, layers[prefix[0]], whole=True)
            else:
                before = self.to(prefix[:-1])
                cost = s.advance(layers[prefix[-2]], before, layers[prefix[-1]], whole=True)[0]
            self.forward[prefix] = cost
        return self.forward[prefix]

    def last(self, order: tuple[int, ...]) -> FloatArray:
        """What the path still needs after the last target of ``order`` (back to the start)."""
        lay = self.guide.layers[order[-1]]
        if not self.back:
            return np.zeros(lay.size)
        return self.guide.sampler.distance_from(self.q_start, lay, whole=True)

    def length(self, order: tuple[int, ...]) -> float:
        """The shortest path's length through ``order`` (inf where a target has no member)."""
        if any(self.guide.layers[t].size == 0 for t in order):
            return np.inf
        return float(np.min(self.to(order) + self.last(order), initial=np.inf))

    def through(self, order: tuple[int, ...]) -> list[FloatArray]:
        """For each target of ``order``, the shortest path's length through each member."""
        s, layers = self.guide.sampler, self.guide.layers
        backward = [self.last(order)]
        for a, b in itertools.pairwise(order[::-1]):
            check_time("pooling the tour's goal states")
            backward.insert(0, s.advance(layers[a], backward[0], layers[b], whole=True)[0])
        return [self.to(order[: i + 1]) + g for i, g in enumerate(backward)]


@dataclass
class _Pool:
    """The members kept at one target, as fractional ticks ``(M, n)`` (turned nearest the
    start, within the joints' windows), each replaced by its lattice goal state once found
    (:meth:`rounded`), or barred when it has none or another member has the same one (up to
    whole turns: ``found`` maps each goal state's key to its member)."""

    target: int
    ticks: FloatArray
    q: FloatArray
    done: BoolArray
    barred: BoolArray
    found: dict[bytes, int] = field(default_factory=dict)

    def rounded(self, guide: TourGuide, start: IntArray, i: int, turns: _Turns) -> bool:
        """Round member ``i`` onto the lattice (the clear state nearest it that keeps the goal
        states' buffer: :func:`generic_goal_states`); False when it has none or it is another
        member's."""
        if not self.done[i]:
            self.done[i] = True
            try:
                state = generic_goal_states(
                    guide.arm,
                    guide.world,
                    start,
                    ToolTarget(guide.targets[self.target], None),
                    guide.tolerance_mm,
                    1,
                    body_buffer=POOL_BODY_BUFFER_MM,
                    samples=self.q[i][None, :],
                    nearest_member=True,
                )[0]
                self.ticks[i] = state
                key = turns.key(state)
                self.barred[i] = key in self.found
                self.found.setdefault(key, i)
            except ArmpathError:
                self.barred[i] = True
        return not self.barred[i]


def member_pools(
    guide: TourGuide,
    start: IntArray,
    orders: list[tuple[int, ...]],
    back: bool,
    ceiling: float,
) -> tuple[list[tuple[int, ...]], list[_Pool]]:
    """The orders pooled (at most :data:`POOL_ORDERS`, shortest member paths first, each below
    ``ceiling``) and the members kept at each target (none where no pooled order keeps any)."""
    arm = guide.arm
    grid = arm.lattice
    q0 = grid.to_joint(start)
    paths = _MemberPaths(guide, q0, back)
    lengths = {o: paths.length(o) for o in orders}
    found = sorted((o for o in orders if lengths[o] < ceiling), key=lambda o: (lengths[o], o))
    found = found[:POOL_ORDERS]
    picked: list[list[IntArray]] = [[] for _ in guide.layers]
    for o in found:
        length = lengths[o]
        for t, cost in zip(o, paths.through(o), strict=True):
            near = np.flatnonzero(cost <= length + POOL_SLACK)
            picked[t].append(near[np.argsort(cost[near], kind="stable")][:POOL_MEMBERS])
    windows = guide.world.joint_windows(arm, q0)
    pools = []
    for t, chosen in enumerate(picked):
        index = np.unique(np.concatenate(chosen)) if chosen else np.zeros(0, dtype=np.int64)
        q = shift_into_limits(arm, guide.with_start(guide.layers[t].q[index], q0), q0)
        q, fits = into_windows(q, windows)
        q = q[fits & arm.within_limits(q)]
        pools.append(
            _Pool(
                t,
                grid.to_ticks_float(q),
                q,
                np.zeros(q.shape[0], dtype=bool),
                np.zeros(q.shape[0], dtype=bool),
            )
        )
    return found, pools


class _Turns:
    """The joints whose whole-turn copies are goals too
    (:func:`~armpath.planning.motion.whole_turn_ticks`): ticks per turn, 0 for the others."""

    def __init__(self, arm: SerialArm) -> None:
        self.turn_ticks = whole_turn_ticks(arm)
        self.ticks = self.turn_ticks.astype(np.float64)
        self.max_ticks = np.asarray(arm.lattice.max_ticks, dtype=np.float64)

    def key(self, state: IntArray) -> bytes:
        """``state`` up to whole turns of those joints."""
        t = self.turn_ticks
        s = np.asarray(state, dtype=np.int64)
        return np.asarray(np.where(t > 0, np.mod(s, np.maximum(t, 1)), s), dtype=np.int64).tobytes()

    def direct(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """Commands of the direct motions from each of ``a`` ``(A, n)`` to the nearest copy of
        each of ``b`` ``(B, n)`` (fractional ticks: the lattice states' own count once they are
        whole)."""
        d = b[None, :, :] - a[:, None, :]
        period = np.where(self.ticks > 0, self.ticks, 1.0)
        d = np.where(self.ticks > 0, d - period * np.round(d / period), d)
        moves = np.abs(d) / self.max_ticks
        return np.asarray(np.ceil(np.max(moves, axis=-1) - 1e-9), dtype=np.float64)


class _LegCache:
    """Legs planned from lattice states to goal states (None: no clear motion found), by the
    actual start and the goal up to whole turns (a leg may end at a goal's copy); what the
    search sees between two states up to whole turns (the most any such leg needed); and what
    each pair of targets' planned legs needed beyond their direct motions."""

    def __init__(
        self, plan_leg: Callable[[IntArray, IntArray, bool], MotionPlan | None], turns: _Turns
    ) -> None:
        self.plan_leg = plan_leg
        self.turns = turns
        self.legs: dict[tuple[bytes, bytes], MotionPlan | None] = {}
        self.costs: dict[tuple[bytes, bytes], float] = {}
        self.excess: dict[tuple[int, int], list[float]] = {}
        self.planned = 0

    def _key(self, a: IntArray, b: IntArray) -> tuple[bytes, bytes]:
        return np.asarray(a, dtype=np.int64).tobytes(), self.turns.key(b)

    def get(self, a: IntArray, b: IntArray) -> tuple[bool, MotionPlan | None]:
        key = self._key(a, b)
        return key in self.legs, self.legs.get(key)

    def plan(self, a: IntArray, b: IntArray, pair: tuple[int, int], direct: float) -> None:
        # back to the start means the start itself, not a copy of it
        leg = self.plan_leg(a, b, pair[1] != _START)
        self.legs[self._key(a, b)] = leg
        self.planned += 1
        commands = np.inf if leg is None else float(leg.sequence.n_commands)
        key = (self.turns.key(a), self.turns.key(b))
        self.costs[key] = max(self.costs.get(key, -np.inf), commands)
        # a leg that cannot be planned counts as endlessly dear: where most fail, the median
        # bars the pair's unplanned legs
        self.excess.setdefault(pair, []).append(commands - direct)

    def between(self, graph: _OrderGraph, k: int) -> dict[tuple[int, int], float]:
        """What the search sees from layer ``k`` of ``graph`` to layer ``k + 1``, by member."""
        index = [
            {self.turns.key(graph.state(kk, i)): i for i in graph.members(kk)} for kk in (k, k + 1)
        ]
        out = {}
        for (a, b), cost in self.costs.items():
            i, j = index[0].get(a), index[1].get(b)
            if i is not None and j is not None:
                out[(i, j)] = cost
        return out

    def surcharge(self, pair: tuple[int, int]) -> float:
        seen = self.excess.get(pair, [])
        return float(np.median(seen)) if len(seen) >= EXCESS_AFTER else 0.0


@dataclass
class _OrderGraph:
    """One order's layers (the start, the pool of each target, the start again when the tour
    returns) and the direct-motion commands between consecutive layers."""

    order: tuple[int, ...]
    layers: list[_Pool | IntArray]
    labels: list[int]
    turns: _Turns
    direct: list[FloatArray]

    @staticmethod
    def build(
        start: IntArray, order: tuple[int, ...], pools: list[_Pool], back: bool, turns: _Turns
    ) -> _OrderGraph:
        ends: list[_Pool | IntArray] = [start[None, :]]
        layers = ends + [pools[t] for t in order] + (ends if back else [])
        labels = [_START, *order] + ([_START] if back else [])
        graph = _OrderGraph(order, layers, labels, turns, [])
        graph.direct = [
            turns.direct(graph.ticks(k), graph.ticks(k + 1)) for k in range(len(layers) - 1)
        ]
        return graph

    def ticks(self, k: int) -> FloatArray:
        lay = self.layers[k]
        return lay.ticks if isinstance(lay, _Pool) else lay.astype(np.float64)

    def state(self, k: int, i: int) -> IntArray:
        return np.asarray(np.round(self.ticks(k)[i]), dtype=np.int64)

    def barred(self, k: int) -> BoolArray:
        lay = self.layers[k]
        return lay.barred if isinstance(lay, _Pool) else np.zeros(lay.shape[0], dtype=bool)

    def members(self, k: int) -> list[int]:
        """The members of layer ``k`` that are lattice states (the start, rounded members)."""
        lay = self.layers[k]
        if isinstance(lay, _Pool):
            return [int(i) for i in np.flatnonzero(lay.done & ~lay.barred)]
        return list(range(lay.shape[0]))

    def refresh(self, target: int, i: int) -> None:
        """Member ``i`` of ``target``'s pool was rounded (or barred): its direct motions (none
        from or to a barred member)."""
        for k, lay in enumerate(self.layers):
            if not (isinstance(lay, _Pool) and lay.target == target):
                continue
            row = self.ticks(k)[i : i + 1]
            if k > 0:
                col = self.turns.direct(self.ticks(k - 1), row)[:, 0]
                self.direct[k - 1][:, i] = np.where(lay.barred[i] | self.barred(k - 1), np.inf, col)
            if k + 1 < len(self.layers):
                out = self.turns.direct(row, self.ticks(k + 1))[0]
                self.direct[k][i, :] = np.where(lay.barred[i] | self.barred(k + 1), np.inf, out)

    def cheapest(self, cache: _LegCache, planned_only: bool = False) -> tuple[float, list[int]]:
        """The cheapest path (a planned leg at what the cache says, an unplanned one at its
        direct commands plus the cache's surcharge; ``planned_only``: unplanned legs barred):
        its estimate and its member in each layer."""
        total = np.zeros(1)
        back_index = []
        for k, d in enumerate(self.direct):
            pair = (self.labels[k], self.labels[k + 1])
            c = np.full_like(d, np.inf) if planned_only else d + cache.surcharge(pair)
            for (i, j), cost in cache.between(self, k).items():
                c[i, j] = cost
            step = total[:, None] + c
            arg = np.argmin(step, axis=0)
            total = step[arg, np.arange(step.shape[1])]
            back_index.append(arg)
        j = int(np.argmin(total))
        path = [j]
        for arg in reversed(back_index):
            path.append(int(arg[path[-1]]))
        path.reverse()
        return float(total[j]), path

    def walk(
        self, path: list[int], cache: _LegCache
    ) -> tuple[list[MotionPlan], tuple[int, IntArray, IntArray, float] | None]:
        """The planned legs along ``path`` from the start, each from where the one before ends,
        up to the first that is not planned from there: ``(step, from, to, direct commands)``
        (None when every leg is planned; a leg that failed ends the walk too)."""
        legs: list[MotionPlan] = []
        here = self.state(0, path[0])
        for k in range(len(self.layers) - 1):
            goal = self.state(k + 1, path[k + 1])
            known, leg = cache.get(here, goal)
            if not known:
                return legs, (k, here, goal, float(self.direct[k][path[k], path[k + 1]]))
            if leg is None:
                return legs, None
            legs.append(leg)
            here = leg.sequence.final_ticks
        return legs, None


def pooled_tour(
    guide: TourGuide,
    start: IntArray,
    orders: list[tuple[int, ...]],
    back: bool,
    options: MotionOptions,
    ceiling: float = np.inf,
    say: Callable[[str], None] | None = None,
) -> PooledTour:
    """The fewest-commands tour found through pools of goal states (see the module) among
    ``orders`` with fewer commands than ``ceiling``; its legs keep the clearance rule (each
    certified by :func:`plan_motion`) and chain: each starts where the one before ends."""
    arm, world = guide.arm, guide.world
    pooled, pools = member_pools(guide, start, orders, back, ceiling)
    waypoints = passage_source(arm, world, start)

    def plan_leg(a: IntArray, b: IntArray, copies: bool) -> MotionPlan | None:
        try:
            return plan_motion(
                arm, world, a, b[None, :], options,
                turn_copies=copies, certified_merge=True, waypoints=waypoints,
            )  # fmt: skip
        except PlanningError:
            return None

    turns = _Turns(arm)
    cache = _LegCache(plan_leg, turns)
    graphs = [_OrderGraph.build(start, o, pools, back, turns) for o in pooled]
    found = lazy_search(
        graphs, cache, lambda pool, i: pool.rounded(guide, start, i, turns), ceiling, say
    )
    order, legs = (None, None) if found is None else found
    return PooledTour(order, legs, cache.planned, tuple(pooled))


def lazy_search(
    graphs: list[_OrderGraph],
    cache: _LegCache,
    round_member: Callable[[_Pool, int], bool],
    ceiling: float = np.inf,
    say: Callable[[str], None] | None = None,
) -> tuple[tuple[int, ...], list[MotionPlan]] | None:
    """One lazy shortest-path search over the orders' graphs (see the module): the cheapest
    path's members are rounded onto the lattice (``round_member``), then its legs planned from
    where the one before ends, until the cheapest path is planned whole (its order and legs),
    its estimate reaches ``ceiling``, or the cache has planned :data:`POOL_LEG_PLANS` legs (then
    the cheapest path planned whole, if any). Without the surcharge (each unplanned leg at its
    direct commands, which no leg beats) the path found is the cheapest of all."""
    tell = say or (lambda _msg: None)
    steps = len(graphs[0].layers) - 1 if graphs else 0
    best: tuple[int, tuple[int, ...], list[MotionPlan]] | None = None
    pools = {id(lay): lay for g in graphs for lay in g.layers if isinstance(lay, _Pool)}
    # the cheapest estimate is planned first, so an order whose first legs turn out dear (into
    # a hollow workpiece) drops behind the others; each pass rounds a member or plans a leg,
    # or ends the search
    for _ in range(sum(p.ticks.shape[0] for p in pools.values()) + POOL_LEG_PLANS):
        if not graphs or cache.planned >= POOL_LEG_PLANS:
            break
        check_time("planning the tour through pools of goal states")
        found = [(g.cheapest(cache), g) for g in graphs]
        (estimate, path), g = min(found, key=lambda f: (f[0][0], f[1].order))
        if not np.isfinite(estimate) or estimate >= ceiling:
            break
        # the path's members onto the lattice first: their direct motions change a little
        fresh = [
            (lay, path[k])
            for k, lay in enumerate(g.layers)
            if isinstance(lay, _Pool) and not lay.done[path[k]]
        ]
        if fresh:
            for lay, i in fresh:
                round_member(lay, i)
                for other in graphs:
                    other.refresh(lay.target, i)
            continue
        legs, missing = g.walk(path, cache)
        if missing is None:
            # every leg planned (the estimate counts each planned pair at the most it needed,
            # so this is no dearer than the estimate and no other path is estimated cheaper)
            if len(legs) == steps:
                best = (sum(leg.sequence.n_commands for leg in legs), g.order, legs)
            break
        k, here, goal, direct = missing
        name = "-".join(str(t + 1) for t in g.order)
        tell(
            f"planning order {name} through pools of goal states: leg {k + 1} "
            f"(estimate {estimate:.0f} commands)"
        )
        cache.plan(here, goal, (g.labels[k], g.labels[k + 1]), direct)
    if best is None:  # out of budget: the cheapest path planned whole, if any
        for g in graphs:
            estimate, path = g.cheapest(cache, planned_only=True)
            legs, missing = g.walk(path, cache)
            total = sum(leg.sequence.n_commands for leg in legs)
            if (
                np.isfinite(estimate)
                and missing is None
                and len(legs) == steps
                and total < min(ceiling, np.inf if best is None else best[0])
            ):
                best = (total, g.order, legs)
    return None if best is None else (best[1], best[2])
