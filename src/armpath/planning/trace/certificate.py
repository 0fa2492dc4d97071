"""The deviation certificate of a pass: the largest distance of the continuous tool path from
the curve, proven by branch and bound (the tool point moves at most ``rate * dt`` between two
instants of a command, and distance to the curve is 1-Lipschitz)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.geometry.curves import Curve
from armpath.kinematics import displacement_bounds, tool_position
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


#: The deviation certificate's precision (mm): its bound exceeds the sampled largest deviation by
#: at most this much, or by 2 % of the tolerance where that is less
#: (:func:`certificate_precision`).
PRECISION_MM = 0.002
_PRECISION_SHARE = 0.02


#: Profile samples per command of :func:`certified_deviation` (the profile's sample
#: ``PROFILE_PER_COMMAND * k`` is the ``k``-th state).
PROFILE_PER_COMMAND = 32


def certificate_precision(tolerance_mm: float) -> float:
    """The precision (mm) a pass traced within ``tolerance_mm`` is certified to."""
    return min(PRECISION_MM, _PRECISION_SHARE * tolerance_mm)


def certified_deviation(
    arm: SerialArm, curve: Curve, states: IntArray, s_near: float, precision: float = PRECISION_MM
) -> tuple[float, float, FloatArray, FloatArray]:
    """Largest distance (mm) of the continuous tip path through lattice ``states`` (ticks) from
    ``curve``, a proven upper bound (branch and bound: the tip moves at most ``rate * dt`` between
    instants, distance is 1-Lipschitz), and a profile ``(s, deviation)`` sampled
    :data:`PROFILE_PER_COMMAND` times per command."""
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

    u = np.linspace(0.0, n, PROFILE_PER_COMMAND * n + 1)
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


def certified_axis_angle(
    arm: SerialArm,
    angle_of: Callable[[FloatArray], FloatArray],
    states: IntArray,
    fixed_direction: bool,
    precision: float = 1e-4,
) -> tuple[float, float | None]:
    """Largest angle (rad) of the tool axis from its rule over the continuous motion through
    lattice ``states``, and a proven upper bound of it when the rule's axis is a fixed
    direction (the tool frame turns at most ``sum_i |dq_i|`` over its revolute joints between
    two instants, and the angle to a fixed direction is 1-Lipschitz in the turn); for a rule
    that follows the surface normal the normal's own turning is not bounded, so the largest
    angle is found by sampling :data:`PROFILE_PER_COMMAND` times a command and bisecting
    around the worst instants (bound None)."""
    states = np.asarray(states, dtype=np.int64)
    grid = arm.lattice
    if states.shape[0] < 2:
        a = angle_of(grid.to_joint(states))
        return float(a.max()), float(a.max()) if fixed_direction else None
    steps = np.diff(states, axis=0).astype(np.float64)
    turning = np.where(grid.prismatic, 0.0, np.abs(steps) * grid.tick).sum(axis=1)  # rad per u
    n = steps.shape[0]

    def angle(u: FloatArray) -> FloatArray:
        k = np.clip(np.floor(u).astype(np.int64), 0, n - 1)
        return angle_of(grid.to_joint(states[k] + (u - k)[:, None] * steps[k]))

    u = np.linspace(0.0, n, PROFILE_PER_COMMAND * n + 1)
    a = angle(u)
    for _ in range(40):
        k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
        h = np.diff(u)
        bound = 0.5 * (a[:-1] + a[1:] + turning[k] * h)
        need = bound > float(a.max()) + precision
        if not np.any(need):
            break
        mid = 0.5 * (u[:-1][need] + u[1:][need])
        order = np.argsort(np.concatenate([u, mid]), kind="stable")
        u = np.concatenate([u, mid])[order]
        a = np.concatenate([a, angle(mid)])[order]
    if not fixed_direction:
        return float(a.max()), None
    k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
    bound_max = float(np.max(0.5 * (a[:-1] + a[1:] + turning[k] * np.diff(u))))
    return float(a.max()), max(bound_max, float(a.max()))
