"""Command sequences on an arm's command lattice (SPEC section 2).

A command moves every joint at once by a whole number of its ticks (the seed controller: ticks
of 0.1 degree, each in ``[-20, 20]``, at most 2 degrees; any arm: its own
:class:`~armpath.model.lattice.Lattice`). Joint states reached by commands are integer tick
vectors, so a sequence replays exactly. During one command all joints move linearly in time and
finish together (synchronous linear interpolation); :meth:`CommandSequence.sample_motion`
samples that continuous motion for checks.

The module-level helpers (``ticks_to_rad``, ``deg_to_ticks``, ``commands_needed``, ...) are the
seed controller's lattice, kept for the seed arm's code and its tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import CommandError, InvalidInputError
from armpath.model.lattice import DEFAULT_MAX_TICKS, DEFAULT_REVOLUTE_TICK_RAD, Lattice

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

#: Size of one tick in degrees.
TICK_DEG = 0.1
#: Size of one tick in radians.
TICK_RAD = DEFAULT_REVOLUTE_TICK_RAD
#: Largest increment of one joint in one command, in ticks (2.0 degrees).
MAX_INCREMENT_TICKS = DEFAULT_MAX_TICKS


def ticks_to_rad(ticks: ArrayLike) -> FloatArray:
    """Joint angles in rad for integer tick states."""
    return np.asarray(ticks, dtype=np.float64) * TICK_RAD


def ticks_to_deg(ticks: ArrayLike) -> FloatArray:
    """Joint angles in degrees for integer tick states (exact decimal multiples of 0.1)."""
    return np.round(np.asarray(ticks, dtype=np.float64) * TICK_DEG, 10)


def deg_to_ticks(deg: ArrayLike, what: str = "joint angles") -> IntArray:
    """Integer ticks for angles in degrees that lie on the 0.1 degree lattice.

    Raises :class:`InvalidInputError` for NaN/inf or angles that are not multiples of 0.1 degree.
    """
    d = np.asarray(deg, dtype=np.float64)
    if not np.all(np.isfinite(d)):
        raise InvalidInputError(f"{what} must be finite numbers, got {d.tolist()}")
    t = d / TICK_DEG
    r = np.round(t)
    if np.any(np.abs(t - r) > 1e-6):
        raise InvalidInputError(
            f"{what} must be multiples of 0.1 deg (the command lattice), got {d.tolist()}"
        )
    return r.astype(np.int64)


def commands_needed(delta_ticks: ArrayLike) -> int:
    """Fewest commands that move the joints by ``delta_ticks``: ``max_i ceil(|d_i| / 20)``."""
    d = np.abs(np.asarray(delta_ticks, dtype=np.int64))
    return int(np.max(-(-d // MAX_INCREMENT_TICKS))) if d.size else 0


def split_move(delta_ticks: ArrayLike, n_commands: int) -> IntArray:
    """Split a joint move into ``n_commands`` legal commands that track the straight line.

    Command ``k`` moves joint ``i`` by ``floor((k+1) d_i / n) - floor(k d_i / n)``, so every joint
    advances as evenly as the lattice allows and all finish together. Raises
    :class:`CommandError` when ``n_commands`` is too few for the move.
    """
    d = np.asarray(delta_ticks, dtype=np.int64)
    need = commands_needed(d)
    if n_commands < need:
        raise CommandError(f"a move of {d.tolist()} ticks needs at least {need} commands")
    if n_commands == 0:
        return np.zeros((0, d.size), dtype=np.int64)
    k = np.arange(n_commands + 1, dtype=np.int64)[:, None]
    cumulative = np.floor_divide(k * d[None, :], n_commands)
    return np.asarray(np.diff(cumulative, axis=0), dtype=np.int64)


@dataclass(frozen=True, eq=False)
class CommandSequence:
    """A start state and a sequence of commands, all as integer ticks of ``lattice``.

    Parameters
    ----------
    start_ticks:
        Joint state before the first command, ``(n_joints,)`` integer ticks.
    commands:
        ``(n_commands, n_joints)`` integer increments, each within its joint's
        ``lattice.max_ticks``.
    lattice:
        The arm's command lattice (``arm.lattice``); ``None``: the seed controller's (0.1 deg,
        20 ticks per joint).
    """

    start_ticks: IntArray
    commands: IntArray
    lattice: Lattice | None = None

    def __post_init__(self) -> None:
        start = _as_int_array(self.start_ticks, "start state")
        if start.ndim != 1:
            raise CommandError(f"start state must be a vector of ticks, got shape {start.shape}")
        cmds = _as_int_array(self.commands, "commands").reshape(-1, start.size)
        lattice = self.lattice if self.lattice is not None else Lattice.uniform(start.size)
        if lattice.n_joints != start.size:
            raise CommandError(
                f"the lattice has {lattice.n_joints} joints, the start state {start.size}"
            )
        lattice.check_commands(cmds)
        start.setflags(write=False)
        cmds.setflags(write=False)
        object.__setattr__(self, "start_ticks", start)
        object.__setattr__(self, "commands", cmds)
        object.__setattr__(self, "lattice", lattice)

    @property
    def grid(self) -> Lattice:
        """The command lattice (never ``None`` after construction)."""
        assert self.lattice is not None
        return self.lattice

    @property
    def n_commands(self) -> int:
        return int(self.commands.shape[0])

    @property
    def n_joints(self) -> int:
        return int(self.start_ticks.size)

    def states(self) -> IntArray:
        """Exact joint states: row 0 is the start, row k the state after command k."""
        return np.vstack([self.start_ticks, self.start_ticks + np.cumsum(self.commands, axis=0)])

    @property
    def final_ticks(self) -> IntArray:
        return np.asarray(self.start_ticks + self.commands.sum(axis=0), dtype=np.int64)

    def sample_motion(self, substeps: int) -> FloatArray:
        """Joint angles (rad) along the continuous motion, ``(n_commands * substeps + 1, n)``.

        Each command is sampled at ``substeps`` equal fractions of its duration (synchronous
        linear interpolation); the last row is the final state.
        """
        if substeps < 1:
            raise InvalidInputError("substeps must be >= 1")
        states = self.states().astype(np.float64)
        s = np.arange(substeps, dtype=np.float64) / substeps
        inner = states[:-1, None, :] + s[None, :, None] * self.commands[:, None, :]
        path = np.vstack([inner.reshape(-1, self.n_joints), states[-1:]])
        return self.grid.to_joint(path)

    def states_joint(self) -> FloatArray:
        """Joint values (rad or length unit) of :meth:`states`."""
        return self.grid.to_joint(self.states())

    def then(self, other: CommandSequence) -> CommandSequence:
        """This sequence followed by ``other`` (which must start where this one ends)."""
        if not np.array_equal(other.start_ticks, self.final_ticks):
            raise CommandError("the second sequence does not start where the first ends")
        return CommandSequence(
            self.start_ticks, np.vstack([self.commands, other.commands]), self.lattice
        )

    @classmethod
    def straight(
        cls,
        start_ticks: ArrayLike,
        goal_ticks: ArrayLike,
        n_commands: int | None = None,
        lattice: Lattice | None = None,
    ) -> CommandSequence:
        """The move from ``start`` to ``goal`` split evenly into the fewest (or given) commands."""
        start = _as_int_array(start_ticks, "start state")
        goal = _as_int_array(goal_ticks, "goal state")
        grid = lattice if lattice is not None else Lattice.uniform(start.size)
        delta = goal - start
        n = grid.commands_needed(delta) if n_commands is None else n_commands
        return cls(start, grid.split(delta, n), grid)

    @classmethod
    def from_states(cls, states: ArrayLike, lattice: Lattice | None = None) -> CommandSequence:
        """The sequence through lattice ``states`` ``(K + 1, n)`` (row 0 the start)."""
        arr = _as_int_array(states, "states")
        if arr.ndim != 2 or arr.shape[0] == 0:
            raise CommandError(f"states must be (K + 1, n) ticks, got shape {arr.shape}")
        return cls(arr[0], np.diff(arr, axis=0), lattice)


def _as_int_array(value: ArrayLike, what: str) -> IntArray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu":
        f = arr.astype(np.float64)
        if not np.all(np.isfinite(f)) or np.any(f != np.round(f)):
            raise CommandError(f"{what} must be integer ticks of 0.1 deg, got {arr.tolist()}")
        arr = f
    return np.array(arr, dtype=np.int64)
