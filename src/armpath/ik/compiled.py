"""The Python face of the compiled all-solutions solvers: poses in, results out.

Each solver (:mod:`~armpath.ik.spherical_wrist`, :mod:`~armpath.ik.three_parallel`,
:mod:`~armpath.ik.general6r`) fills padded arrays in a numba kernel; this base class validates
the targets, scales them and turns the arrays into an :class:`IKBatch` or one
:class:`IKResult`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.kernels import prepare_targets
from armpath.ik.result import IKBatch, IKResult, pose_result, solved_poses
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: What a kernel run gives: padded joint values (model units), scaled residuals, flags (bit 0
#: near-double, bit 1 near-singular), counts, and per pose an index into the method names and
#: one into the failure reasons.
KernelOutput = tuple[FloatArray, FloatArray, IntArray, IntArray, IntArray, IntArray]


def padded_outputs(n_poses: int, cap: int) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
    """Zeroed output arrays of a kernel: joint values, residuals, flags, counts."""
    return (
        np.zeros((n_poses, cap, 6)),
        np.zeros((n_poses, cap, 2)),
        np.zeros((n_poses, cap), dtype=np.int64),
        np.zeros(n_poses, dtype=np.int64),
    )


class CompiledSolver:
    """Base of the complete solvers: ``solve`` (one 4x4 pose) and ``solve_batch`` (N poses)."""

    arm: SerialArm
    #: Length (model unit) that makes the arm's translations of order one inside the kernels.
    length_scale: float
    method_names: tuple[str, ...]
    failure_reasons: tuple[str, ...] = ("no real solution: the pose is out of reach",)

    def _run(self, T: FloatArray) -> KernelOutput:
        """The kernel on validated targets ``(N, 4, 4)`` whose lengths are divided by
        ``length_scale``."""
        raise NotImplementedError

    def solve_batch(self, Ts: FloatArray) -> IKBatch:
        """All solutions of each pose in ``Ts`` (shape ``(N, 4, 4)``, world frame, model unit),
        as padded arrays; ``batch[i]`` is pose ``i``'s :class:`IKResult`."""
        q, res, flags, count, method, reason = self._run(prepare_targets(Ts, self.length_scale))
        return solved_poses(
            q,
            res,
            flags,
            count,
            self.length_scale,
            self.method_names,
            method,
            self.failure_reasons,
            reason,
        )

    def solve(self, T: FloatArray) -> IKResult:
        """All real solutions of one pose (4x4, world frame, model unit)."""
        if np.shape(T) != (4, 4):
            raise InvalidInputError(
                f"solve takes one 4x4 pose, got shape {np.shape(T)}; solve_batch takes many"
            )
        target = prepare_targets(np.asarray(T, dtype=np.float64)[None], self.length_scale)
        q, res, flags, count, method, reason = self._run(target)
        return pose_result(
            q[0],
            res[0, :, 0] * self.length_scale,
            res[0, :, 1],
            (flags[0] & 1) > 0,
            (flags[0] & 2) > 0,
            int(count[0]),
            self.method_names[int(method[0])],
            self.failure_reasons[int(reason[0])],
        )
