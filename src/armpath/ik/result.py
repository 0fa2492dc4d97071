"""Result objects shared by every inverse-kinematics method."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class IKResult:
    """The inverse-kinematics solutions of one target.

    ``solutions`` has shape ``(k, n)``: joint values in rad (revolute, wrapped to (-pi, pi]) or
    the model's length unit (prismatic). ``position_residual`` (length unit) and
    ``rotation_residual_rad`` are each solution's forward-kinematics distance to the target (the
    rotation residual is 0 for position-only goals). ``near_double`` marks solutions at a
    (near-)double root of the elimination, ``near_singular`` those whose Jacobian is (nearly)
    rank deficient. ``within_limits`` says, per solution, whether it lies inside the joint limits
    (revolute angles are then shifted by whole turns into the limits). ``reason`` is empty when
    solutions were found and otherwise says why none was; ``method`` names the solver (and the
    elimination split used, if any).
    """

    solutions: FloatArray
    position_residual: FloatArray
    rotation_residual_rad: FloatArray
    near_double: BoolArray
    near_singular: BoolArray
    method: str
    reason: str = ""
    within_limits: BoolArray | None = None

    @property
    def count(self) -> int:
        return int(self.solutions.shape[0])

    @property
    def ok(self) -> bool:
        return self.count > 0

    @staticmethod
    def empty(n_joints: int, method: str, reason: str) -> IKResult:
        z = np.zeros(0)
        return IKResult(
            np.zeros((0, n_joints)), z, z, z.astype(bool), z.astype(bool), method, reason
        )


def solved_poses(
    q: FloatArray,
    residuals: FloatArray,
    flags: NDArray[np.int64],
    count: NDArray[np.int64],
    length_scale: float,
    method: list[str],
    reason: list[str],
) -> list[IKResult]:
    """One :class:`IKResult` per pose from a compiled solver's padded output arrays.

    ``q`` ``(N, cap, n)`` joint values in the model's units, ``residuals`` ``(N, cap, 2)``
    scaled position and rotation residuals, ``flags`` bit 0 near-double, bit 1 near-singular;
    ``method[i]`` and (for poses without a solution) ``reason[i]`` per pose. Solutions are sorted.
    """
    out = []
    n_joints = q.shape[2]
    for i in range(q.shape[0]):
        k = int(count[i])
        if k == 0:
            out.append(IKResult.empty(n_joints, method[i], reason[i]))
            continue
        order = np.lexsort(q[i, :k].T[::-1])
        out.append(
            IKResult(
                solutions=q[i, order],
                position_residual=residuals[i, order, 0] * length_scale,
                rotation_residual_rad=residuals[i, order, 1],
                near_double=(flags[i, order] & 1) > 0,
                near_singular=(flags[i, order] & 2) > 0,
                method=method[i],
            )
        )
    return out


def chain_length_scale(C: FloatArray) -> float:
    """Mean length of the non-zero translations of a chain's constants (model unit): dividing by
    it makes every length of the arm of order one for the compiled solvers."""
    shifts = [float(np.linalg.norm(T[:3, 3])) for T in C]
    nonzero = [s for s in shifts if s > 1e-12]
    return float(np.mean(nonzero)) if nonzero else 1.0
