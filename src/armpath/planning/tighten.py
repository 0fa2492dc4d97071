"""Fewer commands for a certified motion: its lattice states moved so fewer commands span it.

A motion of ``N`` commands from lattice state ``a`` to lattice state ``b`` is a polyline of
``N`` straight joint motions, each moving every joint by at most its largest step. A searched
motion that goes round an obstacle keeps more commands than the direct count between its ends
(the largest joint change in whole commands): the search's path is longer than it needs to
be, and merging its commands (:func:`~armpath.planning.motion.merge_commands`) only drops
states, it never moves them.

:func:`tightened` asks for ``K < N`` commands between the same ends: the ``K - 1`` states in
between are placed by a smooth optimisation that starts from the motion's own path resampled
to ``K`` commands, penalises every pair's slack below :data:`BUFFER` (length unit) at
:data:`SAMPLES_PER_COMMAND` instants of each command, and pushes each command's joint changes
under its largest step with a weight raised in :data:`STEP_WEIGHTS`, the joints kept within
their limits. The states are then rounded to the lattice and the motion is kept only if its
continuous motion is certified (:func:`~armpath.planning.motion_check.motion_clearance`),
like every other. The counts tried are ``N - 1`` first, then the direct count, then a
bisection between the two, at most :data:`MAX_TRIES` counts in all.

The UR5 cell's spot welds without the pools (``armpath spotweld --scene
examples/ur5_cell.toml --no-pools --no-bound``) come to 109 commands, 114 with the states left
where the search put them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from armpath.budget import check_time
from armpath.commands import CommandSequence
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import displacement_bounds
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion_check import motion_clearance

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Slack (length unit) below which a pair is penalised while the states are placed.
BUFFER = 1.0
#: Instants of each command where the slacks are penalised (its two ends included).
SAMPLES_PER_COMMAND = 7
#: Weights of the joint changes beyond a command's step, raised in turn (each a new solve
#: from the last one's states); the last solve's states are rounded to the lattice. By then
#: no change exceeds its step: on the seed's planning problems, the UR5 cell's welds and the
#: tests' detours, every count certified was certified there, and solves at 100 and 1000 after
#: it (dropped) rescued none of the five counts that failed, which they made 40 % slower.
STEP_WEIGHTS = (0.1, 1.0, 10.0)
#: Iterations of each solve (L-BFGS-B).
ITERATIONS = 100
#: Counts tried for one motion (one fewer than its own, its direct count, then a bisection
#: between).
MAX_TRIES = 5
#: Longest motion (commands) whose states are placed: the solve's unknowns grow with it.
MAX_COMMANDS = 60
#: Configurations whose pair clearances one call may measure, all tries together (each
#: evaluation of the objective measures its instants, and one step of each joint from those
#: instants the step may bring within :data:`BUFFER`: at most 7 per instant, for a six-joint
#: arm, about 1.2 on the seed's planning problems). A 60-command motion of a six-joint arm
#: measures at most about 2,900 an evaluation and some 1,000,000 a try (its three solves take
#: about 110 evaluations each), so this allows it at least two tries.
MAX_CONFIGURATIONS = 2_000_000
#: How far under its largest step (ticks) a joint's change is aimed, so rounding to the lattice
#: keeps it within the step.
_STEP_MARGIN_TICKS = 0.75
#: Finite-difference step (ticks) of the slacks' gradient.
_GRADIENT_TICKS = 0.5


class _OutOfWorkError(Exception):
    """The call's :data:`MAX_CONFIGURATIONS` are measured."""


class _Work:
    """Configurations left to measure in one call of :func:`tightened`."""

    def __init__(self) -> None:
        self.left = MAX_CONFIGURATIONS

    def spend(self, configurations: int) -> None:
        if configurations > self.left:
            raise _OutOfWorkError
        self.left -= configurations


class _Placement:
    """The smooth problem of placing ``k - 1`` states between fixed ends ``a`` and ``b``."""

    def __init__(
        self,
        arm: SerialArm,
        world: CollisionWorld,
        a: FloatArray,
        b: FloatArray,
        k: int,
        work: _Work,
    ) -> None:
        self.arm, self.world, self.work = arm, world, work
        self.grid = arm.lattice
        self.a, self.b, self.k = a, b, k
        self.required = world.required(arm)
        # how far a pair's slack can fall when one joint moves by the gradient's step: every
        # point moves at most the step times the joint's displacement bound, a link pair's
        # distance twice that (both links move)
        pair_speed = np.where([p.is_self for p in world.pairs(arm)], 2.0, 1.0)
        step_reach = _GRADIENT_TICKS * self.grid.tick * displacement_bounds(arm)
        self.fall = step_reach[:, None] * pair_speed[None, :]  # (joints, pairs)
        self.limit = np.maximum(self.grid.max_ticks - _STEP_MARGIN_TICKS, 0.25)
        self.t = np.linspace(0.0, 1.0, SAMPLES_PER_COMMAND)

    def states(self, z: FloatArray) -> FloatArray:
        return np.vstack([self.a, z.reshape(self.k - 1, self.a.size), self.b])

    def _slacks(self, q_ticks: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per configuration and pair, ``clearance - required`` and a proven lower bound."""
        values, lowers = self.world.pair_clearances(self.arm, self.grid.to_joint(q_ticks))
        return values - self.required, lowers - self.required

    @staticmethod
    def _penalty(slack: FloatArray) -> FloatArray:
        """Per configuration, the sum of squared slack shortfalls below the buffer."""
        short = np.maximum(BUFFER - slack, 0.0)
        return np.asarray((short**2).sum(axis=-1))

    def value_and_gradient(self, z: FloatArray, weight: float) -> tuple[float, FloatArray]:
        """The penalty of the states ``z`` at ``weight`` and its gradient.

        The slacks' gradient is a forward difference, one joint at a time, taken only from the
        instants whose step may change the penalty: where every pair's proven slack less the
        most the step can lower it stays at or above :data:`BUFFER`, the penalty is 0 before
        and after the step, and so is the difference."""
        check_time("placing a motion's states")
        x = self.states(z)
        n = self.a.size
        t = self.t[None, :, None]
        inst = (x[:-1, None, :] * (1.0 - t) + x[1:, None, :] * t).reshape(-1, n)
        self.work.spend(inst.shape[0])
        slack, lower = self._slacks(inst)
        base = self._penalty(slack)
        value = float(base.sum())
        rows = [np.flatnonzero((lower - fall < BUFFER).any(axis=1)) for fall in self.fall]
        moved = inst[np.concatenate(rows)]
        at = np.cumsum([0] + [r.size for r in rows])
        for j in range(n):
            moved[at[j] : at[j + 1], j] += _GRADIENT_TICKS
        self.work.spend(moved.shape[0])
        stepped = self._penalty(self._slacks(moved)[0])
        grad_inst = np.zeros_like(inst)
        for j, r in enumerate(rows):
            grad_inst[r, j] = (stepped[at[j] : at[j + 1]] - base[r]) / _GRADIENT_TICKS
        per_command = grad_inst.reshape(self.k, self.t.size, n)
        grad = np.zeros_like(x)
        grad[:-1] += (per_command * (1.0 - t)).sum(axis=1)
        grad[1:] += (per_command * t).sum(axis=1)
        change = np.diff(x, axis=0)
        beyond = np.maximum(np.abs(change) - self.limit, 0.0)
        value += weight * float((beyond**2).sum())
        g_change = 2.0 * weight * beyond * np.sign(change)
        grad[1:] += g_change
        grad[:-1] -= g_change
        return value, grad[1:-1].ravel()


def _resampled(states: FloatArray, k: int) -> FloatArray:
    """``k + 1`` states along the polyline ``states``, evenly by its largest joint change."""
    step = np.abs(np.diff(states, axis=0)).max(axis=1)
    at = np.concatenate([[0.0], np.cumsum(step)])
    want = np.linspace(0.0, at[-1], k + 1)
    return np.column_stack([np.interp(want, at, col) for col in states.T])


def _lattice_motion(arm: SerialArm, world: CollisionWorld, x: FloatArray) -> CommandSequence | None:
    """The states ``x`` (its ends lattice states) rounded to the lattice, as a sequence, if
    every command is within its step and the continuous motion is certified (the joint limits
    hold: ``x`` is within them and they are whole ticks)."""
    grid = arm.lattice
    ticks = np.round(x).astype(np.int64)
    steps = np.diff(ticks, axis=0)
    if np.any(np.abs(steps) > grid.max_ticks):
        return None
    seq = CommandSequence(ticks[0], steps, grid)
    return seq if motion_clearance(arm, world, seq).certified_ok else None


def _try_count(
    arm: SerialArm,
    world: CollisionWorld,
    states: FloatArray,
    k: int,
    bounds: list[tuple[float | None, float | None]],
    work: _Work,
) -> CommandSequence | None:
    problem = _Placement(arm, world, states[0], states[-1], k, work)
    z = _resampled(states, k)[1:-1].ravel()
    for weight in STEP_WEIGHTS:
        res = minimize(
            problem.value_and_gradient,
            z,
            args=(weight,),
            jac=True,
            method="L-BFGS-B",
            bounds=bounds * (k - 1),
            options={"maxiter": ITERATIONS},
        )
        z = res.x
    return _lattice_motion(arm, world, problem.states(z))


def tightened(arm: SerialArm, world: CollisionWorld, sequence: CommandSequence) -> CommandSequence:
    """``sequence`` in fewer commands between the same two states where a certified motion is
    found (see the module's description), else ``sequence`` itself.

    Tries at most :data:`MAX_TRIES` counts between the direct count and the sequence's own
    (one fewer first, then the direct count, then halving), for sequences of at most
    :data:`MAX_COMMANDS` commands, measuring at most :data:`MAX_CONFIGURATIONS` configurations
    in all (the fewest found by then is kept); each try is bounded (its solves' iterations,
    one certification) and hears the time limit."""
    n_commands = sequence.n_commands
    grid = sequence.grid
    floor = int(grid.commands_needed(sequence.final_ticks - sequence.start_ticks))
    if n_commands <= floor or n_commands > MAX_COMMANDS:
        return sequence
    lo_t, hi_t = arm.limits_in_ticks()
    bounds = [
        (None if not np.isfinite(lo) else float(lo), None if not np.isfinite(hi) else float(hi))
        for lo, hi in zip(lo_t, hi_t, strict=True)
    ]
    best = sequence
    low, high = floor, n_commands  # high: the fewest known to work
    work = _Work()
    for attempt in range(MAX_TRIES):
        if low >= high:
            break
        # one fewer first (the likeliest), then the direct count, then halving what is left
        k = high - 1 if attempt == 0 else low if attempt == 1 else (low + high) // 2
        try:
            found = _try_count(arm, world, best.states().astype(np.float64), k, bounds, work)
        except _OutOfWorkError:
            break
        if found is None:
            low = k + 1
        else:
            best, high = found, k
    return best
