"""The lower bound of a tour's commands (see the package)."""

from __future__ import annotations

import contextvars
import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import PlanningError
from armpath.kinematics import landmark_positions
from armpath.planning.bounds.lattice_goals import lattice_goal_states
from armpath.planning.bounds.passage import (
    PassageSamples,
    passage_method,
    passage_sampling,
    sampled_passages,
)
from armpath.planning.bounds.sampling import FamilySampler, Layer
from armpath.planning.bounds.search import CellSearch, Orders, OutOfPairsError, Subsets
from armpath.planning.bounds.value import CommandBound
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Times the directions about samples kept only for what their neighbours allow (not clear
#: themselves) are split at every target before the search, twice as fine each time (seed
#: Task 3, measured before the legs into the workpiece went through its opening: with none the
#: search's budget ends at 93 commands, with one at 103).
TOUR_CLEAR_LEVELS = 1


def tour_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    targets: FloatArray,
    tolerance_mm: float,
    orders: list[tuple[int, ...]] | None,
    back: bool = False,
    rounds: int | None = None,
    on_progress: Callable[[str], None] | None = None,
    clear_levels: int = TOUR_CLEAR_LEVELS,
    max_samples: int | None = None,
    with_errors: bool = True,
    through_openings: bool = True,
    lattice: bool = False,
) -> tuple[CommandBound, dict[tuple[int, ...], int]]:
    """Fewest commands of a tour from ``q_start`` (rad) through ``targets`` ``(K, 3)`` (model
    units) within ``tolerance_mm``: over ``orders`` (None: every order, solved at once by a
    programme over the sets of targets visited,
    :class:`~armpath.planning.bounds.search.Subsets`; no order's own bound then, and the
    bound's ``guide_order`` is its best order), a shortest path through the family at each
    target (every goal configuration that may be clear, its cells split ``clear_levels`` times
    where unsure; obstacles ignored between targets), each leg a whole number of commands;
    ``back`` returns to the start. The family is searched by branch and bound for ``rounds``
    rounds at most (None: as many as the budget allows,
    :func:`~armpath.planning.bounds.search.search_rounds`) and until it holds ``max_samples``
    live samples
    (:class:`~armpath.planning.bounds.search.CellSearch`). Returns the least over the orders
    and each order's bound (:attr:`CellSearch.per_order`). ``with_errors=False`` (a
    diagnostic, not a bound): the samples' sampling errors are left out, which gives the
    shortest path through the samples themselves, what the bound tends to as the sampling gets
    finer. ``through_openings``: a leg from the start to a target inside a hollow obstacle
    takes at least its way through one of the obstacle's openings
    (:mod:`~armpath.planning.bounds.passage`); False: the direct leg only. ``lattice``: first
    the exact relaxation over the targets' lattice goal states (:func:`lattice_tour_bound`),
    never below the sampled one, for at most :data:`MAX_LATTICE_TARGETS` targets; the family is
    sampled where there are more or their states cannot be listed or measured, and where its
    samples then give no proven bound, the lattice states are measured within
    :data:`MAX_LATTICE_PAIRS_UNPROVEN` pairs after all."""
    say = on_progress or (lambda _m: None)
    say("bounding the tour's commands")
    sampler = FamilySampler(fam, tolerance_mm, q_start=q_start)
    points = np.asarray(targets, dtype=np.float64)
    ways = sampled_passages(sampler, q_start, points, with_errors, through_openings, say)
    layers = None
    if lattice and with_errors and len(points) <= MAX_LATTICE_TARGETS:
        multiplicity = None if orders is None else leg_multiplicity(len(points), orders)
        layers = _goal_layers(
            sampler, q_start, points, say, multiplicity, _pair_budget(orders, True)
        )
        if layers is not None:
            exact = lattice_tour_bound(
                sampler, q_start, points, orders, back, ways, say, layers=layers
            )
            if exact is not None:
                return exact
    search = CellSearch(
        sampler,
        Subsets(back) if orders is None else Orders(orders, back),
        list(points),
        [None] * targets.shape[0],
        q_start,
        levels=clear_levels,
        max_samples=max_samples,
        with_errors=with_errors,
        passages=ways,
    )
    found = search.run(rounds, say)
    if found is None:
        raise PlanningError("a target has no family member within the joint limits")
    bound = CommandBound(
        unproven_because=sampler.unproven_because(with_errors),
        commands=int(np.ceil(found.value - 1e-9)),
        value=found.value,
        method=(
            _over_orders(orders, targets.shape[0], back)
            + " of a shortest path from the start through the "
            "solution family at each target (every goal configuration within the tolerance "
            "that may be clear; obstacles ignored between the targets, but not a joint's own "
            "self-collision ranges; tool directions sampled, each distance less the samples' "
            "sampling errors, and searched by branch and bound: cells that cannot hold a path "
            "shorter than one through clear members dropped, the others split where their "
            "error or clearance is unsure), each leg rounded up to whole commands"
            + passage_method(ways, "a leg from the start")
            + ("" if with_errors else "; WITHOUT the sampling errors: an estimate, not a bound")
        ),
        sampling={
            "orders": float(math.factorial(targets.shape[0]) if orders is None else len(orders)),
            "rounds": float(found.rounds),
            "samples": float(found.samples),
            "directions": float(found.directions),
            "largest_error_on_path_commands": found.largest_error,
        }
        | ({"clear_path_commands": found.clear_path} if np.isfinite(found.clear_path) else {})
        | passage_sampling(ways),
        guide_q=found.bound_q[list(found.order)],
        guide_order=tuple(found.order) if orders is None else None,
        clear_path_q=None if found.clear_q is None else found.clear_q[list(found.clear_order)],
        clear_path_order=None if found.clear_q is None else tuple(found.clear_order),
    )
    if layers is not None and not bound.proven:
        # the samples do not cover the family: the lattice states, listed above, give a proven
        # bound if their legs can be measured within a larger budget
        say(f"the sampled bound is not proven: {bound.unproven_because}")
        exact = lattice_tour_bound(
            sampler, q_start, points, orders, back, ways, say, layers=layers,
            max_pairs=_pair_budget(orders, True),
        )  # fmt: skip
        if exact is not None:
            return exact
    return bound, search.per_order


def _over_orders(orders: list[tuple[int, ...]] | None, targets: int, back: bool) -> str:
    """How a tour bound's method names the orders it is over (None: every order at once;
    one: the order given, which ``--order given`` bounds alone) and the way back."""
    if orders is None:
        words = "least over every visiting order (a dynamic programme over the sets of targets "
        words += "visited)"
    elif len(orders) == 1:
        words = "the visiting order " + "-".join(str(k + 1) for k in orders[0]) + " alone"
    elif len(orders) == math.factorial(targets):
        words = "least over every visiting order"
    else:
        words = f"least over {len(orders)} of the {math.factorial(targets):,} visiting orders"
    return words + (", back to the start," if back else "")


def tour_bound_over_lattice(
    fam: CurveFamily,
    q_start: FloatArray,
    targets: FloatArray,
    tolerance_mm: float,
    back: bool = False,
    on_progress: Callable[[str], None] | None = None,
    through_openings: bool = True,
) -> CommandBound | None:
    """:func:`tour_bound` over every order at once on the targets' lattice goal states alone
    (:func:`lattice_tour_bound`), for more targets than the family's samples bound every order
    at once in reasonable time: None where the states cannot be listed or their legs measured
    within the budgets (the caller takes the cheaper bound then,
    :func:`tour_bound_any_order`). Eight welds of the seed arm in free space: 1,033,096 states,
    86 commands in about 75 s, which their plan meets (the cheaper bound: 57)."""
    say = on_progress or (lambda _m: None)
    say("bounding the tour's commands over its lattice goal states")
    sampler = FamilySampler(fam, tolerance_mm, q_start=q_start)
    points = np.asarray(targets, dtype=np.float64)
    layers = _goal_layers(sampler, q_start, points, say)
    if layers is None:  # not listed: the openings' ways would be of no use
        return None
    ways = sampled_passages(sampler, q_start, points, True, through_openings, say)
    found = lattice_tour_bound(sampler, q_start, points, None, back, ways, say, layers=layers)
    return None if found is None else found[0]


def tour_bound_any_order(
    fam: CurveFamily,
    q_start: FloatArray,
    targets: FloatArray,
    tolerance_mm: float,
    back: bool = False,
    on_progress: Callable[[str], None] | None = None,
    clear_levels: int = TOUR_CLEAR_LEVELS,
    through_openings: bool = True,
) -> CommandBound:
    """A cheaper bound of the best order for many targets: every target is entered once, the
    first from the start and each other from another target, so the commands are at least
    the least over the first target of its leg from the start plus, for every other target,
    the shortest leg into it from another target (each family sampled once, each distance
    less the samples' sampling errors, whole commands each), plus the shortest way back with
    ``back``; a leg from the start into a hollow obstacle at least its way through an opening
    (``through_openings``, as :func:`tour_bound`)."""
    say = on_progress or (lambda _m: None)
    say(f"bounding the tour's commands ({targets.shape[0]} targets, any order)")
    # many targets, each sampled once: finding each one's singular directions would cost more
    # (a second or two a target) than its layer
    sampler = FamilySampler(fam, tolerance_mm, q_start=q_start, blow_ups=False)
    layers = []
    for p in targets:
        check_time("bounding the commands")
        layers.append(sampler.layer(p, sampler.base, levels=clear_levels))
    if any(lay.size == 0 for lay in layers):
        raise PlanningError("a target has no family member within the joint limits")
    points = np.asarray(targets, dtype=np.float64)
    sampler.audit_sites(list(points), layers)
    ways = sampled_passages(sampler, q_start, points, through_openings=through_openings)
    from_start = _from_start(sampler, q_start, points, layers, ways)
    # the way back is a leg between the start and a target too (through an opening if it
    # must be)
    total = _entered_once(sampler, layers, from_start, from_start if back else None)
    return CommandBound(
        unproven_because=sampler.unproven_because(),
        commands=int(np.ceil(total - 1e-9)),
        value=total,
        method=(
            "every target entered once: the least over the first target of its leg from the "
            "start plus, for every other target, the shortest leg into its solution family "
            "from another target (every goal configuration within the tolerance that may be "
            "clear; obstacles ignored between the targets, but not a joint's own self-collision "
            "ranges; whole commands, each distance less the samples' sampling errors)"
            + ("; plus the shortest way back" if back else "")
            + passage_method(ways, "a leg from the start")
        ),
        sampling={
            "targets": float(targets.shape[0]),
            "samples": float(sum(lay.size for lay in layers)),
        }
        | passage_sampling(ways),
    )


def _entered_once(
    sampler: FamilySampler,
    layers: list[Layer],
    from_start: list[FloatArray],
    back: list[FloatArray] | None,
) -> float:
    """At least the least over the first target of its leg from the start plus, for every other
    target, the shortest leg into it from another target (plus the shortest way back with
    ``back``): every target is entered once, only the first from the start."""
    into = []
    for t, lay in enumerate(layers):
        others = [other for s, other in enumerate(layers) if s != t]
        if not others:
            into.append(np.inf)  # a lone target is entered from the start only
            continue
        check_time("bounding the tour's commands")
        joined = Layer.joined(others)
        cost, _ = sampler.advance(joined, np.zeros(joined.size), lay, whole=True)
        into.append(float(cost.min()))
    total = min(
        float(from_start[t].min()) + sum(c for s, c in enumerate(into) if s != t)
        for t in range(len(layers))
    )
    if back is not None:
        total += min(float(c.min()) for c in back)
    return total


def _from_start(
    sampler: FamilySampler,
    q_start: FloatArray,
    points: FloatArray,
    layers: list[Layer],
    ways: list[PassageSamples],
) -> list[FloatArray]:
    """Per target, the whole commands from ``q_start`` to each sample of its layer: the direct
    distance, or into a hollow obstacle at least the way through one of its openings."""
    entered = [w.passage.entered(points, sampler.tol) for w in ways]
    out = []
    for k, lay in enumerate(layers):
        cost = sampler.distance_from(q_start, lay, whole=True)
        for way, into in zip(ways, entered, strict=True):
            if into[k]:
                cost = np.maximum(cost, way.to(sampler, lay, whole=True))
        out.append(cost)
    return out


#: Lattice states of all the targets together past which :func:`lattice_tour_bound` gives way
#: to the family's sampled members (about 150 bytes each, and every order at once keeps a cost,
#: 8 bytes, per state for each set of the other targets before it where one is finite, and
#: where it came from, 5 bytes; the pairs of states its legs measure are capped apart). Welds
#: of the seed arm in free space: two, 257,052 states, listed in 17 s, 1.6e10 pairs; five,
#: 640,796; eight, 1,033,096, 0.7 GB at most in all.
MAX_LATTICE_GOALS = 1_500_000
#: Pairs of states the legs of :func:`lattice_tour_bound` may measure, over every prefix of the
#: orders (about 2.5e9 a second on two cores): past it, the family's sampled members instead.
#: Seed Task 3: 9.7e9 pairs, 4 s.
MAX_LATTICE_PAIRS = 40_000_000_000
#: The same where the family's samples give no proven bound (an audit found members outside
#: them, :meth:`FamilySampler.audit`): the lattice's is then the only proof. Three welds of a
#: five-joint SO-101 on a desk: 5.5e10 pairs, about 30 s.
MAX_LATTICE_PAIRS_UNPROVEN = 200_000_000_000
#: Pairs of states every order at once (:func:`lattice_tour_bound` with no orders) may offer
#: its legs' steps, as it goes (:class:`~armpath.planning.bounds.search.Subsets`' ``max_pairs``):
#: its programme leaves out the partial paths that the costs still to go, from each state's
#: nearest states of the other targets, take above a rising cap, so it offers few. The seed arm
#: in free space (two cores): five welds, 640,796 states, 1.2e8 pairs, 1.3 s (69 commands, the
#: fewest; the whole bound 15 s); six, 7.1e8; seven, 880,568 states, 3.2e10 over six caps,
#: 24 s (79, the fewest); eight, 4.7e10 over six caps, 37 s (86, the fewest).
MAX_LATTICE_PAIRS_EVERY_ORDER = 100_000_000_000


def _pair_budget(orders: list[tuple[int, ...]] | None, unproven: bool) -> int:
    """The pairs of states :func:`lattice_tour_bound` may measure over ``orders`` (None: every
    order at once), ``unproven``: where the family's samples give no proven bound."""
    if orders is None:
        return MAX_LATTICE_PAIRS_EVERY_ORDER
    return MAX_LATTICE_PAIRS_UNPROVEN if unproven else MAX_LATTICE_PAIRS


#: Most targets whose lattice states are listed for the bound: each takes seconds (some 12 s
#: a weld of the seed arm in free space), so twelve welds in a given order spent 200 s listing
#: and 24 over 5 min; more are bounded over the family's sampled members.
MAX_LATTICE_TARGETS = 8
#: Targets whose lattice states are listed at once (threads; the listing's kernel releases the
#: GIL).
GOAL_THREADS = 2


def listing_ranges(
    sampler: FamilySampler, q_start: FloatArray
) -> tuple[IntArray, IntArray, IntArray] | None:
    """The ranges :func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states` lists a
    target's states over: the start's lattice state (the joints that do not move the tool point
    stay there) and the lowest and highest ticks of each joint in ``sampler.tip``. None where
    the states cannot be listed completely: a joint that does not move the tool point but moves
    the arm, a joint that turns whole turns where a turn is not a whole number of ticks, or an
    unlimited sliding joint."""
    fam = sampler.fam
    arm, grid = fam.arm, fam.arm.lattice
    tip = sampler.tip
    probe = np.array([q_start, q_start + np.where(tip, 0.0, 1.0)])
    moved = landmark_positions(arm, probe)
    if not np.allclose(moved[0], moved[1], atol=1e-9):
        return None
    # a revolute joint that can turn whole turns is listed over one turn from its lower limit:
    # the metric measures it the shorter way round, or on the start's side of its
    # self-collision range, whichever copy a plan takes (the copies are states of the lattice
    # when a turn is a whole number of ticks)
    tick = np.asarray(grid.tick, dtype=np.float64)[tip]
    turns = sampler.whole_turns
    turn = 2.0 * np.pi / tick
    if np.any(turns & (np.abs(turn - np.round(turn)) > 1e-6)):
        return None
    lower_limit, upper_limit = arm.lower[tip], arm.upper[tip]
    if np.any(~turns & ~(np.isfinite(lower_limit) & np.isfinite(upper_limit))):
        return None  # an unlimited sliding joint
    lower = np.ceil(np.where(np.isfinite(lower_limit), lower_limit, -np.pi) / tick - 1e-9)
    lower = lower.astype(np.int64)
    upper = np.where(
        turns,
        lower + np.round(turn).astype(np.int64) - 1,
        np.floor(np.where(turns, 0.0, upper_limit) / tick + 1e-9).astype(np.int64),
    )
    return grid.nearest_ticks(q_start), lower, upper


def leg_multiplicity(n: int, orders: list[tuple[int, ...]]) -> IntArray:
    """``(n, n)``: how many times the legs from each of ``n`` targets to each other are
    measured by :func:`lattice_tour_bound` over ``orders`` (once per distinct prefix of the
    orders ending in that pair). The pairs of states measured: ``sizes @ multiplicity @
    sizes``."""
    out = np.zeros((n, n), dtype=np.int64)
    for prefix in {order[:k] for order in orders for k in range(2, len(order) + 1)}:
        out[prefix[-2], prefix[-1]] += 1
    return out


def _goal_layers(
    sampler: FamilySampler,
    q_start: FloatArray,
    points: FloatArray,
    say: Callable[[str], None],
    multiplicity: IntArray | None = None,
    max_pairs: int | None = None,
) -> list[Layer] | None:
    """Per target, the lattice goal states that keep the clearance rule, as a layer taken
    exact (:func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states`); None where
    they cannot be listed completely (:func:`listing_ranges`) or a budget is spent: the
    listing stops as soon as the targets listed already have more than
    :data:`MAX_LATTICE_GOALS` states, or with ``multiplicity`` (:func:`leg_multiplicity`)
    more than ``max_pairs`` pairs of states to measure between them."""
    ranges = listing_ranges(sampler, q_start)
    if ranges is None:
        return None
    start, lower, upper = ranges
    fam = sampler.fam
    arm, world, grid = fam.arm, fam.world, fam.arm.lattice
    tip = sampler.tip

    failed: list[int] = []
    sizes = np.zeros(points.shape[0], dtype=np.int64)

    def too_many() -> bool:
        if sizes.sum() > MAX_LATTICE_GOALS:
            return True
        if multiplicity is None or max_pairs is None:
            return False
        return int(sizes @ multiplicity @ sizes) > max_pairs

    def listed(k: int) -> Layer | None:
        if failed or too_many():  # the bound samples instead
            return None
        say(f"listing the lattice states within the tolerance of target {k + 1}")
        found = lattice_goal_states(
            arm,
            points[k],
            sampler.tol,
            tip,
            start,
            lower,
            upper,
            may_be_clear=lambda q, moved: world.may_be_clear_within(arm, q, moved),
        )
        if not found.complete:
            failed.append(k)
            say(f"the lattice states of target {k + 1} are too many to list: sampling instead")
            return None
        q = grid.to_joint(found.ticks)
        q = q[world.satisfied(arm, q)] if q.shape[0] else q
        sizes[k] = q.shape[0]
        if too_many():
            failed.append(k)
            say("the lattice states or the legs between them are too many: sampling instead")
            return None
        u = sampler.units(q)
        clear = np.ones(q.shape[0], dtype=bool)
        return Layer(u, np.zeros_like(u), q, np.zeros((q.shape[0], 3)), clear=clear)

    check_time("bounding the tour's commands")
    # the enumeration's kernel releases the GIL: the targets are listed two at a time
    # (each in a copy of this context, so that the listing hears the caller's time limit)
    with ThreadPoolExecutor(max_workers=GOAL_THREADS) as pool:
        tasks = [
            pool.submit(contextvars.copy_context().run, listed, k) for k in range(points.shape[0])
        ]
        found = [task.result() for task in tasks]
    layers = [lay for lay in found if lay is not None]
    if len(layers) < len(found):  # a listing incomplete, or too many states or pairs
        return None
    return layers


def lattice_tour_bound(
    sampler: FamilySampler,
    q_start: FloatArray,
    points: FloatArray,
    orders: list[tuple[int, ...]] | None,
    back: bool,
    ways: list[PassageSamples],
    say: Callable[[str], None],
    *,
    layers: list[Layer] | None = None,
    max_pairs: int | None = None,
) -> tuple[CommandBound, dict[tuple[int, ...], int]] | None:
    """The tour's relaxation over its lattice goal states (``layers``, one per target, as
    :func:`_goal_layers` lists them; None: listed now): a plan ends each visit at a lattice
    state within the tolerance of the target that keeps the clearance rule, and each leg
    between two lattice states takes at least their largest joint change in whole commands
    (obstacles ignored between the targets; a leg from the start into a hollow obstacle, or
    with ``back`` the way back, at least its way through an opening, as the sampled bound).
    The states are listed completely (:func:`_goal_layers`), so the least over ``orders`` is
    exact for this relaxation: no sampling error. ``orders`` None: every order at once (Held
    and Karp's programme, :class:`~armpath.planning.bounds.search.Subsets`; no order's own
    bound then), and the optimal path's states are the bound's guide and its path through
    clear members (they are lattice states that keep the clearance rule). None where the
    states cannot be listed, or their legs would measure more than ``max_pairs`` pairs of
    states (None: :data:`MAX_LATTICE_PAIRS`, counted before by :func:`leg_multiplicity`;
    every order at once :data:`MAX_LATTICE_PAIRS_EVERY_ORDER`, counted as its programme
    offers them); the caller then samples the family."""
    if layers is None:
        layers = _goal_layers(sampler, q_start, points, say)
    if layers is None:
        return None
    if any(lay.size == 0 for lay in layers):
        raise PlanningError("a target has no lattice state within the tolerance that is clear")
    sizes = np.array([lay.size for lay in layers], dtype=np.int64)
    budget = _pair_budget(orders, False) if max_pairs is None else max_pairs
    if orders is not None and int(sizes @ leg_multiplicity(len(layers), orders) @ sizes) > budget:
        say("the legs between the lattice states are too many to measure: sampling instead")
        return None
    say("bounding the tour's commands over its lattice goal states")
    from_start = _from_start(sampler, q_start, points, layers, ways)
    per_order: dict[tuple[int, ...], int] = {}
    states, order_found = None, None
    if orders is None:
        check_time("bounding the tour's commands")
        try:
            found = Subsets(back, max_pairs=budget).solve(
                sampler, layers, from_start, find_through=False
            )
        except OutOfPairsError:
            say("the legs between the lattice states are too many to measure: sampling instead")
            return None
        best = int(np.ceil(found.total - 1e-9))
        order_found = found.order
        states = np.array([layers[t].q[found.samples[t]] for t in order_found])
    else:
        done: dict[tuple[int, ...], FloatArray] = {}
        for order in orders:
            check_time("bounding the tour's commands")
            for n in range(1, len(order) + 1):  # each prefix once, shared between the orders
                prefix = order[:n]
                if prefix not in done:
                    done[prefix] = (
                        from_start[prefix[0]]
                        if n == 1
                        else sampler.advance(
                            layers[prefix[-2]], done[prefix[:-1]], layers[prefix[-1]], whole=True
                        )[0]
                    )
            cost = done[order]
            if back:
                cost = cost + from_start[order[-1]]
            per_order[order] = int(np.ceil(float(cost.min()) - 1e-9))
        best = min(per_order.values())
    n_orders = math.factorial(len(layers)) if orders is None else len(orders)
    return (
        CommandBound(
            commands=best,
            value=float(best),
            method=(
                _over_orders(orders, len(layers), back)
                + " of a shortest path from the start through "
                "the lattice states within the tolerance of each target that keep the "
                "clearance rule (all of them, listed by branch and bound over boxes of ticks; "
                "obstacles ignored between the targets), each leg at least its largest joint "
                "change in whole commands" + passage_method(ways, "a leg from the start")
            ),
            sampling={
                "orders": float(n_orders),
                "lattice_goal_states": float(sizes.sum()),
            }
            | ({"clear_path_commands": float(best)} if orders is None else {})
            | passage_sampling(ways),
            guide_q=states,
            guide_order=order_found,
            clear_path_q=states,
            clear_path_order=order_found,
        ),
        per_order,
    )
