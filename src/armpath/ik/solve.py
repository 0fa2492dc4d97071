"""One entry point for inverse kinematics: picks the complete method the arm allows.

* ``spherical-wrist``: closed form (Pieper) when axes 4-6 meet in a point and joints 1-3 are
  R, R, R|P (:mod:`armpath.ik.spherical_wrist`).
* ``three-parallel``: closed form when axes 2-4 are parallel and axes 5, 6 meet (UR type), or
  the same read from the tool (:mod:`armpath.ik.three_parallel`).
* ``general``: Raghavan-Roth elimination for any other six-revolute arm
  (:mod:`armpath.ik.general6r`).
* ``numerical``: Levenberg-Marquardt from many seeds (:mod:`armpath.ik.numerical`) for every
  other arm, for position-only goals, and as the fallback when an elimination is degenerate.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.compiled import CompiledSolver
from armpath.ik.general6r import General6RSolver
from armpath.ik.numerical import solve_numerical
from armpath.ik.result import IKResult
from armpath.ik.spherical_wrist import SphericalWristSolver, wrist_center
from armpath.ik.three_parallel import ThreeParallelSolver, three_parallel_layout
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
METHODS = ("auto", "spherical-wrist", "three-parallel", "general", "numerical")


def complete_solver(arm: SerialArm, method: str = "auto") -> CompiledSolver | None:
    """The all-solutions solver for ``arm`` (None if only the numerical one applies)."""
    if method not in METHODS:
        raise InvalidInputError(f"IK method must be one of {METHODS}, got {method!r}")
    if method == "numerical":
        return None
    kinds = [j.kind for j in arm.joints]
    wrist_ok = (
        arm.n_joints == 6
        and kinds[0] is JointKind.REVOLUTE
        and kinds[1] is JointKind.REVOLUTE
        and all(k is JointKind.REVOLUTE for k in kinds[3:])
        and wrist_center(arm) is not None
    )
    if method in ("auto", "spherical-wrist") and wrist_ok:
        return SphericalWristSolver(arm)
    if method == "spherical-wrist":
        raise InvalidInputError(
            f"model {arm.name!r} has no spherical wrist (axes 4-6 must meet in a point)"
        )
    if method in ("auto", "three-parallel") and three_parallel_layout(arm) is not None:
        return ThreeParallelSolver(arm)
    if method == "three-parallel":
        raise InvalidInputError(
            f"model {arm.name!r} does not have three consecutive parallel axes next to two "
            "meeting ones (axes 2-4 parallel and 5, 6 meeting, or 3-5 parallel and 1, 2 meeting)"
        )
    if arm.n_joints == 6 and all(k is JointKind.REVOLUTE for k in kinds):
        return General6RSolver(arm)
    if method == "general":
        raise InvalidInputError(f"model {arm.name!r}: the general solver needs six revolute joints")
    return None


def into_limits(arm: SerialArm, result: IKResult) -> IKResult:
    """Shift revolute angles by whole turns into the joint limits where possible; mark which
    solutions lie inside them."""
    if result.count == 0:
        return replace(result, within_limits=np.zeros(0, dtype=bool))
    q = result.solutions.copy()
    lo, hi = arm.lower, arm.upper
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.REVOLUTE and joint.is_limited:
            for k in range(q.shape[0]):
                v = q[k, i]
                for turn in (0.0, 2 * np.pi, -2 * np.pi, 4 * np.pi, -4 * np.pi):
                    if lo[i] - 1e-9 <= v + turn <= hi[i] + 1e-9:
                        q[k, i] = v + turn
                        break
    inside = np.all((q >= lo - 1e-9) & (q <= hi + 1e-9), axis=1)
    return replace(result, solutions=q, within_limits=inside)


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


def solve_ik(
    arm: SerialArm,
    target: FloatArray,
    *,
    method: str = "auto",
    position_only: bool = False,
    seeds: int = 48,
    rng_seed: int = 0,
) -> IKResult:
    """Every solution of one target: a 4x4 pose, or a 3-vector with ``position_only``.

    Complete methods return every real solution; the numerical method those its seeds find.
    Solutions are shifted into the joint limits where a whole turn allows and flagged by
    ``within_limits``.
    """
    if position_only:
        return into_limits(
            arm, solve_numerical(arm, target, position_only=True, seeds=seeds, rng_seed=rng_seed)
        )
    solver = complete_solver(arm, method)
    if solver is None:
        return into_limits(arm, solve_numerical(arm, target, seeds=seeds, rng_seed=rng_seed))
    result = solver.solve(np.asarray(target, dtype=np.float64))
    if result.count == 0 and "degenerate" in result.reason:
        fallback = solve_numerical(arm, target, seeds=seeds, rng_seed=rng_seed)
        result = replace(
            fallback,
            method=f"{fallback.method} (after {result.method}: {result.reason})",
        )
    return into_limits(arm, result)
