"""Result objects shared by every inverse-kinematics method."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import overload

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class IKResult:
    """The inverse-kinematics solutions of one target.

    ``solutions`` has shape ``(k, n)``: joint values in rad (revolute: wrapped to (-pi, pi],
    then turned by whole turns into the joint limits, or toward ``near`` where the limits
    allow) or the model's length unit (prismatic). ``position_residual`` (length unit) and
    ``rotation_residual_rad`` are each solution's forward-kinematics distance to the target (the
    rotation residual is 0 for position-only goals). ``near_double`` marks solutions at a
    (near-)double root of the elimination, ``near_singular`` those whose Jacobian is (nearly)
    rank deficient. ``within_limits`` says, per solution, whether it lies inside the joint limits
    (revolute angles are then shifted by whole turns into the limits). ``reason`` is empty when
    solutions were found and otherwise says why none was; ``method`` names the solver (and the
    elimination split used, if any). ``family_dimension`` is 0 when the solutions are isolated;
    when the arm has more joints than the goal constrains (a 7-axis arm and a pose, a 6-axis
    arm and a position) the solutions form a continuous family of that dimension and
    ``solutions`` are samples of it.
    """

    solutions: FloatArray
    position_residual: FloatArray
    rotation_residual_rad: FloatArray
    near_double: BoolArray
    near_singular: BoolArray
    method: str
    reason: str = ""
    within_limits: BoolArray | None = None
    family_dimension: int = 0

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


IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class IKBatch(Sequence[IKResult]):
    """The solutions of N target poses in padded arrays: what the compiled solvers produce.

    ``solutions`` has shape ``(N, cap, n)`` (model units, as in :class:`IKResult`), and row
    ``i`` holds ``counts[i]`` solutions followed by NaN. ``position_residual`` (length unit),
    ``rotation_residual_rad``, ``near_double`` and ``near_singular`` have shape ``(N, cap)``.
    ``method_names[method_index[i]]`` names the solver of pose ``i`` and, if it has no solution,
    ``failure_reasons[reason_index[i]]`` says why. Indexing or iterating gives one
    :class:`IKResult` per pose (views of these arrays), built on demand. Each pose's solutions are
    sorted lexicographically.
    """

    solutions: FloatArray
    counts: IntArray
    position_residual: FloatArray
    rotation_residual_rad: FloatArray
    near_double: BoolArray
    near_singular: BoolArray
    method_names: tuple[str, ...]
    method_index: IntArray
    failure_reasons: tuple[str, ...]
    reason_index: IntArray

    def __len__(self) -> int:
        return int(self.counts.shape[0])

    @overload
    def __getitem__(self, i: int) -> IKResult: ...

    @overload
    def __getitem__(self, i: slice) -> list[IKResult]: ...

    def __getitem__(self, i: int | slice) -> IKResult | list[IKResult]:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        if not -len(self) <= i < len(self):
            raise IndexError(f"pose index {i} out of range for {len(self)} poses")
        i = i % len(self)
        return pose_result(
            self.solutions[i],
            self.position_residual[i],
            self.rotation_residual_rad[i],
            self.near_double[i],
            self.near_singular[i],
            int(self.counts[i]),
            self.method_names[int(self.method_index[i])],
            self.failure_reasons[int(self.reason_index[i])],
        )


def pose_result(
    q: FloatArray,
    position_residual: FloatArray,
    rotation_residual_rad: FloatArray,
    near_double: BoolArray,
    near_singular: BoolArray,
    count: int,
    method: str,
    reason: str,
) -> IKResult:
    """The :class:`IKResult` of one pose from its padded rows (the first ``count`` are valid,
    sorted by the compiled solver)."""
    if count == 0:
        return IKResult.empty(q.shape[1], method, reason)
    return IKResult(
        solutions=q[:count],
        position_residual=position_residual[:count],
        rotation_residual_rad=rotation_residual_rad[:count],
        near_double=near_double[:count],
        near_singular=near_singular[:count],
        method=method,
    )


def solved_poses(
    q: FloatArray,
    residuals: FloatArray,
    flags: IntArray,
    count: IntArray,
    length_scale: float,
    method_names: tuple[str, ...],
    method_index: IntArray,
    failure_reasons: tuple[str, ...],
    reason_index: IntArray,
) -> IKBatch:
    """An :class:`IKBatch` from a compiled solver's padded output arrays (modified in place).

    ``q`` ``(N, cap, n)`` joint values in the model's units, ``residuals`` ``(N, cap, 2)``
    scaled position and rotation residuals, ``flags`` bit 0 near-double, bit 1 near-singular.
    """
    unused = np.arange(q.shape[1])[None, :] >= count[:, None]
    q[unused] = np.nan
    residuals[unused] = np.nan
    return IKBatch(
        solutions=q,
        counts=count,
        position_residual=residuals[:, :, 0] * length_scale,
        rotation_residual_rad=residuals[:, :, 1],
        near_double=(flags & 1) > 0,
        near_singular=(flags & 2) > 0,
        method_names=method_names,
        method_index=method_index,
        failure_reasons=failure_reasons,
        reason_index=reason_index,
    )


def chain_length_scale(C: FloatArray) -> float:
    """Mean length of the non-zero translations of a chain's constants (model unit): dividing by
    it makes every length of the arm of order one for the compiled solvers."""
    shifts = [float(np.linalg.norm(T[:3, 3])) for T in C]
    nonzero = [s for s in shifts if s > 1e-12]
    return float(np.mean(nonzero)) if nonzero else 1.0
