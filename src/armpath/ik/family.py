"""The solution family of a tool target: configurations that put the tool centre on a point
(under an orientation rule), for any arm.

A position target leaves the arm free in its other degrees of freedom: a 6-joint arm has a
three-dimensional family of solutions (every tool orientation), a 7-joint arm four. Tasks need
the whole family, not one solution: the fewest commands from a start state are a minimum over
it. :class:`GenericFamily` samples it for any arm:

* arms with an all-solutions IK (six joints: spherical wrist, three parallel axes, or the
  general 6R elimination) take tool rotations spread over what the orientation rule allows and
  keep every solution of every rotation;
* other arms (5 or 7 joints, ...) run Levenberg-Marquardt from many starts inside the limits, on
  the position with the orientation rule as a penalty, for full poses drawn from the rule when
  there is one.

Every sample is checked by forward kinematics (position within :data:`EXACT_FRACTION` of the
arm's size, the orientation rule kept) and lies within the joint limits (revolute angles shifted
by whole turns into the limits, nearest a reference state). :meth:`GenericFamily.refine` pulls
configurations back onto the target by damped Newton steps.

The seed arm has a closed form for its whole family (:mod:`armpath.ik.seed_position`); its
planners use that directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import InvalidInputError
from armpath.ik.solve import complete_solver
from armpath.ik.target import ToolTarget
from armpath.kinematics import forward_frames, jacobian_from_frames, tool_pose
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: A sample's position error must be below this fraction of the arm's size (1e-9 of a 1 m arm:
#: a nanometre in mm).
EXACT_FRACTION = 1e-9
#: Levenberg-Marquardt stops a row whose cost falls by less than ``STALL_FRACTION`` of itself
#: over ``STALL_WINDOW`` iterations (it stalls off the target: no step of the damped Newton
#: method takes it nearer).
STALL_WINDOW = 6
STALL_FRACTION = 1e-3
#: Largest number of family samples kept (memory of the planners' searches).
MAX_SAMPLES = 200_000


def shift_into_limits(arm: SerialArm, q: FloatArray, near: FloatArray | None = None) -> FloatArray:
    """Revolute joints of ``q`` ``(M, n)`` turned by whole turns: into the joint limits where
    a turn allows, and among those (or for unlimited joints) nearest ``near`` (one state
    ``(n,)``, or one per row). Rows that stay outside the limits are returned as they are
    (check with ``arm.within_limits``)."""
    out = np.array(q, dtype=np.float64, copy=True)
    for i, joint in enumerate(arm.joints):
        if joint.kind is not JointKind.REVOLUTE:
            continue
        lo, hi = joint.limits
        ref = 0.0 if near is None else np.asarray(near, dtype=np.float64)[..., i]
        v = out[:, i]
        best = ref + (v - ref + np.pi) % (2 * np.pi) - np.pi  # the turn nearest the reference
        if np.isfinite(lo) or np.isfinite(hi):
            inside = (best >= lo - 1e-9) & (best <= hi + 1e-9)
            for k in (-1, 1, -2, 2):  # the next turns, nearest first
                alt = best + 2 * np.pi * k
                ok = ~inside & (alt >= lo - 1e-9) & (alt <= hi + 1e-9)
                best = np.where(ok, alt, best)
                inside |= ok
        out[:, i] = best
    return out


def _skew(v: FloatArray) -> FloatArray:
    """The cross-product matrices ``(M, 3, 3)`` of vectors ``v`` ``(M, 3)``."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


@dataclass(frozen=True, eq=False)
class GenericFamily:
    """Samples of the solution family of ``target`` for ``arm`` (any arm)."""

    arm: SerialArm
    target: ToolTarget

    @property
    def size(self) -> float:
        return self.arm.size

    def residuals(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Position error (length unit) and orientation-rule excess (rad) of each row."""
        T = tool_pose(self.arm, q)
        pos = np.linalg.norm(T[..., :3, 3] - self.target.position, axis=-1)
        return np.asarray(pos), np.asarray(self.target.angle_errors(T[..., :3, :3]))

    def exact(self, q: FloatArray) -> BoolArray:
        """Rows that reach the target (to :data:`EXACT_FRACTION` of the arm's size) and keep the
        orientation rule (to 1e-9 rad) and the joint limits."""
        return np.asarray(self.reaches(q) & self.arm.within_limits(q))

    def reaches(self, q: FloatArray) -> BoolArray:
        """Rows that reach the target (to :data:`EXACT_FRACTION` of the arm's size) and keep the
        orientation rule (to 1e-9 rad), wherever the joint limits are."""
        pos, ang = self.residuals(q)
        return np.asarray((pos <= EXACT_FRACTION * self.size) & (ang <= 1e-9))

    def samples(
        self,
        near: FloatArray | None = None,
        rotations: int = 2000,
        starts: int = 600,
        rng: np.random.Generator | None = None,
    ) -> FloatArray:
        """Configurations ``(M, n)`` of the family, spread over it, within the limits and turned
        nearest ``near`` (rad / length unit). Empty when the target is out of reach (or the
        sampling found none)."""
        gen = rng or np.random.default_rng(0)
        solver = complete_solver(self.arm) if self.arm.n_joints == 6 else None

        def kept(q: FloatArray) -> FloatArray:
            if q.shape[0] == 0:
                return q
            q = shift_into_limits(self.arm, q, near)
            return q[self.exact(q)]

        q = kept(self._from_rotations(solver, rotations, gen)) if solver is not None else None
        if q is None or q.shape[0] == 0:
            # also where the complete solver finds none: an arm it does not suit (all axes
            # parallel, every twist 90 deg with no offsets) still has members from starts
            q = kept(self._from_starts(starts, gen))
        if q.shape[0] > MAX_SAMPLES:
            q = q[gen.choice(q.shape[0], MAX_SAMPLES, replace=False)]
        return q

    def _from_rotations(self, solver: object, count: int, gen: np.random.Generator) -> FloatArray:
        Rs = self.target.rotations(count, gen)
        T = np.broadcast_to(np.eye(4), (Rs.shape[0], 4, 4)).copy()
        T[:, :3, :3] = Rs
        T[:, :3, 3] = self.target.position
        out = []
        for k in range(0, T.shape[0], 2048):
            check_time("sampling the solution family")
            batch = solver.solve_batch(T[k : k + 2048])  # type: ignore[attr-defined]
            q = batch.solutions.reshape(-1, self.arm.n_joints)
            out.append(q[np.all(np.isfinite(q), axis=1)])
        q = np.concatenate(out) if out else np.zeros((0, self.arm.n_joints))
        return self.refine(q, iterations=2) if q.shape[0] else q

    def _from_starts(self, count: int, gen: np.random.Generator) -> FloatArray:
        arm = self.arm
        lo, hi = arm.sampling_box()
        q = gen.uniform(lo, hi, (count, arm.n_joints))
        if self.target.orientation is not None and arm.n_joints >= 6:
            # full poses drawn from the rule: each start aims at one rotation
            Rs = self.target.rotations(count, gen)[:count]
            q = self.refine(q[: Rs.shape[0]], iterations=60, rotations=Rs)
        return self.refine(q, iterations=60)

    def refine(
        self,
        q: FloatArray,
        iterations: int = 30,
        rotations: FloatArray | None = None,
        lower: FloatArray | None = None,
        upper: FloatArray | None = None,
        axes: FloatArray | None = None,
        compiled: bool = True,
    ) -> FloatArray:
        """Damped Newton (Levenberg-Marquardt) steps that bring each row onto the target: the
        position, the orientation rule (a penalty that acts only outside it) or, with
        ``rotations`` ``(M, 3, 3)``, each row's own full tool rotation, or with ``axes``
        ``(M, 3)`` each row's own direction of the tool's approach axis (the turn about it
        free: an arm of five joints sets no more). Steps stay within the limits and, if given,
        the box ``lower`` .. ``upper`` (per row or for all; a joint whose box is one value is
        held there). The damping counts a prismatic joint's move in the arm's size, as a
        revolute joint's in radians; rows on the target to rounding stop, and so do rows
        whose cost falls by less than ``STALL_FRACTION`` in ``STALL_WINDOW`` iterations.
        ``compiled``: each row through its iterations in one compiled loop
        (:mod:`armpath.ik.lm_kernel`; not for the orientation rule, a cone, which keeps the
        numpy form), else numpy's batched steps."""
        arm = self.arm
        lo = arm.lower if lower is None else np.maximum(arm.lower, lower)
        hi = arm.upper if upper is None else np.minimum(arm.upper, upper)
        q = np.array(q, dtype=np.float64, copy=True)
        if q.shape[0] == 0:
            return q
        n = arm.n_joints
        size = self.size
        lam = np.full(q.shape[0], 1e-3)

        rot_rows = None if rotations is None else np.asarray(rotations)
        axis_rows = None if axes is None else np.asarray(axes)
        lo_rows = np.broadcast_to(np.asarray(lo, dtype=np.float64), q.shape)
        hi_rows = np.broadcast_to(np.asarray(hi, dtype=np.float64), q.shape)

        def errors(x: FloatArray, rows: NDArray[np.int64]) -> tuple[FloatArray, FloatArray]:
            frames = forward_frames(arm, x)
            J = jacobian_from_frames(arm, frames)
            tool = frames[:, -1]
            e_pos = (self.target.position - tool[:, :3, 3]) / size
            Jp = J[:, :3] / size
            parts, jacs = [e_pos], [Jp]
            if rot_rows is not None:
                e_rot = 0.5 * np.sum(
                    np.cross(tool[:, :3, :3], rot_rows[rows], axisa=1, axisb=1, axisc=1), axis=2
                )
                parts.append(e_rot)
                jacs.append(J[:, 3:])
            elif axis_rows is not None:
                axis = tool[:, :3, :3] @ np.asarray(arm.approach_axis, dtype=np.float64)
                parts.append(axis_rows[rows] - axis)
                # the axis turns with the tool: d(axis) = w x axis = -[axis]x J_w dq
                jacs.append(-_skew(axis) @ J[:, 3:])
            elif self.target.orientation is not None:
                e_ang, J_ang = _rule_error(self.target, tool[:, :3, :3], J[:, 3:])
                parts.append(e_ang[:, None])
                jacs.append(J_ang[:, None, :])
            return np.concatenate(parts, axis=1), np.concatenate(jacs, axis=1)

        # the damping measures a prismatic joint's move in the arm's size, as a revolute one's
        # in radians: in its own mm it held a track's carriage where it stood (a start 1 m off
        # along a 2 m track never came nearer than 0.6 m)
        # (a joint held by ``lower`` == ``upper`` takes no part in the steps)
        prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
        scale = np.where(hi_rows > lo_rows, np.where(prismatic, size, 1.0), 0.0)
        if compiled and (
            rot_rows is not None or axis_rows is not None or self.target.orientation is None
        ):
            return _refine_compiled(
                self, q, iterations, rot_rows, axis_rows, lo_rows, hi_rows, scale
            )
        err, J = errors(q, np.arange(q.shape[0]))
        cost = np.sum(err**2, axis=1)
        # rows on the target to rounding stop moving (they are independent of each other)
        on_target = (EXACT_FRACTION * 1e-2) ** 2
        rows = np.flatnonzero(cost >= on_target)
        window_cost = cost.copy()
        for step in range(iterations):
            if rows.size == 0:
                break
            if step and step % STALL_WINDOW == 0:
                # rows stuck in a local minimum off the target (a frame the arm cannot take at
                # this point) stop: their cost no longer falls, and they would not reach it
                moving = cost[rows] < (1.0 - STALL_FRACTION) * window_cost[rows]
                rows = rows[moving]
                window_cost[rows] = cost[rows]
                if rows.size == 0:
                    break
            sr = scale[rows]
            Jr, er, lr = J[rows] * sr[:, None, :], err[rows], lam[rows]
            JtJ = np.swapaxes(Jr, 1, 2) @ Jr
            g = np.einsum("sji,sj->si", Jr, er)
            dx = np.linalg.solve(JtJ + lr[:, None, None] * np.eye(n), g[..., None])[..., 0]
            dq = dx * sr
            q_new = np.clip(q[rows] + dq, lo_rows[rows], hi_rows[rows])
            err_new, J_new = errors(q_new, rows)
            cost_new = np.sum(err_new**2, axis=1)
            better = cost_new < cost[rows]
            won = rows[better]
            q[won], err[won], J[won], cost[won] = (
                q_new[better],
                err_new[better],
                J_new[better],
                cost_new[better],
            )
            lam[rows] = np.where(better, np.maximum(lr / 5.0, 1e-12), np.minimum(lr * 5.0, 1e8))
            rows = rows[cost[rows] >= on_target]
        return q


def _refine_compiled(
    fam: GenericFamily,
    q: FloatArray,
    iterations: int,
    rot_rows: FloatArray | None,
    axis_rows: FloatArray | None,
    lo_rows: FloatArray,
    hi_rows: FloatArray,
    scale: FloatArray,
) -> FloatArray:
    """:meth:`GenericFamily.refine` by the compiled loop (:mod:`armpath.ik.lm_kernel`)."""
    from armpath.ik.lm_kernel import AXIS, POSITION, ROTATION, refine_rows
    from armpath.kinematics import compiled_chain

    m = q.shape[0]
    mode = ROTATION if rot_rows is not None else AXIS if axis_rows is not None else POSITION
    rot = np.zeros((m, 3, 3)) if rot_rows is None else rot_rows[:m]
    ax = np.zeros((m, 3)) if axis_rows is None else axis_rows[:m]
    refine_rows(
        q,
        int(iterations),
        mode,
        np.ascontiguousarray(fam.target.position, dtype=np.float64),
        np.ascontiguousarray(rot, dtype=np.float64),
        np.ascontiguousarray(ax, dtype=np.float64),
        np.asarray(fam.arm.approach_axis, dtype=np.float64),
        np.ascontiguousarray(lo_rows),
        np.ascontiguousarray(hi_rows),
        np.ascontiguousarray(scale),
        float(fam.size),
        float((EXACT_FRACTION * 1e-2) ** 2),
        STALL_WINDOW,
        STALL_FRACTION,
        *compiled_chain(fam.arm)[:5],
    )
    return q


def _rule_error(target: ToolTarget, R: FloatArray, Jw: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The orientation rule's excess (rad, 0 inside) and its gradient along the joints (from
    the angular-velocity Jacobian ``Jw`` ``(M, 3, n)``): an axis cone only (a pose rule is met
    through full rotations)."""
    from armpath.ik.target import AxisCone

    o = target.orientation
    if not isinstance(o, AxisCone):
        return np.zeros(R.shape[0]), np.zeros((R.shape[0], Jw.shape[2]))
    a = R @ o.axis_tool  # world approach axis (M, 3)
    cos = np.clip(a @ o.direction, -1.0, 1.0)
    angle = np.arccos(cos)
    excess = np.maximum(angle - o.tolerance_rad, 0.0)
    # d angle = -(d cos) / sin, d a = w x a, d cos = (w x a) . d = w . (a x d)
    s = np.maximum(np.sin(angle), 1e-9)
    axd = np.cross(a, o.direction)
    grad = -np.einsum("mk,mkn->mn", axd, Jw) / s[:, None]
    # the residual to drive to zero is -excess (a step dq reduces the angle by grad @ dq)
    active = excess > 0
    return np.where(active, -excess, 0.0), np.where(active[:, None], grad, 0.0)


def family_of(arm: SerialArm, target: ToolTarget) -> GenericFamily:
    """The sampler of ``target``'s family for ``arm`` (checks the target's position is finite)."""
    if target.position.shape != (3,):
        raise InvalidInputError("a target needs a 3-D point")
    return GenericFamily(arm, target)


__all__ = ["EXACT_FRACTION", "GenericFamily", "family_of", "shift_into_limits"]
