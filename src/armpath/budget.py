"""Bounds on the work a call may do: wall-clock time limits and size limits.

Every search loop in armpath ends by design (a progress measure that provably decreases, or an
explicit iteration budget). On top of that a caller may set a **time limit**: inside
``with time_limit(seconds):`` long loops call :func:`check_time`, which raises
:class:`~armpath.errors.TimeLimitError` once the limit has run out. The limit is held in a
context variable, so nested calls see it, and so do threads that run their work in a copy of
the caller's context (``contextvars.copy_context().run``, as armpath's own do; a thread pool's
workers do not otherwise); without one, :func:`check_time` costs one lookup.

**Size limits** refuse inputs that would need more memory or work than the machine has before
any work starts: :func:`check_size` compares a count (samples, voxels, periods, ...) with its
named limit and says which option to change. The limits live here, one place for each.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass

from armpath.errors import InvalidInputError, TimeLimitError

#: Largest number of configurations (or points) sampled by one workspace-type computation.
MAX_SAMPLES = 200_000_000
#: Largest number of cells of a voxel grid or a pixel map.
MAX_GRID_CELLS = 50_000_000
#: Largest number of controller periods of one trajectory (one joint state each).
MAX_PERIODS = 5_000_000
#: Largest number of joint values (controller periods times joints) of one sampled trajectory:
#: 80 MB an array (a 64-joint trajectory of a million periods held 3.1 GB and wrote 768 MB).
MAX_TRAJECTORY_VALUES = 10_000_000
#: Largest number of commands of one command sequence a planner or converter produces.
MAX_COMMANDS = 1_000_000
#: Largest joint value, in ticks, that rounds to an exact integer state.
MAX_STATE_TICKS = 2.0**52
#: Largest number of candidate designs of a design sweep.
MAX_DESIGNS = 10_000
#: Most searches (or failed attempts) of one motion plan (``plan_motion``).
MAX_SEARCHES = 100
#: Largest number of parallel jobs.
MAX_JOBS = 256
#: Largest coordinate or size a scene, curve or target point may use (mm): 1000 km. Beyond it
#: squared distances lose every digit a 0.01 mm clearance needs (and overflow near 1e154 mm).
MAX_COORDINATE_MM = 1e9
#: Largest time limit accepted (s): one week.
MAX_TIME_LIMIT_S = 7 * 24 * 3600.0
#: Longest controller period accepted (s): a minute (controllers command every few ms).
MAX_PERIOD_S = 60.0


@dataclass(frozen=True)
class Deadline:
    """A time limit: ``seconds`` from ``started`` (``time.monotonic``)."""

    seconds: float
    started: float

    @property
    def elapsed(self) -> float:
        return time.monotonic() - self.started

    @property
    def remaining(self) -> float:
        return self.seconds - self.elapsed


_deadline: contextvars.ContextVar[Deadline | None] = contextvars.ContextVar(
    "armpath_deadline", default=None
)


def check_time_limit_value(seconds: float | None, option: str = "--time-limit") -> None:
    """Refuse a time limit that is not a positive finite number of seconds (at most a week)."""
    if seconds is None:
        return
    if not (math.isfinite(seconds) and 0 < seconds <= MAX_TIME_LIMIT_S):
        raise InvalidInputError(
            f"{option} must be a number of seconds in (0, {MAX_TIME_LIMIT_S:g}], got {seconds}"
        )


@contextlib.contextmanager
def time_limit(seconds: float | None) -> Iterator[Deadline | None]:
    """Within the block, :func:`check_time` raises once ``seconds`` have passed (``None``: no
    limit). An enclosing, earlier deadline stays in force."""
    check_time_limit_value(seconds, "time limit")
    outer = _deadline.get()
    if seconds is None:
        yield outer
        return
    mine = Deadline(float(seconds), time.monotonic())
    if outer is not None and outer.remaining < mine.seconds:
        mine = outer
    token = _deadline.set(mine)
    try:
        yield mine
    finally:
        _deadline.reset(token)


def current_deadline() -> Deadline | None:
    """The time limit in force, if any."""
    return _deadline.get()


#: What a message of a time limit that ran out advises.
RAISE_TIME_LIMIT = (
    "raise the time limit (--time-limit; time_limit_s= in Python) or make the problem smaller"
)


def check_time(doing: str = "") -> None:
    """Raise :class:`TimeLimitError` if the time limit in force has run out.

    ``doing`` says what was under way ("tracing pass 2"); it goes into the message.
    """
    d = _deadline.get()
    if d is None or d.remaining > 0:
        return
    what = f" while {doing}" if doing else ""
    raise TimeLimitError(
        f"the time limit of {d.seconds:g} s ran out{what} (after {d.elapsed:.1f} s); "
        + RAISE_TIME_LIMIT
    )


def count_text(count: float) -> str:
    """A count for a message: every digit of a whole count below 10**15 (1,000,001), else three
    significant digits; a whole number beyond any float (501! = 6.11e1136) from its digits."""
    if isinstance(count, int) and count > sys.float_info.max:
        digits = str(count)
        return f"{digits[0]}.{digits[1:3]}e{len(digits) - 1}"
    if count < 1e15 and float(count).is_integer():
        return f"{count:,.0f}"
    return f"{count:.3g}"


def check_size(count: float, limit: float, what: str, option: str) -> None:
    """Refuse work of ``count`` units (``what``) above ``limit``, naming ``option`` to change.

    ``count`` may be a float (an estimate that could overflow an integer)."""
    if not math.isfinite(count) or count > limit:
        shown = count_text(count) if math.isfinite(count) else "an unbounded number"
        raise InvalidInputError(
            f"{what}: this would need {shown} (the limit is {limit:,.0f}); change {option}"
        )


def check_point_mm(values: list[float], what: str) -> list[float]:
    """``values`` (a point's coordinates, mm), or :class:`InvalidInputError` when one is not
    finite or beyond :data:`MAX_COORDINATE_MM` (the limit named)."""
    for x in values:
        if not math.isfinite(x):
            raise InvalidInputError(f"{what}: {x!r} is not a finite number")
        if abs(x) > MAX_COORDINATE_MM:
            raise InvalidInputError(
                f"{what}: {x:g} mm is beyond the largest coordinate accepted "
                f"({MAX_COORDINATE_MM:g} mm)"
            )
    return values


__all__ = [
    "MAX_COMMANDS",
    "MAX_COORDINATE_MM",
    "MAX_DESIGNS",
    "MAX_GRID_CELLS",
    "MAX_JOBS",
    "MAX_PERIODS",
    "MAX_SAMPLES",
    "MAX_TIME_LIMIT_S",
    "MAX_TRAJECTORY_VALUES",
    "RAISE_TIME_LIMIT",
    "Deadline",
    "check_point_mm",
    "check_size",
    "check_time",
    "check_time_limit_value",
    "current_deadline",
    "time_limit",
]


# Added for the non-planning commands (workspace, blind zones, design sweep, trajectories).

#: Largest number of waypoints of one trajectory (rows of a waypoints file, points of a circle).
MAX_WAYPOINTS = 10_000
#: Largest number of joints of an arm, and of a joint-space trajectory (columns).
MAX_JOINTS = 64
#: Largest number of samples (joint vectors, points) held in memory at once: one chunk.
MAX_CHUNK = 4_000_000
#: Largest number of horizontal circles per workpiece face of a blind-zone survey: each takes
#: about 6 s (both faces of the seed workpiece, 2 cores), so 100 about 10 min (1,000 ran for
#: hours); 100 circles on the seed workpiece's 180 mm are one every 1.8 mm.
MAX_BANDS = 100
#: Largest number of tool orientations tested at one point (a dexterity grid).
MAX_ORIENTATIONS = 1_000_000

#: Most random starts of one numerical IK solve (each runs up to its iteration limit of
#: Levenberg-Marquardt steps: about 0.8 ms for iiwa14, so 10,000 about 8 s; 100,000 took 100 s).
MAX_IK_SEEDS = 10_000

#: Largest number of points at which one curve is scanned (a circle of a blind-zone survey),
#: and of vertices of a polyline (its arc-length table holds each: 1,000,000 about 200 MB).
MAX_CURVE_POINTS = 1_000_000

__all__ += [
    "MAX_BANDS",
    "MAX_CHUNK",
    "MAX_CURVE_POINTS",
    "MAX_IK_SEEDS",
    "MAX_JOINTS",
    "MAX_ORIENTATIONS",
    "MAX_WAYPOINTS",
]
