"""Goal states for a tour chosen together: a shortest path through clear members of the family.

:func:`~armpath.planning.reach.goal_states` picks each target's goal states nearest the *start*:
good for the first leg, often poor between targets (a UR5 whose welds sit on the far side of
a workpiece reaches each of them in a different posture). Here the solution family at every
target is sampled over tool directions (:class:`~armpath.planning.bounds.FamilySampler`, the
samples of the tour's lower bound), the members whose links keep the margin plus a buffer are
kept, and for a visiting order the shortest path from the start through one member per target
is found (largest joint change per leg, whole commands, obstacles between the targets
ignored). Each member on that path is then turned into lattice goal states next to it
(:func:`~armpath.planning.reach_generic.generic_goal_states` on the members nearest it), and the
tour is planned leg by leg to those. For a path a tour's lower bound found through clear members,
every lattice goal state within a command of each member is listed
(:meth:`TourGuide.states_near`), the cheapest combination first.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import ArmpathError
from armpath.geometry.primitives import PROVABLE_SLACK
from armpath.geometry.world import CollisionWorld
from armpath.ik.family import shift_into_limits
from armpath.ik.target import ToolTarget
from armpath.model.lattice import Lattice
from armpath.model.serial_arm import SerialArm
from armpath.planning.bounds import FamilySampler, Layer
from armpath.planning.bounds.lattice_goals import lattice_goal_states
from armpath.planning.bounds.tour import listing_ranges
from armpath.planning.reach import GOAL_BODY_BUFFER_MM
from armpath.planning.reach_generic import generic_goal_states
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Tool directions sampled at each target (before the clearance filter).
GUIDE_DIRECTIONS = 2000
#: Members nearest a path's member handed to the lattice search at each target.
NEAREST_MEMBERS = 48
#: Lattice goal states kept next to each path member.
GUIDE_GOALS = 4
#: Boxes of ticks the listing of the lattice goal states within a command of one member may
#: look at (about a microsecond each; past it the listing stops): a UR5 whose tool point lies
#: off joint 6's axis (every joint moves it), about 35,000 a weld at 0.05 mm.
NEAR_BOXES = 5_000_000
#: Lattice goal states the listing within a command of one member may hold (past it, those
#: listed so far), and those nearest the member that the cheapest combination is chosen from
#: (the programme holds a pair of targets' states at once: a wide tolerance lists many).
NEAR_LISTED = 200_000
NEAR_STATES = 1_000


@dataclass(frozen=True)
class TourGuide:
    """Clear members of the family at each target (command units, no sampling error)."""

    arm: SerialArm
    world: CollisionWorld
    sampler: FamilySampler
    layers: list[Layer]
    #: the targets ``(K, 3)``, in the model's length unit (as the tour's)
    targets: FloatArray
    tolerance_mm: float
    #: each member's room (mm): the least clearance of its links beyond the margin, per layer
    #: (empty: not known)
    room: tuple[FloatArray, ...] = ()

    @staticmethod
    def build(
        fam: CurveFamily,
        targets: FloatArray,
        tolerance_mm: float,
        body_buffer_mm: float = GOAL_BODY_BUFFER_MM,
        q_start: FloatArray | None = None,
        levels: int = 0,
    ) -> TourGuide:
        """Sample the family at every target and keep the members whose links keep the margin
        plus ``body_buffer_mm`` (the tool tip: outside every obstacle); ``levels``: times the
        tool directions about members that may be clear are split (finer next to the
        obstacles: :meth:`FamilySampler.layer`)."""
        arm, world = fam.arm, fam.world
        sampler = FamilySampler(fam, tolerance_mm, GUIDE_DIRECTIONS, q_start, blow_ups=False)
        pairs = world.pairs(arm)
        is_tip = np.array([p.is_tip for p in pairs], dtype=bool)
        required = world.required(arm)
        layers, rooms = [], []
        for p in targets:
            check_time("choosing the tour's goal states")
            lay = sampler.layer(p, sampler.base, levels=levels)
            values, _ = world.pair_clearances(arm, lay.q)
            if lay.size:
                room = np.min(values[:, ~is_tip] - required[~is_tip], axis=-1, initial=np.inf)
                ok = (room >= body_buffer_mm) & np.all(values[:, is_tip] >= 0.0, axis=-1)
            else:
                room, ok = np.zeros(0), np.zeros(0, dtype=bool)
            layers.append(Layer(lay.u[ok], lay.err[ok], lay.q[ok], lay.dirs[ok]).without_errors())
            rooms.append(room[ok])
        return TourGuide(
            arm, world, sampler, layers, np.asarray(targets), tolerance_mm, tuple(rooms)
        )

    def with_buffer(self, body_buffer_mm: float) -> TourGuide:
        """This guide with only the members whose links keep the margin plus
        ``body_buffer_mm`` (at least the buffer it was built with)."""
        return self.subset([room >= body_buffer_mm for room in self.room])

    def subset(self, keep: list[NDArray[np.bool_]]) -> TourGuide:
        """This guide with only the members ``keep`` (a mask per target)."""
        layers = [lay.subset(k) for lay, k in zip(self.layers, keep, strict=True)]
        rooms = tuple(room[k] for room, k in zip(self.room, keep, strict=True))
        return replace(self, layers=layers, room=rooms)

    def path(
        self, q_start: FloatArray, order: tuple[int, ...], back: bool
    ) -> tuple[float, list[FloatArray]] | None:
        """The shortest path from ``q_start`` (rad) through one clear member per target in
        ``order`` (whole commands per leg; ``back``: and back to the start): its commands and
        its members (rad, each turned nearest the one before); None when a target has none."""
        layers = [self.layers[t] for t in order]
        if any(lay.size == 0 for lay in layers):
            return None
        s = self.sampler
        cost = s.distance_from(q_start, layers[0], whole=True)
        args = []
        for a, b in itertools.pairwise(layers):
            check_time("choosing the tour's goal states")
            cost, arg = s.advance(a, cost, b, whole=True)
            args.append(arg)
        if back:
            cost = cost + s.distance_from(q_start, layers[-1], whole=True)
        if not np.any(np.isfinite(cost)):
            return None
        j = int(np.argmin(cost))
        total = float(cost[j])
        picks = [j]
        for arg in reversed(args):
            picks.append(int(arg[picks[-1]]))
        picks.reverse()
        members, prev = [], q_start
        for lay, k in zip(layers, picks, strict=True):
            q = self.with_start(lay.q[k][None], q_start)
            q = self.sampler.within_windows(shift_into_limits(self.arm, q, prev))[0]
            members.append(q)
            prev = q
        return total, members

    def goal_states(
        self,
        q_start: FloatArray,
        order: tuple[int, ...],
        members: list[FloatArray],
        nearest: bool = True,
    ) -> list[IntArray] | None:
        """Lattice goal states next to each path member (nearest it first, at most
        :data:`GUIDE_GOALS`; next to each member sampled, the clear lattice state ``nearest`` it,
        else the most accurate one: :func:`generic_goal_states`), one array per target of
        ``order``; None when a member has none."""
        grid = self.arm.lattice
        out = []
        for t, q in zip(order, members, strict=True):
            check_time("choosing the tour's goal states")
            lay = self.layers[t]
            near = np.argsort(self.sampler.distance_from(q, lay), kind="stable")[:NEAREST_MEMBERS]
            samples = shift_into_limits(self.arm, self.with_start(lay.q[near], q_start), q)
            try:
                states = generic_goal_states(
                    self.arm,
                    self.world,
                    grid.nearest_ticks(q),
                    ToolTarget(self.targets[t], None),
                    self.tolerance_mm,
                    GUIDE_GOALS,
                    samples=np.vstack([q[None], samples]),
                    nearest_member=nearest,
                )
            except ArmpathError:
                return None
            out.append(states)
        return out

    def states_near(
        self,
        start_ticks: IntArray,
        order: tuple[int, ...],
        members: list[FloatArray],
        back: bool,
    ) -> list[IntArray] | None:
        """Every clear lattice goal state within one command of each path member (a complete
        listing, :func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states`, over the
        box of ticks one command wide each way about the member: its joints that turn whole
        turns taken on the turn nearest the member before, the start's for the first; the
        joints that do not move the tool point at the start's ticks), the states of the
        cheapest path through them by direct motions first (one per target, whole commands per
        leg, obstacles ignored; ``back``: and back to the start), one array per target of
        ``order`` (at most :data:`NEAR_STATES` each, those nearest the member; past
        :data:`NEAR_BOXES` boxes or :data:`NEAR_LISTED` states, of those listed so far). None
        where the states cannot be listed (:func:`~armpath.planning.bounds.tour.listing_ranges`)
        or a member has none."""
        grid = self.arm.lattice
        tip = self.sampler.tip
        ranges = listing_ranges(self.sampler, grid.to_joint(start_ticks))
        if ranges is None:
            return None
        fixed, lower, upper = ranges
        turns = self.sampler.whole_turns
        whole = np.flatnonzero(tip)[turns]
        step = np.asarray(grid.max_ticks, dtype=np.int64)[tip]
        sets = []
        before = grid.to_joint(start_ticks)
        for t, q in zip(order, members, strict=True):
            check_time("choosing the tour's goal states")
            q = np.array(q, dtype=np.float64, copy=True)
            q[whole] = before[whole] + np.angle(np.exp(1j * (q[whole] - before[whole])))
            centre = grid.nearest_ticks(q)[tip]
            lo = np.where(turns, centre - step, np.maximum(centre - step, lower))
            hi = np.where(turns, centre + step, np.minimum(centre + step, upper))
            if np.any(lo > hi):
                return None
            found = lattice_goal_states(
                self.arm,
                self.targets[t],
                self.tolerance_mm / self.arm.mm_per_unit,
                tip,
                fixed,
                lo,
                hi,
                may_be_clear=lambda x, moved: self.world.may_be_clear_within(self.arm, x, moved),
                max_boxes=NEAR_BOXES,
                max_states=NEAR_LISTED,
            )
            states = found.ticks
            if states.shape[0]:
                clear = self.world.satisfied(self.arm, grid.to_joint(states), PROVABLE_SLACK)
                states = states[clear]
            if states.shape[0] == 0:
                return None
            away = np.max(np.abs(states[:, tip] - centre) / step, axis=1)
            sets.append(states[np.argsort(away, kind="stable")[:NEAR_STATES]])
            before = q
        return _cheapest_first(np.asarray(start_ticks, dtype=np.int64), sets, back, grid)

    def with_start(self, q: FloatArray, q_start: FloatArray) -> FloatArray:
        """``q`` with the joints that do not move the tool point at their start values."""
        out = np.array(q, dtype=np.float64, copy=True)
        still = ~self.sampler.tip
        out[:, still] = q_start[still]
        return out


def _cheapest_first(
    start: IntArray, sets: list[IntArray], back: bool, grid: Lattice
) -> list[IntArray]:
    """``sets`` of lattice states (one array per target, in order) with the states of the
    cheapest path from ``start`` through one of each first (direct motions, whole commands;
    ``back``: and back to the start)."""
    cost = grid.commands_needed_many(sets[0] - start[None, :]).astype(np.float64)
    came = []
    for a, b in itertools.pairwise(sets):
        step = cost[:, None] + grid.commands_needed_many(b[None, :, :] - a[:, None, :])
        came.append(np.argmin(step, axis=0))
        cost = step[came[-1], np.arange(b.shape[0])]
    if back:
        cost = cost + grid.commands_needed_many(start[None, :] - sets[-1])
    picks = [int(np.argmin(cost))]
    for arg in reversed(came):
        picks.append(int(arg[picks[-1]]))
    picks.reverse()
    return [
        np.vstack([s[k : k + 1], np.delete(s, k, axis=0)]) for s, k in zip(sets, picks, strict=True)
    ]
