"""Minimum-snap and minimum-jerk joint trajectories through waypoints (seed 003 section 2.2.3).

Each joint is a piecewise polynomial of degree ``2 r - 1`` (``r = 4`` snap, ``r = 3`` jerk), one
piece per segment between waypoints. The cost is the integral of the squared ``r``-th derivative,
a quadratic form in the coefficients; waypoints, continuity of the derivatives ``1 ..
continuity`` at the inner waypoints and the boundary derivatives (rest, or given) are linear
equality constraints. The optimum solves one sparse KKT system, factorised once and solved for
every joint. Coefficients are kept in the normalised time ``s = t / T_i`` of each segment, so the
system stays well conditioned for any segment durations.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.sparse.linalg import splu

from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]
ORDERS = {"jerk": 3, "snap": 4}


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


def _row(n: int, d: int, at_end: bool, T: float) -> FloatArray:
    """Coefficients' weights in the ``d``-th time derivative at s = 0 or s = 1."""
    w = np.zeros(n)
    for k in range(d, n):
        w[k] = _falling(k, d) * (1.0 if at_end else (1.0 if k == d else 0.0))
    return w / T**d


def minimum_snap(
    waypoints: ArrayLike,
    times: ArrayLike,
    *,
    kind: str = "snap",
    continuity: int | None = None,
    start_derivatives: ArrayLike | None = None,
    end_derivatives: ArrayLike | None = None,
) -> PiecewisePolynomial:
    """The minimum-snap (``kind="snap"``) or minimum-jerk (``"jerk"``) trajectory through
    ``waypoints`` ``(m, joints)`` at ``times`` ``(m,)`` (s, increasing).

    ``continuity`` (``r - 1 .. 2 r - 2``): derivatives ``1 .. continuity`` are continuous at the
    inner waypoints (default ``r - 1``: velocity, acceleration, jerk for snap; the optimum is then
    smooth up to ``2 r - 2`` by itself). Boundary derivatives ``1 .. r - 1`` are zero (rest to
    rest) unless ``start_derivatives`` / ``end_derivatives`` ``(r - 1, joints)`` give them.
    """
    if kind not in ORDERS:
        raise InvalidInputError(f"kind must be one of {tuple(ORDERS)}, got {kind!r}")
    r = ORDERS[kind]
    W = np.asarray(waypoints, dtype=np.float64)
    if W.ndim == 1:
        W = W[:, None]
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if W.ndim != 2 or W.shape[0] < 2 or t.shape[0] != W.shape[0]:
        raise InvalidInputError(
            f"need at least 2 waypoints and one time per waypoint, got {W.shape[0]} waypoints "
            f"and {t.shape[0]} times"
        )
    if not (np.all(np.isfinite(W)) and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise InvalidInputError("waypoints must be finite and times strictly increasing")
    cont = r - 1 if continuity is None else int(continuity)
    if not r - 1 <= cont <= 2 * r - 2:
        raise InvalidInputError(
            f"continuity must be in {r - 1}..{2 * r - 2} for {kind} (below {r - 1} the optimum is "
            f"not unique), got {cont}"
        )
    n_seg, n, J = W.shape[0] - 1, 2 * r, W.shape[1]
    durations = np.diff(t)
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
    r_idx: list[int] = []
    c_idx: list[int] = []
    vals: list[float] = []
    b: list[FloatArray] = []

    def constraint(entries: list[tuple[int, FloatArray]], rhs: FloatArray) -> None:
        row = len(b)
        for seg, w in entries:
            for k in np.flatnonzero(w):
                r_idx.append(row)
                c_idx.append(seg * n + int(k))
                vals.append(float(w[k]))
        b.append(rhs)

    for i in range(n_seg):
        T = durations[i]
        constraint([(i, _row(n, 0, False, T))], W[i])
        constraint([(i, _row(n, 0, True, T))], W[i + 1])
    for i in range(n_seg - 1):
        for d in range(1, cont + 1):
            constraint(
                [
                    (i, _row(n, d, True, durations[i])),
                    (i + 1, -_row(n, d, False, durations[i + 1])),
                ],
                np.zeros(J),
            )
    for d in range(1, r):
        constraint([(0, _row(n, d, False, durations[0]))], bounds[0][d - 1])
        constraint([(n_seg - 1, _row(n, d, True, durations[-1]))], bounds[1][d - 1])
    A = sparse.csc_matrix((vals, (r_idx, c_idx)), shape=(len(b), n_seg * n))
    Q = sparse.block_diag([_cost_matrix(n, r) * T ** (1 - 2 * r) for T in durations], format="csc")
    # Scale the cost so its entries are comparable to the constraints' (does not move the optimum).
    Q = Q / max(abs(Q).max(), 1e-300)
    K = sparse.bmat([[2.0 * Q, A.T], [A, None]], format="csc")
    rhs = np.vstack([np.zeros((n_seg * n, J)), np.array(b)])
    try:
        sol = splu(K).solve(rhs)
    except RuntimeError as exc:
        raise InvalidInputError(f"the waypoint constraints are inconsistent ({exc})") from None
    if not np.all(np.isfinite(sol)):
        raise InvalidInputError("the KKT system of the trajectory is singular")
    coeffs = sol[: n_seg * n].reshape(n_seg, n, J)
    return PiecewisePolynomial(t.copy(), coeffs, r)


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
    if not (np.all(v > 0) and np.all(a > 0)):
        raise InvalidInputError("velocity and acceleration limits must be > 0")
    d = np.abs(np.diff(W, axis=0))
    trapezoid = np.where(d > v**2 / a, d / v + v / a, 2.0 * np.sqrt(d / a))
    seg = np.maximum(trapezoid.max(axis=1), 1e-3)
    return np.asarray(start + np.concatenate([[0.0], np.cumsum(seg)]), dtype=np.float64)
