"""Time-optimal and jerk-limited retiming, compared with the minimum-snap QP.

Four ways to move through the same waypoints under per-joint limits (``MotionLimits``:
velocity, acceleration, jerk in the waypoints' unit per s, s^2, s^3):

- ``scaled``: the unbounded minimum-snap trajectory, slowed uniformly just enough that every
  limit holds (exact: the coefficients live in normalised time, so only the times change).
- ``bounded``: the minimum-snap QP with the limits as constraints, on the same relative segment
  times, uniformly compressed to the shortest feasible duration (bisection on the time scale).
- ``toppra``: time-optimal retiming of the minimum-snap *path* (the same geometric curve in
  joint space) under velocity and acceleration limits. toppra has no jerk limit; its limits hold
  at its grid points only, so it is re-run with the limits tightened by the measured excess.
- ``ruckig``: jerk-limited time-optimal motion between consecutive waypoints, passing each inner
  waypoint with the velocity and acceleration the ``scaled`` trajectory has there (the free
  ruckig computes state-to-state motions only; intermediate waypoints are its paid feature).
  The path between waypoints is ruckig's own, not the minimum-snap curve.

Every loop has a budget: the bisection at most ``MAX_BISECTIONS`` steps (and it stops when the
scale factors no longer differ in floating point), toppra at most ``rounds`` runs, ruckig one
motion a segment. The time limit in force is checked before every QP, toppra run and ruckig
segment.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import check_time
from armpath.errors import InvalidInputError
from armpath.trajectory.minsnap import (
    ORDERS,
    InfeasibleLimitsError,
    MotionLimits,
    PiecewisePolynomial,
    QPSolverError,
    minimum_snap,
    segment_durations_ok,
)

FloatArray = NDArray[np.float64]
RETIMING_METHODS = ("scaled", "bounded", "toppra", "ruckig")
#: Most halvings of the time scale below the scaled optimum's (the bounded optimum is rarely
#: more than 2-4 times faster).
MAX_HALVINGS = 8
#: Most bisection steps of the shortest bounded duration (rtol >= MIN_RTOL needs about 35).
MAX_BISECTIONS = 64
#: Finest relative tolerance of the shortest bounded duration.
MIN_RTOL = 1e-9


class JointTrajectory(Protocol):
    """Anything that gives joint values and derivatives over ``[start, start + duration]``."""

    @property
    def start(self) -> float: ...

    @property
    def duration(self) -> float: ...

    def evaluate(self, t: ArrayLike, derivative: int = 0) -> FloatArray: ...


@dataclass(frozen=True)
class Retimed:
    """One retiming: its trajectory, duration (s), peak |velocity|, |acceleration|, |jerk| per
    joint (unit/s^k, measured every ``1e-3`` of the duration) and the computing time (s)."""

    method: str
    trajectory: JointTrajectory
    duration_s: float
    peak_velocity: FloatArray
    peak_acceleration: FloatArray
    peak_jerk: FloatArray
    compute_s: float

    def verdict(self, limits: MotionLimits) -> str:
        """``"met"``, or which limits are exceeded (e.g. ``"exceeds jerk"``)."""
        over = [name for name, ok in self.within(limits).items() if not ok]
        return "exceeds " + ", ".join(over) if over else "met"

    def within(self, limits: MotionLimits, rtol: float = 1e-3) -> dict[str, bool]:
        """Whether each given derivative limit holds (to ``rtol``)."""
        given = limits.per_joint(self.peak_velocity.size)
        peaks = {
            "velocity": self.peak_velocity,
            "acceleration": self.peak_acceleration,
            "jerk": self.peak_jerk,
        }
        return {
            name: bool(np.all(peaks[name] <= given[name] * (1 + rtol)))
            for name in peaks
            if name in given
        }


def _sampled_peaks(traj: JointTrajectory, samples: int = 1001) -> tuple[FloatArray, ...]:
    t = traj.start + np.linspace(0.0, traj.duration, samples)
    return tuple(np.abs(traj.evaluate(t, d)).max(axis=0) for d in (1, 2, 3))


def _retimed(method: str, traj: JointTrajectory, started: float, exact: bool) -> Retimed:
    compute = time.perf_counter() - started
    if exact and isinstance(traj, PiecewisePolynomial):
        v, a, j = (traj.peak(d) for d in (1, 2, 3))
    else:
        v, a, j = _sampled_peaks(traj)
    return Retimed(method, traj, float(traj.duration), v, a, j, compute)


def slowest_factor(traj: PiecewisePolynomial, limits: MotionLimits) -> float:
    """The uniform time-scale factor at which ``traj`` just meets the derivative limits
    (velocity scales as 1/f, acceleration 1/f^2, jerk 1/f^3); < 1 means it could go faster,
    0 that it does not move (any time scale meets the limits)."""
    given = limits.per_joint(traj.coefficients.shape[2])
    names = [name for name in ("velocity", "acceleration", "jerk") if name in given]
    if not names:
        raise InvalidInputError("retiming needs a velocity, acceleration or jerk limit")
    factor = 0.0
    for name in names:
        d = ("velocity", "acceleration", "jerk").index(name) + 1
        ratio = float(np.max(traj.peak(d) / given[name]))
        if not np.isfinite(ratio):
            raise InvalidInputError(f"the trajectory's peak {name} is not finite")
        factor = max(factor, ratio ** (1.0 / d))
    return factor


def scaled(traj: PiecewisePolynomial, limits: MotionLimits) -> PiecewisePolynomial:
    """``traj`` uniformly slowed (or sped up) until its tightest derivative limit is met; a
    trajectory that does not move is returned as it is."""
    factor = slowest_factor(traj, limits)
    return traj if factor == 0.0 else traj.time_scaled(factor)


def shortest_bounded(
    waypoints: ArrayLike,
    times: ArrayLike,
    limits: MotionLimits,
    *,
    kind: str = "snap",
    solver: str = "clarabel",
    rtol: float = 1e-3,
) -> PiecewisePolynomial:
    """The bounded minimum-snap QP on ``times`` uniformly compressed to the shortest duration
    at which it is still feasible (bisection on the scale factor to ``rtol``, at least
    ``MIN_RTOL``). Waypoints that do not move give the free optimum unchanged.

    With position limits (``lower``, ``upper``), which no time scale mends, a scaled optimum
    that overshoots them is slowed by doublings, at most ``MAX_HALVINGS``, until the QP keeps
    within them. The search ends by design: at most ``MAX_HALVINGS`` halvings of the scale,
    then at most
    ``MAX_BISECTIONS`` bisection steps, each halving ``log(hi / lo)`` (and stopping when the
    midpoint no longer differs from the ends in floating point). Below the scaled optimum's
    factor, a scale whose segment durations leave the solvable range, or at which the QP solver
    stops without a solution (near the edge of feasibility it may neither solve nor prove
    infeasibility), counts as infeasible."""
    if not (np.isfinite(rtol) and MIN_RTOL <= rtol < 1.0):
        raise InvalidInputError(f"rtol must be in [{MIN_RTOL:g}, 1), got {rtol}")
    t = np.asarray(times, dtype=np.float64)
    free = minimum_snap(waypoints, t, kind=kind)
    given = limits.per_joint(free.coefficients.shape[2])
    hi = slowest_factor(free, limits)  # feasible: the scaled free optimum meets the limits
    if hi == 0.0:
        return free  # nothing moves: every duration meets the limits
    r = ORDERS[kind]
    if not segment_durations_ok(np.diff(t) * hi, r):
        raise InvalidInputError(
            f"the waypoints move so little against the limits that the scaled optimum lasts "
            f"{hi * (t[-1] - t[0]):.3g} s, outside what the {kind} solve can take"
        )

    def solve(f: float, first: bool = False) -> PiecewisePolynomial | None:
        check_time("finding the shortest feasible duration")
        scaled_t = t[0] + f * (t - t[0])
        if not segment_durations_ok(np.diff(scaled_t), r):
            return None
        try:
            return minimum_snap(waypoints, scaled_t, kind=kind, limits=limits, solver=solver)
        except InfeasibleLimitsError:
            return None
        except QPSolverError:
            if first:
                raise
            return None

    positions = "lower" in given or "upper" in given
    best = solve(hi * (1 + 1e-9), first=not positions)
    if best is None and positions:
        # The scaled optimum meets the rates but may overshoot a position limit, which no time
        # scale mends: slower, the QP has room to stay within it.
        for _ in range(MAX_HALVINGS):
            hi *= 2.0
            best = solve(hi)
            if best is not None:
                break
    if best is None:
        raise InvalidInputError(
            "the bounded QP failed where the scaled optimum is feasible"
            if not positions
            else "no duration up to "
            f"{hi * (t[-1] - t[0]):.3g} s keeps the joints within their position limits "
            "through the waypoints"
        )
    lo = hi
    for _ in range(MAX_HALVINGS):
        lo /= 2.0
        found = solve(lo)
        if found is None:
            break
        hi, best = lo, found
    for _ in range(MAX_BISECTIONS):
        if hi / lo <= 1 + rtol:
            break
        mid = float(np.sqrt(hi * lo))
        if not lo < mid < hi:
            break  # hi and lo are neighbouring floats
        found = solve(mid)
        if found is None:
            lo = mid
        else:
            hi, best = mid, found
    return best


class ToppraTrajectory:
    """toppra's time parametrisation of a joint path, as a ``JointTrajectory``."""

    def __init__(self, spline: Any, duration: float) -> None:
        self._spline = spline
        self._duration = duration

    @property
    def start(self) -> float:
        return 0.0

    @property
    def duration(self) -> float:
        return self._duration

    def evaluate(self, t: ArrayLike, derivative: int = 0) -> FloatArray:
        tt = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), 0.0, self._duration)
        if derivative <= 2:
            return np.asarray(self._spline(tt, derivative), dtype=np.float64)
        # Jerk: toppra's acceleration is piecewise linear in time; difference it on a fine step.
        h = 1e-4 * max(self._duration, 1e-9)
        up = self.evaluate(tt + h, 2)
        dn = self.evaluate(tt - h, 2)
        return np.asarray((up - dn) / (2 * h))


def _arc_length_path(traj: PiecewisePolynomial, knots_per_segment: int) -> Any:
    """The path of ``traj`` as a toppra cubic spline over joint-space arc length, through
    points evenly spaced in arc length. Unlike time, arc length stays a regular parameter where
    the trajectory rests (its speed vanishes there to high order, which toppra cannot handle)."""
    from toppra import SplineInterpolator

    n_seg = len(traj.times) - 1
    dense_t = np.linspace(traj.times[0], traj.times[-1], 200 * n_seg + 1)
    q = traj.evaluate(dense_t)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    if arc[-1] <= 0.0:
        raise InvalidInputError("the path has zero length; nothing to retime")
    sigma = np.linspace(0.0, arc[-1], knots_per_segment * n_seg + 1)
    knot_t = np.interp(sigma, arc, dense_t)
    return SplineInterpolator(sigma, traj.evaluate(knot_t), bc_type="clamped")


def toppra_retime(
    traj: PiecewisePolynomial,
    limits: MotionLimits,
    gridpoints: int = 2000,
    knots_per_segment: int = 40,
    rounds: int = 4,
) -> ToppraTrajectory:
    """Time-optimal retiming of the path of ``traj`` with toppra under the velocity and
    acceleration limits (jerk is not limited). The path is handed to toppra as a cubic spline
    over arc length through ``knots_per_segment`` points per segment. toppra enforces the
    limits at ``gridpoints`` path points; between them they can be exceeded slightly, so the
    limits are tightened by the excess measured on 20001 samples and toppra re-run (up to
    ``rounds`` times)."""
    import toppra
    import toppra.algorithm as algorithm
    import toppra.constraint as constraint

    toppra.setup_logging("WARNING")
    J = traj.coefficients.shape[2]
    given = limits.per_joint(J)
    if "velocity" not in given or "acceleration" not in given:
        raise InvalidInputError("toppra retiming needs velocity and acceleration limits")
    path = _arc_length_path(traj, knots_per_segment)
    start, end = path.path_interval
    grid = np.linspace(float(start), float(end), gridpoints + 1)
    v_lim, a_lim = given["velocity"].copy(), given["acceleration"].copy()
    result: ToppraTrajectory | None = None
    for round_ in range(max(rounds, 1)):
        check_time(f"retiming with toppra (run {round_ + 1})")
        instance = algorithm.TOPPRA(
            [
                constraint.JointVelocityConstraint(np.stack([-v_lim, v_lim], axis=1)),
                constraint.JointAccelerationConstraint(np.stack([-a_lim, a_lim], axis=1)),
            ],
            path,
            gridpoints=grid,
            parametrizer="ParametrizeConstAccel",
        )
        spline = instance.compute_trajectory(0.0, 0.0)
        if spline is None:
            raise InvalidInputError("toppra could not parametrise the path under these limits")
        result = ToppraTrajectory(spline, float(spline.duration))
        v, a, _ = _sampled_peaks(result, 20001)
        over_v, over_a = v / given["velocity"], a / given["acceleration"]
        if max(over_v.max(), over_a.max()) <= 1 + 1e-3:
            break
        v_lim = v_lim / np.maximum(over_v, 1.0)
        a_lim = a_lim / np.maximum(over_a, 1.0)
    assert result is not None
    return result


class RuckigTrajectory:
    """Consecutive ruckig state-to-state motions, as a ``JointTrajectory``."""

    def __init__(self, pieces: list[Any], durations: FloatArray) -> None:
        self._pieces = pieces
        self._knots = np.concatenate([[0.0], np.cumsum(durations)])

    @property
    def start(self) -> float:
        return 0.0

    @property
    def duration(self) -> float:
        return float(self._knots[-1])

    def evaluate(self, t: ArrayLike, derivative: int = 0) -> FloatArray:
        tt = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), 0.0, self.duration)
        if derivative == 3:
            h = 1e-6 * max(self.duration, 1e-9)
            return (self.evaluate(tt + h, 2) - self.evaluate(tt - h, 2)) / (2 * h)
        if derivative > 3:
            raise InvalidInputError("ruckig trajectories have derivatives up to jerk")
        piece = np.clip(
            np.searchsorted(self._knots, tt, side="right") - 1, 0, len(self._pieces) - 1
        )
        local = tt - self._knots[piece]
        rows = [
            self._pieces[k].at_time(float(ti))[derivative]
            for k, ti in zip(piece, local, strict=True)
        ]
        return np.array(rows, dtype=np.float64).reshape(tt.size, -1)


def ruckig_retime(traj: PiecewisePolynomial, limits: MotionLimits) -> RuckigTrajectory:
    """Jerk-limited time-optimal motion through the waypoints (knots) of ``traj``, passing each
    with ``traj``'s velocity and acceleration there; ``traj`` must meet the limits (use
    ``scaled``) so these states are admissible."""
    from ruckig import InputParameter, Result, Ruckig, Trajectory

    J = traj.coefficients.shape[2]
    given = limits.per_joint(J)
    if not all(k in given for k in ("velocity", "acceleration", "jerk")):
        raise InvalidInputError("ruckig retiming needs velocity, acceleration and jerk limits")
    q, v, a = (traj.evaluate(traj.times, d) for d in (0, 1, 2))
    generator = Ruckig(J)
    pieces: list[Any] = []
    durations = []
    for i in range(len(traj.times) - 1):
        check_time(f"retiming with ruckig (segment {i + 1})")
        inp = InputParameter(J)
        inp.current_position, inp.current_velocity, inp.current_acceleration = (
            q[i].tolist(),
            v[i].tolist(),
            a[i].tolist(),
        )
        inp.target_position, inp.target_velocity, inp.target_acceleration = (
            q[i + 1].tolist(),
            v[i + 1].tolist(),
            a[i + 1].tolist(),
        )
        inp.max_velocity = given["velocity"].tolist()
        inp.max_acceleration = given["acceleration"].tolist()
        inp.max_jerk = given["jerk"].tolist()
        piece = Trajectory(J)
        status = generator.calculate(inp, piece)
        if status not in (Result.Working, Result.Finished):
            raise InvalidInputError(f"ruckig failed between waypoints {i} and {i + 1}: {status}")
        pieces.append(piece)
        durations.append(piece.duration)
    return RuckigTrajectory(pieces, np.array(durations))


def compare_retimings(
    waypoints: ArrayLike,
    times: ArrayLike,
    limits: MotionLimits,
    *,
    kind: str = "snap",
    methods: tuple[str, ...] = RETIMING_METHODS,
) -> list[Retimed]:
    """Every requested retiming of the waypoints (at the given relative segment times) under
    ``limits``, with durations, peaks and computing times."""
    unknown = set(methods) - set(RETIMING_METHODS)
    if unknown:
        raise InvalidInputError(
            f"unknown retiming method(s) {sorted(unknown)}; choose from {RETIMING_METHODS}"
        )
    out = []
    started = time.perf_counter()
    free = minimum_snap(waypoints, times, kind=kind)
    base = scaled(free, limits)
    if "scaled" in methods:
        out.append(_retimed("scaled", base, started, exact=True))
    if "bounded" in methods:
        check_time("retiming")
        started = time.perf_counter()
        out.append(
            _retimed(
                "bounded", shortest_bounded(waypoints, times, limits, kind=kind), started, True
            )
        )
    if "toppra" in methods:
        check_time("retiming")
        started = time.perf_counter()
        out.append(_retimed("toppra", toppra_retime(base, limits), started, exact=False))
    if "ruckig" in methods:
        check_time("retiming")
        started = time.perf_counter()
        out.append(_retimed("ruckig", ruckig_retime(base, limits), started, exact=False))
    return out
