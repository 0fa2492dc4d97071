"""Minimum-snap and minimum-jerk joint trajectories through waypoints (seed 003 section 2.2.3).

Each joint is a piecewise polynomial of degree ``2 r - 1`` (``r = 4`` snap, ``r = 3`` jerk), one
piece per segment between waypoints. The cost is the integral of the squared ``r``-th derivative,
a quadratic form in the coefficients; waypoints, continuity of the derivatives ``1 ..
continuity`` at the inner waypoints and the boundary derivatives (rest, or given) are linear
equality constraints. The optimum solves one sparse KKT system, factorised once and solved for
every joint. Coefficients are kept in the normalised time ``s = t / T_i`` of each segment, so the
system stays well conditioned for any segment durations.

Bounds (:mod:`armpath.budget`): at most ``MAX_WAYPOINTS`` waypoints of ``MAX_JOINTS`` joints,
checked before any work; the bounded QP re-solves at most ``MAX_QP_ROUNDS`` times a joint and
checks the time limit in force before every solve.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.sparse.linalg import splu

from armpath.budget import MAX_JOINTS, MAX_WAYPOINTS, check_size, check_time
from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]
ORDERS = {"jerk": 3, "snap": 4}


class InfeasibleLimitsError(InvalidInputError):
    """The motion limits cannot be met with the given segment times (the bounded QP is
    infeasible, or at the edge of feasibility)."""


class QPSolverError(InvalidInputError):
    """The QP solver stopped without a solution (neither solved nor proved infeasible)."""


def _falling(k: int, d: int) -> float:
    """k (k-1) ... (k-d+1): the factor of s^(k-d) in the d-th derivative of s^k."""
    return float(factorial(k) // factorial(k - d)) if k >= d else 0.0


@dataclass(frozen=True)
class PiecewisePolynomial:
    """Joint trajectories: ``coefficients[i, k, j]`` of ``s^k`` on segment ``i`` for joint ``j``,
    ``s = (t - times[i]) / (times[i+1] - times[i])``; ``times`` (s) has one entry per waypoint."""

    times: FloatArray
    coefficients: FloatArray
    order: int

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def evaluate(self, t: ArrayLike, derivative: int = 0) -> FloatArray:
        """Values ``(len(t), joints)`` of the ``derivative``-th time derivative at times ``t``
        (clamped to the trajectory's span)."""
        tt = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), self.times[0], self.times[-1])
        seg = np.clip(np.searchsorted(self.times, tt, side="right") - 1, 0, len(self.times) - 2)
        T = self.times[seg + 1] - self.times[seg]
        s = (tt - self.times[seg]) / T
        n = self.coefficients.shape[1]
        out = np.zeros((tt.shape[0], self.coefficients.shape[2]))
        for k in range(derivative, n):
            out += (
                _falling(k, derivative)
                * (s ** (k - derivative))[:, None]
                * self.coefficients[seg, k, :]
            )
        return np.asarray(out / (T**derivative)[:, None])

    def peak(self, derivative: int = 1) -> FloatArray:
        """Largest ``|d^derivative q / dt^derivative|`` of each joint over the whole trajectory
        (at the local extremes of every segment, refined by Newton steps; unit/s^derivative)."""
        fine = np.linspace(0.0, 1.0, 129)
        T = np.diff(self.times)
        out = np.zeros(self.coefficients.shape[2])
        for j in range(out.size):
            seg, s = _peak_points(self.coefficients[:, :, j], derivative, fine)
            c = _derivative_in_s(self.coefficients[seg, :, j], derivative)
            values = _horner(c, s[:, None])[:, 0] / T[seg] ** derivative
            out[j] = float(np.max(np.abs(values)))
        return out

    def time_scaled(self, factor: float) -> PiecewisePolynomial:
        """The same path ``factor`` times slower (velocities / factor, accelerations /
        factor^2, ...); the coefficients, kept in normalised segment time, are unchanged."""
        if not (np.isfinite(factor) and factor > 0):
            raise InvalidInputError(f"time scale factor must be > 0, got {factor}")
        times = self.times[0] + factor * (self.times - self.times[0])
        return PiecewisePolynomial(times, self.coefficients, self.order)

    def cost(self) -> FloatArray:
        """Integral of the squared ``order``-th derivative per joint (unit^2 / s^(2 order - 1))."""
        total = np.zeros(self.coefficients.shape[2])
        for i in range(len(self.times) - 1):
            T = self.times[i + 1] - self.times[i]
            Q = _cost_matrix(self.coefficients.shape[1], self.order) * T ** (1 - 2 * self.order)
            c = self.coefficients[i]
            total += np.einsum("kj,kl,lj->j", c, Q, c)
        return total


def _cost_matrix(n: int, r: int) -> FloatArray:
    """``Q[k, l] = integral_0^1 (d^r s^k)(d^r s^l) ds`` for coefficients of ``s^0 .. s^(n-1)``."""
    Q = np.zeros((n, n))
    for k in range(r, n):
        for m in range(r, n):
            Q[k, m] = _falling(k, r) * _falling(m, r) / (k + m - 2 * r + 1)
    return Q


@dataclass(frozen=True)
class MotionLimits:
    """Per-joint motion limits in the trajectory's joint unit (``None``: not limited).

    ``lower`` / ``upper`` bound the position (unit); ``velocity`` (unit/s), ``acceleration``
    (unit/s^2) and ``jerk`` (unit/s^3) bound the magnitude of the derivatives. Scalars apply to
    every joint.
    """

    velocity: ArrayLike | None = None
    acceleration: ArrayLike | None = None
    jerk: ArrayLike | None = None
    lower: ArrayLike | None = None
    upper: ArrayLike | None = None

    def per_joint(self, joints: int) -> dict[str, FloatArray]:
        """The given limits broadcast to ``(joints,)``, by name; checked to be meaningful."""
        out: dict[str, FloatArray] = {}
        for name in ("velocity", "acceleration", "jerk", "lower", "upper"):
            value = getattr(self, name)
            if value is None:
                continue
            try:
                v = np.broadcast_to(np.asarray(value, dtype=np.float64), (joints,)).copy()
            except ValueError:
                raise InvalidInputError(
                    f"{name} limit needs 1 or {joints} values, got {np.shape(value)}"
                ) from None
            if name in ("velocity", "acceleration", "jerk") and not np.all(
                np.isfinite(v) & (v > 0)
            ):
                raise InvalidInputError(f"{name} limits must be > 0 and finite, got {v.tolist()}")
            if name in ("lower", "upper") and not np.all(np.isfinite(v)):
                raise InvalidInputError(f"{name} position limits must be finite")
            out[name] = v
        if "lower" in out and "upper" in out and np.any(out["lower"] >= out["upper"]):
            raise InvalidInputError("lower position limits must be below the upper ones")
        return out


#: Which derivative each limit bounds.
LIMIT_DERIVATIVE = {"lower": 0, "upper": 0, "velocity": 1, "acceleration": 2, "jerk": 3}
QP_SOLVERS = ("clarabel", "osqp")
#: Largest number of limit sample points per segment of the bounded QP.
MAX_SAMPLES_PER_SEGMENT = 256
#: A limit counts as met when exceeded by at most this fraction of it.
LIMIT_RTOL = 1e-5
MAX_QP_ROUNDS = 12


@dataclass(frozen=True)
class _Problem:
    """The equality-constrained problem: cost ``x' Q x`` (scaled), ``A x = B[:, joint]``."""

    Q: sparse.csc_matrix
    A: sparse.csc_matrix
    B: FloatArray
    n_seg: int
    n: int
    order: int
    continuity: int

    def pinned(self, d: int, seg: NDArray[np.int64], s: FloatArray) -> NDArray[np.bool_]:
        """Points where the ``d``-th derivative is already fixed or repeated by the equality
        constraints (waypoints, boundary derivatives, the left end of a continuous knot); a limit
        row there adds nothing but a dependent constraint."""
        at_start, at_end = s <= 0.0, s >= 1.0
        if d == 0:
            return np.asarray(at_start | at_end)
        boundary = 1 <= d <= self.order - 1
        return np.asarray(
            (at_start & (((seg > 0) & (d <= self.continuity)) | ((seg == 0) & boundary)))
            | (at_end & (seg == self.n_seg - 1) & boundary)
        )


def _equality_problem(
    W: FloatArray, t: FloatArray, r: int, cont: int, bounds: list[FloatArray]
) -> _Problem:
    n_seg, n, J = W.shape[0] - 1, 2 * r, W.shape[1]
    segs = np.arange(n_seg)
    zeros, ones = np.zeros(n_seg), np.ones(n_seg)
    first, last = np.array([0]), np.array([n_seg - 1])
    # Each entry: the rows' indices, their segments, the weights (rows, n) and the right-hand side.
    parts: list[tuple[NDArray[np.int64], NDArray[np.int64], FloatArray]] = []
    rhs: list[FloatArray] = []
    count = 0

    def add(terms: list[tuple[NDArray[np.int64], FloatArray]], b: FloatArray) -> None:
        nonlocal count
        rows = count + np.arange(b.shape[0])
        parts.extend((rows, seg, weights) for seg, weights in terms)
        rhs.append(b)
        count += b.shape[0]

    # each segment starts at its waypoint and ends at the next
    add([(segs, _derivative_weights(t, n, 0, segs, zeros))], W[:-1])
    add([(segs, _derivative_weights(t, n, 0, segs, ones))], W[1:])
    for d in range(1, cont + 1):  # derivative d continuous at the inner waypoints
        add(
            [
                (segs[:-1], _derivative_weights(t, n, d, segs[:-1], ones[:-1])),
                (segs[1:], -_derivative_weights(t, n, d, segs[1:], zeros[1:])),
            ],
            np.zeros((n_seg - 1, J)),
        )
    for d in range(1, r):  # boundary derivatives
        add([(first, _derivative_weights(t, n, d, first, zeros[:1]))], bounds[0][d - 1][None, :])
        add([(last, _derivative_weights(t, n, d, last, ones[:1]))], bounds[1][d - 1][None, :])
    k = np.arange(n)
    A = sparse.csr_matrix(
        (
            np.concatenate([w.ravel() for _, _, w in parts]),
            (
                np.concatenate([np.repeat(rows, n) for rows, _, _ in parts]),
                np.concatenate([(seg[:, None] * n + k).ravel() for _, seg, _ in parts]),
            ),
        ),
        shape=(count, n_seg * n),
    )
    A.eliminate_zeros()
    b = np.vstack(rhs)
    Q = sparse.kron(sparse.diags(np.diff(t) ** (1 - 2 * r)), _cost_matrix(n, r), format="csc")
    # Scale the cost so its entries are comparable to the constraints' (does not move the optimum).
    Q = Q / max(abs(Q).max(), 1e-300)
    # Rows scaled to unit largest entry (same solution, better conditioned for the QP solvers).
    row_scale = 1.0 / np.asarray(abs(A).max(axis=1).todense()).ravel()
    A = sparse.diags(row_scale) @ A
    B = b * row_scale[:, None]
    return _Problem(sparse.csc_matrix(Q), sparse.csc_matrix(A), B, n_seg, n, r, cont)


def _derivative_weights(
    t: FloatArray, n: int, d: int, seg: NDArray[np.int64], s: FloatArray
) -> FloatArray:
    """Weights ``(len(seg), n)`` of segment coefficients in the ``d``-th time derivative at
    normalised times ``s`` of segments ``seg``."""
    T = (t[seg + 1] - t[seg])[:, None]
    k = np.arange(n)
    weights = np.array([_falling(int(kk), d) for kk in k])[None, :]
    power = np.clip(k - d, 0, None)[None, :]
    return np.asarray(np.where(k[None, :] >= d, weights * s[:, None] ** power, 0.0) / T**d)


def _derivative_rows(
    t: FloatArray, n: int, d: int, seg: NDArray[np.int64], s: FloatArray
) -> sparse.csr_matrix:
    """Rows giving the ``d``-th time derivative at normalised times ``s`` of segments ``seg``."""
    vals = _derivative_weights(t, n, d, seg, s)
    rows = np.repeat(np.arange(len(seg)), n)
    cols = (seg[:, None] * n + np.arange(n)[None, :]).ravel()
    return sparse.csr_matrix((vals.ravel(), (rows, cols)), shape=(len(seg), (len(t) - 1) * n))


def _limit_rows(
    problem: _Problem,
    t: FloatArray,
    limits: dict[str, FloatArray],
    joint: int,
    seg: NDArray[np.int64],
    s: FloatArray,
) -> tuple[sparse.csr_matrix, FloatArray]:
    """``G x <= h`` at the given points (those not pinned by equalities) for every limit of one
    joint, rows scaled to ``h = +-1`` (velocity, acceleration, jerk: both signs; positions: one
    side each)."""
    blocks, rhs = [], []
    for name, value in limits.items():
        d = LIMIT_DERIVATIVE[name]
        keep = ~problem.pinned(d, seg, s)
        D = _derivative_rows(t, problem.n, d, seg[keep], s[keep])
        v = float(value[joint])
        if name == "lower":
            scale = max(abs(v), 1.0)
            blocks.append(-D / scale)
            rhs.append(np.full(D.shape[0], -v / scale))
        elif name == "upper":
            scale = max(abs(v), 1.0)
            blocks.append(D / scale)
            rhs.append(np.full(D.shape[0], v / scale))
        else:
            blocks += [D / v, -D / v]
            rhs += [np.ones(D.shape[0]), np.ones(D.shape[0])]
    return sparse.csr_matrix(sparse.vstack(blocks)), np.concatenate(rhs)


def _solve_qp(
    problem: _Problem,
    G: sparse.csr_matrix,
    h: FloatArray,
    b: FloatArray,
    solver: str,
    cost_scale: float,
) -> tuple[FloatArray | None, str]:
    """One joint's QP: its solution, or ``None`` and the solver's status. ``cost_scale`` makes
    the cost of order one (the solvers' optimality tolerances are absolute)."""
    import warnings

    from qpsolvers import Problem, solve_problem

    kwargs: dict[str, float] = (
        {"eps_abs": 1e-8, "eps_rel": 1e-8, "max_iter": 200000, "polish": True}
        if solver == "osqp"
        else {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10}
    )
    qp = Problem(
        (2.0 * cost_scale) * problem.Q,
        np.zeros(problem.Q.shape[0]),
        sparse.csc_matrix(G),
        h,
        problem.A,
        b,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the status is reported in our own error instead
        solution = solve_problem(qp, solver, None, False, **kwargs)
    info = solution.extras.get("info")
    status = str(getattr(info, "status", None) or solution.extras.get("status", "failed"))
    x = solution.x
    if x is None or not np.all(np.isfinite(x)) or not solution.found:
        return None, status
    return np.asarray(x), status


def minimum_snap(
    waypoints: ArrayLike,
    times: ArrayLike,
    *,
    kind: str = "snap",
    continuity: int | None = None,
    start_derivatives: ArrayLike | None = None,
    end_derivatives: ArrayLike | None = None,
    limits: MotionLimits | None = None,
    solver: str = "clarabel",
    samples_per_segment: int = 16,
) -> PiecewisePolynomial:
    """The minimum-snap (``kind="snap"``) or minimum-jerk (``"jerk"``) trajectory through
    ``waypoints`` ``(m, joints)`` at ``times`` ``(m,)`` (s, increasing).

    ``continuity`` (``r - 1 .. 2 r - 2``): derivatives ``1 .. continuity`` are continuous at the
    inner waypoints (default ``r - 1``: velocity, acceleration, jerk for snap; the optimum is then
    smooth up to ``2 r - 2`` by itself). Boundary derivatives ``1 .. r - 1`` are zero (rest to
    rest) unless ``start_derivatives`` / ``end_derivatives`` ``(r - 1, joints)`` give them.

    Without ``limits`` the optimum is one sparse KKT solve for all joints. With ``limits``
    (position, velocity, acceleration, jerk; in the waypoints' unit) each joint is a QP solved by
    ``solver`` (``"clarabel"`` or ``"osqp"``, through qpsolvers). The limits are imposed at
    ``samples_per_segment`` evenly spaced times per segment; the result is then checked at every
    local extreme of each bounded derivative (found on a grid 8 times finer and refined by
    Newton steps), violated extremes are added and the QP solved again (at most
    ``MAX_QP_ROUNDS`` solves), so each limit holds along the whole trajectory to ``LIMIT_RTOL``
    (1e-5) of its value. Raises ``InfeasibleLimitsError`` (an ``InvalidInputError``) when the
    limits cannot be met with these segment times (lengthen them, e.g. ``allocate_times``).

    At most ``MAX_WAYPOINTS`` waypoints of ``MAX_JOINTS`` joints; segment durations must keep
    their ``(2 r - 1)``-th powers within the floating-point range (see
    :func:`segment_durations_ok`).
    """
    if kind not in ORDERS:
        raise InvalidInputError(f"kind must be one of {tuple(ORDERS)}, got {kind!r}")
    r = ORDERS[kind]
    W = np.asarray(waypoints, dtype=np.float64)
    if W.ndim == 1:
        W = W[:, None]
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if W.ndim != 2 or W.shape[0] < 2 or t.shape[0] != W.shape[0] or W.shape[1] < 1:
        raise InvalidInputError(
            f"need at least 2 waypoints of at least 1 joint and one time per waypoint, got "
            f"{W.shape[0]} waypoints of {W.shape[1] if W.ndim == 2 else 0} joints and "
            f"{t.shape[0]} times"
        )
    check_size(W.shape[0], MAX_WAYPOINTS, "waypoints", "the waypoints")
    check_size(W.shape[1], MAX_JOINTS, "joints", "the waypoints")
    if not (np.all(np.isfinite(W)) and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise InvalidInputError("waypoints must be finite and times strictly increasing")
    if not segment_durations_ok(np.diff(t), r):
        lo, hi = _duration_range(r)
        raise InvalidInputError(
            f"segment durations must lie within {lo:.1e} .. {hi:.1e} s for minimum {kind}, got "
            f"{np.diff(t).min():.3g} .. {np.diff(t).max():.3g} s"
        )
    cont = r - 1 if continuity is None else int(continuity)
    if not r - 1 <= cont <= 2 * r - 2:
        raise InvalidInputError(
            f"continuity must be in {r - 1}..{2 * r - 2} for {kind} (below {r - 1} the optimum is "
            f"not unique), got {cont}"
        )
    J = W.shape[1]
    bounds = []
    for given in (start_derivatives, end_derivatives):
        if given is None:
            bounds.append(np.zeros((r - 1, J)))
        else:
            g = np.asarray(given, dtype=np.float64).reshape(r - 1, -1)
            if g.shape[1] != J or not np.all(np.isfinite(g)):
                raise InvalidInputError(
                    f"boundary derivatives must be {r - 1} finite rows of {J} values"
                )
            bounds.append(g)
    per_joint = limits.per_joint(J) if limits is not None else {}
    if per_joint and solver not in QP_SOLVERS:
        raise InvalidInputError(f"solver must be one of {QP_SOLVERS}, got {solver!r}")
    if not 2 <= samples_per_segment <= MAX_SAMPLES_PER_SEGMENT:
        raise InvalidInputError(
            f"samples_per_segment must be in 2..{MAX_SAMPLES_PER_SEGMENT}, got "
            f"{samples_per_segment}"
        )
    _check_fixed_values(per_joint, W, bounds)
    problem = _equality_problem(W, t, r, cont, bounds)
    if not per_joint:
        coeffs = _kkt_solve(problem)
    else:
        coeffs = _bounded_solve(problem, t, per_joint, solver, samples_per_segment)
    return PiecewisePolynomial(t.copy(), coeffs, r)


def _duration_range(r: int) -> tuple[float, float]:
    """Shortest and longest segment durations (s) whose ``(2 r - 1)``-th power is a normal,
    finite float."""
    info = np.finfo(np.float64)
    p = 1.0 / (2 * r - 1)
    return float(info.tiny) ** p, float(info.max) ** p


def segment_durations_ok(durations: ArrayLike, r: int) -> bool:
    """Whether every segment duration (s) can be used by the solve of order ``r`` (4: snap,
    3: jerk): its cost weight ``T^(1 - 2 r)`` and the derivative scales ``T^-d`` (d < 2 r)
    neither overflow nor vanish."""
    T = np.asarray(durations, dtype=np.float64)
    lo, hi = _duration_range(r)
    return bool(np.all(np.isfinite(T) & (lo <= T) & (hi >= T)))


def _check_fixed_values(
    limits: dict[str, FloatArray], W: FloatArray, bounds: list[FloatArray]
) -> None:
    """Waypoints and given boundary derivatives must themselves respect the limits."""
    tol = 1e-9
    if "lower" in limits and np.any(limits["lower"] - tol > W):
        raise InvalidInputError("a waypoint lies below the lower position limit")
    if "upper" in limits and np.any(limits["upper"] + tol < W):
        raise InvalidInputError("a waypoint lies above the upper position limit")
    for name in ("velocity", "acceleration", "jerk"):
        d = LIMIT_DERIVATIVE[name]
        if name in limits and d <= bounds[0].shape[0]:
            for given in bounds:
                if np.any(np.abs(given[d - 1]) > limits[name] * (1 + tol)):
                    raise InvalidInputError(f"a given boundary {name} exceeds its limit")


def _kkt_solve(problem: _Problem) -> FloatArray:
    K = sparse.bmat([[2.0 * problem.Q, problem.A.T], [problem.A, None]], format="csc")
    rhs = np.vstack([np.zeros((problem.Q.shape[0], problem.B.shape[1])), problem.B])
    try:
        sol = splu(K).solve(rhs)
    except RuntimeError as exc:
        raise InvalidInputError(f"the waypoint constraints are inconsistent ({exc})") from None
    if not np.all(np.isfinite(sol)):
        raise InvalidInputError("the KKT system of the trajectory is singular")
    return np.asarray(sol[: problem.Q.shape[0]].reshape(problem.n_seg, problem.n, -1))


def _derivative_in_s(c: FloatArray, d: int) -> FloatArray:
    """Coefficients (in s) of the ``d``-th s-derivative of polynomials ``c`` ``(..., n)``."""
    n = c.shape[-1]
    if d >= n:
        return np.zeros((*c.shape[:-1], 1))
    w = np.array([_falling(k + d, d) for k in range(n - d)])
    return np.asarray(c[..., d:] * w)


def _horner(c: FloatArray, s: FloatArray) -> FloatArray:
    """Values of polynomials ``c`` ``(m, n)`` at ``s`` ``(m, p)`` (one row of points each)."""
    out = np.zeros(s.shape)
    for k in range(c.shape[-1] - 1, -1, -1):
        out = out * s + c[:, k : k + 1]
    return out


def _peak_points(c: FloatArray, d: int, fine: FloatArray) -> tuple[NDArray[np.int64], FloatArray]:
    """Segments and normalised times of the local maxima of ``|d^d p / ds^d|`` on every segment
    of one joint (``c``: ``(n_seg, n)``): grid maxima on ``fine`` refined by Newton steps on the
    next derivative, kept inside [0, 1]."""
    p, p1, p2 = (_derivative_in_s(c, d + e) for e in range(3))
    a = np.abs(_horner(p, np.broadcast_to(fine, (c.shape[0], fine.size))))
    padded = np.pad(a, ((0, 0), (1, 1)), constant_values=-1.0)
    peak = (a >= padded[:, :-2]) & (a >= padded[:, 2:])
    seg, idx = np.nonzero(peak)
    s = fine[idx].copy()
    for _ in range(6):
        f = _horner(p1[seg], s[:, None])[:, 0]
        fp = _horner(p2[seg], s[:, None])[:, 0]
        step = np.where(np.abs(fp) > 1e-300, f / np.where(fp == 0.0, 1.0, fp), 0.0)
        trial = np.clip(s - step, 0.0, 1.0)
        # Keep a Newton step only where it does not lower |value| (stays on the peak).
        better = np.abs(_horner(p[seg], trial[:, None])[:, 0]) >= np.abs(
            _horner(p[seg], s[:, None])[:, 0]
        )
        s = np.where(better, trial, s)
    return seg.astype(np.int64), s


def _signed(c: FloatArray, name: str) -> FloatArray:
    """Segment coefficients (``(n_seg, n)``, one joint) whose largest magnitudes are where a
    limit ``name`` may be broken: a position limit's side alone (the position moved wholly
    below zero for ``lower``, so its minima are the peaks, wholly above for ``upper``); the
    rates' both signs as they are."""
    if name not in ("lower", "upper"):
        return c
    beyond = float(np.abs(c).sum(axis=1).max()) + 1.0  # |q| on any segment is below this
    shifted = c.copy()
    shifted[:, 0] += -beyond if name == "lower" else beyond
    return shifted


def _bounded_solve(
    problem: _Problem,
    t: FloatArray,
    limits: dict[str, FloatArray],
    solver: str,
    samples: int,
) -> FloatArray:
    n_seg, n = problem.n_seg, problem.n
    grid = np.linspace(0.0, 1.0, samples)
    seg = np.repeat(np.arange(n_seg), samples)
    s = np.tile(grid, n_seg)
    fine = np.linspace(0.0, 1.0, 8 * (samples - 1) + 1)
    # Interior-point Clarabel converges faster with the moving peak bracketed by close rows;
    # OSQP (ADMM) slows down badly on such nearly parallel rows, so it gets the peak alone.
    bracket = 0.25 * fine[1] if solver == "clarabel" else 0.0
    coeffs = np.empty((n_seg, n, problem.B.shape[1]))
    free = _kkt_solve(problem)
    for j in range(problem.B.shape[1]):
        G, h = _limit_rows(problem, t, limits, j, seg, s)
        # Start from the sample points where the unbounded optimum comes within half of a limit;
        # the rounds below add any other point that turns out to matter.
        x_free = free[:, :, j].ravel()
        near = np.flatnonzero(G @ x_free - h > -0.5)
        cost_scale = 1.0 / max(float(x_free @ problem.Q @ x_free), 1e-12)
        G, h = G[near], h[near]
        for round_ in range(MAX_QP_ROUNDS):
            check_time(f"solving the bounded QP (joint {j + 1}, round {round_ + 1})")
            x, status = (
                (x_free, "unbounded optimum")
                if G.shape[0] == 0
                else _solve_qp(problem, G, h, problem.B[:, j], solver, cost_scale)
            )
            if x is None:
                if "infeasib" in status.lower():
                    raise InfeasibleLimitsError(
                        f"joint {j + 1}: the limits cannot be met with these segment times "
                        f"(the trajectory lasts {t[-1] - t[0]:.4g} s); lengthen the segments"
                    )
                raise QPSolverError(
                    f"joint {j + 1}: the {solver} QP solver stopped without a solution "
                    f"(status: {status}); try the other solver of {QP_SOLVERS}"
                )
            # Check every limit at the local extremes of its derivative; add those violated.
            new_G, new_h = [], []
            for name in limits:
                d = LIMIT_DERIVATIVE[name]
                pseg, ps = _peak_points(_signed(x.reshape(n_seg, n), name), d, fine)
                keep = ~problem.pinned(d, pseg, ps)
                pseg, ps = pseg[keep], ps[keep]
                if ps.size == 0:
                    continue
                Gp, hp = _limit_rows(problem, t, {name: limits[name]}, j, pseg, ps)
                excess = (Gp @ x - hp).reshape(-1, ps.size).max(axis=0)
                bad = np.flatnonzero(excess > LIMIT_RTOL)
                if bad.size:
                    # The peak moves as the QP adjusts; bracket it so it converges in few rounds.
                    offsets = np.array([-bracket, 0.0, bracket]) if bracket else np.zeros(1)
                    near_seg = np.repeat(pseg[bad], offsets.size)
                    near_s = np.clip((ps[bad][:, None] + offsets).ravel(), 0.0, 1.0)
                    Gb, hb = _limit_rows(problem, t, {name: limits[name]}, j, near_seg, near_s)
                    new_G.append(Gb)
                    new_h.append(hb)
            if not new_G:
                break
            G = sparse.csr_matrix(sparse.vstack([G, *new_G]))
            h = np.concatenate([h, *new_h])
        else:
            raise InfeasibleLimitsError(
                f"joint {j + 1}: the {solver} QP did not meet the limits between its sample "
                f"points after {MAX_QP_ROUNDS} rounds; the segment times are at the edge of "
                "feasibility, lengthen them slightly"
            )
        coeffs[:, :, j] = x.reshape(n_seg, n)
    return coeffs


def allocate_times(
    waypoints: ArrayLike, max_velocity: ArrayLike, max_acceleration: ArrayLike, start: float = 0.0
) -> FloatArray:
    """Waypoint times (s): each segment gets the slowest joint's rest-to-rest trapezoid time
    under per-joint velocity and acceleration limits (unit/s, unit/s^2)."""
    W = np.asarray(waypoints, dtype=np.float64)
    if W.ndim == 1:
        W = W[:, None]
    v = np.broadcast_to(np.asarray(max_velocity, dtype=np.float64), (W.shape[1],))
    a = np.broadcast_to(np.asarray(max_acceleration, dtype=np.float64), (W.shape[1],))
    if not (np.all(np.isfinite(v) & (v > 0)) and np.all(np.isfinite(a) & (a > 0))):
        raise InvalidInputError("velocity and acceleration limits must be finite and > 0")
    if not np.all(np.isfinite(W)):
        raise InvalidInputError("waypoints must be finite")
    d = np.abs(np.diff(W, axis=0))
    trapezoid = np.where(d > v**2 / a, d / v + v / a, 2.0 * np.sqrt(d / a))
    seg = np.maximum(trapezoid.max(axis=1), 1e-3)
    return np.asarray(start + np.concatenate([[0.0], np.cumsum(seg)]), dtype=np.float64)
