"""Dexterous workspace: points the tool reaches in every orientation (seed 003).

A point is tested by solving the inverse kinematics, with every solution, for the tool at that
point in each orientation of a grid (fixed X-Y-Z angles), and keeping the solutions inside the
joint limits. The complete solvers (closed form or elimination) make this a batched call per
point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from armpath.errors import InvalidInputError
from armpath.ik import complete_solver
from armpath.ik.compiled import CompiledSolver
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def orientation_grid(step: float, lo: float = -np.pi, hi: float = np.pi) -> FloatArray:
    """Rotation matrices ``(k, 3, 3)`` of every fixed-angle triple (alpha about x, beta about y,
    gamma about z, applied in that order about the fixed axes) on a grid ``lo:step:hi`` (rad,
    both ends included): seed 003 uses [-pi, pi] in steps of 0.1 pi, 21^3 = 9261 orientations."""
    if not (np.isfinite(step) and step > 0 and hi >= lo):
        raise InvalidInputError(
            f"orientation grid needs step > 0 and hi >= lo, got {step}, {lo}, {hi}"
        )
    n = int(np.floor((hi - lo) / step + 1e-9)) + 1
    angles = lo + step * np.arange(n)
    a, b, c = np.meshgrid(angles, angles, angles, indexing="ij")
    triples = np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1)
    return np.asarray(Rotation.from_euler("xyz", triples).as_matrix(), dtype=np.float64)


def limits_mask(arm: SerialArm, q: FloatArray) -> BoolArray:
    """Whether each joint vector ``(..., n)`` lies inside the joint limits, a revolute angle
    shifted by whole turns where that helps; NaN rows (padding) are outside."""
    q = np.asarray(q, dtype=np.float64)
    ok = np.all(np.isfinite(q), axis=-1)
    for i, joint in enumerate(arm.joints):
        lo, hi = joint.limits
        v = q[..., i]
        if joint.kind is JointKind.REVOLUTE and hi - lo < 2.0 * np.pi:
            # the shift that brings v closest above lo
            v = lo + np.mod(v - lo, 2.0 * np.pi)
        with np.errstate(invalid="ignore"):
            ok &= (v >= lo - 1e-9) & (v <= hi + 1e-9)
    return np.asarray(ok)


@dataclass(frozen=True)
class Dexterity:
    """How many of the tested orientations the tool reaches at ``point`` (model unit)."""

    point: FloatArray
    reached: BoolArray
    solutions: NDArray[np.int64]

    @property
    def n_reached(self) -> int:
        return int(np.count_nonzero(self.reached))

    @property
    def n_tested(self) -> int:
        return int(self.reached.shape[0])

    @property
    def dexterous(self) -> bool:
        """Every tested orientation is reached."""
        return bool(self.reached.all())


def dexterity(
    arm: SerialArm,
    point: FloatArray,
    rotations: FloatArray,
    *,
    solver: CompiledSolver | None = None,
) -> Dexterity:
    """Test the tool at ``point`` in each of ``rotations`` ``(k, 3, 3)``: reached when some
    inverse-kinematics solution lies inside the joint limits. ``solver`` defaults to the arm's
    complete solver (one is required)."""
    solver = solver or complete_solver(arm)
    if solver is None:
        raise InvalidInputError(
            f"model {arm.name!r} has no all-solutions IK (dexterity needs one: six joints with a "
            "spherical wrist, three parallel axes, or six revolute joints)"
        )
    p = np.asarray(point, dtype=np.float64).reshape(3)
    R = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    T = np.zeros((R.shape[0], 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = p
    T[:, 3, 3] = 1.0
    batch = solver.solve_batch(T)
    inside = limits_mask(arm, batch.solutions)
    return Dexterity(p, np.asarray(inside.any(axis=1)), np.asarray(inside.sum(axis=1)))
