"""Reach a point in the fewest commands, then with the smallest fingertip error.

The seed arm's fingertip depends on joints 1-5, so a target has a two-dimensional family of
joint solutions (:mod:`armpath.ik.seed_position`). A sequence of ``N`` commands can change every
joint by at most ``2N`` degrees, so

1. **Lower bound.** The smallest largest joint change over every configuration within the
   tolerance of the target, ``t*``, gives ``N >= ceil(t* / 2 deg)``. ``t*`` is found by a grid over
   the whole family (wrist point D on a sphere around the target, eight branches, joints 1 and 4
   taken at the turn nearest the start, limits respected) refined by SLSQP on the epigraph
   problem ``min t s.t. |E(q) - target| <= tol, |q_i - start_i| <= t``.
2. **Lattice search.** For ``N`` from the bound upward, every lattice state within ``20 N`` ticks of
   the start (and within limits) that lies near the family is enumerated: two of the joints
   {1, 4, 5} run over *all* their lattice values in the feasible region, the other three are
   solved in closed form and rounded down and up, for three choices of the pair (so that no
   singular parametrization hides a good state); the best states are then polished by exhaustive
   +-1 tick neighbourhoods.
3. **Motion.** The move to the best state is split evenly into ``N`` commands and its continuous
   motion is checked against the scene with a certified bound; the first clear state in order of
   error is taken. Blocked direct motions raise :class:`~armpath.errors.PlanningError` (planning
   around obstacles is a separate planner).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.angles import nearest_equivalent, wrap_to_pi
from armpath.budget import check_time
from armpath.commands import (
    MAX_INCREMENT_TICKS,
    TICK_DEG,
    TICK_RAD,
    CommandSequence,
    ticks_to_rad,
)
from armpath.errors import (
    CollisionError,
    InvalidInputError,
    PlanningError,
    TimeLimitError,
    UnreachableError,
)
from armpath.geometry.primitives import PROVABLE_SLACK
from armpath.geometry.world import CollisionWorld
from armpath.ik.seed_position import (
    FIXED_PAIRS,
    family_from_wrist,
    fingertip,
    solve_with_fixed_pair,
)
from armpath.ik.target import Orientation, ToolTarget
from armpath.kinematics import tool_point_with_jacobian, tool_pose, tool_position
from armpath.model.lattice import unique_states
from armpath.model.seed_arm import SeedArmGeometry, seed_geometry_of
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import MotionOptions, MotionPlan, plan_motion
from armpath.planning.motion_check import (
    MotionClearance,
    check_state_clear,
    check_target_clear_of_fixed_links,
    motion_clearance,
)
from armpath.planning.passages import passage_source
from armpath.tolerances import POINT_TOLERANCE_MM, check_point_tolerance, nearest_found_advice

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Joints that move the fingertip (0-based); joint 6 only turns the tool and is left unchanged.
TIP_JOINTS = 5
#: A target this close (mm) inside a surface counts as on it (a point computed on the surface).
SURFACE_TOLERANCE_MM = 1e-6
#: Defaults of :func:`goal_states`: how many states, the links' clearance beyond the margin (mm)
#: and the least largest-joint difference between the family samples they start from (deg).
GOAL_COUNT = 12
GOAL_BODY_BUFFER_MM = 1.5
GOAL_SPREAD_DEG = 4.0
#: Family samples checked for clearance at a time while goal states are picked.
GOAL_SAMPLE_CHUNK = 8192


@dataclass(frozen=True)
class ReachOptions:
    """Settings of :func:`plan_reach`.

    Attributes
    ----------
    tolerance_mm:
        Largest acceptable fingertip error (mm). Fewest commands first, among plans within this
        tolerance; then the smallest error.
    extra_commands:
        How many commands beyond the lower bound to try before giving up.
    sphere_step_deg:
        Grid step (deg) over the sphere of wrist points that maps the solution family.
    polish_candidates:
        How many of the best lattice states get their +-1 tick neighbourhoods searched.
    max_motion_checks:
        Largest number of candidate motions checked for clearance per command count (spread
        over the feasible region, at most 3 per 5 deg cell of joint space).
    clearance_tolerance_mm:
        Precision of the continuous clearance computation (mm).
    plan_around:
        When every direct motion is blocked, plan around the obstacles
        (:func:`armpath.planning.motion.plan_motion` to clear goal states from
        :func:`goal_states`) instead of raising :class:`PlanningError`.
    """

    tolerance_mm: float = POINT_TOLERANCE_MM
    extra_commands: int = 3
    sphere_step_deg: float = 1.0
    polish_candidates: int = 64
    max_motion_checks: int = 60
    clearance_tolerance_mm: float = 0.01
    plan_around: bool = True

    def __post_init__(self) -> None:
        check_point_tolerance(self.tolerance_mm)
        if not 0 <= self.extra_commands <= 20:
            raise InvalidInputError(f"extra_commands must be in [0, 20], got {self.extra_commands}")
        if not (1 <= self.max_motion_checks <= 10_000 and 0 <= self.polish_candidates <= 10_000):
            raise InvalidInputError("max_motion_checks and polish_candidates must be in [1, 1e4]")
        if not (0.05 <= self.sphere_step_deg <= 5.0):
            raise InvalidInputError("sphere_step_deg must be in [0.05, 5] deg")


@dataclass(frozen=True)
class LowerBound:
    """What the search proved about the command count.

    ``commands = ceil(max_joint_change_deg / 2)``: no sequence of fewer commands can bring the
    fingertip within the tolerance. ``exact_max_joint_change_deg`` is the same minimum for
    reaching the target exactly, attained at ``configuration_deg`` (every joint, deg or mm;
    joints that do not move the tool point as they start). For any other arm the change and
    configuration are the family's least found, and ``commands`` the count the lattice
    states prove (``method`` says which), which may lie above it: lattice states are fewer.
    """

    commands: int
    max_joint_change_deg: float
    exact_max_joint_change_deg: float
    configuration_deg: tuple[float, ...]
    method: str
    #: Whether the bound is a proof (the seed arm's closed-form family searched on a grid
    #: and refined; any other arm's lattice states listed,
    #: :func:`~armpath.planning.reach_generic.lattice_bound`) or the best
    #: a multi-start search over the family found (where the listing's budget ran out).
    proven: bool = True


@dataclass(frozen=True, eq=False)
class ReachResult:
    """A reach plan and its metrics (lengths mm, angles deg, commands in ticks of 0.1 deg)."""

    sequence: CommandSequence
    target_mm: FloatArray
    tip_mm: FloatArray
    error_mm: float
    tolerance_mm: float
    lower_bound: LowerBound
    clearance: MotionClearance
    lattice_states_examined: int
    motion_checks: int
    fewer_commands_rejected: tuple[str, ...] = ()
    method: str = "direct"
    #: The orientation rule of the tool at the target, if any, and the tool's angle to it at
    #: the goal (rad; the rule's direction or rotation).
    orientation: Orientation | None = None
    angle_rad: float | None = None

    @property
    def n_commands(self) -> int:
        return self.sequence.n_commands

    @property
    def is_provably_fewest(self) -> bool:
        """Whether the plan meets a proven lower bound, i.e. no plan has fewer commands."""
        return self.lower_bound.proven and self.n_commands == self.lower_bound.commands

    @property
    def meets_bound(self) -> bool:
        """Whether the plan has as few commands as the bound the search found."""
        return self.n_commands == self.lower_bound.commands


@dataclass(frozen=True)
class _Problem:
    arm: SerialArm
    geometry: SeedArmGeometry
    world: CollisionWorld
    start_ticks: IntArray
    target: FloatArray
    lo_ticks: IntArray  # joint-limit box of joints 1-5, ticks (huge where unlimited)
    hi_ticks: IntArray
    unlimited: NDArray[np.bool_]

    @property
    def start_rad(self) -> FloatArray:
        return ticks_to_rad(self.start_ticks[:TIP_JOINTS])

    def box(self, n: int) -> tuple[IntArray, IntArray]:
        """The lattice states of joints 1-5 that ``n`` commands can reach from the start within
        the joint limits: ``lo .. hi`` ticks, inclusive."""
        start = self.start_ticks[:TIP_JOINTS]
        return (
            np.maximum(start - MAX_INCREMENT_TICKS * n, self.lo_ticks),
            np.minimum(start + MAX_INCREMENT_TICKS * n, self.hi_ticks),
        )

    def normalize(self, q: FloatArray) -> FloatArray:
        """Take unlimited joints to the turn nearest the start, others to [-pi, pi)."""
        s = self.start_rad
        out = np.empty_like(q)
        free = np.flatnonzero(self.unlimited)
        bound = np.flatnonzero(~self.unlimited)
        out[..., free] = nearest_equivalent(q[..., free], s[free])
        out[..., bound] = wrap_to_pi(q[..., bound])
        return out

    def full(self, q5: ArrayLike) -> FloatArray:
        """Joints 1-5 (rad) completed with the start's joint 6."""
        q = np.asarray(q5, dtype=np.float64)
        j6 = np.broadcast_to(ticks_to_rad(self.start_ticks[TIP_JOINTS:]), (*q.shape[:-1], 1))
        return np.concatenate([q, j6], axis=-1)

    def squared_error(self, q5: FloatArray) -> tuple[float, FloatArray]:
        """The squared distance (mm^2) of the fingertip from the target at joints 1-5 ``q5``
        (rad), and its gradient in them: the objective of the nearest-point descents."""
        tip, J = tool_point_with_jacobian(self.arm, self.full(q5))
        e = tip - self.target
        return float(e @ e), 2.0 * e @ J[:, :TIP_JOINTS]

    def errors_of_ticks(self, q_ticks: IntArray) -> FloatArray:
        """Fingertip error (mm) of lattice states of joints 1-5, ``(M, 5)`` ticks."""
        tip = fingertip(self.geometry, ticks_to_rad(q_ticks))
        return np.asarray(np.linalg.norm(tip - self.target, axis=-1))


@dataclass(frozen=True, eq=False)
class _Family:
    """Samples of the solution family on the sphere grid of wrist points.

    ``q`` is ``(P, A, 8, 5)`` rad (polar x azimuth x branch x joint), ``change`` the largest joint
    change from the start ``(P, A, 8)`` rad (``inf`` where a branch is missing or outside the
    limits). ``extra_q`` / ``extra_change`` hold solutions found by other means. ``near``: the
    grid is the family of a point within the tolerance of the target, not of the target (which
    lies just beyond reach): configurations within the tolerance, none exactly on the target.
    """

    q: FloatArray
    change: FloatArray
    extra_q: FloatArray
    extra_change: FloatArray
    near: bool = False

    def points(self) -> tuple[FloatArray, FloatArray]:
        """All samples flattened: ``(M, 5)`` and ``(M,)``."""
        return (
            np.vstack([self.q.reshape(-1, TIP_JOINTS), self.extra_q]),
            np.r_[self.change.reshape(-1), self.extra_change],
        )

    def with_point(self, q: FloatArray, change: float) -> _Family:
        return _Family(
            self.q,
            self.change,
            np.vstack([self.extra_q, q[None]]),
            np.r_[self.extra_change, change],
            self.near,
        )

    def step_ticks(self, limit: float) -> float:
        """Largest joint step (ticks) between neighbouring samples where either is within
        ``limit`` rad of largest change. Jumps over 90 deg are unlimited joints wrapping.
        (Remembered per ``limit``: every fixed pair of one search asks for the same.)"""
        memo: dict[float, float] = self.__dict__.setdefault("_step_memo", {})
        if limit not in memo:
            memo[limit] = self._step_ticks(limit)
        return memo[limit]

    def _step_ticks(self, limit: float) -> float:
        steps = [0.0]
        for axis in (0, 1):
            d = np.abs(np.diff(self.q, axis=axis)).max(axis=-1) / TICK_RAD
            c = self.change
            near = np.minimum(np.delete(c, -1, axis=axis), np.delete(c, 0, axis=axis)) <= limit
            ok = near & np.isfinite(d) & (d < 900)
            if np.any(ok):
                steps.append(float(d[ok].max()))
        return max(steps)


def _family(p: _Problem, step_deg: float) -> _Family:
    q, change = _family_samples(p, step_deg)
    return _Family(q, change, np.zeros((0, TIP_JOINTS)), np.zeros(0))


def _family_samples(p: _Problem, step_deg: float) -> tuple[FloatArray, FloatArray]:
    """Solution family on a sphere grid (polar x azimuth).

    Returns joints ``(P, A, 8, 5)`` rad and the largest change from the start ``(P, A, 8)`` rad
    (``inf`` where a branch does not exist or leaves the joint limits).
    """
    n_polar = max(8, round(180.0 / step_deg))
    polar = np.linspace(0.0, np.pi, n_polar + 1)
    azim = np.linspace(-np.pi, np.pi, 2 * n_polar, endpoint=False)
    P, A = np.meshgrid(polar, azim, indexing="ij")
    dirs = np.stack([np.sin(P) * np.cos(A), np.sin(P) * np.sin(A), np.cos(P)], axis=-1)
    wrist = p.target + p.geometry.de_mm * dirs
    q = p.normalize(family_from_wrist(p.geometry, p.target, wrist))
    change = np.max(np.abs(q - p.start_rad), axis=-1)
    inside = np.all((q >= ticks_to_rad(p.lo_ticks)) & (q <= ticks_to_rad(p.hi_ticks)), axis=-1)
    change = np.where(inside & np.isfinite(change), change, np.inf)
    return q, change


def _reachable_family(p: _Problem, step_deg: float, tolerance_mm: float, seed: int) -> _Family:
    """The target's solution family sampled every ``step_deg``; raises
    :class:`UnreachableError` naming the nearest reachable point and its distance when no
    configuration within the joint limits comes within ``tolerance_mm`` of the target."""
    fam = _family(p, step_deg)
    if np.isfinite(fam.change).any():
        return fam
    # no sample of the family within the limits
    dist, q_near = _nearest_reachable(p, np.random.default_rng(seed))
    if dist > tolerance_mm:
        tip = tool_position(p.arm, p.full(q_near))
        raise UnreachableError(
            f"target ({', '.join(f'{v:g}' for v in p.target)}) mm is out of reach within the "
            f"joint limits: the nearest reachable point "
            f"({', '.join(f'{round(v, 2) + 0.0:.2f}' for v in tip)}) "
            f"mm is {dist:.3f} mm away"
        )
    # the target lies just beyond reach (a stretched arm's tool point within the tolerance of
    # it) or the grid missed a thin sliver of the family: the family of a point on the line
    # from the target through the nearest reachable one, half way from that one to the
    # tolerance's edge and so a little inside the workspace (configurations within the
    # tolerance, every branch), and the optimizer's solution
    tip = tool_position(p.arm, p.full(q_near))
    toward = tip - p.target
    inside = p.target + toward * ((dist + 0.5 * (tolerance_mm - dist)) / max(dist, 1e-12))
    if dist > 1e-9 and np.linalg.norm(inside - p.target) <= tolerance_mm:
        fam = replace(_family(replace(p, target=inside), step_deg), near=True)
    q_near = p.normalize(q_near)
    return fam.with_point(q_near, float(np.max(np.abs(q_near - p.start_rad))))


def _nearest_reachable(p: _Problem, rng: np.random.Generator) -> tuple[float, FloatArray]:
    """Smallest distance from the target to any fingertip position within the joint limits."""
    lo = np.maximum(ticks_to_rad(p.lo_ticks), -np.pi)
    hi = np.minimum(ticks_to_rad(p.hi_ticks), np.pi)
    starts = rng.uniform(lo, hi, size=(48, TIP_JOINTS))
    best_d, best_q = np.inf, starts[0]
    for x0 in starts:
        from scipy.optimize import minimize  # imported when first needed

        res = minimize(
            p.squared_error, x0, jac=True, method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True))
        )
        d = float(np.sqrt(max(res.fun, 0.0)))
        if d < best_d:
            best_d, best_q = d, res.x
    return best_d, best_q


def _minimax(p: _Problem, x0: FloatArray, tol: float | None) -> tuple[float, FloatArray] | None:
    """Refine ``min t s.t. tip within tol (exact if None), |q - start| <= t`` from ``x0``."""
    s = p.start_rad
    lo = ticks_to_rad(p.lo_ticks).astype(float)
    hi = ticks_to_rad(p.hi_ticks).astype(float)
    bounds = [
        (None if u else float(a), None if u else float(b))
        for a, b, u in zip(lo, hi, p.unlimited, strict=True)
    ] + [(0.0, None)]
    z0 = np.r_[x0, np.max(np.abs(x0 - s))]

    last: list[tuple[bytes, FloatArray, FloatArray]] = []  # the last point's tip and
    # Jacobian (SLSQP asks a point's constraints and then their gradients)

    def tip_and_jac(z: FloatArray) -> tuple[FloatArray, FloatArray]:
        key = np.asarray(z[:TIP_JOINTS], dtype=np.float64).tobytes()
        if not last or last[0][0] != key:
            tip, J = tool_point_with_jacobian(p.arm, p.full(z[:TIP_JOINTS]))
            last[:] = [(key, tip - p.target, np.hstack([J[:, :TIP_JOINTS], np.zeros((3, 1))]))]
        return last[0][1], last[0][2]

    def tip_err(z: FloatArray) -> FloatArray:
        return tip_and_jac(z)[0]

    def tip_jac(z: FloatArray) -> FloatArray:
        return tip_and_jac(z)[1]

    eye = np.eye(TIP_JOINTS)
    box_jac = np.vstack(
        [np.hstack([-eye, np.ones((TIP_JOINTS, 1))]), np.hstack([eye, np.ones((TIP_JOINTS, 1))])]
    )
    cons: list[dict[str, object]] = [
        {
            "type": "ineq",
            "fun": lambda z: np.r_[z[-1] - (z[:-1] - s), z[-1] + (z[:-1] - s)],
            "jac": lambda z: box_jac,
        }
    ]
    if tol is None:
        cons.append({"type": "eq", "fun": tip_err, "jac": tip_jac})
    else:
        cons.append(
            {
                "type": "ineq",
                "fun": lambda z: np.array([tol * tol - float(tip_err(z) @ tip_err(z))]),
                "jac": lambda z: (-2.0 * tip_err(z) @ tip_jac(z))[None, :],
            }
        )
    from scipy.optimize import minimize  # imported when first needed

    res = minimize(
        lambda z: z[-1],
        z0,
        jac=lambda z: np.r_[np.zeros(TIP_JOINTS), 1.0],
        method="SLSQP",
        bounds=bounds,
        constraints=cons,
        options={"maxiter": 300, "ftol": 1e-13},
    )
    q = res.x[:TIP_JOINTS]
    err = float(np.linalg.norm(tip_err(res.x)))
    limit = 1e-7 if tol is None else tol * (1 + 1e-9)
    if (
        not np.all(np.isfinite(q))
        or err > limit
        or not np.all((q >= lo - 1e-12) & (q <= hi + 1e-12))
    ):
        return None
    return float(np.max(np.abs(q - s))), q


def _seed_points(fam: _Family, count: int) -> FloatArray:
    """Start points for refinement: the best samples, at least 5 deg apart from each other."""
    picks: list[FloatArray] = []
    q, change = fam.points()
    for i in np.argsort(change)[: count * 400]:
        if not np.isfinite(change[i]):
            break
        if all(np.max(np.abs(q[i] - c)) > np.radians(5.0) for c in picks):
            picks.append(q[i])
        if len(picks) >= count:
            break
    return np.array(picks).reshape(-1, TIP_JOINTS)


def _lower_bound(p: _Problem, fam: _Family, tol: float) -> tuple[LowerBound, FloatArray]:
    """The bound on the commands, and the configuration (joints 1-5, rad) within the
    tolerance where it is attained."""
    q, change = fam.points()
    best_exact, best_q = float(np.min(change)), None
    if np.isfinite(best_exact):
        best_q = q[int(np.argmin(change))]
    seeds = _seed_points(fam, 16)
    for x0 in seeds:
        out = _minimax(p, x0, None)
        if out is not None and out[0] < best_exact:
            best_exact, best_q = out
    if best_q is None:
        raise PlanningError("no configuration within the joint limits reaches the target")
    best_tol, q_within = best_exact, best_q
    # relaxed to the tolerance from the best configuration and from the best of each part of
    # the family (up to 16, 5 deg apart): the least change within the tolerance may lie in
    # another branch than the exact one's, and where the family was sampled about a point near
    # the target (the target just beyond reach) none is exact (about 0.5 s)
    for x0 in [best_q, *seeds]:
        relaxed = _minimax(p, x0, tol)
        if relaxed is not None and relaxed[0] < best_tol:
            best_tol, q_within = relaxed
    t_ticks = best_tol / TICK_RAD
    bound = max(int(np.ceil(t_ticks / MAX_INCREMENT_TICKS - 1e-7)), 0)
    found = LowerBound(
        commands=bound,
        max_joint_change_deg=float(np.degrees(best_tol)),
        exact_max_joint_change_deg=float(np.degrees(best_exact)),
        # joint 6 does not move the fingertip: held where it starts
        configuration_deg=tuple(float(v) for v in np.degrees(best_q))
        + tuple(float(v) for v in np.degrees(ticks_to_rad(p.start_ticks[TIP_JOINTS:]))),
        method=(
            "min over all configurations within the tolerance of the target of the largest "
            "joint change: grid over the 2-D solution family (wrist point on a sphere around the "
            "target, 8 branches) refined by SLSQP; commands >= ceil(change / 2 deg)"
        ),
    )
    return found, q_within


def _pair_grid(p: _Problem, fam: _Family, pair: tuple[int, int], n: int) -> IntArray:
    """All lattice values ``(M, 2)`` of ``pair`` where the family comes near the ``n``-box.

    The grid samples of the family whose largest change is within ``2n`` deg plus the largest
    step between neighbouring samples mark blocks of the ``pair`` lattice; those blocks and their
    neighbours are enumerated completely, so the feasible region is covered whatever its shape.
    """
    box_lo, box_hi = p.box(n)
    idx = list(pair)
    limit = MAX_INCREMENT_TICKS * n * TICK_RAD
    step = fam.step_ticks(limit)
    block = int(np.clip(np.ceil(step), 8, 64))
    q, change = fam.points()
    near = change <= limit + step * TICK_RAD
    if not np.any(near):
        return np.zeros((0, 2), dtype=np.int64)
    vals = q[near][:, idx] / TICK_RAD
    blocks = unique_states(np.floor(vals / block).astype(np.int64))
    ring = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 2)
    blocks = unique_states((blocks[:, None, :] + ring[None]).reshape(-1, 2))
    offs = np.stack(np.meshgrid(np.arange(block), np.arange(block), indexing="ij"), -1)
    pairs = (blocks[:, None, :] * block + offs.reshape(-1, 2)[None]).reshape(-1, 2)
    keep = np.all((pairs >= box_lo[idx]) & (pairs <= box_hi[idx]), axis=-1)
    return np.asarray(pairs[keep], dtype=np.int64)


def _lattice_candidates(
    p: _Problem, fam: _Family, n: int, tol: float, polish: int
) -> tuple[IntArray, FloatArray]:
    """Lattice states of joints 1-5 within ``n`` commands of the start, sorted by tip error.

    Returns every state found within ``tol`` of the target plus the ``polish`` best ones.
    """
    box_lo, box_hi = p.box(n)
    kept: list[IntArray] = []
    kept_err: list[FloatArray] = []

    def keep(cands: IntArray) -> None:
        cands = cands[np.all((cands >= box_lo) & (cands <= box_hi), axis=-1)]
        errs = p.errors_of_ticks(cands)
        good = errs <= tol
        if np.count_nonzero(~good) > polish:  # the best few beyond the tolerance, for polishing
            cut = np.partition(errs[~good], polish)[polish]
            good |= errs <= cut
        else:
            good[:] = True
        kept.append(cands[good])
        kept_err.append(errs[good])

    for pair in FIXED_PAIRS:
        grid = _pair_grid(p, fam, pair, n)
        solved = [j for j in range(TIP_JOINTS) if j not in pair]
        for k in range(0, grid.shape[0], 25_000):
            check_time("searching the lattice near the target")
            chunk = grid[k : k + 25_000]
            sol = solve_with_fixed_pair(
                p.geometry, p.target, pair, chunk[:, 0] * TICK_RAD, chunk[:, 1] * TICK_RAD
            )
            ticks = (p.normalize(sol) / TICK_RAD).reshape(-1, TIP_JOINTS)
            ok = np.all(np.isfinite(ticks), axis=-1)
            ok &= np.all((ticks >= box_lo - 1) & (ticks <= box_hi + 1), axis=-1)
            ticks = ticks[ok]
            if ticks.size == 0:
                continue
            base = np.floor(ticks).astype(np.int64)
            base[:, list(pair)] = np.round(ticks[:, list(pair)]).astype(np.int64)
            corners = np.array([[(c >> b) & 1 for b in range(3)] for c in range(8)])
            cands = np.repeat(base[:, None, :], 8, axis=1)
            cands[:, :, solved] += corners[None]
            keep(cands.reshape(-1, TIP_JOINTS))
    if not kept:
        return np.zeros((0, TIP_JOINTS), dtype=np.int64), np.zeros(0)
    cands, index = unique_states(np.concatenate(kept), return_index=True)
    return _polished(p, cands, np.concatenate(kept_err)[index], box_lo, box_hi, polish)


def _polished(
    p: _Problem,
    cands: IntArray,
    errs: FloatArray,
    box_lo: IntArray,
    box_hi: IntArray,
    polish: int,
) -> tuple[IntArray, FloatArray]:
    """``cands`` (lattice states of joints 1-5, fingertip errors ``errs`` to ``p``'s target)
    with the exhaustive +-1 tick neighbourhoods of the ``polish`` best added, within the box
    ``box_lo .. box_hi``, until the best no longer improves (at most 6 rounds); sorted by
    error."""
    steps = np.stack(np.meshgrid(*[[-1, 0, 1]] * TIP_JOINTS, indexing="ij"), -1).reshape(-1, 5)
    for _ in range(6):
        check_time("polishing lattice states near the target")
        best_before = float(errs.min()) if errs.size else np.inf
        top = cands[np.argsort(errs)[:polish]]
        near = unique_states((top[:, None, :] + steps[None, :, :]).reshape(-1, TIP_JOINTS))
        near = near[np.all((near >= box_lo) & (near <= box_hi), axis=-1)]
        near_err = p.errors_of_ticks(near)
        cands, index = unique_states(np.concatenate([cands, near]), return_index=True)
        errs = np.r_[errs, near_err][index]
        if not errs.size or errs.min() >= best_before:
            break
    order = np.argsort(errs, kind="stable")
    return cands[order], errs[order]


#: Where the search also looks off the target (see :func:`_with_ball_candidates`): points on
#: the way from the target through the nearest fingertip the n-command box allows, as shares
#: of that distance (those within the tolerance), and the most states of theirs kept.
BALL_SHARES = (1.0, 1.05, 1.1, 1.15, 1.25, 1.4, 1.6)
BALL_KEPT = 2_000


def _nearest_in_box(p: _Problem, q0: FloatArray, n: int) -> FloatArray:
    """Joints 1-5 (rad) within ``n`` commands of the start and the joint limits that bring the
    fingertip nearest the target (L-BFGS-B from ``q0``, a configuration in that box)."""
    from scipy.optimize import minimize  # imported when first needed

    reach_rad = n * MAX_INCREMENT_TICKS * TICK_RAD
    s = p.start_rad
    lo = np.maximum(s - reach_rad, ticks_to_rad(p.lo_ticks))
    hi = np.minimum(s + reach_rad, ticks_to_rad(p.hi_ticks))

    res = minimize(
        p.squared_error,
        np.clip(q0, lo, hi),
        jac=True,
        method="L-BFGS-B",
        bounds=list(zip(lo, hi, strict=True)),
    )
    return np.asarray(np.clip(res.x, lo, hi), dtype=np.float64)


def _with_ball_candidates(
    p: _Problem,
    q_within: FloatArray,
    n: int,
    opts: ReachOptions,
    cands: IntArray,
    errs: FloatArray,
) -> tuple[IntArray, FloatArray]:
    """``cands`` (lattice states of joints 1-5, sorted by their fingertip errors ``errs``)
    with the states within ``n`` commands found off the target: a wide tolerance lets the
    fewest commands end short of it (the seed's Task 1 with 20 mm: 61 commands, not the 63
    onto the target). The fingertip nearest the target that ``n`` commands allow (from the
    bound's configuration ``q_within``, rad) gives the way off it; the families of points on
    that way (:data:`BALL_SHARES` of it, nearest first, within the tolerance, until the
    states within it are as many as the motions checked) are searched as the target's is,
    the states judged by their error to the target itself and polished toward it in the
    n-command box; the :data:`BALL_KEPT` best are kept."""
    near = fingertip(p.geometry, _nearest_in_box(p, q_within, n)) - p.target
    gap = float(np.linalg.norm(near))
    box_lo, box_hi = p.box(n)
    kept, kept_err = [cands], [errs]
    for share in BALL_SHARES:
        if not gap > 1e-9 or share * gap > opts.tolerance_mm:
            break
        within = sum(int(np.count_nonzero(e <= opts.tolerance_mm)) for e in kept_err)
        if within >= opts.max_motion_checks:
            break  # enough to choose from: the nearer shares gave the smaller errors
        check_time(f"searching the lattice off the target for {n} commands")
        shifted = replace(p, target=p.target + share * near)
        fam = _family(shifted, opts.sphere_step_deg)
        # what is within the tolerance less the shift of the shifted point is within the
        # tolerance of the target; the polish keeps the best beyond
        inside = max(opts.tolerance_mm - share * gap, 0.0)
        found, _ = _lattice_candidates(shifted, fam, n, inside, opts.polish_candidates)
        kept.append(found)
        kept_err.append(p.errors_of_ticks(found))
    all_cands, first = unique_states(np.concatenate(kept), return_index=True)
    all_errs = np.concatenate(kept_err)[first]
    best = np.argsort(all_errs, kind="stable")[:BALL_KEPT]
    return _polished(p, all_cands[best], all_errs[best], box_lo, box_hi, opts.polish_candidates)


def _diverse(cands: IntArray, order: IntArray, count: int, per_cell: int = 3) -> IntArray:
    """At most ``count`` of ``order`` (kept in order), at most ``per_cell`` per 5 deg cell.

    Neighbouring lattice states give nearly the same motion; spreading the motion checks over
    the feasible region finds a clear motion sooner when the best ones are blocked.
    """
    cells = np.floor_divide(cands[order], 50)
    _, inverse = unique_states(cells, return_inverse=True)
    inverse = np.asarray(inverse, dtype=np.intp).reshape(-1)
    rank = np.zeros_like(inverse)
    seen: dict[int, int] = {}
    for k, c in enumerate(inverse.tolist()):
        rank[k] = seen.get(c, 0)
        seen[c] = rank[k] + 1
    return np.asarray(order[rank < per_cell][:count], dtype=np.int64)


def _validated_problem(
    arm: SerialArm, world: CollisionWorld, start_ticks: ArrayLike, target: ArrayLike
) -> _Problem:
    geometry = seed_geometry_of(arm)
    start = np.asarray(start_ticks)
    if start.shape != (arm.n_joints,):
        raise InvalidInputError(
            f"start state needs {arm.n_joints} joint values, got shape {start.shape}"
        )
    start = CommandSequence(start, np.zeros((0, arm.n_joints), np.int64)).start_ticks
    arm.check_limits(ticks_to_rad(start), what="start state")
    p = np.asarray(target, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InvalidInputError(
            f"target must be three finite numbers (x, y, z) in mm, got {p.tolist()}"
        )
    lo = np.array([j.limits[0] for j in arm.joints[:TIP_JOINTS]])
    hi = np.array([j.limits[1] for j in arm.joints[:TIP_JOINTS]])
    unlimited = ~np.isfinite(lo) & ~np.isfinite(hi)
    big = 10**9
    lo_t = np.where(np.isfinite(lo), np.ceil(lo / TICK_RAD - 1e-9), -big).astype(np.int64)
    hi_t = np.where(np.isfinite(hi), np.floor(hi / TICK_RAD + 1e-9), big).astype(np.int64)
    problem = _Problem(arm, geometry, world, start, p, lo_t, hi_t, unlimited)
    for obstacle in world.obstacles:
        depth = -float(obstacle.signed_distance(p))
        if depth > SURFACE_TOLERANCE_MM:
            raise CollisionError(
                f"target ({', '.join(f'{v:g}' for v in p)}) mm lies {depth:.3f} mm inside "
                f"{obstacle.name}: the fingertip may touch a surface but not enter it"
            )
    check_state_clear(arm, world, ticks_to_rad(start))
    return problem


def plan_reach(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    target_mm: ArrayLike,
    options: ReachOptions | None = None,
    seed: int = 0,
    orientation: Orientation | None = None,
) -> ReachResult:
    """Plan the fewest commands that bring the fingertip to ``target_mm``, then the least error.

    The seed arm (at the origin, fingertip tool, seed lattice, no orientation rule) takes the
    closed form of its solution family, whose bound is a proof; where its plan needs more
    commands than that bound, the generic search's direct motions are tried too and the fewer
    commands kept. Every other arm, tool, lattice or orientation rule (``orientation``: an
    :class:`~armpath.ik.target.AxisCone` or :class:`~armpath.ik.target.PoseOrientation`)
    takes the generic search (:mod:`armpath.planning.reach_generic`).

    Parameters
    ----------
    arm:
        A seed-type arm (:func:`armpath.model.seed_arm`).
    world:
        Obstacles and clearance rule; the whole continuous motion must satisfy it.
    start_ticks:
        Start joint state, integer ticks of 0.1 deg (6 values).
    target_mm:
        Target point of the fingertip (mm).
    options:
        Tolerance and search settings.
    seed:
        Seed of the multi-start search for the nearest reachable point (unreachable targets).

    Raises
    ------
    InvalidInputError, JointLimitError, CollisionError
        Bad start state or target.
    UnreachableError
        No configuration within the limits comes within the tolerance; names the nearest
        reachable distance.
    PlanningError
        The target is reachable but no direct motion within the tried command counts is clear
        and planning around the obstacles failed (or ``plan_around`` is off).
    """
    opts = options or ReachOptions()
    if orientation is not None or not _seed_fast_path(arm):
        return _plan_reach_generic(arm, world, start_ticks, target_mm, opts, seed, orientation)
    found = _plan_reach_seed(arm, world, start_ticks, target_mm, opts, seed)
    if found.n_commands <= found.lower_bound.commands:
        return found
    # above the bound: the closed form's search looks about the target's own family and on
    # the way to the nearest fingertip the box allows, which a wide tolerance outgrows (50 mm:
    # 38 commands where 37 reach within it); the generic search lists every lattice state
    # within the tolerance that fewer commands reach, and its direct motion is taken where
    # it needs fewer
    try:
        generic = _plan_reach_generic(
            arm, world, start_ticks, target_mm, replace(opts, plan_around=False), seed, None
        )
    except (PlanningError, UnreachableError):
        return found
    return generic if generic.n_commands < found.n_commands else found


def _plan_reach_seed(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    target_mm: ArrayLike,
    opts: ReachOptions,
    seed: int,
) -> ReachResult:
    """:func:`plan_reach` for the seed arm through its closed-form solution family."""
    p = _validated_problem(arm, world, start_ticks, target_mm)
    check_target_clear_of_fixed_links(arm, world, p.target, opts.tolerance_mm)
    fam = _reachable_family(p, opts.sphere_step_deg, opts.tolerance_mm, seed)
    bound, q_within = _lower_bound(p, fam, opts.tolerance_mm)
    # fewer commands than reaching the target itself takes: only states off the target (within
    # the tolerance) can do it, and the search about the target's own family finds none
    exact_commands = int(np.ceil(bound.exact_max_joint_change_deg / 2.0 - 1e-7))

    examined, checks = 0, 0

    def result(
        seq: CommandSequence, clearance: MotionClearance, rejected: tuple[str, ...], method: str
    ) -> ReachResult:
        tip = tool_position(arm, ticks_to_rad(seq.final_ticks))
        return ReachResult(
            sequence=seq,
            target_mm=p.target,
            tip_mm=tip,
            error_mm=float(np.linalg.norm(tip - p.target)),
            tolerance_mm=opts.tolerance_mm,
            lower_bound=bound,
            clearance=clearance,
            lattice_states_examined=examined,
            motion_checks=checks,
            fewer_commands_rejected=rejected,
            method=method,
        )

    failures: list[str] = []
    least_error = np.inf  # of the lattice states the search at each count looked at (mm)
    for n in range(bound.commands, bound.commands + opts.extra_commands + 1):
        check_time(f"searching the lattice for {n} commands")
        cands, errs = _lattice_candidates(p, fam, n, opts.tolerance_mm, opts.polish_candidates)
        within = errs <= opts.tolerance_mm
        if n < exact_commands:
            cands, errs = _with_ball_candidates(p, q_within, n, opts, cands, errs)
            within = errs <= opts.tolerance_mm
        examined += cands.shape[0]
        least_error = min(least_error, float(errs.min(initial=np.inf)))
        if not np.any(within):
            if errs.size:
                why = f"smallest fingertip error on the lattice is {errs[0]:.4f} mm >"
            else:  # the search looks about the configurations that put the fingertip on it
                why = "the search found no lattice state near the target within the"
            failures.append(f"{n} commands: {why} tolerance {opts.tolerance_mm} mm")
            continue
        cands, errs = cands[within], errs[within]
        # cheap filter: the goal state itself must be clear
        head = min(cands.shape[0], 4 * opts.max_motion_checks)
        goal_slack = world.slack(arm, p.full(ticks_to_rad(cands[:head])))
        order = _diverse(cands, np.flatnonzero(goal_slack >= 0), opts.max_motion_checks)
        if order.size == 0:
            failures.append(f"{n} commands: every goal state within tolerance is in collision")
            continue
        blocked = ""
        for i in order:
            check_time(f"checking the direct motions of {n} commands")
            goal = np.r_[cands[i], p.start_ticks[TIP_JOINTS:]]
            seq = CommandSequence.straight(p.start_ticks, goal)
            checks += 1
            mc = motion_clearance(arm, world, seq, tolerance=opts.clearance_tolerance_mm)
            if mc.certified_ok:
                if seq.n_commands < bound.commands:
                    raise AssertionError("plan beats the proven lower bound: search bug")
                return result(seq, mc, tuple(failures), "direct")
            blocked = blocked or (
                f"{mc.limiting_pair} is {mc.limiting_slack:+.2f} mm off its required clearance "
                f"during command {mc.limiting_command}"
            )
        failures.append(f"{n} commands: every direct motion is blocked (e.g. {blocked})")
    if opts.plan_around:
        goals, _ = _goal_states(
            p,
            fam,
            opts.tolerance_mm,
            GOAL_COUNT,
            GOAL_BODY_BUFFER_MM,
            GOAL_SPREAD_DEG,
            least_error,
        )
        plan = plan_motion(
            arm,
            world,
            p.start_ticks,
            goals,
            MotionOptions(seed=seed),
            turn_copies=True,
            waypoints=passage_source(arm, world, p.start_ticks),
        )
        rejected = (*failures, "planned around the obstacles instead")
        return result(plan.sequence, plan.clearance, rejected, plan.method)
    raise PlanningError(
        "no clear direct motion reaches the target within "
        f"{bound.commands + opts.extra_commands} commands ({'; '.join(failures)})"
    )


def _seed_fast_path(arm: SerialArm) -> bool:
    """Whether the seed arm's closed-form family serves ``arm``: the seed geometry at the
    origin with the fingertip as its tool, on the seed controller's lattice."""
    try:
        seed_geometry_of(arm)
    except InvalidInputError:
        return False
    return arm.lattice.is_default


def _plan_reach_generic(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    target_mm: ArrayLike,
    opts: ReachOptions,
    seed: int,
    orientation: Orientation | None,
) -> ReachResult:
    """:func:`plan_reach` for any arm (:mod:`armpath.planning.reach_generic`)."""
    from armpath.planning.reach_generic import lattice_bound, reach_any_arm

    target = ToolTarget(np.asarray(target_mm, dtype=np.float64), orientation)
    start = np.asarray(start_ticks)
    out = reach_any_arm(
        arm,
        world,
        start,
        target,
        opts.tolerance_mm,
        extra_commands=opts.extra_commands,
        max_motion_checks=min(opts.max_motion_checks, 40),
        plan_around=opts.plan_around,
        seed=seed,
    )
    grid = arm.lattice
    seq = out.sequence
    T = tool_pose(arm, grid.to_joint(seq.final_ticks))
    tip = T[:3, 3]
    b = out.bound
    span = np.abs(grid.to_ticks_float(b.configuration) - seq.start_ticks) * grid.tick_display
    commands, method, proven = b.commands, b.method, False
    try:
        listed = lattice_bound(arm, target, opts.tolerance_mm, seq.start_ticks, seq.n_commands)
    except TimeLimitError:  # the plan stands; its bound stays the family's estimate
        listed, method = None, f"{method}; the time limit ran out while listing lattice states"
    if listed is not None and (listed.rule_kept or listed.commands >= b.commands):
        # a proof: every lattice state within the tolerance that needs fewer commands than
        # the plan listed (a whole pose's rule left out: taken where it is no weaker than the
        # family's estimate)
        commands, proven = listed.commands, True
        fewer = (
            f"the fewest any of them needs, {listed.commands}"
            if listed.states
            else f"none, so at least {listed.commands}"
        )
        rule = (
            ""
            if target.orientation is None
            else f" keeping the {target.orientation.words()}"
            if listed.rule_kept
            else " (the orientation rule left out)"
        )
        method = (
            f"every lattice state within the tolerance of the target{rule} that "
            f"{listed.box_commands} commands may reach listed by branch and bound over boxes of "
            f"ticks ({listed.boxes} boxes, {listed.states} states): {fewer}; the family's "
            f"estimate: {b.commands}"
        )
    lb = LowerBound(
        commands=commands,
        max_joint_change_deg=float(span.max(initial=0.0)),
        exact_max_joint_change_deg=float(span.max(initial=0.0)),
        configuration_deg=tuple(
            float(v) for v in grid.display(grid.to_ticks_float(b.configuration))
        ),
        method=method,
        proven=proven,
    )
    return ReachResult(
        sequence=seq,
        target_mm=target.position,
        tip_mm=tip,
        error_mm=float(np.linalg.norm(tip - target.position)),
        tolerance_mm=opts.tolerance_mm,
        lower_bound=lb,
        clearance=out.clearance,  # type: ignore[arg-type]
        lattice_states_examined=out.examined,
        motion_checks=out.checks,
        fewer_commands_rejected=out.rejected,
        method=out.method,
        orientation=orientation,
        angle_rad=None if orientation is None else float(target.angles(T[:3, :3])),
    )


def goal_states(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    target_mm: ArrayLike,
    tolerance_mm: float = POINT_TOLERANCE_MM,
    count: int = GOAL_COUNT,
    body_buffer_mm: float = GOAL_BODY_BUFFER_MM,
    spread_deg: float = GOAL_SPREAD_DEG,
    sphere_step_deg: float = 1.0,
    orientation: Orientation | None = None,
) -> tuple[IntArray, FloatArray]:
    """Lattice states that put the fingertip within ``tolerance_mm`` of the target, clear of
    obstacles, nearest first.

    The solution family is sampled on the wrist-sphere grid; samples whose links keep the
    margin plus ``body_buffer_mm`` (the tool tip only must not penetrate; the buffer lets a
    planner approach the goal with a certified edge test) are taken in order of
    their largest joint change from the start, at least ``spread_deg`` apart. Around each, the
    lattice is searched locally (two joints on their ticks near the sample, the other three
    solved and rounded both ways, then +-1 tick polishing); the lattice state with the smallest
    error whose links keep the margin plus ``body_buffer_mm`` is kept.

    Returns ``(G, n)`` integer ticks and their fingertip errors (mm), at most ``count``, sorted
    by largest joint change from the start. Raises :class:`PlanningError` when no clear state
    exists.
    """
    if orientation is not None or not _seed_fast_path(arm):
        from armpath.planning.reach_generic import generic_goal_states, validated_start

        target = ToolTarget(np.asarray(target_mm, dtype=np.float64), orientation)
        start = validated_start(arm, world, np.asarray(start_ticks), target)
        states = generic_goal_states(
            arm, world, start, target, tolerance_mm, count, body_buffer_mm, spread_deg
        )
        T = tool_pose(arm, arm.lattice.to_joint(states))
        return states, np.linalg.norm(T[:, :3, 3] - target.position, axis=-1)
    p = _validated_problem(arm, world, start_ticks, target_mm)
    fam = _reachable_family(p, sphere_step_deg, tolerance_mm, 0)
    return _goal_states(p, fam, tolerance_mm, count, body_buffer_mm, spread_deg)


def plan_to_point(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    target_mm: ArrayLike,
    tolerance_mm: float = POINT_TOLERANCE_MM,
    options: MotionOptions | None = None,
    orientation: Orientation | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> MotionPlan:
    """A clear motion from ``start_ticks`` to a lattice state that puts the tool point within
    ``tolerance_mm`` of ``target_mm`` (and keeps ``orientation``, a rule of the tool's
    rotation): the target's goal states (:func:`goal_states`), then
    :func:`~armpath.planning.motion.plan_motion` to the nearest it reaches (their whole-turn
    copies too; waypoints in the openings of hollow obstacles where no direct motion is
    clear: :mod:`~armpath.planning.passages`). What ``armpath plan --to-xyz`` and
    :func:`armpath.plan` do; unlike :func:`plan_reach`, the objective of ``options`` is
    minimised and no bound is proven.
    """
    check_point_tolerance(tolerance_mm)
    say = on_progress or (lambda _msg: None)
    say("goal states at the target")
    goals, _ = goal_states(
        arm, world, start_ticks, target_mm, tolerance_mm, orientation=orientation
    )
    return plan_motion(
        arm,
        world,
        start_ticks,
        goals,
        options,
        on_progress=on_progress,
        turn_copies=True,
        waypoints=passage_source(arm, world, np.asarray(start_ticks, dtype=np.int64)),
    )


def _goal_states(
    p: _Problem,
    fam: _Family,
    tolerance_mm: float,
    count: int,
    body_buffer_mm: float,
    spread_deg: float,
    nearest_mm: float = np.inf,
) -> tuple[IntArray, FloatArray]:
    """:func:`goal_states` for a validated problem and its sampled solution family
    (``nearest_mm``: the least tool point error of a lattice state an earlier search found,
    which a refusal for want of any within the tolerance names where it is the nearest)."""
    arm, world = p.arm, p.world
    q, change = fam.points()
    finite = np.isfinite(change)
    q, change = q[finite], change[finite]
    if q.shape[0] == 0:
        raise UnreachableError(
            f"target ({', '.join(f'{v:g}' for v in p.target)}) mm is out of reach within the "
            "joint limits"
        )
    pairs = world.pairs(arm)
    is_tip = np.array([c.is_tip for c in pairs], dtype=bool)
    # a lattice state's tool tip only must not penetrate (its pairs require 0), provably
    buffer = np.where(is_tip, PROVABLE_SLACK, body_buffer_mm)
    # the family samples nearest the start first, whose links keep the margin plus the buffer
    # (the tool tip is not asked here), each at least ``spread`` from those picked before;
    # checked a chunk at a time until enough are picked
    body_extra = np.where(is_tip, -np.inf, body_buffer_mm)
    order = np.argsort(change, kind="stable")
    spread = np.radians(spread_deg)
    picked = np.zeros((0, q.shape[1]))
    any_clear = False
    for lo in range(0, order.size, GOAL_SAMPLE_CHUNK):
        check_time("finding goal states")
        chunk = q[order[lo : lo + GOAL_SAMPLE_CHUNK]]
        chunk = chunk[world.satisfied(arm, p.full(chunk), body_extra)]
        any_clear = any_clear or chunk.shape[0] > 0
        for earlier in picked:  # far enough from every earlier pick
            chunk = chunk[np.max(np.abs(chunk - earlier), axis=-1) >= spread]
        while chunk.shape[0] and picked.shape[0] < 4 * count:
            picked = np.vstack([picked, chunk[:1]])
            chunk = chunk[1:][np.max(np.abs(chunk[1:] - chunk[0]), axis=-1) >= spread]
        if picked.shape[0] >= 4 * count:
            break
    if not any_clear:
        from armpath.planning.reach_generic import no_clear_goal_error

        where = ", ".join(f"{v:g}" for v in p.target)
        raise no_clear_goal_error(where, "mm", world, body_buffer_mm)
    picks = list(picked)
    any_within = False  # whether any lattice state came within the tolerance
    states: list[IntArray] = []
    errors: list[float] = []
    steps = np.stack(np.meshgrid(*[[-1, 0, 1]] * TIP_JOINTS, indexing="ij"), -1).reshape(-1, 5)
    offsets = np.stack(np.meshgrid(np.arange(-2, 3), np.arange(-2, 3), indexing="ij"), -1)
    offsets = offsets.reshape(-1, 2)
    corners = np.array([[(c >> b) & 1 for b in range(3)] for c in range(8)])
    nearest = nearest_mm  # the smallest error of any lattice state looked at (mm)
    for q_star in picks:
        check_time("finding goal states")
        t_star = q_star / TICK_RAD
        cands: list[IntArray] = []
        for pair in FIXED_PAIRS:
            grid = np.round(t_star[list(pair)]).astype(np.int64) + offsets
            sol = solve_with_fixed_pair(
                p.geometry, p.target, pair, grid[:, 0] * TICK_RAD, grid[:, 1] * TICK_RAD
            )
            ticks = (p.normalize(sol) / TICK_RAD).reshape(-1, TIP_JOINTS)
            ticks = ticks[np.all(np.isfinite(ticks), axis=-1)]
            ticks = ticks[np.max(np.abs(ticks - t_star), axis=-1) < 30]  # the same branch
            if ticks.size == 0:
                continue
            solved = [j for j in range(TIP_JOINTS) if j not in pair]
            base = np.floor(ticks).astype(np.int64)
            base[:, list(pair)] = np.round(ticks[:, list(pair)]).astype(np.int64)
            c = np.repeat(base[:, None, :], 8, axis=1)
            c[:, :, solved] += corners[None]
            cands.append(c.reshape(-1, TIP_JOINTS))
        if not cands:
            # no exact solution with two joints on the lattice: the target lies on the edge of
            # the workspace (a stretched arm's tool point within the tolerance of it, the
            # target itself just beyond reach); the lattice states about the sample itself
            corner = np.array([[(c >> b) & 1 for b in range(TIP_JOINTS)] for c in range(32)])
            cands.append(np.floor(t_star).astype(np.int64) + corner)
        c5 = unique_states(np.concatenate(cands))
        c5 = unique_states((c5[:, None, :] + steps[None]).reshape(-1, TIP_JOINTS))
        c5 = c5[np.all((c5 >= p.lo_ticks) & (c5 <= p.hi_ticks), axis=-1)]
        errs = p.errors_of_ticks(c5)
        nearest = min(nearest, float(errs.min())) if errs.size else nearest
        within = errs <= tolerance_mm
        if not np.any(within):
            continue
        any_within = True
        c5, errs = c5[within], errs[within]
        full = np.hstack([c5, np.broadcast_to(p.start_ticks[TIP_JOINTS:], (c5.shape[0], 1))])
        # the clear state of smallest error: candidates checked in order of error
        by_error = np.argsort(errs, kind="stable")
        k = -1
        for lo in range(0, by_error.size, 64):
            idx = by_error[lo : lo + 64]
            ok = world.satisfied(arm, ticks_to_rad(full[idx]), buffer)
            if np.any(ok):
                k = int(idx[np.argmax(ok)])
                break
        if k < 0:
            continue
        if any(np.array_equal(full[k], s) for s in states):
            continue
        states.append(full[k])
        errors.append(float(errs[k]))
        if len(states) >= count:
            break
    if not states:
        where = ", ".join(f"{v:g}" for v in p.target)
        if not any_within:
            found = (
                f"; {nearest_found_advice(nearest)}"
                if np.isfinite(nearest)
                else "; a wider tolerance finds one"
            )
            raise PlanningError(
                f"no lattice state found within {tolerance_mm} mm of ({where}) mm: the "
                f"{len(picks)} configurations of the family searched about have none on the "
                f"{TICK_DEG:g} deg lattice" + found
            )
        raise PlanningError(
            f"no lattice state within {tolerance_mm} mm of ({where}) mm satisfies the "
            "clearance rule"
        )
    out = np.array(states, dtype=np.int64)
    change_ticks = np.max(np.abs(out[:, :TIP_JOINTS] - p.start_ticks[:TIP_JOINTS]), axis=-1)
    order = np.argsort(change_ticks, kind="stable")
    return out[order], np.array(errors)[order]
