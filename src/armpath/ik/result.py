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
