"""Visiting several target points in the best order (Task 3, the spot welds).

For each target, :func:`~armpath.planning.reach.goal_states` gives a few clear lattice states
that put the fingertip on it. Every visiting order is ranked by a lower bound of its commands:
a shortest path through the layers start -> goals of the 1st target -> goals of the 2nd ...,
each step costing the commands of the direct motion (obstacles ignored, so no order can do
better for these goal states). The best-ranked orders are then planned leg by leg with
:func:`~armpath.planning.motion.plan_motion` (direct where clear, else searched), then every
next order whose bound is below the best plan so far (a few at most), and the order with the
fewest planned commands wins. Each planned order is planned a second time through goal states
chosen together (:mod:`~armpath.planning.tour_guide`: the shortest path through clear members
of the family at every target), the shorter plan counting; the order whose such path is
shortest is planned too, and for each room the members keep beyond the margin
(:data:`GUIDE_BUFFERS_MM`: less room lets them lie nearer each other, at the price of tighter
legs) the :data:`GUIDED_ORDERS` orders whose guided paths are shortest. Last, the orders whose
shortest paths through clear members are shortest are planned through pools of goal states
kept open until the legs between them are known (:mod:`~armpath.planning.tour_pool`). The
tour's bound over every order and every goal configuration comes from
:func:`~armpath.planning.bounds.tour_bound`.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import check_time, count_text
from armpath.commands import CommandSequence
from armpath.errors import (
    ArmpathError,
    ArmpathWarning,
    InvalidInputError,
    PlanningError,
    UnreachableError,
)
from armpath.geometry.curves import Polyline
from armpath.geometry.world import CollisionWorld
from armpath.ik.target import Orientation
from armpath.kinematics import tool_position
from armpath.model.lattice import Lattice
from armpath.model.serial_arm import SerialArm
from armpath.planning.bounds import (
    CommandBound,
    tour_bound,
    tour_bound_any_order,
    tour_bound_over_lattice,
)
from armpath.planning.bounds.carriage import points_travel_bound, with_carriage
from armpath.planning.bounds.search import check_max_samples
from armpath.planning.bounds.tour import MAX_LATTICE_TARGETS
from armpath.planning.choices import Objective, VisitOrder
from armpath.planning.motion import (
    MotionOptions,
    MotionPlan,
    PlanMetrics,
    merged_certified,
    plan_metrics,
    plan_motion,
)
from armpath.planning.motion_check import (
    MotionClearance,
    check_state_clear,
    plan_clearance,
)
from armpath.planning.reach import (
    GOAL_BODY_BUFFER_MM,
    goal_states,
)
from armpath.planning.tour_guide import TourGuide
from armpath.planning.tour_pool import pool_guide, pooled_tour
from armpath.planning.trace.family import CurveFamily, curve_family
from armpath.tolerances import POINT_TOLERANCE_MM, check_point_tolerance

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class Visit:
    """Target ``target_index`` reached after command ``after_command`` (1-based) with
    fingertip error ``error_mm``."""

    target_index: int
    target_mm: tuple[float, float, float]
    after_command: int
    error_mm: float


@dataclass(frozen=True, eq=False)
class TourResult:
    """A planned tour: the whole command sequence and where each target is reached."""

    sequence: CommandSequence
    order: tuple[int, ...]
    visits: tuple[Visit, ...]
    legs: tuple[MotionPlan, ...]
    returns_to_start: bool
    clearance: MotionClearance
    metrics: PlanMetrics
    order_lower_bounds: dict[tuple[int, ...], int]
    orders_planned: dict[tuple[int, ...], int]
    tolerance_mm: float
    orders_not_planned: dict[tuple[int, ...], str] = field(default_factory=dict)
    #: The fewest commands of any tour through the targets (every order, or the given one, and
    #: every goal configuration; :func:`~armpath.planning.bounds.tour_bound`), None when not
    #: computed; and each order's bound of the same kind (empty when not computed per order).
    lower_bound: CommandBound | None = None
    order_family_bounds: dict[tuple[int, ...], int] = field(default_factory=dict)
    #: Why :attr:`lower_bound` is None (None when it was computed).
    no_bound_because: str | None = None
    #: The tool orientation rule of each target (None: the tool point only; None throughout:
    #: no rule).
    orientations: tuple[Orientation | None, ...] | None = None

    @property
    def n_commands(self) -> int:
        return self.sequence.n_commands

    @property
    def max_error_mm(self) -> float:
        return max(v.error_mm for v in self.visits)


#: Most targets whose visiting orders are all ranked (``order="auto"``): 8! = 40,320 orders.
MAX_AUTO_ORDER_TARGETS = 8
#: Most targets of one tour (``order="given"``).
MAX_TOUR_TARGETS = 500
#: Orders listed with their bounds in a result (the best-ranked first).
LISTED_ORDERS = 24
#: Orders planned beyond the best-ranked ones while their bound is below the best plan.
EXTRA_ORDERS = 4
#: A plan more than this times its order's goal-state bound is planned again with
#: :data:`SECOND_LOOK_SEARCHES` searches per searched leg (keeping the shorter).
SECOND_LOOK_RATIO = 1.25
#: Searches per leg (different seeds, the best kept) of that second look.
SECOND_LOOK_SEARCHES = 3


class _AbandonedError(Exception):
    """A tour's order given up while planned: it cannot need fewer ``commands`` than the
    best plan so far."""

    def __init__(self, commands: int) -> None:
        super().__init__(f"needs at least {commands} commands")
        self.commands = commands


def _direct_commands(a: IntArray, b: IntArray, lattice: Lattice) -> FloatArray:
    """Fewest direct-motion commands from each state of ``a`` ``(A, n)`` to each of ``b``
    ``(B, n)``: ``(A, B)``."""
    return lattice.commands_needed_many(b[None, :, :] - a[:, None, :]).astype(np.float64)


def _order_bounds(
    start: IntArray,
    goals: list[IntArray],
    orders: list[tuple[int, ...]],
    back: bool,
    lattice: Lattice,
) -> dict[tuple[int, ...], int]:
    """For every order, the fewest direct-motion commands through one goal state per target
    (a shortest path through the layers of goal states; obstacles ignored, so a lower bound for
    these goal states). The step costs between two targets are computed once, when an order
    first takes that step (a few orders of many targets take few of the possible steps)."""
    first: dict[int, FloatArray] = {}
    between: dict[tuple[int, int], FloatArray] = {}
    home: dict[int, FloatArray] = {}
    out: dict[tuple[int, ...], int] = {}
    for k, order in enumerate(orders):
        if k % 1024 == 0:
            check_time("ranking the visiting orders")
        if order[0] not in first:
            first[order[0]] = _direct_commands(start[None, :], goals[order[0]], lattice)[0]
        cost = first[order[0]]
        for a, b in itertools.pairwise(order):
            if (a, b) not in between:
                between[(a, b)] = _direct_commands(goals[a], goals[b], lattice)
            cost = np.min(cost[:, None] + between[(a, b)], axis=0)
        if back:
            if order[-1] not in home:
                home[order[-1]] = _direct_commands(goals[order[-1]], start[None, :], lattice)[:, 0]
            cost = cost + home[order[-1]]
        out[order] = int(np.min(cost))
    return out


def _least_in(
    arm: SerialArm,
    start: IntArray,
    tours: list[tuple[list[MotionPlan], tuple[int, ...]]],
    opts: MotionOptions,
) -> tuple[list[MotionPlan], tuple[int, ...]]:
    """Of the tours planned (each its legs and order), the one of least tool point path (mm)
    or weighted joint travel, as ``opts.objective`` asks; the fewest commands break a tie. The
    orders are ranked and pruned by their bounds on commands, so this chooses among the orders
    planned, not over every order."""

    def cost(legs: list[MotionPlan]) -> tuple[float, int]:
        commands = np.vstack([leg.sequence.commands for leg in legs])
        m = plan_metrics(arm, CommandSequence(start, commands, arm.lattice), opts.energy_weights)
        value = m.tip_path_mm if opts.objective is Objective.PATH else m.energy_deg
        return round(value, 6), m.commands

    return min(tours, key=lambda t: cost(t[0]))


def _warn_of_twins(
    pts: FloatArray, orientations: Sequence[Orientation | None] | None, tolerance_mm: float
) -> None:
    """An :class:`~armpath.errors.ArmpathWarning` naming the targets within the tolerance of
    each other with the same tool rule (a point listed twice): one pose reaches both, the
    second with no command of its own."""
    from scipy.spatial import cKDTree

    pairs = sorted(cKDTree(pts).query_pairs(tolerance_mm))
    if orientations is not None:
        pairs = [(i, j) for i, j in pairs if _same_rule(orientations[i], orientations[j])]
    if not pairs:
        return
    said = ", ".join(
        f"{i + 1} and {j + 1} ({float(np.linalg.norm(pts[i] - pts[j])):.3f} mm apart)"
        for i, j in pairs[:5]
    )
    more = f" and {len(pairs) - 5} more pairs" if len(pairs) > 5 else ""
    warnings.warn(
        f"targets {said}{more} lie within the {tolerance_mm:g} mm tolerance of each other: "
        "one pose reaches both, the second with no command of its own (a point listed twice?)",
        ArmpathWarning,
        stacklevel=3,
    )


def _same_rule(a: Orientation | None, b: Orientation | None) -> bool:
    """Whether two targets' tool rules are the same (both none, or equal field by field)."""
    if a is None or b is None:
        return a is b
    return type(a) is type(b) and all(
        np.array_equal(np.asarray(getattr(a, f.name)), np.asarray(getattr(b, f.name)))
        for f in fields(a)
    )


def plan_tour(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    targets_mm: ArrayLike,
    order: VisitOrder | str = VisitOrder.AUTO,
    return_to_start: bool = False,
    tolerance_mm: float = POINT_TOLERANCE_MM,
    goals_per_target: int = 16,
    orders_to_plan: int = 2,
    options: MotionOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
    orientations: Sequence[Orientation | None] | None = None,
    bound: bool = True,
    bound_samples: int | None = None,
    pools: bool = True,
) -> TourResult:
    """Plan a clear tour from ``start_ticks`` through every target (mm), optionally back.

    ``order`` is ``"auto"`` (every order ranked by its lower bound, the ``orders_to_plan`` best
    planned, then up to :data:`EXTRA_ORDERS` more while their bound is below the best plan; at
    most :data:`MAX_AUTO_ORDER_TARGETS` targets) or ``"given"`` (the targets' order,
    at most :data:`MAX_TOUR_TARGETS`). Without orientation rules, each planned order is also
    planned through goal states chosen together (:class:`TourGuide`; compared over every order
    up to :data:`MAX_GUIDED_ORDERS`, of more over the bound's best order and the best ranked:
    :func:`_guided_orders`; the one whose guided path is shortest planned too, and at
    each of :data:`GUIDE_BUFFERS_MM` the :data:`GUIDED_ORDERS` whose guided paths are shortest
    and no longer than the best plan, through the lattice goal states nearest the guide's members
    and through the most accurate ones: :data:`GUIDED_NEAREST`) and the shorter plan counts; such
    a plan is given up before a leg once its legs so far plus the fewest direct-motion commands
    through the goal states still to go reach the plan it would have to beat. Raises
    :class:`PlanningError` when a target cannot be reached clear of the obstacles, and
    :class:`UnreachableError` naming every target out of reach, each with the nearest point
    the arm reaches.
    ``orders_not_planned`` of the result says, for each ranked order that has no planned command
    count, why. ``orientations``: a tool orientation rule per target (None: the tool point
    only). ``bound``: prove the lower bound over every order and goal configuration
    (:func:`~armpath.planning.bounds.tour_bound`, its search holding up to ``bound_samples``
    live samples: more, a tighter bound, later; False: the result's ``lower_bound`` is None,
    the orders' bounds for their goal states are kept). ``pools``: without orientation rules,
    the orders whose shortest paths through clear members are shortest are planned once more
    through pools of goal states, each leg planned when a lazy shortest path over the pools
    needs it (:func:`~armpath.planning.tour_pool.pooled_tour`; at most
    :data:`~armpath.planning.tour_pool.POOL_LEG_PLANS` leg plans), and the plan counts when it
    needs fewer commands.
    """
    try:
        order = VisitOrder(order)
    except ValueError:
        valid = ", ".join(o.value for o in VisitOrder)
        raise InvalidInputError(f"order must be one of {valid}, got {order!r}") from None
    pts = np.asarray(targets_mm, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] == 0 or not np.all(np.isfinite(pts)):
        raise InvalidInputError(f"targets must be a list of finite (x, y, z) mm, got {pts.shape}")
    if orientations is not None and len(orientations) != pts.shape[0]:
        raise InvalidInputError(
            f"one orientation rule per target: got {len(orientations)} for {pts.shape[0]}"
        )
    if order == "auto" and pts.shape[0] > MAX_AUTO_ORDER_TARGETS:
        raise InvalidInputError(
            f"{pts.shape[0]} targets have {count_text(math.factorial(pts.shape[0]))} visiting "
            "orders; "
            f"order 'auto' ranks them all for at most {MAX_AUTO_ORDER_TARGETS} targets: use "
            "order 'given' (--order given) for more"
        )
    if pts.shape[0] > MAX_TOUR_TARGETS:
        raise InvalidInputError(
            f"a tour visits at most {MAX_TOUR_TARGETS} targets, got {pts.shape[0]}"
        )
    check_point_tolerance(tolerance_mm)
    check_max_samples(bound_samples)
    if not 1 <= orders_to_plan <= 100:
        raise InvalidInputError(f"orders to plan must be in [1, 100], got {orders_to_plan}")
    _warn_of_twins(pts, orientations, tolerance_mm)
    start = np.asarray(start_ticks, dtype=np.int64)
    check_state_clear(arm, world, arm.lattice.to_joint(start))  # before the goal states
    say = on_progress or (lambda _msg: None)
    opts = options or MotionOptions()
    goals: list[IntArray] = []
    failed: list[tuple[int, UnreachableError]] = []  # every target out of reach, said at once
    for i, p in enumerate(pts):
        say(f"goal states for target {i + 1} ({', '.join(f'{v:.2f}' for v in p)}) mm")
        try:
            rule = None if orientations is None else orientations[i]
            g, _ = goal_states(
                arm, world, start, p, tolerance_mm, goals_per_target, orientation=rule
            )
        except UnreachableError as exc:  # each its own nearest point: name them all
            failed.append((i, exc))
            continue
        except ArmpathError as exc:  # what the arm, tool or scene lacks: the first says it
            raise type(exc)(f"target {i + 1}: {exc}") from None
        goals.append(g)
    if failed:
        raise UnreachableError("; ".join(f"target {i + 1}: {exc}" for i, exc in failed))
    orders = (
        [tuple(range(len(pts)))]
        if order == "given"
        else list(itertools.permutations(range(len(pts))))
    )
    say(f"ranking {len(orders):,} visiting order(s) by their lower bounds")
    bounds = _order_bounds(start, goals, orders, return_to_start, arm.lattice)
    ranking = sorted(orders, key=lambda o: (bounds[o], o))
    fam = _targets_family(arm, world, pts) if pts.shape[0] <= MAX_BOUND_TARGETS else None
    family_bound, family_bounds, no_bound_because = _family_bounds(
        fam if bound else None, start, pts, ranking, return_to_start, tolerance_mm, say,
        bound_samples,
    )  # fmt: skip
    if not bound:
        no_bound_because = "not asked for"
    guided_orders = _guided_orders(orders, ranking, family_bound)
    q0 = arm.lattice.to_joint(start)
    guide_all = _tour_guide(fam, pts, tolerance_mm, orientations, say, arm.lattice.to_joint(start))
    guide = None if guide_all is None else guide_all.with_buffer(GUIDE_BUFFERS_MM[0])
    guide_paths: dict[tuple[int, ...], tuple[float, list[FloatArray]]] = {}
    if guide is not None:
        for o in guided_orders:
            found = guide.path(q0, o, return_to_start)
            if found is not None:
                guide_paths[o] = found
    plan_first = orders_to_plan
    guided_best = None  # planned whatever its bound for the goal states
    if guide_paths:  # the order whose guided path is shortest is planned too
        shortest = min(guide_paths, key=lambda o: (guide_paths[o][0], o))
        if shortest not in ranking[:orders_to_plan]:
            ranking.remove(shortest)
            ranking.insert(orders_to_plan, shortest)
            plan_first += 1
        guided_best = shortest

    def legs_of(
        o: tuple[int, ...],
        name: str,
        first: list[IntArray] | None,
        opts: MotionOptions = opts,
        ceiling: int | None = None,
    ) -> list[MotionPlan]:
        """The legs of order ``o``: to the goal states ``first`` of each target where given
        and reachable, else to the target's goal states. With a ``ceiling`` (commands), the
        order is abandoned (:class:`_AbandonedError`) before a leg once the legs so far plus the
        fewest direct-motion commands through the goal states still to go reach it."""
        legs: list[MotionPlan] = []
        state = start
        # the goal states each leg may go to, by target (what the bound below counts)
        ahead = list(goals)
        if first is not None:
            for k, t in enumerate(o):
                ahead[t] = np.vstack([first[k], goals[t]])
        for i, t in enumerate(o):
            if ceiling is not None:
                rest = _order_bounds(state, ahead, [o[i:]], return_to_start, arm.lattice)[o[i:]]
                if _commands(legs) + rest >= ceiling:
                    raise _AbandonedError(_commands(legs) + rest)
            leg = None
            if first is not None:
                # the goal state nearest the guide's member first: a motion to the set takes
                # the one nearest here, which can undo what the guide chose for the next legs
                for chosen in (first[i][:1], first[i][1:]):
                    if chosen.shape[0] == 0:
                        continue
                    try:
                        leg = plan_motion(
                            arm, world, state, chosen, opts, turn_copies=True, certified_merge=False
                        )
                        break
                    except PlanningError:
                        leg = None
            if leg is None:
                try:
                    leg = plan_motion(
                        arm, world, state, goals[t], opts, turn_copies=True, certified_merge=False
                    )
                except PlanningError:
                    # the goal states nearest the start may lie on other branches than where
                    # the arm is now: take the target's goal states nearest here and try again
                    say(f"planning order {name}: goal states of target {t + 1} from here")
                    rule = None if orientations is None else orientations[t]
                    near, _ = goal_states(
                        arm, world, state, pts[t], tolerance_mm, goals_per_target,
                        orientation=rule,
                    )  # fmt: skip
                    leg = plan_motion(
                        arm, world, state, near, opts, turn_copies=True, certified_merge=False
                    )
            legs.append(leg)
            state = leg.sequence.final_ticks
        if return_to_start:
            say(f"planning order {name}: back to the start")
            legs.append(plan_motion(arm, world, state, start[None, :], opts, certified_merge=False))
        return legs

    def plan_order(
        o: tuple[int, ...], name: str, opts: MotionOptions = opts
    ) -> tuple[list[MotionPlan], list[IntArray] | None, str | None]:
        """The shorter of order ``o``'s plan to each target's goal states and its plan through
        the goal states chosen together: the legs ([] when neither was planned), the guided
        goal states when those legs go through them, and why the first plan failed."""
        failure = None
        try:
            legs = legs_of(o, name, None, opts)
        except PlanningError as exc:
            legs, failure = [], str(exc)
        guided = _guided_goals(guide, q0, o, return_to_start, guide_paths)
        if guided is not None:
            say(f"planning order {name} through the goal states chosen together")
            try:
                other = legs_of(o, name, guided, opts, _commands(legs) if legs else None)
            except (PlanningError, _AbandonedError):
                other = []
            if other and (not legs or _commands(other) < _commands(legs)):
                return other, guided, failure
        return legs, None, failure

    def count_guided(o: tuple[int, ...], guided: list[IntArray]) -> None:
        """The bound of order ``o`` over its goal states with the guided ones among them."""
        with_guided = list(goals)
        for i, t in enumerate(o):
            with_guided[t] = np.vstack([guided[i], goals[t]])
        bounds[o] = _order_bounds(start, with_guided, [o], return_to_start, arm.lattice)[o]

    best: tuple[int, list[MotionPlan], tuple[int, ...]] | None = None
    planned: dict[tuple[int, ...], int] = {}
    #: every tour planned, for an objective other than commands (see :func:`_least_in`)
    tours: list[tuple[list[MotionPlan], tuple[int, ...]]] = []
    not_planned: dict[tuple[int, ...], str] = {}

    def kept(
        o: tuple[int, ...],
        legs: list[MotionPlan],
        through: list[IntArray],
        best: tuple[int, list[MotionPlan], tuple[int, ...]] | None,
    ) -> tuple[int, list[MotionPlan], tuple[int, ...]] | None:
        """Order ``o`` planned in ``legs`` through the goal states ``through`` (one array
        per target in order) counted: the best plan, ``best`` or this one if it needs fewer
        commands (its order's bound then counts those goal states)."""
        total = _commands(legs)
        planned[o] = min(planned.get(o, total), total)
        tours.append((legs, o))
        not_planned.pop(o, None)
        if best is not None and total >= best[0]:
            return best
        count_guided(o, through)
        return total, legs, o

    failures: list[str] = []
    # the best-ranked orders, then every next one whose bound is below the best plan so far
    # (at most EXTRA_ORDERS more): the ranking is by bound, so the first that is not ends it
    # (for another objective, the plan_first best-ranked orders whatever their bounds: a tour
    # of more commands may move less)
    by_commands = opts.objective is Objective.COMMANDS
    tried = 0
    for o in ranking[: plan_first + EXTRA_ORDERS]:
        if tried >= plan_first and (not by_commands or best is None or bounds[o] >= best[0]):
            break
        tried += 1
        name = "-".join(str(i + 1) for i in o)
        if by_commands and best is not None and bounds[o] >= best[0] and o != guided_best:
            not_planned[o] = (
                f"not planned: its bound over its candidate goal states, {bounds[o]}, is no "
                f"fewer than the {best[0]} commands planned for order "
                f"{'-'.join(str(i + 1) for i in best[2])}"
            )
            continue
        say(
            f"planning order {name} (at least {bounds[o]} commands through its candidate goal "
            "states)"
        )
        legs, through, failure = plan_order(o, name)
        if failure is not None:
            failures.append(f"order {name}: {failure}")
            not_planned[o] = f"planning failed: {failure}"
        if through is not None:
            count_guided(o, through)
        if not legs:
            continue
        not_planned.pop(o, None)
        total = _commands(legs)
        planned[o] = total
        tours.append((legs, o))
        if best is None or total < best[0]:
            best = (total, legs, o)
    # goal states chosen together at every buffer: members nearer the obstacles can lie nearer
    # each other (the seed's Task 3: 141 commands with 1.5 mm, 133 with 0.5 mm)
    if guide_all is not None:
        for buffer in GUIDE_BUFFERS_MM:
            first = buffer == GUIDE_BUFFERS_MM[0]
            if first and guide is not None:  # the guide above: its paths are found already
                buffered, paths = guide, guide_paths
            else:
                buffered = guide_all.with_buffer(buffer)
                paths = {}
                for o in guided_orders:
                    found = buffered.path(q0, o, return_to_start)
                    if found is not None:
                        paths[o] = found
            for o in sorted(paths, key=lambda o: (paths[o][0], o))[:GUIDED_ORDERS]:
                if (first and o in planned) or (best is not None and paths[o][0] >= best[0]):
                    continue  # planned so already, or its members are too far apart to beat it
                for nearest in GUIDED_NEAREST:
                    guided = buffered.goal_states(q0, o, paths[o][1], nearest)
                    if guided is None:
                        continue
                    name = "-".join(str(i + 1) for i in o)
                    kind = "nearest its members" if nearest else "most accurate"
                    say(
                        f"planning order {name} through goal states keeping {buffer:g} mm "
                        f"more ({kind})"
                    )
                    best_so_far = None if best is None else best[0]
                    try:
                        legs = legs_of(o, name, guided, ceiling=best_so_far)
                    except _AbandonedError as exc:
                        # a bound through these goal states alone, not the order's
                        say(
                            f"gave up order {name} through these goal states: at least "
                            f"{exc.commands} commands through them, the best plan so far "
                            f"{best_so_far}"
                        )
                        continue
                    except PlanningError:
                        continue
                    best = kept(o, legs, guided, best)
    # the path through clear members that the bound's search found, where it is cheaper than
    # the best plan: through every lattice goal state within a command of its members, the
    # cheapest combination first (six welds in free space: its path 73, the plans above 74;
    # the lattice states next to its members that the guide's listing finds, 75 at best)
    path = _bound_clear_path(family_bound)
    if guide_all is not None and path is not None and (best is None or path[0] < best[0]):
        _, o, members = path
        name = "-".join(str(i + 1) for i in o)
        say(f"planning order {name} through the bound's path through clear members")
        near = guide_all.states_near(start, o, members, return_to_start)
        if near is not None:
            try:
                along = legs_of(o, name, near, ceiling=None if best is None else best[0])
                best = kept(o, along, near, best)
            except (_AbandonedError, PlanningError):
                pass  # the plans above stand
    # many goal states per target kept open until the legs between them are planned
    # (:mod:`~armpath.planning.tour_pool`): the seed's Task 3 127 -> 122 commands
    if pools and guide_all is not None and fam is not None:
        say("sampling the goal states' pools at every target")
        try:
            pooled = pooled_tour(
                pool_guide(fam, pts, tolerance_mm, q0),
                start,
                guided_orders,
                return_to_start,
                opts,
                ceiling=np.inf if best is None else best[0],
                say=say,
            )
        except PlanningError:  # no member at some target: the plans above stand
            pooled = None
        if pooled is not None and pooled.order is not None and pooled.legs is not None:
            reached = pooled.legs[: len(pooled.order)]
            through = [leg.sequence.final_ticks[None, :] for leg in reached]
            best = kept(pooled.order, pooled.legs, through, best)
    if best is None:
        raise PlanningError("no order could be planned: " + "; ".join(failures))
    if best[0] > SECOND_LOOK_RATIO * bounds[best[2]] and opts.searches < SECOND_LOOK_SEARCHES:
        # far above what direct motions between its goal states need: the searched legs
        # detour; more searches per leg (the best kept) find shorter ways round
        o = best[2]
        name = "-".join(str(i + 1) for i in o)
        say(f"planning order {name} again, {SECOND_LOOK_SEARCHES} searches per leg")
        again, through, _ = plan_order(o, name, replace(opts, searches=SECOND_LOOK_SEARCHES))
        if again:
            tours.append((again, o))
        if again and _commands(again) < best[0]:
            best = (_commands(again), again, o)
            planned[o] = best[0]
            if through is not None:
                count_guided(o, through)
    _, legs, chosen = best
    if opts.objective is not Objective.COMMANDS:
        legs, chosen = _least_in(arm, start, tours, opts)
        planned[chosen] = _commands(legs)  # the plan kept for its order, not its fewest
    if opts.objective is Objective.COMMANDS:
        # the kept legs only: a certified merge costs about a quarter second, placing a
        # leg's states up to a few seconds
        say("merging the legs' commands where a certified straight motion needs fewer")
        legs = [merged_certified(arm, world, leg, opts.energy_weights) for leg in legs]
        planned[chosen] = _commands(legs)
    # the orders not planned, each with why (against the tour kept, its legs merged)
    final = _commands(legs)
    for o in ranking[tried : tried + LISTED_ORDERS]:
        if o in planned:  # planned through the goal states chosen together
            continue
        why = (
            f"not planned: the {orders_to_plan} best-ranked order(s) and the one whose "
            "guided path is shortest are planned, then those "
            f"whose bound is below the best plan (at most {EXTRA_ORDERS} more) and the "
            f"{GUIDED_ORDERS} whose guided paths are shortest at each room kept"
        )
        if bounds[o] >= final:
            why += f"; its bound {bounds[o]} cannot beat the {final} commands planned"
        else:
            why += f"; its bound {bounds[o]} is below the {final} commands planned"
        not_planned[o] = why
    commands = np.vstack([leg.sequence.commands for leg in legs])
    sequence = CommandSequence(start, commands, arm.lattice)
    visits = []
    k = 0
    for t, leg in zip(chosen, legs, strict=False):
        k += leg.sequence.n_commands
        tip = tool_position(arm, arm.lattice.to_joint(leg.sequence.final_ticks))
        visits.append(
            Visit(t, tuple(float(v) for v in pts[t]), k, float(np.linalg.norm(tip - pts[t])))  # type: ignore[arg-type]
        )
    say("certifying the whole tour's continuous motion")
    clearance = plan_clearance(arm, world, sequence)
    if not clearance.certified_ok:
        raise PlanningError(
            f"tour failed its final clearance check ({clearance.limiting_pair} "
            f"{clearance.limiting_slack:+.3f} mm at command {clearance.limiting_command})"
        )
    if family_bound is not None:
        family_bound = family_bound.against_plan(sequence.n_commands)
    reported = family_bound
    if bound:  # an arm on a track: its carriage's travel, proven (and cheap) for any order
        carriage = points_travel_bound(
            arm, pts, arm.lattice.to_joint(start), tolerance_mm, "weld", return_to_start
        )
        reported = with_carriage(family_bound, carriage, float(sequence.n_commands))
        if reported is not None:
            no_bound_because = None
    return TourResult(
        sequence=sequence,
        order=chosen,
        visits=tuple(visits),
        legs=tuple(legs),
        returns_to_start=return_to_start,
        clearance=clearance,
        metrics=plan_metrics(arm, sequence, opts.energy_weights),
        order_lower_bounds=bounds,
        orders_planned=planned,
        tolerance_mm=tolerance_mm,
        orders_not_planned=not_planned,
        lower_bound=reported,
        order_family_bounds=family_bounds,
        no_bound_because=no_bound_because,
        orientations=None if orientations is None else tuple(orientations),
    )


#: Most targets whose every order gets its own bound over the whole family (4! = 24 orders).
EXACT_ORDER_TARGETS = 4
#: Targets up to which the bound searches every order at once (a programme over the sets of
#: targets visited, :class:`~armpath.planning.bounds.search.Subsets`, no order's own bound:
#: over the lattice goal states where they can be listed and measured, else over the family's
#: samples); more, up to :data:`~armpath.planning.bounds.tour.MAX_LATTICE_TARGETS`, over the
#: lattice goal states alone where they can be
#: (:func:`~armpath.planning.bounds.tour_bound_over_lattice`), else the cheaper bound of
#: :func:`~armpath.planning.bounds.tour_bound_any_order`. Welds of the seed arm in free space:
#: six and seven proven at their plans' 73 and 79 commands over their lattice goal states (68
#: after three rounds of the family's samples); eight at 86, which their plan then meets (92
#: against the cheaper bound's 57 in 38 s), where the family's samples would take 162 s and
#: 0.75 GB for 74.
SUBSET_TARGETS = 7
#: Most targets of a tour whose bound over the family is computed.
MAX_BOUND_TARGETS = 24


def _targets_family(arm: SerialArm, world: CollisionWorld, pts: FloatArray) -> CurveFamily:
    """The solution family of the tool point at the targets (a polyline through them)."""
    vertices = [pts[0]]
    for p in pts[1:]:
        if np.any(p != vertices[-1]):
            vertices.append(p)
    if len(vertices) == 1:  # the family needs a curve; any second point will do
        vertices.append(vertices[0] + np.array([1.0, 0.0, 0.0]))
    return curve_family(arm, world, Polyline("targets", np.array(vertices)))


#: Most visiting orders whose guided paths and pools are compared (4! = 24): of more (five
#: targets or more), those of :func:`_guided_orders`.
MAX_GUIDED_ORDERS = 24
#: The room (mm) beyond the margin that the members of a guided path keep: the first for the
#: planned orders' second plan, each for the :data:`GUIDED_ORDERS` orders whose guided paths
#: are shortest (their lattice goal states keep :data:`GOAL_BODY_BUFFER_MM` all the same). The
#: UR5 cell's welds: 131 commands with 1.5 and 0.5 mm, 119 with 0.2 mm too (0.1 and 0.05 mm
#: more: 119; the seed's Task 3 135 with any of these; measured before :data:`GUIDED_NEAREST`).
GUIDE_BUFFERS_MM = (GOAL_BODY_BUFFER_MM, 0.5, 0.2)
#: Orders planned through their guided goal states at each buffer.
GUIDED_ORDERS = 4
#: Those orders are planned through the lattice goal states nearest the guide's members, then
#: through the most accurate ones next to them (:meth:`TourGuide.goal_states`): neither wins
#: everywhere (seed Task 3: 127 commands with the nearest, 134 with the most accurate; the UR5
#: cell's welds 122 and 118; both: 127 and 118, in about 25 % more time).
GUIDED_NEAREST = (True, False)


def _commands(legs: list[MotionPlan]) -> int:
    return sum(leg.sequence.n_commands for leg in legs)


def _tour_guide(
    fam: CurveFamily | None,
    pts: FloatArray,
    tolerance_mm: float,
    orientations: Sequence[Orientation | None] | None,
    say: Callable[[str], None],
    q_start: FloatArray,
) -> TourGuide | None:
    """Clear family members at every target (:class:`TourGuide`); None without a family or
    with a tool orientation rule (the guide samples every tool direction)."""
    if fam is None or (orientations is not None and any(o is not None for o in orientations)):
        return None
    say("sampling clear configurations at every target")
    try:
        return TourGuide.build(fam, pts, tolerance_mm, min(GUIDE_BUFFERS_MM), q_start)
    except PlanningError:
        return None


def _guided_orders(
    orders: list[tuple[int, ...]],
    ranking: list[tuple[int, ...]],
    family_bound: CommandBound | None,
) -> list[tuple[int, ...]]:
    """The orders the guide and the pools compare: every order up to
    :data:`MAX_GUIDED_ORDERS`; of more, the order of the family bound's path (the relaxation's
    best, where the bound found one) and the best ranked after it, that many in all."""
    if len(orders) <= MAX_GUIDED_ORDERS:
        return orders
    first = None if family_bound is None else family_bound.guide_order
    chosen = [] if first is None else [first]
    chosen += [o for o in ranking if o != first][: MAX_GUIDED_ORDERS - len(chosen)]
    return chosen


def _guided_goals(
    guide: TourGuide | None,
    q0: FloatArray,
    order: tuple[int, ...],
    back: bool,
    paths: dict[tuple[int, ...], tuple[float, list[FloatArray]]],
) -> list[IntArray] | None:
    """Lattice goal states along the guided path of ``order`` (found already in ``paths``),
    one array per target in order; None without one."""
    if guide is None:
        return None
    found = paths.get(order) or guide.path(q0, order, back)
    if found is None:
        return None
    return guide.goal_states(q0, order, found[1])


def _bound_clear_path(
    bound: CommandBound | None,
) -> tuple[float, tuple[int, ...], list[FloatArray]] | None:
    """The cheapest path through clear members that a tour bound's search found: its
    commands, its order and its members (rad, one per target in that order); None without
    one."""
    if bound is None or bound.clear_path_q is None or bound.clear_path_order is None:
        return None
    commands = bound.sampling.get("clear_path_commands", np.inf)
    return commands, bound.clear_path_order, list(bound.clear_path_q)


def _family_bounds(
    fam: CurveFamily | None,
    start: IntArray,
    pts: FloatArray,
    orders: list[tuple[int, ...]],
    back: bool,
    tolerance_mm: float,
    say: Callable[[str], None],
    max_samples: int | None = None,
) -> tuple[CommandBound | None, dict[tuple[int, ...], int], str | None]:
    """The bound over every goal configuration: per order for a given order or up to
    :data:`EXACT_ORDER_TARGETS` targets, every order at once up to :data:`SUBSET_TARGETS`
    (and up to :data:`~armpath.planning.bounds.tour.MAX_LATTICE_TARGETS` over the lattice
    goal states where they can be listed and measured), else the cheaper bound; each order's
    bound where computed; and why there is none: without
    a family (beyond :data:`MAX_BOUND_TARGETS` targets) or where a target has no member within
    the limits."""
    if fam is None:
        return (
            None,
            {},
            f"the bound over every goal configuration takes at most {MAX_BOUND_TARGETS} "
            f"welds, this tour has {pts.shape[0]}",
        )
    q0 = fam.arm.lattice.to_joint(start)
    say("bounding the tour's commands over every goal configuration")
    try:
        if len(orders) == 1 or pts.shape[0] <= EXACT_ORDER_TARGETS:
            found, per_order = tour_bound(
                fam,
                q0,
                pts,
                tolerance_mm,
                orders,
                back,
                on_progress=say,
                max_samples=max_samples,
                lattice=True,
            )
        elif pts.shape[0] <= SUBSET_TARGETS:
            found, per_order = tour_bound(
                fam, q0, pts, tolerance_mm, None, back, on_progress=say, max_samples=max_samples,
                lattice=True,
            )  # fmt: skip
        else:
            found = None
            if pts.shape[0] <= MAX_LATTICE_TARGETS:
                found = tour_bound_over_lattice(fam, q0, pts, tolerance_mm, back, on_progress=say)
            if found is None:
                found = tour_bound_any_order(fam, q0, pts, tolerance_mm, back, on_progress=say)
            per_order = {}
    except PlanningError as exc:
        return None, {}, str(exc)
    return found, per_order, None
