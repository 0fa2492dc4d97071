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
from armpath.ik.numerical import SAME_SOLUTION, distinct_solutions, solve_numerical
from armpath.ik.result import IKResult
from armpath.ik.spherical_wrist import SphericalWristSolver, wrist_center
from armpath.ik.three_parallel import ThreeParallelSolver, three_parallel_layout
from armpath.kinematics import tool_point_joints
from armpath.model.serial_arm import JointKind, SerialArm, check_arm

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


def require_complete_solver(arm: SerialArm, what: str) -> CompiledSolver:
    """The all-solutions solver for ``arm``, or :class:`InvalidInputError` saying that
    ``what`` needs one, which arms have one and why this arm has none."""
    solver = complete_solver(arm)
    if solver is not None:
        return solver
    n = arm.n_joints
    prismatic = sum(j.kind is JointKind.PRISMATIC for j in arm.joints)
    if n < 6:
        why = f"its {n} joints cannot set the tool's whole pose"
    elif n > 6:
        why = f"its {n} joints reach each pose in a continuous family of solutions"
    else:
        why = f"{prismatic} of its joints slide" if prismatic else "its joints do not fit one"
    raise InvalidInputError(
        f"{what} needs every inverse-kinematics solution of the tool's pose, which armpath "
        "finds for six joints (a spherical wrist, three parallel axes, or six revolute joints); "
        f"model {arm.name!r} has none: {why}"
    )


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
    near: FloatArray | None = None,
) -> IKResult:
    """Every solution of one target: a 4x4 pose, or a 3-vector with ``position_only``.

    Complete methods return every real solution; the numerical method those its seeds find.
    Solutions are shifted into the joint limits where a whole turn allows and flagged by
    ``within_limits``. When the arm has more joints than the goal constrains, the solutions
    are samples of a continuous family (``family_dimension`` > 0). ``near`` (joint values,
    rad / model length unit) starts the numerical search there first and orders the
    solutions nearest to it first (in commands of the arm's lattice); a continuous family
    gets its member nearest ``near`` as well.
    """
    check_arm(arm)
    n = arm.n_joints
    shape = np.shape(target)
    if shape != ((3,) if position_only else (4, 4)):
        one = "a 3-vector (position_only)" if position_only else "a 4x4 pose"
        if not position_only and shape == (3,):
            hint = "; a point alone needs position_only=True"
        elif not position_only:
            hint = "; complete_solver(arm).solve_batch takes many poses"
        else:
            hint = ""
        raise InvalidInputError(f"solve_ik takes one target, {one}, got shape {shape}{hint}")
    initial = None
    if near is not None:
        initial = np.asarray(near, dtype=np.float64).reshape(-1)
        if initial.shape != (n,) or not np.isfinite(initial).all():
            raise InvalidInputError(f"near needs {n} finite joint values of {arm.name}")
    family = max(0, n - (3 if position_only else 6))
    if position_only:
        result = solve_numerical(
            arm, target, position_only=True, seeds=seeds, rng_seed=rng_seed, initial=initial
        )
        idle = ~tool_point_joints(arm)
        if idle.any():
            result = _held(arm, result, idle, arm.home if initial is None else initial)
            family = max(0, n - int(idle.sum()) - 3)
    else:
        solver = complete_solver(arm, method)
        if solver is None:
            result = solve_numerical(arm, target, seeds=seeds, rng_seed=rng_seed, initial=initial)
        else:
            result = solver.solve(np.asarray(target, dtype=np.float64))
            if result.count == 0 and "degenerate" in result.reason:
                fallback = solve_numerical(
                    arm, target, seeds=seeds, rng_seed=rng_seed, initial=initial
                )
                result = replace(
                    fallback,
                    method=f"{fallback.method} (after {result.method}: {result.reason})",
                )
    result = into_limits(arm, replace(result, family_dimension=family))
    if initial is not None and family and result.count:
        result = _with_nearest_member(arm, result, target, position_only, initial)
    if initial is not None and result.count > 1:
        result = nearest_first(arm, result, initial)
    return result


def _held(arm: SerialArm, result: IKResult, idle: BoolArray, value: FloatArray) -> IKResult:
    """A position's solutions with the joints that do not move the tool point (``idle``) held
    at ``value`` (home or --near: they only turn the tool about the point), the same ones
    merged: a SCARA's two elbows rather than samples of the turn of its last joint."""
    if result.count == 0:
        return result
    q = result.solutions.copy()
    q[:, idle] = np.asarray(value, dtype=np.float64)[idle]
    kept = distinct_solutions(q, arm.lattice.prismatic, SAME_SOLUTION)
    names = ", ".join(f"q{i + 1}" for i in np.flatnonzero(idle))
    return replace(
        result,
        solutions=q[kept],
        position_residual=result.position_residual[kept],
        rotation_residual_rad=result.rotation_residual_rad[kept],
        near_double=result.near_double[kept],
        near_singular=result.near_singular[kept],
        method=f"{result.method}; {names} held: it does not move the tool point"
        if idle.sum() == 1
        else f"{result.method}; {names} held: they do not move the tool point",
    )


def _with_nearest_member(
    arm: SerialArm, result: IKResult, target: FloatArray, position_only: bool, q0: FloatArray
) -> IKResult:
    """``result`` plus the member of its continuous family nearest ``q0`` in commands: SLSQP
    minimises the largest joint change (in units of one command's most ticks) on the family
    (the goal as equality constraints, from the nearest sample found), then
    Levenberg-Marquardt polishes it to the tolerances."""
    from scipy.optimize import minimize

    from armpath.kinematics import forward_frames

    n = arm.n_joints
    step = arm.lattice.tick * arm.lattice.max_ticks
    T = np.asarray(target, dtype=np.float64)
    start = nearest_first(arm, result, q0).solutions[0]
    size = 1.0 + float(np.max(np.abs(forward_frames(arm, arm.home)[:, :3, 3])))

    def goal_error(x: FloatArray) -> FloatArray:
        tool = forward_frames(arm, x[:n])[-1]
        if position_only:
            return np.asarray((tool[:3, 3] - T.reshape(-1)[:3]) / size, dtype=np.float64)
        rot = 0.5 * np.sum(np.cross(tool[:3, :3], T[:3, :3], axisa=0, axisb=0), axis=0)
        return np.concatenate([(tool[:3, 3] - T[:3, 3]) / size, rot])

    # the start shifted by whole turns next to q0, so the change is measured the short way
    shifted = start.copy()
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.REVOLUTE:
            shifted[i] = q0[i] + (start[i] - q0[i] + np.pi) % (2.0 * np.pi) - np.pi
    lo = np.minimum(arm.lower, shifted)
    hi = np.maximum(arm.upper, shifted)
    commands0 = float(np.max(np.abs(shifted - q0) / step))
    eye = np.hstack([np.eye(n) / step[:, None], np.zeros((n, 1))])
    ones = np.zeros((n, n + 1))
    ones[:, n] = 1.0
    res = minimize(
        lambda x: float(x[n]),
        np.append(shifted, commands0),
        jac=lambda x: np.eye(n + 1)[n],
        constraints=[
            {"type": "eq", "fun": goal_error},
            {
                "type": "ineq",
                "fun": lambda x: x[n] - (x[:n] - q0) / step,
                "jac": lambda x: ones - eye,
            },
            {
                "type": "ineq",
                "fun": lambda x: x[n] + (x[:n] - q0) / step,
                "jac": lambda x: ones + eye,
            },
        ],
        bounds=[*zip(lo, hi, strict=True), (0.0, None)],
        method="SLSQP",
        options={"maxiter": 300, "ftol": 1e-10},
    )
    res.x = res.x[:n]
    polished = solve_numerical(
        arm,
        T if not position_only else T.reshape(-1)[:3],
        position_only=position_only,
        seeds=1,
        initial=np.clip(res.x, arm.lower, arm.upper),
        retry=False,
    )
    if polished.count == 0:
        return result
    merged = into_limits(
        arm,
        replace(
            result,
            solutions=np.vstack([polished.solutions[:1], result.solutions]),
            position_residual=np.concatenate(
                [polished.position_residual[:1], result.position_residual]
            ),
            rotation_residual_rad=np.concatenate(
                [polished.rotation_residual_rad[:1], result.rotation_residual_rad]
            ),
            near_double=np.concatenate([[False], result.near_double]),
            near_singular=np.concatenate([[False], result.near_singular]),
        ),
    )
    return merged


def nearest_first(arm: SerialArm, result: IKResult, q: FloatArray) -> IKResult:
    """``result`` with its solutions ordered by the commands they need from ``q`` (the largest
    joint change in units of the joint's most ticks per command, revolute joints the shorter
    way round), nearest first; each revolute angle turned by whole turns to lie nearest ``q``
    where the joint limits allow (a UR5's -187 deg rather than 173 deg from -80 deg)."""
    q = np.asarray(q, dtype=np.float64)
    sols = result.solutions.copy()
    d = sols - q[None, :]
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.REVOLUTE:
            turned = sols[:, i] - np.round(d[:, i] / (2.0 * np.pi)) * 2.0 * np.pi
            lo, hi = joint.limits
            fits = (turned >= lo - 1e-9) & (turned <= hi + 1e-9)
            sols[:, i] = np.where(fits, turned, sols[:, i])
            d[:, i] = (d[:, i] + np.pi) % (2.0 * np.pi) - np.pi
    step = arm.lattice.tick * arm.lattice.max_ticks
    order = np.argsort(np.max(np.abs(d) / step, axis=1), kind="stable")

    def pick(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[order]

    return replace(
        result,
        solutions=sols[order],
        position_residual=result.position_residual[order],
        rotation_residual_rad=result.rotation_residual_rad[order],
        near_double=result.near_double[order],
        near_singular=result.near_singular[order],
        within_limits=pick(result.within_limits),
    )
