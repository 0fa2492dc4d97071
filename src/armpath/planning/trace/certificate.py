"""The deviation certificate of a pass: the largest distance of the continuous tool path from
the curve, proven by branch and bound (the tool point moves at most ``rate * dt`` between two
instants of a command, and distance to the curve is 1-Lipschitz)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.geometry.curves import Curve
from armpath.kinematics import displacement_bounds, tool_position
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def certified_deviation(
    arm: SerialArm, curve: Curve, states: IntArray, s_near: float, precision: float = 0.002
) -> tuple[float, float, FloatArray, FloatArray]:
    """Largest distance (mm) of the continuous tip path through lattice ``states`` (ticks) from
    ``curve``, a proven upper bound (branch and bound: the tip moves at most ``rate * dt`` between
    instants, distance is 1-Lipschitz), and a profile ``(s, deviation)`` sampled 32 times per
    command."""
    states = np.asarray(states, dtype=np.int64)
    if states.shape[0] < 2:
        P = tool_position(arm, arm.lattice.to_joint(states))
        d, s = curve.closest(P)
        return float(d.max()), float(d.max()), s, d
    grid = arm.lattice
    steps = np.diff(states, axis=0).astype(np.float64)
    rate = (np.abs(steps) * grid.tick) @ displacement_bounds(arm)  # mm per unit of u
    n = steps.shape[0]

    def tip(u: FloatArray) -> FloatArray:
        k = np.clip(np.floor(u).astype(np.int64), 0, n - 1)
        return tool_position(arm, grid.to_joint(states[k] + (u - k)[:, None] * steps[k]))

    u = np.linspace(0.0, n, 32 * n + 1)
    d, s = curve.closest(tip(u))
    profile_s = s.copy()
    if curve.closed:
        L = curve.length
        profile_s = np.asarray(np.unwrap(s / L * 2 * np.pi) * L / (2 * np.pi))
        profile_s += L * np.round((s_near - profile_s[0]) / L)
    profile_d = d.copy()
    for _ in range(40):
        k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
        h = np.diff(u)
        bound = 0.5 * (d[:-1] + d[1:] + rate[k] * h)
        best = float(d.max())
        need = bound > best + precision
        if not np.any(need):
            break
        mid = 0.5 * (u[:-1][need] + u[1:][need])
        d_mid, _ = curve.closest(tip(mid))
        order = np.argsort(np.concatenate([u, mid]), kind="stable")
        u = np.concatenate([u, mid])[order]
        d = np.concatenate([d, d_mid])[order]
    k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
    bound = float(np.max(0.5 * (d[:-1] + d[1:] + rate[k] * np.diff(u))))
    return float(d.max()), max(bound, float(d.max())), profile_s, profile_d
