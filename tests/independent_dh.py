"""Independent D-H kinematics and a brute-force IK for the tests (no armpath code).

Written from the textbook formulas: standard ``A = Rz(theta) Tz(d) Tx(a) Rx(alpha)``, modified
(Craig) ``A = Rx(alpha) Tx(a) Rz(theta) Tz(d)``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares


def _rz(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _rx(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _tz(d):
    T = np.eye(4)
    T[2, 3] = d
    return T


def _tx(a):
    T = np.eye(4)
    T[0, 3] = a
    return T


def dh_pose(a, alpha, d, q, *, modified=False, prismatic=None, offset=None):
    """Tool pose of a D-H table at joint values q (revolute: theta = q + offset)."""
    n = len(a)
    prismatic = np.zeros(n, bool) if prismatic is None else np.asarray(prismatic)
    offset = np.zeros(n) if offset is None else np.asarray(offset)
    T = np.eye(4)
    for i in range(n):
        theta = 0.0 if prismatic[i] else q[i] + offset[i]
        dist = d[i] + offset[i] + q[i] if prismatic[i] else d[i]
        if modified:
            T = T @ _rx(alpha[i]) @ _tx(a[i]) @ _rz(theta) @ _tz(dist)
        else:
            T = T @ _rz(theta) @ _tz(dist) @ _tx(a[i]) @ _rx(alpha[i])
    return T


def pose_residual(T, target):
    """(position distance, largest rotation-matrix entry difference)."""
    return float(np.linalg.norm(T[:3, 3] - target[:3, 3])), float(
        np.abs(T[:3, :3] - target[:3, :3]).max()
    )


def brute_force_ik(a, alpha, d, target, *, starts=400, seed=0):
    """Distinct solutions found by scipy least squares from many random starts (6R)."""
    rng = np.random.default_rng(seed)
    scale = max(1.0, float(np.abs(np.r_[a, d]).max()))

    def resid(q):
        T = dh_pose(a, alpha, d, q)
        return np.r_[(T[:3, 3] - target[:3, 3]) / scale, (T[:3, :3] - target[:3, :3]).ravel()]

    found = []
    for _ in range(starts):
        sol = least_squares(resid, rng.uniform(-np.pi, np.pi, 6), xtol=1e-15, ftol=1e-15)
        if np.abs(sol.fun).max() > 1e-9:
            continue
        q = (sol.x + np.pi) % (2 * np.pi) - np.pi
        if not any(np.all(np.abs((q - f + np.pi) % (2 * np.pi) - np.pi) < 1e-5) for f in found):
            found.append(q)
    return found


def dh_positions(a, alpha, d, Q):
    """Tool positions ``(N, 3)`` of a revolute standard D-H table at joint values ``Q (N, n)``
    rad: the product of ``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` for many configurations at once."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    T = np.broadcast_to(np.eye(4), (Q.shape[0], 4, 4)).copy()
    for i in range(len(a)):
        ct, st = np.cos(Q[:, i]), np.sin(Q[:, i])
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        A = np.zeros((Q.shape[0], 4, 4))
        A[:, 0, 0], A[:, 0, 1], A[:, 0, 2], A[:, 0, 3] = ct, -st * ca, st * sa, a[i] * ct
        A[:, 1, 0], A[:, 1, 1], A[:, 1, 2], A[:, 1, 3] = st, ct * ca, -ct * sa, a[i] * st
        A[:, 2, 1], A[:, 2, 2], A[:, 2, 3] = sa, ca, d[i]
        A[:, 3, 3] = 1.0
        T = T @ A
    return T[:, :3, 3]
