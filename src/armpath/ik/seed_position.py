"""Closed-form position IK of seed-type arms (SPEC section 1): the whole solution family.

The fingertip E depends on joints 1-5 only, so a target point has a two-dimensional family of
solutions. Two closed-form parametrizations of that family are given here, both vectorized:

* by the wrist point D on the sphere of radius DE around the target
  (:func:`family_from_wrist`): eight branches (arm side x elbow x wrist flip);
* by fixing two of the joints {1, 4, 5} (:func:`solve_with_fixed_pair`): four solutions for the
  remaining three.

Notation: with ``P = E - B`` expressed in the frame turned by ``-theta1`` about z as
``(X, Y, Z)`` and ``k = CD ez + DE (s4 s5, -c4 s5, c5)`` the wrist vector in the forearm frame,

    X = k_x = DE s4 s5,     (Y, Z) = Rot(theta2) [ (0, BC) + Rot(theta3) (k_y, k_z) ],

where ``Rot`` turns the (y, z) plane about x. Angles are rad; returned joint values are
``(theta1, ..., theta5)``, NaN where a branch has no real solution. Joint limits are not applied
here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.angles import wrap_to_pi
from armpath.errors import InvalidInputError
from armpath.model.seed_arm import SeedArmGeometry

FloatArray = NDArray[np.float64]

__all__ = ["FIXED_PAIRS", "family_from_wrist", "fingertip", "solve_with_fixed_pair"]

#: Pairs of joints (0-based) that can be fixed, the other three solved in closed form.
FIXED_PAIRS: tuple[tuple[int, int], ...] = ((0, 3), (0, 4), (3, 4))


def fingertip(g: SeedArmGeometry, q: ArrayLike) -> FloatArray:
    """Closed-form fingertip E of a seed-type arm for joints ``(..., >= 5)`` rad: ``(..., 3)`` mm.

    A fast special case of :func:`armpath.kinematics.tool_position` for large lattice searches.
    """
    qa = np.asarray(q, dtype=np.float64)
    t1, t2, t3, t4, t5 = (qa[..., i] for i in range(5))
    s5 = np.sin(t5)
    # wrist vector in the forearm frame: CD ez + DE Rz(t4) Rx(t5) ez
    kx = g.de_mm * np.sin(t4) * s5
    ky = -g.de_mm * np.cos(t4) * s5
    kz = g.cd_mm + g.de_mm * np.cos(t5)
    phi = t2 + t3
    cp, sp = np.cos(phi), np.sin(phi)
    # in the arm frame turned by t1: (X, Y, Z) = BC Rx(t2) ez + Rx(phi) k
    X = kx
    Y = -g.bc_mm * np.sin(t2) + cp * ky - sp * kz
    Z = g.bc_mm * np.cos(t2) + sp * ky + cp * kz
    c1, s1 = np.cos(t1), np.sin(t1)
    return np.stack([c1 * X - s1 * Y, s1 * X + c1 * Y, g.ab_mm + Z], axis=-1)


def _planar(
    g: SeedArmGeometry, Y: FloatArray, Z: FloatArray, k_y: FloatArray, k_z: FloatArray
) -> list[tuple[FloatArray, FloatArray]]:
    """Both elbow solutions ``(theta2, theta3)`` of the planar two-link sub-problem."""
    a = g.bc_mm
    K = np.hypot(k_y, k_z)
    beta = np.arctan2(k_y, k_z)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (Y * Y + Z * Z - a * a - K * K) / (2.0 * a * K)
    ok = np.abs(ratio) <= 1.0
    acos = np.arccos(np.clip(ratio, -1.0, 1.0))
    out = []
    for sign in (1.0, -1.0):
        t3 = beta + sign * acos
        m_y = np.cos(t3) * k_y - np.sin(t3) * k_z
        m_z = a + np.sin(t3) * k_y + np.cos(t3) * k_z
        t2 = np.arctan2(Z, Y) - np.arctan2(m_z, m_y)
        out.append((np.where(ok, wrap_to_pi(t2), np.nan), np.where(ok, wrap_to_pi(t3), np.nan)))
    return out


def _target_relative(g: SeedArmGeometry, target: ArrayLike) -> FloatArray:
    p = np.asarray(target, dtype=np.float64)
    if p.shape[-1:] != (3,) or not np.all(np.isfinite(p)):
        raise InvalidInputError(f"target must be finite (x, y, z), got {p.tolist()}")
    return np.asarray(p - np.array([0.0, 0.0, g.ab_mm]), dtype=np.float64)


def solve_with_fixed_pair(
    g: SeedArmGeometry,
    target: ArrayLike,
    pair: tuple[int, int],
    a: ArrayLike,
    b: ArrayLike,
) -> FloatArray:
    """Solutions with joints ``pair`` fixed to ``a`` and ``b`` (rad): shape ``(..., 4, 5)``.

    ``pair`` is one of :data:`FIXED_PAIRS` (0-based joint indices). Each of the four solutions is
    NaN where it does not exist.
    """
    if pair not in FIXED_PAIRS:
        raise InvalidInputError(f"pair must be one of {FIXED_PAIRS}, got {pair}")
    P = _target_relative(g, target)
    va, vb = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
    c = g.de_mm
    sols: list[FloatArray] = []

    def finish(t1: FloatArray, t4: FloatArray, t5: FloatArray) -> None:
        X = np.cos(t1) * P[..., 0] + np.sin(t1) * P[..., 1]
        Y = -np.sin(t1) * P[..., 0] + np.cos(t1) * P[..., 1]
        Z = np.broadcast_to(P[..., 2], X.shape)
        k_y = -c * np.cos(t4) * np.sin(t5)
        k_z = g.cd_mm + c * np.cos(t5)
        for t2, t3 in _planar(g, Y, Z, k_y, k_z):
            sols.append(np.stack(np.broadcast_arrays(t1, t2, t3, t4, t5), axis=-1))

    with np.errstate(divide="ignore", invalid="ignore"):
        if pair in ((0, 3), (0, 4)):
            # X = DE s4 s5 is symmetric in joints 4 and 5: solve the free one of the two
            t1, fixed = va, vb
            X = np.cos(t1) * P[..., 0] + np.sin(t1) * P[..., 1]
            ratio = X / (c * np.sin(fixed))
            base = np.where(np.abs(ratio) <= 1.0, np.arcsin(np.clip(ratio, -1.0, 1.0)), np.nan)
            for free in (base, wrap_to_pi(np.pi - base)):
                t4, t5 = (fixed, free) if pair == (0, 3) else (free, fixed)
                finish(t1, t4, t5)
        else:
            t4, t5 = va, vb
            kx = c * np.sin(t4) * np.sin(t5)
            rho = np.hypot(P[..., 0], P[..., 1])
            alpha = np.arctan2(P[..., 1], P[..., 0])
            ratio = kx / rho
            acos = np.where(np.abs(ratio) <= 1.0, np.arccos(np.clip(ratio, -1.0, 1.0)), np.nan)
            for sign in (1.0, -1.0):
                finish(wrap_to_pi(alpha + sign * acos), t4, t5)
    return np.stack(sols, axis=-2)


def family_from_wrist(g: SeedArmGeometry, target: ArrayLike, wrist: ArrayLike) -> FloatArray:
    """All solutions whose wrist point D is ``wrist`` (``(..., 3)``, at distance DE from target).

    Returns ``(..., 8, 5)`` rad: branches ordered (arm side, elbow, wrist flip), NaN where the
    wrist point is out of reach of links BC and CD or does not lie at distance DE from the target.
    """
    p = np.asarray(target, dtype=np.float64)
    D = np.asarray(wrist, dtype=np.float64)
    v = D - np.array([0.0, 0.0, g.ab_mm])
    rho0 = np.hypot(v[..., 0], v[..., 1])
    h = v[..., 2]
    on_sphere = np.abs(np.linalg.norm(p - D, axis=-1) - g.de_mm) <= 1e-6 * g.de_mm
    out = []
    for side in (1.0, -1.0):
        with np.errstate(divide="ignore", invalid="ignore"):
            nx = np.where(rho0 > 0, side * v[..., 0] / rho0, 0.0)
            ny = np.where(rho0 > 0, side * v[..., 1] / rho0, side)
        t1 = np.arctan2(-nx, ny)
        rho = side * rho0
        # planar two-link with k = (0, CD) (wrist vector before the wrist joints)
        zero = np.zeros_like(rho)
        for t2, t3 in _planar(g, rho, h, zero, zero + g.cd_mm):
            phi = t2 + t3
            # E - D in the forearm frame R3 = Rz(t1) Rx(phi)
            w = (p - D) / g.de_mm
            wx = np.cos(t1) * w[..., 0] + np.sin(t1) * w[..., 1]
            wy_ = -np.sin(t1) * w[..., 0] + np.cos(t1) * w[..., 1]
            uy = np.cos(phi) * wy_ + np.sin(phi) * w[..., 2]
            uz = -np.sin(phi) * wy_ + np.cos(phi) * w[..., 2]
            for s5 in (1.0, -1.0):
                t5 = s5 * np.arccos(np.clip(uz, -1.0, 1.0))
                t4 = np.arctan2(s5 * wx, -s5 * uy)
                sol = np.stack(np.broadcast_arrays(t1, t2, t3, t4, t5), axis=-1)
                out.append(np.where(on_sphere[..., None], sol, np.nan))
    return np.stack(out, axis=-2)
