"""Fewest-command reach for any arm: the bound over the whole solution family, the lattice
search from it, the continuous clearance proof.

N commands change joint ``i`` by at most ``N * step_i`` (``step_i`` = its tick times its most
ticks a command), so a plan of N commands exists only if some configuration within the
tolerance of the target (and its orientation rule) has ``max_i |q_i - s_i| / step_i <= N``.

1. **Bound.** The solution family (:class:`~armpath.ik.family.GenericFamily`: every
   orientation's all-solutions IK, or Levenberg-Marquardt from many starts) is sampled, and the
   best samples by that command metric are refined by SLSQP (minimise ``t`` subject to the tip
   within the tolerance, the orientation rule, ``|q_i - s_i| <= t step_i`` and the limits); the
   smallest ``t`` found gives ``N >= ceil(t)``. It is a multi-start optimum over the family, so
   it is reported as the bound the search found, with its method.
2. **Lattice.** For ``N`` from the bound up, family members within ``N`` commands are searched
   on the lattice: around each, the integer offsets of a box (wider for joints that move the
   tool less) whose linearised tool error is within the tolerance are kept and checked exactly
   (forward kinematics, the rule, the limits, ``N`` commands).
3. **Motion.** The candidates nearest the target are tried as straight moves of ``N`` commands,
   their continuous clearance certified (:func:`~armpath.planning.motion_check.motion_clearance`);
   if every direct motion is blocked, the collision-free planner plans around the obstacles.
4. **Proof.** Every lattice state within the tolerance that needs fewer commands than the plan
   is listed (:func:`lattice_bound`): the fewest they need, or the plan's count where there
   are none, is a proven bound, which replaces the family's estimate.
"""

from __future__ import annotations

import contextvars
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from armpath.budget import MAX_COMMANDS, check_size, check_time
from armpath.commands import CommandSequence
from armpath.errors import CollisionError, InvalidInputError, PlanningError, UnreachableError
from armpath.geometry.primitives import PROVABLE_SLACK
from armpath.geometry.world import CollisionWorld, into_windows
from armpath.ik.family import GenericFamily, shift_into_limits
from armpath.ik.target import AxisCone, PoseOrientation, ToolTarget
from armpath.kinematics import (
    forward_frames,
    jacobian_from_frames,
    joints_that_move,
    pose_frames,
    tick_jacobian,
    tool_point_joints,
    tool_point_with_jacobian,
    tool_pose,
)
from armpath.model.lattice import unique_states
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.motion import MotionOptions, plan_motion
from armpath.planning.motion_check import (
    check_state_clear,
    check_target_clear_of_fixed_links,
    motion_clearance,
)
from armpath.tolerances import nearest_found_advice

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Largest number of integer offsets searched around one family member.
BOX_BUDGET = 60_000
#: Family members searched on the lattice for one command count.
MEMBERS_PER_COUNT = 48
#: A target this close (model unit) inside a surface counts as on it.
SURFACE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class GenericBound:
    """The command bound found over the family: ``commands = ceil(change)`` where ``change`` is
    the smallest largest ``|q_i - s_i| / step_i`` within the tolerance, at ``configuration``."""

    commands: int
    change_commands: float
    configuration: FloatArray
    samples: int
    method: str


def validated_start(
    arm: SerialArm, world: CollisionWorld, start_ticks: IntArray, target: ToolTarget
) -> IntArray:
    grid = arm.lattice
    start = np.asarray(start_ticks)
    if start.shape != (arm.n_joints,):
        raise InvalidInputError(
            f"start state needs {arm.n_joints} joint values, got shape {start.shape}"
        )
    start = CommandSequence(start, np.zeros((0, arm.n_joints), np.int64), grid).start_ticks
    arm.check_limits(grid.to_joint(start), what="start state")
    for obstacle in world.obstacles:
        depth = -float(obstacle.signed_distance(target.position))
        if depth > SURFACE_TOLERANCE:
            raise CollisionError(
                f"target ({', '.join(f'{v:g}' for v in target.position)}) {arm.length_unit} lies "
                f"{depth:.3f} {arm.length_unit} inside {obstacle.name}: the tool may touch a "
                "surface but not enter it"
            )
        if abs(depth) <= SURFACE_TOLERANCE:
            blocker = world.touch_blocker(arm)
            if blocker is not None:
                raise InvalidInputError(
                    f"target ({', '.join(f'{v:g}' for v in target.position)}) "
                    f"{arm.length_unit} lies on {obstacle.name}, but {blocker}"
                )
    check_state_clear(arm, world, grid.to_joint(start))
    return start


def command_metric(arm: SerialArm, q: FloatArray, start: FloatArray) -> FloatArray:
    """The continuous commands a straight move from ``start`` to each row of ``q`` needs."""
    return arm.lattice.commands_for_change(q - start)


def _pose_residuals(
    arm: SerialArm, target: ToolTarget, q: FloatArray
) -> tuple[FloatArray, FloatArray]:
    T = tool_pose(arm, q)
    return (
        np.asarray(np.linalg.norm(T[..., :3, 3] - target.position, axis=-1)),
        np.asarray(target.angles(T[..., :3, :3])),
    )


def _out_of_reach(
    arm: SerialArm, target: ToolTarget, dist: float, tip: FloatArray
) -> UnreachableError:
    """The error of a target no configuration within the joint limits reaches: the nearest
    reachable point (``tip``) and its distance ``dist`` (model unit)."""
    unit = arm.length_unit
    where = ", ".join(f"{v:g}" for v in target.position)
    return UnreachableError(
        f"target ({where}) {unit} is out of reach within the joint limits: the nearest "
        f"reachable point ({', '.join(f'{round(v, 2) + 0.0:.2f}' for v in tip)}) {unit} "
        f"is {dist:.3f} {unit} away"
    )


def _no_member(
    arm: SerialArm, target: ToolTarget, dist: float, tip: FloatArray, tolerance: float
) -> UnreachableError:
    """The error of a target the family sampler found no member for: out of reach (the nearest
    reachable point ``tip``, ``dist`` away, beyond the ``tolerance``), within reach but not with
    the target's tool orientation rule, or not found reaching it."""
    if dist > tolerance:
        return _out_of_reach(arm, target, dist, tip)
    unit = arm.length_unit
    where = ", ".join(f"{v:g}" for v in target.position)
    if target.orientation is not None:
        return UnreachableError(
            f"target ({where}) {unit} is within reach but no configuration found puts the "
            f"tool there with its {target.orientation.words()}"
        )
    return UnreachableError(
        f"target ({where}) {unit}: no configuration within the limits found reaching it "
        f"(the nearest point found is {dist:.4f} {unit} away, too near the tolerance's edge "
        "to search about it: a wider tolerance does)"
    )


def no_clear_goal_error(
    where: str, unit: str, world: CollisionWorld, body_buffer: float, held: str = ""
) -> PlanningError:
    """The error of a target (at ``where``, in ``unit``) none of whose sampled configurations
    keeps the goal states' clearance: the margin from the obstacles (where there are any) and
    between the links, with ``body_buffer`` to spare; ``held``: the tool orientation rule the
    configurations keep, in words (:meth:`ToolOrientation.words`), where there is one."""
    return PlanningError(
        f"no configuration reaching ({where}) {unit}"
        + (f" with its {held}" if held else "")
        + " keeps the links "
        + (f"{world.margin:g} {unit} clear of the obstacles and " if world.obstacles else "")
        + f"{world.self_margin:g} {unit} clear of each other"
        + (f", with {body_buffer:g} {unit} to spare for the motion onto it" if body_buffer else "")
    )


def _limit_bounds(arm: SerialArm) -> list[tuple[float | None, float | None]]:
    """The joint limits as scipy's bounds (None where a joint is unlimited)."""
    return [
        (float(a) if np.isfinite(a) else None, float(b) if np.isfinite(b) else None)
        for a, b in zip(arm.lower, arm.upper, strict=True)
    ]


def nearest_reachable(
    arm: SerialArm, target: ToolTarget, rng: np.random.Generator
) -> tuple[float, FloatArray]:
    """The smallest distance from the target to the tool point over the joint limits (the
    orientation rule ignored), and the tool point there."""
    from scipy.optimize import minimize

    fam = GenericFamily(arm, ToolTarget(target.position))
    q = fam._from_starts(400, rng)  # Levenberg-Marquardt toward the point from 400 starts
    tip = tool_pose(arm, q)[:, :3, 3]
    d = np.linalg.norm(tip - target.position, axis=1)
    # the nearest few polished on the squared distance within the limits (the descent's ends
    # can lie millimetres short of the least: painter004's 134.4 mm against 131.2)
    bounds = _limit_bounds(arm)

    def squared(x: FloatArray) -> tuple[float, FloatArray]:
        tip, J = tool_point_with_jacobian(arm, x)
        e = tip - target.position
        return float(e @ e), np.asarray(2.0 * e @ J, dtype=np.float64)

    best_d, best_tip = float(d.min()), tip[int(np.argmin(d))]
    for k in np.argsort(d)[:NEAREST_POLISHED]:
        check_time("finding the nearest reachable point")
        res = minimize(squared, q[k], jac=True, bounds=bounds, method="L-BFGS-B")
        polished = tool_pose(arm, np.asarray(res.x))[:3, 3]
        dist = float(np.linalg.norm(polished - target.position))
        if dist < best_d:
            best_d, best_tip = dist, polished
    return best_d, best_tip


#: Descents toward an unreachable point that :func:`nearest_reachable` polishes.
NEAREST_POLISHED = 8


def _refine_bound(
    arm: SerialArm,
    target: ToolTarget,
    start: FloatArray,
    x0: FloatArray,
    tol: float,
) -> tuple[float, FloatArray] | None:
    """``min t`` subject to the tool within ``tol`` of the target, the orientation rule, every
    joint within ``t`` commands of ``start`` and the limits (SLSQP from ``x0``)."""
    step = arm.lattice.max_step
    n = arm.n_joints
    size = arm.size
    bounds = [*_limit_bounds(arm), (0.0, None)]
    o = target.orientation

    last: list[tuple[bytes, FloatArray]] = []  # the frames of the last point (SLSQP asks a
    # point's constraint and then its gradient)

    def frames(z: FloatArray) -> FloatArray:
        key = np.asarray(z[:n], dtype=np.float64).tobytes()
        if not last or last[0][0] != key:
            last[:] = [(key, pose_frames(arm, z[:n]))]
        return last[0][1]

    def pos_con(z: FloatArray) -> float:
        e = frames(z)[-1, :3, 3] - target.position
        return float((tol**2 - e @ e) / size**2)

    def pos_jac(z: FloatArray) -> FloatArray:
        F = frames(z)
        e = F[-1, :3, 3] - target.position
        J = jacobian_from_frames(arm, F[None])[0][:3]
        return np.asarray(np.r_[-2.0 * e @ J / size**2, 0.0], dtype=np.float64)

    cons: list[dict[str, object]] = [{"type": "ineq", "fun": pos_con, "jac": pos_jac}]
    if isinstance(o, AxisCone):

        def axis_con(z: FloatArray) -> float:
            a = frames(z)[-1, :3, :3] @ o.axis_tool
            return float(a @ o.direction - np.cos(o.tolerance_rad))

        def axis_jac(z: FloatArray) -> FloatArray:
            F = frames(z)
            a = F[-1, :3, :3] @ o.axis_tool
            Jw = jacobian_from_frames(arm, F[None])[0][3:]
            return np.asarray(np.r_[np.cross(a, o.direction) @ Jw, 0.0], dtype=np.float64)

        cons.append({"type": "ineq", "fun": axis_con, "jac": axis_jac})
    elif isinstance(o, PoseOrientation):

        def pose_con(z: FloatArray) -> float:
            R = frames(z)[-1, :3, :3]
            return float((np.trace(R.T @ o.R_world_tool) - 1.0) / 2.0 - np.cos(o.tolerance_rad))

        cons.append({"type": "ineq", "fun": pose_con})
    eye = np.eye(n)
    # t * step_i - (q_i - s_i) >= 0 and t * step_i + (q_i - s_i) >= 0, with t in units of the
    # largest step (rad or model unit, as the joints: with 1e-4 deg ticks t in commands runs
    # to 50,000 against joints of order 1, and SLSQP stopped far from the least)
    unit = float(step.max())
    A = np.vstack([np.c_[-eye, step / unit], np.c_[eye, step / unit]])
    b = np.r_[start, -start]
    cons.append({"type": "ineq", "fun": lambda z: A @ z + b, "jac": lambda z: A})
    z0 = np.r_[x0, unit * float(np.max(np.abs(x0 - start) / step))]
    from scipy.optimize import minimize  # imported when first needed

    res = minimize(
        lambda z: float(z[-1]),
        z0,
        jac=lambda z: np.r_[np.zeros(n), 1.0],
        method="SLSQP",
        bounds=bounds,
        constraints=cons,
        options={"maxiter": 200, "ftol": 1e-12},
    )
    q = np.asarray(res.x[:n])
    pos, ang = _pose_residuals(arm, target, q[None])
    if not np.all(np.isfinite(q)) or pos[0] > tol * (1 + 1e-6) or not arm.within_limits(q):
        return None
    if o is not None and ang[0] > o.tolerance_rad + 1e-7:
        return None
    return float(np.max(np.abs(q - start) / step)), q


def _diverse(q: FloatArray, metric: FloatArray, count: int, spread: FloatArray) -> FloatArray:
    """Up to ``count`` rows of ``q``, smallest ``metric`` first, each at least ``spread``
    (per joint, largest ratio >= 1) from those already taken."""
    picks: list[FloatArray] = []
    for i in np.argsort(metric, kind="stable"):
        if not np.isfinite(metric[i]):
            break
        if all(np.max(np.abs(q[i] - c) / spread) >= 1.0 for c in picks):
            picks.append(q[i])
            if len(picks) >= count:
                break
    return np.array(picks).reshape(-1, q.shape[1])


def _members_in_box(
    fam: GenericFamily,
    q_best: FloatArray,
    start: FloatArray,
    n: int,
    rng: np.random.Generator,
    count: int = 200,
) -> FloatArray:
    """Family members within ``n`` commands of ``start``: ``q_best`` moved at random inside the
    n-command box and pulled back onto the target by Newton steps that stay in the box."""
    step = fam.arm.lattice.max_step
    lower, upper = start - n * step, start + n * step
    half = np.minimum(q_best - lower, upper - q_best)
    q0 = q_best + rng.uniform(-1.0, 1.0, (count, q_best.size)) * np.maximum(half, 0.0) * 0.9
    q = fam.refine(q0, iterations=40, lower=lower, upper=upper)
    return q[fam.exact(q)]


def generic_bound(
    arm: SerialArm,
    target: ToolTarget,
    start_ticks: IntArray,
    tolerance: float,
    samples: FloatArray,
    starts: int = 24,
) -> GenericBound:
    """The command bound over the sampled family, refined by SLSQP from the ``starts`` best
    diverse samples."""
    start = arm.lattice.to_joint(start_ticks)
    metric = command_metric(arm, samples, start)
    k = int(np.argmin(metric))
    best, best_q = float(metric[k]), samples[k]
    spread = arm.lattice.max_step * 2.0
    for x0 in _diverse(samples, metric, starts, spread):
        check_time("refining the bound on the commands")
        out = _refine_bound(arm, target, start, x0, tolerance)
        if out is not None and out[0] < best:
            best, best_q = out
    rule = "" if target.orientation is None else f" and the {target.orientation.words()}"
    return GenericBound(
        commands=max(int(np.ceil(best - 1e-9)), 0),
        change_commands=best,
        configuration=best_q,
        samples=int(samples.shape[0]),
        method=(
            f"min over {samples.shape[0]} sampled configurations reaching the target{rule} "
            f"(every tool orientation's all-solutions IK, or Levenberg-Marquardt from many "
            f"starts) of the largest joint change in commands, the best {starts} refined by "
            "SLSQP within the tolerance; commands >= ceil(change)"
        ),
    )


#: Boxes :func:`lattice_bound` may look at where it lists six joints (about a quarter of a
#: microsecond each, some 5 s on two threads): past it the bound stays the family's estimate.
#: The reaches tried (UR5, iiwa14, Z1, SO-101, 23 to 53 commands) looked at 2,500 to 540,000;
#: the UR5 cell's reach with a whole pose asked (plan 77) 20.4 million. A box of more joints
#: costs about the square of their number: :data:`BOUND_BOX_JOINTS`.
LATTICE_BOUND_BOXES = 40_000_000
#: Joints listed up to which a box counts as one against :data:`LATTICE_BOUND_BOXES`; with
#: ``n`` more, as ``(n / BOUND_BOX_JOINTS)**2``. A chain of 16 joints spent 30 s on the whole
#: budget (its reach, 13 commands, stayed an estimate), one of 33 spent 182 s.
BOUND_BOX_JOINTS = 7
#: Lattice states :func:`lattice_bound` may list.
LATTICE_BOUND_STATES = 200_000


@dataclass(frozen=True)
class LatticeBound:
    """A proven reach bound: no lattice state within ``commands - 1`` commands of the start puts
    the tool point within the tolerance of the target (and keeps its orientation rule where
    ``rule_kept``; otherwise the bound is the point's alone); ``states`` were listed in the box
    of ``box_commands`` commands about the start, ``boxes`` looked at."""

    commands: int
    states: int
    box_commands: int
    boxes: int
    rule_kept: bool = True


def lattice_bound(
    arm: SerialArm,
    target: ToolTarget,
    tolerance: float,
    start_ticks: IntArray,
    plan_commands: int,
    max_boxes: int | None = None,
    max_states: int | None = None,
) -> LatticeBound | None:
    """The fewest commands any plan from ``start_ticks`` needs to put the tool point within
    ``tolerance`` of ``target.position``, proven by listing every lattice state that needs
    fewer than ``plan_commands`` (a plan's count) and does so
    (:func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states`, a complete branch and
    bound): ``N`` commands move joint ``i`` at most ``N`` times its most ticks, so those states
    lie in that box about the start. The bound is the fewest the listed states need, or
    ``plan_commands`` where there are none (``max_boxes``, ``max_states``: the budgets, by
    default :data:`LATTICE_BOUND_BOXES` and :data:`LATTICE_BOUND_STATES`; the boxes' for up
    to :data:`BOUND_BOX_JOINTS` joints listed, fewer for more). Obstacles are left
    out, and the joints that move neither the tool point nor the rule's axis are held where
    they start (moving them adds to no state's count). An axis rule
    (:class:`~armpath.ik.target.AxisCone`) is kept: the states listed for the point are taken
    where their axis keeps it. So is a whole pose's
    (:class:`~armpath.ik.target.PoseOrientation`) where every joint moves the tool point, or
    one revolute joint alone does not (a tool on the last axis): that joint is then turned,
    for each listed state, to the tick nearest its start's that keeps the pose
    (:func:`_turn_keeping_pose`). Otherwise the pose is left out (``rule_kept`` False: a bound
    for the point alone). None where a budget ran out."""
    from armpath.planning.bounds.lattice_goals import GoalStates, lattice_goal_states

    grid = arm.lattice
    max_boxes = LATTICE_BOUND_BOXES if max_boxes is None else max_boxes
    max_states = LATTICE_BOUND_STATES if max_states is None else max_states
    start = np.asarray(start_ticks, dtype=np.int64)
    rule = target.orientation
    if plan_commands <= 0:
        return LatticeBound(0, 0, 0, 0)
    tip = tool_point_joints(arm)
    if isinstance(rule, AxisCone):
        # the joints that turn the rule's axis are listed too (the others turn the tool
        # about it)
        q = np.random.default_rng(0).uniform(-np.pi, np.pi, (8, arm.n_joints))
        tip |= joints_that_move(
            arm,
            lambda a, x: tool_pose(a, x)[..., :3, :3] @ rule.axis_tool,
            np.clip(q, arm.lower, arm.upper),
        )
    reach = (plan_commands - 1) * np.asarray(grid.max_ticks, dtype=np.int64)
    lowest, highest = arm.tick_limits
    box_lower = np.maximum(start - reach, lowest).astype(np.int64)  # ticks, every joint
    box_upper = np.minimum(start + reach, highest).astype(np.int64)
    lower, upper = box_lower[tip], box_upper[tip]
    if np.any(lower > upper):  # the start lies outside a limit (a state is checked before)
        return None
    max_boxes = int(max_boxes * min(1.0, (BOUND_BOX_JOINTS / int(tip.sum())) ** 2))
    # the box halved along its widest joint, the halves listed at once (the listing's kernel
    # releases the GIL; each in a copy of this context, so that it hears the caller's time
    # limit)
    widest = int(np.argmax(upper - lower))
    middle = int(lower[widest] + (upper[widest] - lower[widest]) // 2)
    halves = [(lower, upper.copy()), (lower.copy(), upper)]
    halves[0][1][widest], halves[1][0][widest] = middle, middle + 1
    halves = [(lo, hi) for lo, hi in halves if lo[widest] <= hi[widest]]

    def listed(lo: IntArray, hi: IntArray) -> GoalStates:
        return lattice_goal_states(
            arm,
            target.position,
            tolerance * (1.0 + 1e-9) + 1e-12,  # a superset of the exact test's states
            tip,
            start,
            lo,
            hi,
            max_boxes=max_boxes // len(halves),
            max_states=max_states // len(halves),
        )

    with ThreadPoolExecutor(max_workers=len(halves)) as pool:
        tasks = [pool.submit(contextvars.copy_context().run, listed, *h) for h in halves]
        parts = [task.result() for task in tasks]
    if not all(part.complete for part in parts):
        return None
    ticks = np.vstack([part.ticks for part in parts])
    boxes = sum(part.boxes for part in parts)
    idle = np.flatnonzero(~tip)
    turned = (
        isinstance(rule, PoseOrientation)
        and idle.size == 1
        and arm.joints[int(idle[0])].kind is JointKind.REVOLUTE
    )
    rule_kept = rule is None or isinstance(rule, AxisCone) or idle.size == 0 or turned
    needed = np.zeros(0, dtype=np.int64)
    if ticks.shape[0]:
        q = grid.to_joint(ticks)
        pos, angle = _pose_residuals(
            arm, target if rule_kept else replace(target, orientation=None), q
        )
        ok = (pos <= tolerance) & arm.within_limits(q)
        if rule is not None and rule_kept and not turned:
            ok &= angle <= rule.tolerance_rad  # as a plan's goal state is taken
        ticks = ticks[ok]
        needed = grid.commands_needed_many(ticks - start)
        if turned and ticks.shape[0]:
            assert isinstance(rule, PoseOrientation)
            i = int(idle[0])
            keeps, turn = _turn_keeping_pose(
                arm,
                rule,
                ticks,
                i,
                int(start[i]),
                int(box_lower[i]),
                int(box_upper[i]),
            )
            ticks, needed = ticks[keeps], np.maximum(needed, turn)[keeps]
    fewest = plan_commands
    if ticks.shape[0]:
        fewest = min(fewest, int(needed.min()))
    return LatticeBound(fewest, int(ticks.shape[0]), plan_commands - 1, boxes, rule_kept)


def _turn_keeping_pose(
    arm: SerialArm,
    rule: PoseOrientation,
    ticks: IntArray,
    joint: int,
    start_tick: int,
    low_tick: int,
    high_tick: int,
) -> tuple[BoolArray, IntArray]:
    """For each state ``ticks (K, n)`` (``joint`` at any value), whether a tick of ``joint``
    within ``low_tick`` .. ``high_tick`` (inside its limits) puts the tool frame within the
    rule's tolerance, and the commands the nearest such tick to ``start_tick`` takes it from
    there.

    The tool's rotation is ``P Rz(theta) Q`` in the joint's value ``theta`` (the others held),
    so ``trace(R_target^T R) = a cos(theta) + b sin(theta) + c``, read off at 0, pi/2 and pi;
    the rule asks for at least ``1 + 2 cos(tolerance)``: an arc of ``theta`` about
    ``atan2(b, a)`` (or all, or none). Its ends are widened by 1e-9, so no tick keeping the
    rule is missed."""
    grid = arm.lattice
    tick = float(grid.tick[joint])
    q = grid.to_joint(ticks)
    f = []
    for theta in (0.0, 0.5 * np.pi, np.pi):
        q[:, joint] = theta
        R = tool_pose(arm, q)[:, :3, :3]
        f.append(np.einsum("kij,ij->k", R, rule.R_world_tool))
    c = 0.5 * (f[0] + f[2])
    a, b = 0.5 * (f[0] - f[2]), f[1] - c
    need = 1.0 + 2.0 * np.cos(rule.tolerance_rad) - 1e-9
    r = np.hypot(a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(r > 1e-12, (need - c) / r, np.where(c >= need, -np.inf, np.inf))
    everywhere = x <= -1.0
    half = np.arccos(np.clip(x, -1.0, 1.0)) + 1e-9
    centre = np.arctan2(b, a)
    lo, hi = low_tick, high_tick
    best = np.full(ticks.shape[0], np.inf)  # ticks from the start to the nearest keeping it
    if lo <= hi:
        best[everywhere] = abs(int(np.clip(start_tick, lo, hi)) - start_tick)
        some = (x < 1.0) & ~everywhere
        turns = np.arange(
            int(np.floor((lo * tick - np.pi) / (2 * np.pi))) - 1,
            int(np.ceil((hi * tick + np.pi) / (2 * np.pi))) + 2,
        )
        for k in turns:
            first = np.maximum(np.ceil((centre - half + 2 * np.pi * k) / tick), lo)
            last = np.minimum(np.floor((centre + half + 2 * np.pi * k) / tick), hi)
            there = some & (first <= last)
            gap = np.abs(np.clip(start_tick, first, np.maximum(first, last)) - start_tick)
            best = np.minimum(best, np.where(there, gap, np.inf))
    keeps = np.isfinite(best)
    turn = np.ceil(np.where(keeps, best, 0.0) / int(grid.max_ticks[joint]))
    return keeps, turn.astype(np.int64)


def _count(radius: IntArray) -> float:
    """How many offsets a box of these radii holds (in floating point: 25^16 overflows the
    integers of a sixteen-joint arm's box)."""
    return float(np.prod(2.0 * radius + 1.0))


def _box(arm: SerialArm, q: FloatArray, tol: float) -> tuple[IntArray, FloatArray]:
    """Integer offsets around ``q``'s nearest lattice state (a box, wider for joints that move
    the tool less, at most :data:`BOX_BUDGET` of them) and the tool's linearised move (model
    unit) for each offset from ``q`` itself."""
    J = tick_jacobian(arm, q)
    lever = np.linalg.norm(J, axis=0)
    active = lever > 1e-9 * tol
    radius = np.zeros(arm.n_joints, dtype=np.int64)
    if np.any(active):
        # joints that move the tool less get more ticks: the radius is ``scale * tol / lever``
        # (1 to 12 ticks), with the largest scale whose box holds the budget (bisection)
        inv = np.divide(tol, lever, out=np.zeros_like(lever), where=active)

        def box(scale: float) -> IntArray:
            return np.where(active, np.clip(np.round(scale * inv), 1, 12), 0).astype(np.int64)

        lo_s, hi_s = 0.0, 1e4
        for _ in range(40):
            mid = 0.5 * (lo_s + hi_s)
            if _count(box(mid)) <= BOX_BUDGET:
                lo_s = mid
            else:
                hi_s = mid
        radius = box(lo_s)
        if _count(radius) > BOX_BUDGET:  # even one tick either way on every joint (3^11)
            radius = _one_tick_on_most(np.where(active, lever, 0.0), BOX_BUDGET)
    return _offsets(radius), J


def _one_tick_on_most(lever: FloatArray, budget: int) -> IntArray:
    """Radii of one tick on the joints of largest ``lever`` (how far a tick moves the tool;
    0: the joint gets none), as many as a box of ``budget`` offsets holds (3^k)."""
    fit = int(np.log(budget) / np.log(3.0))
    radius = np.zeros(lever.size, dtype=np.int64)
    radius[np.argsort(-lever, kind="stable")[:fit]] = 1
    radius[lever <= 0.0] = 0
    return radius


def _offsets(radius: IntArray) -> IntArray:
    """Every integer offset within ``radius`` of 0 on each coordinate, ``(K, len(radius))``
    (the coordinates of radius 0 held at 0, so an arm of any number of joints fits numpy's
    32 dimensions as long as the box does)."""
    moving = np.flatnonzero(radius)
    out = np.zeros((int(_count(radius)), radius.size), dtype=np.int64)
    if moving.size:
        grid = np.indices(tuple(2 * radius[moving] + 1)).reshape(moving.size, -1).T
        out[:, moving] = grid - radius[moving]
    return out


def lattice_candidates(
    arm: SerialArm,
    target: ToolTarget,
    q: FloatArray,
    tol: float,
    both: bool = False,
) -> tuple[IntArray, FloatArray]:
    """Lattice states near family member ``q`` whose tool is within ``tol`` of the target (and
    keeps its orientation rule) and that lie within the limits: ``(K, n)`` ticks and their exact
    position errors (model unit).

    Two searches: (1) a box of integer offsets around ``q``'s nearest lattice state whose
    linearised tool error is within the tolerance; (2) the joints that move the tool least
    (up to three, *fine*) are solved, the others (*coarse*) run over a box of lattice values:
    for each coarse choice whose linearised error the fine joints can take up, the fine joints
    are solved exactly (Newton steps on the forward kinematics) and rounded both ways. The
    second finds lattice states where the coarse joints alone put the tool millimetres apart
    (large arms: a tick of the base joint moves the tool 2 mm on a 1 m reach). It runs where
    the first finds fewer than four, or always with ``both``, as a reach asks: a wider
    tolerance then keeps the accurate states a narrower one finds (a KUKA-like arm's reach
    erred 0.0039 mm with a tolerance of 0.05 mm and 0.028 mm with 0.2 mm: the first search's
    box found enough states, the most accurate not among them)."""
    grid = arm.lattice
    offsets, J = _box(arm, q, tol)
    exact = grid.to_ticks_float(q)
    base = np.round(exact).astype(np.int64)
    lin = (offsets + (base - exact)) @ J.T  # the tool's linearised move from q
    near = np.einsum("ij,ij->i", lin, lin) <= (1.5 * tol + 1e-3 * tol) ** 2

    def checked(cand: IntArray) -> tuple[IntArray, FloatArray]:
        if cand.shape[0] == 0:
            return cand, np.zeros(0)
        q_c = grid.to_joint(cand)
        pos, ang = _pose_residuals(arm, target, q_c)
        ok = (pos <= tol) & arm.within_limits(q_c)
        if target.orientation is not None:
            ok &= ang <= target.orientation.tolerance_rad
        return cand[ok], pos[ok]

    found, err = checked(base + offsets[near])
    if found.shape[0] >= 4 and not both:
        return found, err
    more, more_err = checked(np.unique(_solved_fine(arm, target, q, tol, J), axis=0))
    keep = ~np.any(np.all(more[:, None, :] == found[None, :, :], axis=-1), axis=1)
    return np.vstack([found, more[keep]]), np.r_[err, more_err[keep]]


#: Coarse lattice choices tried around one family member by the fine-joint solve.
COARSE_BUDGET = 20_000


def _solved_fine(
    arm: SerialArm, target: ToolTarget, q: FloatArray, tol: float, J: FloatArray
) -> IntArray:
    """Lattice states from the fine-joint solve of :func:`lattice_candidates` (unchecked)."""
    grid = arm.lattice
    n = arm.n_joints
    lever = np.linalg.norm(J, axis=0)
    active = np.flatnonzero(lever > 1e-9 * tol)
    if active.size < 2:
        return np.zeros((0, n), dtype=np.int64)
    by_lever = active[np.argsort(lever[active])]
    fine = by_lever[: min(3, active.size - 1)]
    coarse = np.setdiff1d(active, fine)
    if coarse.size == 0 or np.linalg.matrix_rank(J[:, fine], tol=1e-9 * lever.max()) < 2:
        return np.zeros((0, n), dtype=np.int64)
    # the coarse box: equal radii within the budget; where even one tick either way on every
    # coarse joint is too many (more than nine of them), on those that move the tool most
    radius = max(int(np.floor((COARSE_BUDGET ** (1.0 / coarse.size) - 1) / 2)), 1)
    radii = np.full(coarse.size, radius, dtype=np.int64)
    if _count(radii) > COARSE_BUDGET:
        radii = _one_tick_on_most(lever[coarse], COARSE_BUDGET)
    d_c = _offsets(radii)
    exact = grid.to_ticks_float(q)
    base = np.round(exact).astype(np.int64)
    r = base - exact
    # what the fine joints must take up, and how much of it they can (least squares)
    y = -(d_c + r[coarse]) @ J[:, coarse].T - J[:, fine] @ r[fine]
    pinv = np.linalg.pinv(J[:, fine])
    x = y @ pinv.T
    miss = np.linalg.norm(x @ J[:, fine].T - y, axis=1)
    # a loose linear prefilter (the exact solve below absorbs the curvature)
    keep = np.flatnonzero(miss <= max(10.0 * tol, 0.2 * float(lever[coarse].min())))
    if keep.size == 0:
        return np.zeros((0, n), dtype=np.int64)
    keep = keep[np.argsort(miss[keep])[:400]]
    ticks = np.broadcast_to(base.astype(np.float64), (keep.size, n)).copy()
    ticks[:, coarse] += d_c[keep]
    ticks[:, fine] += x[keep]
    qs = grid.to_joint(ticks)
    for _ in range(4):  # exact Newton on the fine joints
        frames = forward_frames(arm, qs)
        e = target.position - frames[:, -1, :3, 3]
        Jf = jacobian_from_frames(arm, frames)[:, :3][:, :, fine]
        step = np.einsum("mij,mj->mi", np.linalg.pinv(Jf), e)
        qs[:, fine] += step
    t_fine = grid.to_ticks_float(qs)[:, fine]
    corners = np.array([[(c >> b) & 1 for b in range(fine.size)] for c in range(2**fine.size)])
    out = np.repeat(
        np.round(grid.to_ticks_float(qs)).astype(np.int64)[:, None], corners.shape[0], 1
    )
    out[:, :, fine] = np.floor(t_fine).astype(np.int64)[:, None, :] + corners[None]
    return out.reshape(-1, n)


#: Where no family member reaches the target exactly, the nearest point the arm reaches is
#: aimed at instead when it lies within this share of the tolerance of the target (the rest
#: of the tolerance about it is searched: a UR5's target 0.03 mm beyond its stretched reach,
#: with 0.05 mm, was refused at one half).
NEAREST_SHARE = 0.8


@dataclass(frozen=True)
class GenericReach:
    """What the generic search produced (the planner wraps it into a reach result)."""

    sequence: CommandSequence
    clearance: object
    bound: GenericBound
    examined: int
    checks: int
    rejected: tuple[str, ...]
    method: str


def reach_any_arm(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: IntArray,
    target: ToolTarget,
    tolerance: float,
    extra_commands: int = 3,
    max_motion_checks: int = 40,
    plan_around: bool = True,
    seed: int = 0,
    at_nearest: bool = False,
) -> GenericReach:
    """The fewest commands from ``start_ticks`` to the target (then the smallest error), for any
    arm (see the module docstring); ``at_nearest``: the target is already the nearest point the
    arm reaches to the one asked for (taken once, so this ends): where no member reaches the
    target exactly but one comes within :data:`NEAREST_SHARE` of the tolerance (an arm whose
    tool point cannot go everywhere near it; a target just beyond a stretched arm's reach),
    the fewest commands are searched within the tolerance less that distance of the nearest
    point, and the bound is the least found there. Raises
    :class:`UnreachableError` naming the nearest reachable point when no configuration within
    the limits reaches the target."""
    grid = arm.lattice
    start = validated_start(arm, world, start_ticks, target)
    check_target_clear_of_fixed_links(arm, world, target.position, tolerance)
    s_q = grid.to_joint(start)
    rng = np.random.default_rng(seed)
    fam = GenericFamily(arm, target)
    # a joint that does not move the tool point (a SCARA's last, the UR5's sixth without a
    # tool) only turns the tool about it: with no orientation rule held where it starts in
    # every member tried, not turned at random
    idle = ~tool_point_joints(arm) if target.orientation is None else np.zeros(arm.n_joints, bool)

    def held(q: FloatArray) -> FloatArray:
        q = np.array(q, dtype=np.float64)
        q[..., idle] = s_q[idle]
        return q

    samples = held(fam.samples(near=s_q, rng=rng))
    unit = arm.length_unit
    where = ", ".join(f"{v:g}" for v in target.position)
    if samples.shape[0] == 0:
        dist, tip = nearest_reachable(arm, target, rng)
        if dist > tolerance:
            raise _out_of_reach(arm, target, dist, tip)
        if target.orientation is None and dist <= NEAREST_SHARE * tolerance and not at_nearest:
            # an arm whose tool point cannot go everywhere near the target (fewer than three
            # joints move it, or all in one plane) has no member reaching it exactly: the
            # nearest point it reaches is taken, and a state within the tolerance less the
            # distance of that point is within the tolerance of the target
            near_point = replace(target, position=np.asarray(tip, dtype=np.float64))
            try:
                near = reach_any_arm(
                    arm, world, start_ticks, near_point, tolerance - dist, extra_commands,
                    max_motion_checks, plan_around, seed, at_nearest=True,
                )  # fmt: skip
            except UnreachableError:
                raise UnreachableError(
                    f"target ({where}) {unit}: no configuration within the limits found reaching "
                    f"it, nor the nearest point the arm reaches, {dist:.2g} {unit} from it"
                ) from None
            method = f"{near.bound.method}; at the nearest point reached, {dist:.2g} {unit} off"
            return replace(near, bound=replace(near.bound, method=method))
        raise _no_member(arm, target, dist, tip, tolerance)
    bound = generic_bound(arm, target, start, tolerance, samples)
    check_size(
        bound.commands,
        MAX_COMMANDS,
        "commands of the reach (the least found over the family)",
        "the target, the start, or the arm's lattice (its ticks and largest steps)",
    )
    metric = command_metric(arm, samples, s_q)
    pool = np.vstack([bound.configuration[None], samples])
    pool_metric = np.r_[bound.change_commands, metric]
    spread = grid.max_step * 0.5
    examined, checks = 0, 0
    failures: list[str] = []
    for n in range(bound.commands, bound.commands + extra_commands + 1):
        check_time(f"searching the lattice for {n} commands")
        within = pool_metric <= n + 1e-9
        members = _diverse(pool[within], pool_metric[within], MEMBERS_PER_COUNT, spread)
        if members.shape[0] < MEMBERS_PER_COUNT // 2:
            # few samples fit in n commands (n is tight): draw more members of the family
            # inside the n-command box around the bound's configuration
            extra = held(_members_in_box(fam, bound.configuration, s_q, n, rng))
            if extra.shape[0]:
                em = command_metric(arm, extra, s_q)
                pool = np.vstack([pool, extra])
                pool_metric = np.r_[pool_metric, em]
                within = pool_metric <= n + 1e-9
                members = _diverse(pool[within], pool_metric[within], MEMBERS_PER_COUNT, spread)
        found: list[IntArray] = []
        errors: list[float] = []
        for q in members:
            cand, err = lattice_candidates(arm, target, q, tolerance, both=True)
            examined += cand.shape[0]
            if cand.shape[0] == 0:
                continue
            fits = grid.commands_needed_many(cand - start) <= n
            found.extend(cand[fits])
            errors.extend(err[fits])
        if not found:
            failures.append(
                f"{n} commands: no lattice state within {tolerance:g} {unit} of the target found "
                f"near {members.shape[0]} family members within {n} commands"
            )
            continue
        cands = np.array(found)
        errs = np.array(errors)
        cands, first = unique_states(cands, return_index=True)
        errs = errs[first]
        order = np.argsort(errs, kind="stable")
        clear = world.slack(arm, grid.to_joint(cands[order[: 4 * max_motion_checks]])) >= 0
        tried = order[: 4 * max_motion_checks][clear][:max_motion_checks]
        if tried.size == 0:
            failures.append(f"{n} commands: every goal state within tolerance is in collision")
            continue
        blocked = ""
        for i in tried:
            check_time(f"checking the direct motions of {n} commands")
            seq = CommandSequence.straight(start, cands[i], lattice=grid)
            checks += 1
            mc = motion_clearance(arm, world, seq)
            if mc.certified_ok:
                return GenericReach(seq, mc, bound, examined, checks, tuple(failures), "direct")
            blocked = blocked or (
                f"{mc.limiting_pair} is {mc.limiting_slack:+.2f} {unit} off its required "
                f"clearance during command {mc.limiting_command}"
            )
        failures.append(f"{n} commands: every direct motion is blocked (e.g. {blocked})")
    if not plan_around:
        raise PlanningError(
            f"no clear direct motion reaches the target within "
            f"{bound.commands + extra_commands} commands ({'; '.join(failures)})"
        )
    goals = generic_goal_states(arm, world, start, target, tolerance, samples=samples, rng=rng)
    try:
        plan = plan_motion(arm, world, start, goals, MotionOptions(seed=seed), turn_copies=True)
    except PlanningError as exc:
        # the members with the joints that do not move the tool point held where they start
        # can leave one goal state, whose motions may all fail (a tool tip 0.002 mm above a
        # table: no motion onto it proven clear); the whole family's goal states, as
        # plan_to_point takes them, where there are such joints and other goal states
        if not idle.any():
            raise
        try:
            more = generic_goal_states(arm, world, start, target, tolerance, rng=rng)
        except PlanningError:
            raise exc from None
        new = ~(more[:, None, :] == goals[None, :, :]).all(axis=-1).any(axis=1)
        if not new.any():
            raise
        try:
            plan = plan_motion(arm, world, start, more, MotionOptions(seed=seed), turn_copies=True)
        except PlanningError:
            raise exc from None
    end = plan.sequence.states()[-1]
    if grid.commands_needed_many((end - start)[None])[0] < bound.commands:
        # the bound is the least found over samples, not proven: a plan's end state that
        # needs fewer commands is a configuration reaching the target the samples missed
        q_end = grid.to_joint(end)
        change = float(command_metric(arm, q_end[None], s_q)[0])
        bound = replace(
            bound,
            commands=max(int(np.ceil(change - 1e-9)), 0),
            change_commands=change,
            configuration=q_end,
            method=bound.method + "; lowered to the planned end state, which needs fewer",
        )
    return GenericReach(
        plan.sequence,
        plan.clearance,
        bound,
        examined,
        checks,
        (*failures, "planned around the obstacles instead"),
        plan.method,
    )


def goal_links_rule(
    arm: SerialArm, world: CollisionWorld, position: FloatArray, body_buffer: float
) -> Callable[[FloatArray, float], BoolArray]:
    """The goal states' clearance rule at a tool point ``position``: a function of
    configurations ``q (M, n)`` rad and a ``tip_tolerance`` telling which may be goal states,
    their links keeping the margin plus ``body_buffer`` and the tool point no deeper than
    ``tip_tolerance`` in an obstacle. The tool's own link against the surface its point touches,
    or the nearest surface within the planner's retreat (:attr:`MotionOptions.approach_mm`, by
    default), meets it head-on from a retracted pre-goal (see plan_motion): it needs the margin
    only, not the buffer."""
    pairs = world.pairs(arm)
    is_tip = np.array([c.is_tip for c in pairs], dtype=bool)
    required = world.required(arm)
    # the surfaces the tool meets head-on: those its point touches, and the nearest within the
    # motion planner's retreat of the target (it plans onto such a goal from a pre-goal backed
    # off along that surface's normal, see retracted_pre_goal); a target a hair above a table
    # was held to the buffer against it, and refused
    gaps = np.array([abs(float(o.signed_distance(position))) for o in world.obstacles])
    touched = {o.name for o, gap in zip(world.obstacles, gaps, strict=True) if gap <= 1e-6}
    if gaps.size and gaps.min() <= MotionOptions().approach_mm:
        touched.add(world.obstacles[int(np.argmin(gaps))].name)
    tool_link = pairs[int(np.flatnonzero(is_tip)[0])].part.removesuffix(" tip") if any(
        is_tip
    ) else None  # fmt: skip
    buffer = np.array(
        [0.0 if (c.part == tool_link and c.other in touched) else body_buffer for c in pairs]
    )

    def clear(q: FloatArray, tip_tolerance: float) -> BoolArray:
        values, _ = world.pair_clearances(arm, q)
        ok = np.where(is_tip, values >= -tip_tolerance, values - required >= buffer)
        return np.asarray(np.all(ok, axis=-1), dtype=bool)

    return clear


def generic_goal_states(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: IntArray,
    target: ToolTarget,
    tolerance: float,
    count: int = 12,
    body_buffer: float = 1.5,
    spread_deg: float = 4.0,
    samples: FloatArray | None = None,
    rng: np.random.Generator | None = None,
    nearest_member: bool = False,
) -> IntArray:
    """Lattice states within ``tolerance`` of the target whose links keep the margin plus
    ``body_buffer`` (the tool tip only must not enter; where no state found does, the margin
    alone), at most ``count``, spread over the family (members at least ``spread_deg``
    apart), nearest the start in commands first.

    Next to each member the clear lattice state with the smallest error is taken, or with
    ``nearest_member`` the one nearest the member in commands (the smallest error among
    equals): members chosen for where they lie (a tour's guide) keep their place, where the
    most accurate state can lie degrees away along a wrist joint."""
    grid = arm.lattice
    start = np.asarray(start_ticks, dtype=np.int64)
    s_q = grid.to_joint(start)
    gen = rng or np.random.default_rng(0)
    if samples is None:
        samples = GenericFamily(arm, target).samples(near=s_q, rng=gen)
    where = ", ".join(f"{v:g}" for v in target.position)
    if samples.shape[0] == 0:
        raise _no_member(arm, target, *nearest_reachable(arm, target, gen), tolerance)
    samples = shift_into_limits(arm, samples, s_q)
    # a joint that cannot cross its own self-collision ranges reaches only the copies of its
    # values on the start's side of them (the UR5's elbow): measured there, or not at all
    samples, reachable = into_windows(samples, world.joint_windows(arm, s_q))
    samples = samples[reachable]
    if samples.shape[0] == 0:
        raise PlanningError(
            f"every configuration reaching ({where}) {arm.length_unit} lies beyond a joint's "
            "self-collision range from the start"
        )
    # the links keep the buffer where any member lets them; where none does (a Kinova's
    # links within 2.5 mm of the UR5 cell's workpiece at every member reaching its first
    # weld, which a reach reached directly), the margin alone
    found = None
    for buffer in dict.fromkeys((body_buffer, 0.0)):
        found = _clear_goal_states(
            arm, world, start, target, tolerance, samples, count, spread_deg, nearest_member,
            buffer,
        ) or found  # fmt: skip
        if found is not None and found[0]:
            break
    if found is None:
        held = "" if target.orientation is None else target.orientation.words()
        raise no_clear_goal_error(where, arm.length_unit, world, 0.0, held)
    states, within, members = found
    if not states and within == 0:
        raise PlanningError(_lattice_too_coarse(arm, target, members, tolerance, where))
    if not states:
        raise PlanningError(
            f"no lattice state within {tolerance:g} {arm.length_unit} of ({where}) "
            f"{arm.length_unit} satisfies the clearance rule"
        )
    out = np.array(states, dtype=np.int64)
    order = np.argsort(grid.commands_needed_many(out - start), kind="stable")
    return out[order]


def _clear_goal_states(
    arm: SerialArm,
    world: CollisionWorld,
    start: IntArray,
    target: ToolTarget,
    tolerance: float,
    samples: FloatArray,
    count: int,
    spread_deg: float,
    nearest_member: bool,
    body_buffer: float,
) -> tuple[list[IntArray], int, FloatArray] | None:
    """What :func:`generic_goal_states` takes with the links keeping ``body_buffer`` beyond
    the margin: the lattice states (at most ``count``), how many lattice states lay within
    the tolerance (clear or not), and the members searched about; None where no member of
    ``samples`` keeps the rule."""
    grid = arm.lattice
    s_q = grid.to_joint(start)
    # a member's tool point is on the target, which may lie on a surface: rounding puts it a
    # hair inside; the lattice states near it are held to the rule exactly below
    goal_clear = goal_links_rule(arm, world, target.position, body_buffer)
    body_ok = goal_clear(samples, tolerance)
    if not np.any(body_ok):
        return None
    samples = samples[body_ok]
    metric = command_metric(arm, samples, s_q)
    members = _diverse(samples, metric, 4 * count, np.full(arm.n_joints, np.radians(spread_deg)))
    states: list[IntArray] = []
    within = 0  # lattice states within the tolerance, clear or not
    for q in members:
        check_time("finding goal states")
        cand, err = lattice_candidates(arm, target, q, tolerance)
        within += cand.shape[0]
        if cand.shape[0] == 0:
            continue
        ok = goal_clear(grid.to_joint(cand), -PROVABLE_SLACK)  # the tip provably outside
        if not np.any(ok):
            continue
        idx = np.flatnonzero(ok)
        if nearest_member:
            away = np.round(command_metric(arm, grid.to_joint(cand[idx]), q), 9)
            k = int(idx[np.lexsort((err[idx], away))[0]])
        else:
            k = int(idx[np.argmin(err[idx])])
        if any(np.array_equal(cand[k], s) for s in states):
            continue
        states.append(cand[k])
        if len(states) >= count:
            break
    return states, within, members


def _lattice_too_coarse(
    arm: SerialArm, target: ToolTarget, members: FloatArray, tolerance: float, where: str
) -> str:
    """Why no lattice state is within ``tolerance`` of the target near any of ``members``: how
    far one tick moves the tool there, and the smallest error of a lattice state near them
    (searched with the tolerance doubled up to eight times, over the first 16 members)."""
    unit = arm.length_unit
    lever = np.linalg.norm(tick_jacobian(arm, members[0]), axis=0)
    moving = np.flatnonzero(lever > 1e-9 * max(float(lever.max()), 1e-300))
    joints = ", ".join(str(j + 1) for j in moving)
    rule = target.orientation
    if isinstance(rule, AxisCone):
        held = (
            f" with the tool axis within {np.degrees(rule.tolerance_rad):g} deg of "
            f"({', '.join(f'{v:.3g}' for v in rule.direction)})"
        )
        wider = ", or a wider axis tolerance (--axis-tolerance; axis_tolerance_deg=)"
    elif rule is not None:
        held = f" with the tool frame within {np.degrees(rule.tolerance_rad):g} deg of the pose"
        wider = ", or a wider angle tolerance (--angle-tolerance; angle_tolerance_deg=)"
    else:
        held = wider = ""
    why = (
        f"no lattice state puts the tool within {tolerance:g} {unit} of ({where}) {unit}{held}: "
        f"one tick of the joints that move the tool point there ({joints}) moves it "
        f"{lever[moving].min():.3g}..{lever[moving].max():.3g} {unit}"
    )
    tol = tolerance
    for _ in range(8):
        tol *= 2.0
        errors = [lattice_candidates(arm, target, q, tol)[1] for q in members[:16]]
        found = np.concatenate(errors)
        if found.size:
            nearest = float(found.min())
            hint = (
                f" (only {moving.size} joints move the tool point: a tool offset from the "
                "wrist centre lets the others take up the error)"
                if moving.size <= 3 < arm.n_joints
                else ""
            )
            return f"{why}; {nearest_found_advice(nearest, unit)}{wider}{hint}"
    return f"{why}; none within {tol:g} {unit} either" + (
        f": try{wider.removeprefix(', or')}" if wider else ""
    )


__all__ = [
    "GenericBound",
    "GenericReach",
    "LatticeBound",
    "command_metric",
    "generic_bound",
    "generic_goal_states",
    "goal_links_rule",
    "lattice_bound",
    "lattice_candidates",
    "nearest_reachable",
    "no_clear_goal_error",
    "reach_any_arm",
]
