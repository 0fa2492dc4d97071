"""The tracer: greedy lattice commands that carry the tool point along one piece of a curve.

From the current lattice state, the tracer looks for the command that carries the tool point
farthest along the curve: for each candidate advance it follows the reference path (pulled
gently toward it), projects onto the curve point (offset outward by half the tolerance, at most
:data:`MAX_SURFACE_OFFSET_MM`, when the curve lies on a surface, so the tip neither leaves the
band nor enters the surface), and
searches the lattice around it (a box of offsets that grows where few lattice states lie
near the curve: an arm whose tick moves the tool point far has few). Candidates are
pre-filtered by their linearized offset in the curve's normal plane, then checked exactly: end
point within the band, the continuous motion sampled within the band and outside the surface,
the clearance rule with a small buffer. Every accepted command advances the tool point by at
least :data:`MIN_ADVANCE_MM` toward a fixed end, so every pass ends.

A pass onto the end of an arc is also traced from that end back over half its way (the *end
chain*, :meth:`Tracer.end_chain`): where the family narrows toward a tight end, a pass traced
into it creeps while one traced out of it goes on at full stride. The pass follows the chain's
joint path and finishes along it, reversed, from where one command reaches it, when that takes
fewer commands (the seed crack: 73 -> 70 commands along it).
"""

from __future__ import annotations

import functools
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import PlanningError
from armpath.ik.lm_kernel import project_point
from armpath.jit import njit
from armpath.kinematics import (
    compiled_chain,
    position_jacobian,
    tick_jacobian,
    tool_position,
)
from armpath.model.lattice import unique_states
from armpath.planning.bounds.lattice_goals import lattice_goal_states
from armpath.planning.trace.family import CurveFamily
from armpath.planning.trace.reference import Piece

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Lattice offsets searched around a projected configuration, per joint that moves the tool
#: point (ticks): +-4 for up to five such joints (the seed arm), fewer for more joints. The
#: box grows by one tick at a time while fewer than :data:`_MIN_CANDIDATES` of its states lie
#: near the target and it keeps at most :data:`_MAX_BOX_OFFSETS` offsets.
_BOX = {5: 4, 6: 3, 7: 2}
#: Lattice states near the target that a search around one configuration looks for. The seed
#: arm's box of +-4 holds fewer on its crack one time in twenty (median 87); a UR5's tick moves
#: the tool point about twice as far and its box holds a median of 8, too few for the tracer to
#: go on (the UR5 cell's seam took four passes). 16 did best of 16, 32, 48, 64 and 128 on both.
_MIN_CANDIDATES = 16
#: Most lattice states near the target that one search around a configuration checks (of more,
#: as many evenly through the box). The seed crack finds at most 150 with its tolerance of
#: 0.1 mm and the UR5 cell's seam 37; a tolerance of 1 mm finds about 10,500 on the crack and
#: 10 mm nearly every state of the box (57,503 of 59,049 at one configuration), which made
#: tracing it take 2 min rather than 38 s with this cap (15 s once the target also stays near
#: the seam: :data:`MAX_SURFACE_OFFSET_MM`); 1 mm: 38 s rather than 17 s, 139 commands rather
#: than 138.
_MAX_CANDIDATES = 2_000
#: Most offsets of a grown box (+-6 ticks for five joints, +-4 for six; 16 bytes each).
_MAX_BOX_OFFSETS = 600_000
#: Farthest outside a surface the tracer aims the tool point (mm): half the tolerance, but a wide
#: tolerance moved the target off the seam (the seed crack with 10 mm: 159 commands aiming 5 mm
#: out, 137 aiming 0.5 mm out, against 145 with the default 0.1 mm; 3 mm: 137 either way, the
#: UR5 cell's seam with 5 mm: 134 either way).
MAX_SURFACE_OFFSET_MM = 0.5
#: Instants per command at which a candidate's continuous motion is checked while searching.
_PATH_SAMPLES = 16
#: Golden-section steps of the search for the peak distance where a command passes a corner
#: of the curve (each narrows the interval to 0.618 of itself: 24 steps to 1e-5 of the 1/16
#: of a command between two checked instants).
_CORNER_SEARCH_STEPS = 24
#: Share of the tolerance within which the tracer keeps the tool point at a command's end and
#: at the checked instants of its motion; the rest is for the deviation certificate's precision
#: (:func:`~armpath.planning.trace.certificate.certificate_precision`: 2 % of the tolerance at
#: most) and for what the continuous path rises between the checked instants. 0.9 -> 0.97: the
#: seed's 25 mm free circle 68 -> 66 commands, the UR5 cell's 40 mm circle 100 -> 98, its seam
#: 181 -> 177, the seed crack 143 -> 142, their certified deviations at most 0.0989 mm within
#: 0.1 mm (0.98 let the UR5 circle's reach 0.1001 mm).
BAND_SHARE = 0.97
#: The share a pass is traced again with when its certified deviation exceeds the tolerance.
FALLBACK_BAND_SHARE = 0.9
#: Extra clearance the links (and the tool tip, but from the surface it follows) keep while
#: tracing, so the certification of the continuous motion (bound from sampling) succeeds (mm).
_BODY_BUFFER_MM = 0.02
#: The tool axis keeps this far inside its rule's cone at the checked instants, so that the
#: certified worst angle of the continuous motion stays within the rule (rad: 0.2 deg).
_AXIS_MARGIN_RAD = float(np.radians(0.2))
#: Least advance of the tip along the curve that one tracing command must make (mm): the
#: progress measure that makes every pass end.
MIN_ADVANCE_MM = 0.05
_MIN_ADVANCE_MM = MIN_ADVANCE_MM
#: A pass has reached its goal when the tip's nearest curve point is this close to it (mm); the
#: last command may advance less than :data:`MIN_ADVANCE_MM` to get there.
GOAL_REACHED_MM = 1e-3
#: Candidate advances along the curve per command (mm), tried largest first: every 0.5 mm, so
#: a command ends within 0.5 mm of the farthest target it can reach (coarser steps cost the
#: seed crack's trace about one command in twelve).
_ADVANCES_MM = tuple(float(a) for a in np.arange(20.0, 0.25, -0.5))
#: Within this distance of a pass's goal (mm), a command that advances less than
#: :data:`_CREEP_MM` is compared with one onto the goal along the family
#: (:meth:`Tracer._onto_goal`), and where no command advances, the most slack or the goal is
#: tried: where the family narrows toward an arc's end, the seed crack traced from its far end
#: crept 17 commands over its last 7 mm (89 commands along instead of 93 with this).
_ENDGAME_MM = 15.0
_CREEP_MM = 1.0
#: Mid-pass, a command along the reference that advances less than this (mm) is compared with
#: the farthest of commands also turned along the family (:meth:`Tracer._along_family`).
_STALL_MM = 2.0
#: How far :meth:`Tracer._along_family` and :meth:`Tracer._onto_goal` turn the joints along the
#: family (largest joint, deg), either way; the first also where no lattice state near the
#: reference lies ahead at all. A KUKA-like arm's 150 mm ring, its reference near the wrist's
#: fold (joint 5 at 3-6 deg, so joint 4 moves the tool point 0.02 mm a tick), stalled there
#: with turns up to 1 deg and took a second pass (116 commands); turned up to 2 deg it goes on
#: in one (108; 105 once the pass may end on its own first state, see :meth:`Tracer.run`).
_TURNS_DEG = (0.25, 0.5, 1.0, 1.5, 2.0)
#: Commands near the reference that end about as far along are ranked by how far along (mm)
#: less this much per degree (equivalent) their end lies from the reference: one ending 2 deg
#: nearer it ranks with one a tenth of a millimetre farther, and the next commands have room
#: about the family's middle. The listing's states (:meth:`Tracer._listed`) are not: ranked so,
#: the UR5 cell's 80 mm circle took 105 commands rather than 106, but the SO-100 round a 30 mm
#: circle was left 2.2 mm short of covered (186.2 of 188.4 mm).
_GAP_WEIGHT_MM_PER_DEG = 0.05
#: Commands compared there by how far the command after each gets.
_LOOKAHEAD = 6
#: Within this distance of a pass's goal (mm), a pass that finds no command takes its last one
#: back and turns toward the most slack instead, at most :data:`_MAX_BACKTRACKS` times a pass.
_BACKTRACK_WITHIN_MM = 5.0
_MAX_BACKTRACKS = 3
#: Where no command near the reference continues a pass (:meth:`Tracer._bridge`): the curve
#: points ahead, up to this far (mm) and at least this far apart (mm; twice the tolerance
#: where that is more), near which every lattice state one command away is listed, and the
#: most states and boxes of the listing near one point (about a tenth of a second; past it
#: the states found so far are the candidates).
_BRIDGE_REACH_MM = 12.0
_BRIDGE_SPACING_MM = 0.2
_BRIDGE_STATES = 20_000
_BRIDGE_BOXES = 500_000
#: Mid-pass, past the farthest command found near the reference's projection, every lattice
#: state one command on within the band of the curve up to this far ahead (mm) is listed, about
#: points this far apart (mm; the tolerance where that is more), of states within this far of
#: the reference (largest joint, deg equivalents), at most :data:`_MAX_CANDIDATES` about a
#: point (a 10 mm tolerance's band holds 20,000 one command on: the seed arm took 76 s rather
#: than 4 s round a 25 mm circle, in as many commands). The seed arm's 25 mm circle in the seed
#: scene: 65 -> 64 commands; the UR5 cell's 80 mm circle 108 -> 106, its seam 174 -> 171 (2 deg
#: did as well, 6 and 8 deg worse on the seam, up to 180: states farther from the reference
#: went farther, and the commands after them less far).
_LISTED_REACH_MM = 3.0
_LISTED_SPACING_MM = 0.1
_LISTED_GAP_DEG = 4.0
#: Most boxes the listing for one command looks at (the seed arm's and the UR5's take at most
#: 64,000 and 119,000 round their circles; a UR5 on a track, seven joints moving the tool
#: point, spent 1.9 s a command listing 30 points to their budgets, and found nothing farther:
#: its 1.7 m seam took 462 s rather than 38 s), and the boxes of listings in a row that find
#: nothing farther after which a pass lists no more (eight such commands on the track; the UR5
#: cell's seam, where listings in a row found nothing for stretches but each looked at few
#: boxes, took 174 commands rather than 171 when eight listings in a row ended it).
_LISTED_BOXES = 200_000
_LISTED_FRUITLESS_BOXES = 8 * _LISTED_BOXES
#: Share of a pass that is also traced from its goal back toward where it begins (its *end
#: chain*, :meth:`Tracer.end_chain`): the pass then follows the chain's joint path and finishes
#: along it, reversed, from where a command reaches it. Traced into the tight end of its
#: reachable arc, the seed crack's last 55 mm took 10 commands; traced out of it, 7. Its pass
#: took 73 commands alone; with a chain over 100 mm 74, 200 mm 71, 300 mm 71, 400 mm 70, 550 mm
#: 70, 800 mm (all of it) 70.
END_CHAIN_SHARE = 0.5


def _box_radii(joints: int, largest_step: int) -> list[int]:
    """The radii (ticks) of the boxes searched for ``joints`` joints, smallest first, none
    wider than a command's ``largest_step`` (ticks)."""
    radius = min(_BOX.get(joints, 4 if joints < 5 else 1), largest_step)
    radii = [radius]
    while (2 * radii[-1] + 3) ** joints <= _MAX_BOX_OFFSETS and radii[-1] < largest_step:
        radii.append(radii[-1] + 1)
    return radii


@functools.cache
def _offsets(joints: int, radius: int) -> IntArray:
    """Every integer offset of a box of ``joints`` joints, +-``radius`` ticks, the first joint
    slowest (shared, read-only)."""
    box = np.arange(-radius, radius + 1)
    offsets = np.stack(np.meshgrid(*[box] * joints, indexing="ij"), -1).reshape(-1, joints)
    offsets.flags.writeable = False
    return np.asarray(offsets, dtype=np.int64)


@njit(cache=True)
def _within_disc(
    joints: int, radius: int, A: FloatArray, shift: FloatArray, radius2: float
) -> NDArray[np.bool_]:
    """Which offsets ``o`` of the box of ``joints`` joints, +-``radius`` ticks (in the order of
    :func:`_offsets`), have ``|o A + shift|^2 <= radius2`` (``A`` is ``(joints, 2)``). The box
    is walked joint by joint, and a partial offset whose point lies farther from the disc than
    the remaining joints can move it (their rows' lengths times the radius) is passed over with
    all its completions (the box has 117,649 offsets for six joints, most of them far); each
    kept offset's point is summed in the same order as over the whole box."""
    width = 2 * radius + 1
    out = np.zeros(width**joints, dtype=np.bool_)
    reach = np.zeros(joints + 1)  # how far the joints from j on can move the point
    for j in range(joints - 1, -1, -1):
        reach[j] = reach[j + 1] + radius * np.sqrt(A[j, 0] ** 2 + A[j, 1] ** 2)
    limit = np.sqrt(radius2) * (1.0 + 1e-9) + 1e-12
    stride = np.ones(joints, dtype=np.int64)
    for j in range(joints - 2, -1, -1):
        stride[j] = stride[j + 1] * width
    digit = np.zeros(joints, dtype=np.int64)
    xs = np.empty(joints + 1)
    ys = np.empty(joints + 1)
    first = np.zeros(joints + 1, dtype=np.int64)  # index of the prefix's first completion
    xs[0], ys[0] = shift[0], shift[1]
    level = 0
    while True:
        o = digit[level] - radius
        x = xs[level] + o * A[level, 0]
        y = ys[level] + o * A[level, 1]
        at = first[level] + digit[level] * stride[level]
        if level == joints - 1:
            out[at] = x * x + y * y <= radius2
        elif np.sqrt(x * x + y * y) - reach[level + 1] <= limit:
            level += 1
            xs[level], ys[level], first[level], digit[level] = x, y, at, 0
            continue
        digit[level] += 1
        while digit[level] == width:
            level -= 1
            if level < 0:
                return out
            digit[level] += 1


def _frozen(q: IntArray) -> IntArray:
    """A read-only copy of the lattice state ``q`` (kept by the tracer's memo)."""
    out = np.array(q, dtype=np.int64, copy=True)
    out.flags.writeable = False
    return out


class Tracer:
    """Greedy lattice tracing of one arc along a reference path through the family."""

    def __init__(
        self, fam: CurveFamily, piece: Piece, tolerance: float, band_share: float = BAND_SHARE
    ) -> None:
        self.fam = fam
        self.arm = fam.arm
        self.world = fam.world
        self.arc = piece.arc
        self.tol = tolerance
        #: the share of the tolerance the checked tool points keep within (:data:`BAND_SHARE`)
        self.band_share = band_share
        self.offset = min(tolerance / 2, MAX_SURFACE_OFFSET_MM) if fam.surface is not None else 0.0
        self.wrap = fam.unlimited
        self.grid = fam.arm.lattice
        self.tip = fam.tip_joints
        #: joint changes in degree equivalents: a command's largest move counts 2 (so degrees
        #: for a revolute joint that moves 2 deg a command, half the mm of a prismatic joint
        #: that moves 2 mm); what the tracer's joint-move thresholds are written in
        self.deg_eq = 2.0 / (np.asarray(self.grid.tick, dtype=np.float64) * self.grid.max_ticks)
        # the tip touches the surface it follows; everything else keeps the buffer, the tip too
        # (a curve where a workpiece meets the table: the tip rode on the table, and the
        # certificate could not prove that it never entered it)
        self.extra = np.where(fam.touch_pairs, 0.0, _BODY_BUFFER_MM)
        self.piece = piece
        self.layers, self.ref = piece.layers, piece.ref
        self.radii = _box_radii(int(self.tip.sum()), int(self.grid.max_ticks[self.tip].min()))
        #: what :meth:`_options` and :meth:`_toward_best` found, by method, state and arc lengths
        #: (the endgame's lookahead asks again for the state it then moves to, and a take-back
        #: again for the state before); emptied when the reference turns (:meth:`align`)
        self._found: dict[tuple[str, bytes, float, float], Any] = {}
        #: whether mid-pass commands are also sought among every lattice state the band
        #: holds a little past the farthest near the reference (:meth:`_find_options`)
        self.listed = True
        #: how many commands :meth:`_listed` found mid-pass (none: a pass traced so is the
        #: same as one traced without)
        self.listed_taken = 0
        #: how many the last :meth:`end_chain` took so
        self.chain_listed_taken = 0
        #: boxes :meth:`_listed` looked at, and of them those of the listings in a row that
        #: found nothing farther (past :data:`_LISTED_FRUITLESS_BOXES`, the pass lists no more)
        self._boxes_listed = self._fruitless_boxes = 0

    def q_ref(self, s: float | FloatArray) -> FloatArray:
        s_arr = np.asarray(s, dtype=np.float64)
        return np.stack(
            [np.interp(s_arr, self.layers, self.ref[:, j]) for j in range(self.ref.shape[1])],
            axis=-1,
        )

    def align(self, q_start: FloatArray) -> None:
        """Shift unlimited joints of the reference by whole turns to start (where the piece is
        traced from) near ``q_start``."""
        first = self.q_ref(self.piece.begin_mm)
        turns = np.round((q_start - first) / (2 * np.pi)) * self.wrap
        self.ref = self.ref + turns * 2 * np.pi
        self._found.clear()

    def matched(self, q: FloatArray, like: FloatArray) -> FloatArray:
        """The representation of each configuration's links (``q`` ``(6,)`` or ``(M, 6)``)
        nearest ``like`` among :meth:`CurveFamily.same_links`, unlimited joints turned by whole
        turns;
        representations outside the joint limits are not used."""
        q2 = np.atleast_2d(q)
        reps = self.fam.same_links(q2, np.pi)  # (R, M, n)
        reps = reps + np.round((like - reps) / (2 * np.pi)) * 2 * np.pi * self.wrap
        gap = np.abs(reps - like).max(axis=-1)
        gap = np.where(self.arm.within_limits(reps), gap, np.inf)
        gap[0] = np.where(np.isfinite(gap).any(axis=0), gap[0], 0.0)  # keep q if none fits
        pick = np.argmin(gap, axis=0)
        out = reps[pick, np.arange(q2.shape[0])]
        return np.asarray(out if q.ndim == 2 else out[0], dtype=np.float64)

    # -- curve geometry -------------------------------------------------------------------------
    def target(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Target tip point at ``s`` and two unit vectors spanning the curve's normal plane."""
        c, t, n = self.fam.frame(s)
        if not np.any(n):
            helper = np.array([0.0, 0.0, 1.0]) if abs(t[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            n = helper - (helper @ t) * t
            n /= np.linalg.norm(n)
        return c + self.offset * n if self.fam.surface is not None else c, n, np.cross(t, n)

    def unwrap_s(self, s: FloatArray, near: float) -> FloatArray:
        if not self.fam.curve.closed:
            return s
        L = self.fam.curve.length
        return np.asarray(s + L * np.round((near - s) / L))

    def tip_checks(self, P: FloatArray, near: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Distance to the curve, arc length of the closest point (unwrapped near ``near``) and
        signed distance to the surface (inf without one) of tip points ``(..., 3)``."""
        d, s = self.fam.curve.closest(P)
        if self.fam.surface is not None:
            sd = self.fam.surface.signed_distance(P)
        else:
            sd = np.full(d.shape, np.inf)
        return d, self.unwrap_s(s, near), sd

    def in_band(self, d: FloatArray, sd: FloatArray, off_surface: float) -> NDArray[np.bool_]:
        """Tip points within :attr:`band_share` of the tolerance from the curve and, on a
        surface, at least ``off_surface`` times the tolerance outside it (``d``, ``sd`` from
        :meth:`tip_checks`)."""
        near = d <= self.band_share * self.tol
        return np.asarray(near & (sd >= off_surface * self.tol), dtype=bool)

    # -- lattice ---------------------------------------------------------------------------
    def project(self, q: FloatArray, E: FloatArray) -> FloatArray:
        """Nearest family member to ``q`` (minimum-norm Newton steps, at most five, in the
        joints that move the tool point) with the tip at ``E`` (compiled:
        :func:`~armpath.ik.lm_kernel.project_point`)."""
        out = project_point(
            np.asarray(q, dtype=np.float64),
            np.asarray(E, dtype=np.float64),
            self.tip,
            5,
            *compiled_chain(self.arm)[:5],
        )
        return np.asarray(out, dtype=np.float64)

    def lattice_near(
        self, base: FloatArray, n: FloatArray, b: FloatArray, fixed: IntArray
    ) -> IntArray:
        """Lattice states around ``base`` (rad) whose tip, linearized, is within half the
        tolerance of the base's tip in the normal plane: those of the smallest box (see
        :data:`_BOX`) that holds :data:`_MIN_CANDIDATES` of them, or of the largest; of more
        than :data:`_MAX_CANDIDATES`, that many evenly through the box."""
        tick = self.grid.tick[self.tip]
        J = position_jacobian(self.arm, base)[:, self.tip]
        A_t = (np.stack([n, b]) @ J).T * tick[:, None]  # mm per tick
        exact = base[self.tip] / tick
        rounded = np.round(exact).astype(np.int64)
        shift = (rounded - exact) @ A_t
        for radius in self.radii:
            offsets = _offsets(int(self.tip.sum()), radius)
            keep = _within_disc(int(self.tip.sum()), radius, A_t, shift, (self.tol / 2) ** 2)
            if np.count_nonzero(keep) >= _MIN_CANDIDATES:
                break
        near = np.flatnonzero(keep)
        if near.size > _MAX_CANDIDATES:
            near = near[np.linspace(0, near.size - 1, _MAX_CANDIDATES).round().astype(np.int64)]
        cand = rounded + offsets[near]
        out = np.broadcast_to(np.asarray(fixed, dtype=np.int64), (cand.shape[0], self.tip.size))
        out = out.copy()
        out[:, self.tip] = cand
        return out

    def valid_ends(
        self, qk: IntArray, sk: float, cand: IntArray, goal: float
    ) -> tuple[IntArray, FloatArray]:
        """Candidates whose command from ``qk`` keeps the tip in the band and the arm clear while
        it moves toward arc length ``goal``; returned with the arc length their end state
        reaches. On a surface, the tip keeps a tenth of the tolerance outside it at the end and
        a twentieth at the checked instants of the motion."""
        sign = 1.0 if goal >= sk else -1.0
        if cand.shape[0] == 0:
            return cand, np.zeros(0)
        cand = cand[self.grid.legal(cand - qk)]
        cand = cand[self.arm.within_limits(self.grid.to_joint(cand))]
        if cand.shape[0] == 0:
            return cand, np.zeros(0)
        q_cand = self.grid.to_joint(cand)
        E_end = tool_position(self.arm, q_cand)
        d, s, sd = self.tip_checks(E_end, sk)
        # each command advances by the least advance, or ends the pass at its goal
        ahead = (sign * (s - sk) > _MIN_ADVANCE_MM) | (
            (sign * (s - sk) > 0.0) & (sign * (goal - s) <= GOAL_REACHED_MM)
        )
        ok = self.in_band(d, sd, 0.1) & ahead
        ok &= self.fam.axis_ok(q_cand, _AXIS_MARGIN_RAD)
        ok &= sign * (s - goal) <= self.tol
        cand, s, E_end = cand[ok], s[ok], E_end[ok]
        if cand.shape[0] == 0:
            return cand, s
        t = np.linspace(0.0, 1.0, _PATH_SAMPLES + 1)[1:-1]
        Q = qk[None, None, :] + t[None, :, None] * (cand - qk)[:, None, :]
        Q_rad = self.grid.to_joint(Q)
        E = tool_position(self.arm, Q_rad)
        d2, s2, sd2 = self.tip_checks(E, sk)
        in_band = self.in_band(d2, sd2, 0.05)
        ok = np.all(in_band & self.fam.axis_ok(Q_rad, _AXIS_MARGIN_RAD), axis=1)
        ok &= self._follows(qk, sk, E, s2, E_end, s)
        ok[ok] = self._within_at_corners(qk, sk, cand[ok], s2[ok], s[ok])
        cand, s, Q = cand[ok], s[ok], Q[ok]
        if cand.shape[0] == 0:
            return cand, s
        checked = np.concatenate([Q[:, 1::2], cand[:, None, :]], axis=1)
        clear = self.world.satisfied(self.arm, self.grid.to_joint(checked), self.extra).all(axis=1)
        return cand[clear], s[clear]

    def _follows(
        self,
        qk: IntArray,
        sk: float,
        E: FloatArray,
        s: FloatArray,
        E_end: FloatArray,
        s_end: FloatArray,
    ) -> NDArray[np.bool_]:
        """Per candidate, whether its tip follows the curve rather than jumping across it: the
        arc length of the closest curve point may change between consecutive samples of the
        motion (``E``, ``s`` ``(M, S)``, then the end) by no more than the tip moves plus twice
        the tolerance. Near a sharp corner (a polyline folding back on itself) the closest point
        jumps from one side to the other while the tip stays short of the apex; such a motion
        would leave the apex farther than the tolerance from the tool path."""
        E0 = np.broadcast_to(tool_position(self.arm, self.grid.to_joint(qk)), (E.shape[0], 1, 3))
        path = np.concatenate([E0, E, E_end[:, None, :]], axis=1)
        arc = np.concatenate([np.full((s.shape[0], 1), sk), s, s_end[:, None]], axis=1)
        moved = np.linalg.norm(np.diff(path, axis=1), axis=-1)
        return np.asarray(
            np.all(np.abs(np.diff(arc, axis=1)) <= 1.02 * moved + 2.0 * self.tol, axis=1),
            dtype=bool,
        )

    def _within_at_corners(
        self, qk: IntArray, sk: float, cand: IntArray, s_mid: FloatArray, s_end: FloatArray
    ) -> NDArray[np.bool_]:
        """Per candidate, whether its tip stays within the band where its motion passes a
        corner of the curve (:attr:`~armpath.geometry.curves.Curve.corners_mm`): there the
        distance to the curve peaks sharply between the checked instants (the nearest point
        passes from one side of the corner to the other; a UR5's 12-sided polygon went
        0.0062 mm past its 0.1 mm tolerance between two of them), so the largest distance
        between the instants on either side of the corner (``s_mid (M, S)``, ``s_end (M,)``:
        arc lengths there, unwrapped near ``sk``, and a tolerance's margin) is found by
        golden-section search."""
        corners = self.fam.curve.corners_mm
        ok = np.ones(cand.shape[0], dtype=bool)
        if corners.size == 0 or cand.shape[0] == 0:
            return ok
        if self.fam.curve.closed:  # the corners a turn either side of sk's, ascending
            L = self.fam.curve.length
            turn = np.floor(sk / L)
            corners = np.concatenate([corners + L * (turn + k) for k in (-1.0, 0.0, 1.0)])
        arc = np.concatenate([np.full((cand.shape[0], 1), sk), s_mid, s_end[:, None]], axis=1)
        lo = np.minimum(arc[:, :-1], arc[:, 1:]) - self.tol
        hi = np.maximum(arc[:, :-1], arc[:, 1:]) + self.tol
        # (M, S + 1): a corner lies between instants i and i + 1 (the corners ascending)
        passes = np.searchsorted(corners, lo, "left") < np.searchsorted(corners, hi, "right")
        which, interval = np.nonzero(passes)
        if which.size == 0:
            return ok
        t = np.linspace(0.0, 1.0, _PATH_SAMPLES + 1)
        a, b = t[interval], t[interval + 1]
        start = np.asarray(qk, dtype=np.float64)[None, :]
        step = (cand[which] - qk).astype(np.float64)

        def distance(x: FloatArray) -> FloatArray:
            q = self.grid.to_joint(start + x[:, None] * step)
            return np.asarray(self.fam.curve.closest(tool_position(self.arm, q))[0])

        golden = 0.5 * (np.sqrt(5.0) - 1.0)
        x1, x2 = b - golden * (b - a), a + golden * (b - a)
        d1, d2 = distance(x1), distance(x2)
        for _ in range(_CORNER_SEARCH_STEPS):
            left = d1 >= d2  # the peak lies in [a, x2]
            b = np.where(left, x2, b)
            a = np.where(left, a, x1)
            x2_new = np.where(left, x1, a + golden * (b - a))
            x1_new = np.where(left, b - golden * (b - a), x2)
            moved = np.where(left, x1_new, x2_new)
            d_new = distance(moved)
            d1, d2 = np.where(left, d_new, d2), np.where(left, d1, d_new)
            x1, x2 = x1_new, x2_new
        peak = np.maximum(d1, d2)
        within = peak <= self.band_share * self.tol
        np.logical_and.at(ok, which, within)
        return ok

    def step(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """The command from ``qk`` that carries the tip farthest along the curve toward arc
        length ``goal``; within :data:`_ENDGAME_MM` of it, of the :data:`_LOOKAHEAD` best, the
        one after which the next command gets farthest (where the family narrows, the farthest
        command can end where the next ones creep)."""
        options = self._options(qk, sk, goal, self.listed)
        if not options:
            return None
        if len(options) == 1 or abs(goal - sk) > _ENDGAME_MM:
            return options[0]
        sign = 1.0 if goal >= sk else -1.0
        best, best_value = options[0], -np.inf
        for q1, s1 in options:
            if sign * (goal - s1) <= GOAL_REACHED_MM:
                return q1, s1
            after = self._options(q1, s1, goal, self.listed)
            value = sign * (after[0][1] if after else s1 - sign * _ENDGAME_MM)
            if value > best_value + 1e-9:
                best, best_value = (q1, s1), value
        return best

    def _bridge(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """Where no command near the reference continues the pass: of every lattice state one
        command from ``qk`` that puts the tool point within the band of a curve point ahead
        (:meth:`_listed`, points :data:`_BRIDGE_SPACING_MM` apart up to
        :data:`_BRIDGE_REACH_MM` ahead, farthest first), the one whose command is valid
        (:meth:`valid_ends`) and gets farthest; None where none is. A coarse lattice leaves
        stretches of the curve with no state near (the SO-100's pan joint, 0.32 mm a tick
        across a circle where it turns back), which the reference's neighbourhood may not
        cross and one command can."""
        span = min(_BRIDGE_REACH_MM, abs(goal - sk))
        spacing = max(_BRIDGE_SPACING_MM, 2.0 * self.tol)
        return self._listed(qk, sk, goal, np.arange(span, _MIN_ADVANCE_MM, -spacing))

    def _listed(
        self,
        qk: IntArray,
        sk: float,
        goal: float,
        advances_mm: FloatArray,
        reference_gap_deg: float = np.inf,
        max_states: int = _BRIDGE_STATES,
        max_boxes: float = np.inf,
    ) -> tuple[IntArray, float] | None:
        """The valid command (:meth:`valid_ends`) from ``qk`` that gets farthest toward
        ``goal``, of those ending at any lattice state one command away whose tool point lies
        within the band of the curve point ``advances_mm`` ahead (tried in the order given,
        the first that holds a valid one kept; listed by
        :func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states`, completely
        unless :data:`_BRIDGE_BOXES` boxes or ``max_states`` states are spent about a point,
        or ``max_boxes`` over all of them); of ends within ``reference_gap_deg`` of the
        reference (largest joint, deg equivalents). None where none is."""
        sign = 1.0 if goal >= sk else -1.0
        most = np.asarray(self.grid.max_ticks, dtype=np.int64)
        lowest, highest = self.arm.tick_limits
        lower = np.maximum(qk - most, lowest).astype(np.int64)[self.tip]
        upper = np.minimum(qk + most, highest).astype(np.int64)[self.tip]
        if np.any(lower > upper):
            return None
        unit = self.arm.mm_per_unit
        boxes_left = max_boxes
        for advance in advances_mm:
            check_time("tracing the curve")
            if boxes_left <= 0:
                break
            s1 = sk + sign * float(advance)
            found = lattice_goal_states(
                self.arm,
                self.target(s1)[0] / unit,
                self.band_share * self.tol / unit,
                self.tip,
                np.asarray(qk, dtype=np.int64),
                lower,
                upper,
                max_boxes=int(min(_BRIDGE_BOXES, boxes_left)),
                max_states=max_states,
            )
            boxes_left -= found.boxes
            self._boxes_listed += found.boxes
            if found.ticks.shape[0] == 0:
                continue
            cand, s_end = self.valid_ends(qk, sk, found.ticks, goal)
            if np.isfinite(reference_gap_deg) and cand.shape[0]:
                near = self._reference_gap_deg(cand, s_end) <= reference_gap_deg
                cand, s_end = cand[near], s_end[near]
            if cand.shape[0]:
                k = int(np.argmax(sign * s_end))
                return _frozen(cand[k]), float(s_end[k])
        return None

    def _reference_gap_deg(self, cand: IntArray, s: FloatArray) -> FloatArray:
        """How far each lattice state lies from the reference at the arc length it reaches:
        its largest joint gap in degree equivalents (:attr:`deg_eq`)."""
        gap = np.abs(self.grid.to_joint(cand) - self.q_ref(s))[:, self.tip]
        return np.asarray((gap * self.deg_eq[self.tip]).max(axis=1), dtype=np.float64)

    def _options(
        self, qk: IntArray, sk: float, goal: float, listed: bool = True
    ) -> list[tuple[IntArray, float]]:
        """:meth:`_find_options`, once per state and arc lengths."""
        key = ("options" if listed else "near", np.asarray(qk, np.int64).tobytes(), sk, goal)
        if key not in self._found:
            found = self._find_options(qk, sk, goal, listed)
            self._found[key] = [(_frozen(q), s) for q, s in found]
        return list(self._found[key])

    def _find_options(
        self, qk: IntArray, sk: float, goal: float, listed: bool = True
    ) -> list[tuple[IntArray, float]]:
        """The best commands from ``qk`` toward ``goal``, best first: the one that carries the
        tip farthest (near the reference), and within :data:`_ENDGAME_MM` of the goal the next
        ones of that advance (at most :data:`_LOOKAHEAD`) and a command onto the goal along the
        family where the best creeps; empty when none is valid. Mid-pass and ``listed``, a
        command to any lattice state the band holds up to :data:`_LISTED_REACH_MM` farther,
        within :data:`_LISTED_GAP_DEG` of the reference, replaces the best where it gets
        farther (:meth:`_listed`)."""
        sign = 1.0 if goal >= sk else -1.0
        endgame = abs(goal - sk) <= _ENDGAME_MM
        if listed and not endgame:
            near = self._options(qk, sk, goal, listed=False)
            if not near or self._fruitless_boxes >= _LISTED_FRUITLESS_BOXES:
                return near
            # the states near the reference's projection hold few of those the band holds
            # one command on: all of them, a little farther on, near the reference
            got = abs(near[0][1] - sk)
            reach = min(got + _LISTED_REACH_MM, abs(goal - sk))
            spacing = max(_LISTED_SPACING_MM, self.tol)
            advances = np.arange(reach, got, -spacing)
            spent = self._boxes_listed
            farther = self._listed(
                qk, sk, goal, advances, _LISTED_GAP_DEG, _MAX_CANDIDATES, _LISTED_BOXES
            )
            if farther is not None and sign * (farther[1] - near[0][1]) > 0:
                self.listed_taken += 1
                self._fruitless_boxes = 0
                return [farther]
            self._fruitless_boxes += self._boxes_listed - spent
            return near
        qk_rad = self.grid.to_joint(qk)
        last = None
        for adv in _ADVANCES_MM:
            s1 = sk + sign * min(adv, abs(goal - sk))
            if s1 in (sk, last):
                continue
            last = s1
            drift = self.q_ref(s1) - self.q_ref(sk)
            half = 0.5 / self.deg_eq
            pull = np.clip(0.3 * (self.q_ref(sk) - qk_rad), -half, half)
            cand, s = self._commands_toward(qk, sk, s1, goal, [drift + pull, drift])
            if cand.shape[0]:
                ref_gap = self._reference_gap_deg(cand, s)
                order = np.argsort(-(sign * s - _GAP_WEIGHT_MM_PER_DEG * ref_gap), kind="stable")
                order = order[: _LOOKAHEAD if endgame else 1]
                out = [(cand[k], float(s[k])) for k in order]
                if abs(s[order[0]] - sk) < _STALL_MM and not endgame:
                    wider = self._along_family(qk, sk, goal)
                    if wider is not None and sign * (wider[1] - s[order[0]]) > 0:
                        out.insert(0, wider)
                if abs(s[order[0]] - sk) < _CREEP_MM and endgame:
                    # creeping near the goal (a tight end): a command onto the goal itself
                    # along the family may get farther
                    onto = self._onto_goal(qk, sk, goal)
                    if onto is not None and sign * (onto[1] - s[order[0]]) > 0:
                        out.insert(0, onto)
                return out
        if endgame:
            found = self._toward_best(qk, sk, goal) or self._onto_goal(qk, sk, goal)
            return [found] if found is not None else []
        # no lattice state near the reference ahead (where the family's members near it have
        # few lattice states about the curve): turned farther along the family
        wider = self._along_family(qk, sk, goal)
        return [wider] if wider is not None else []

    def _commands_toward(
        self, qk: IntArray, sk: float, s1: float, goal: float, moves: list[FloatArray]
    ) -> tuple[IntArray, FloatArray]:
        """Valid next states (see :meth:`valid_ends`) near the tip target at ``s1``: each joint
        move (rad) from ``qk`` is projected onto the target and the lattice searched around it
        (moves that end up more than 2.3 deg from ``qk`` are dropped: :attr:`deg_eq`)."""
        qk_rad = self.grid.to_joint(qk)
        E, n, b = self.target(s1)
        found = []
        for move in moves:
            base = self.project(qk_rad + move, E)
            if (np.abs(base - qk_rad) * self.deg_eq).max() <= 2.3:
                found.append(self.lattice_near(base, n, b, qk))
        if not found:
            return np.zeros((0, qk.size), dtype=np.int64), np.zeros(0)
        return self.valid_ends(qk, sk, unique_states(np.concatenate(found)), goal)

    def _toward_best(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """:meth:`_find_toward_best`, once per state and arc lengths."""
        key = ("toward_best", np.asarray(qk, np.int64).tobytes(), sk, goal)
        if key not in self._found:
            found = self._find_toward_best(qk, sk, goal)
            self._found[key] = None if found is None else (_frozen(found[0]), found[1])
        result: tuple[IntArray, float] | None = self._found[key]
        return result

    def _find_toward_best(
        self, qk: IntArray, sk: float, goal: float
    ) -> tuple[IntArray, float] | None:
        """Near the end of an arc (a tight spot): small advances, the joints turned toward the
        family member with the most slack there rather than along the reference."""
        qk_rad = self.grid.to_joint(qk)
        sign = 1.0 if goal >= sk else -1.0
        for adv in (3.0, 1.5, 0.8, 0.4, 0.2, 0.1):
            s1 = sk + sign * min(adv, abs(goal - sk))
            v = self.fam.best(s1, fine=True)
            if not v.reachable:
                continue
            turn = self.matched(v.q, qk_rad) - qk_rad
            moves = [
                np.clip(turn, -t / self.deg_eq, t / self.deg_eq) for t in (1.9, 1.0, 0.5, 0.25)
            ]
            cand, s = self._commands_toward(qk, sk, s1, goal, moves)
            if cand.shape[0]:
                # the most slack first (a tight spot), then the farthest
                score = self.fam.score(self.grid.to_joint(cand))
                k = int(np.lexsort((-sign * s, -np.round(score, 2)))[0])
                return cand[k], float(s[k])
        return None

    def _along_family(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """Where the command along the reference stalls mid-pass: the lattice searched about
        targets a few mm on, the joints also turned along the family (the null space of the
        tip's Jacobian) by each of :data:`_TURNS_DEG` either way; the farthest valid command."""
        qk_rad = self.grid.to_joint(qk)
        sign = 1.0 if goal >= sk else -1.0
        turns = self._null_moves(qk_rad)
        for adv in (8.0, 6.0, 4.0, 3.0, 2.0):
            s1 = sk + sign * min(adv, abs(goal - sk))
            drift = self.q_ref(s1) - self.q_ref(sk)
            cand, s = self._commands_toward(qk, sk, s1, goal, [drift + t for t in turns] + turns)
            if cand.shape[0]:
                k = int(np.argmax(sign * s))
                return cand[k], float(s[k])
        return None

    def _null_moves(self, qk_rad: FloatArray) -> list[FloatArray]:
        """Joint moves (rad) along the family from ``qk_rad``: each direction of the null space
        of the tip's Jacobian, scaled to turn a joint by each of :data:`_TURNS_DEG` either way."""
        J = position_jacobian(self.arm, qk_rad)[:, self.tip]
        _, _, vt = np.linalg.svd(J)
        moves = []
        for v in vt[3:]:
            full = np.zeros(qk_rad.size)
            full[self.tip] = v / np.abs(v).max()
            moves += [sign * t * full / self.deg_eq for t in _TURNS_DEG for sign in (1.0, -1.0)]
        return moves

    def _onto_goal(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """The last command of a pass, when neither the reference nor the most slack leads
        there: the lattice is searched about several members with the tip at the goal, the
        joints turned from ``qk`` along the family (the null space of the tip's Jacobian) by
        each of :data:`_TURNS_DEG` either way. Lattice states with the tip in the band about
        one point are sparse; more of the family holds more of them."""
        moves = self._null_moves(self.grid.to_joint(qk))
        cand, s = self._commands_toward(qk, sk, goal, goal, moves)
        if cand.shape[0] == 0:
            return None
        sign = 1.0 if goal >= sk else -1.0
        k = int(np.argmax(sign * s))
        return cand[k], float(s[k])

    def start_state(
        self,
        s_from: float,
        body_buffer_mm: float = _BODY_BUFFER_MM,
        hold: IntArray | None = None,
    ) -> tuple[IntArray, float]:
        """A lattice state with the tip in the band as close after ``s_from`` as found (before
        it, for a piece traced backward), whose links keep ``body_buffer_mm`` beyond the
        clearance rule. ``hold``: the state the arm comes from, whose joints that do not move
        the tool point are kept where the rules allow (a solution's own turn of a wrist that
        only rolls the tool cost a UR-type arm up to 90 commands a transit)."""
        extra = np.where(self.extra > 0, body_buffer_mm, 0.0)
        sign, edge = self.piece.sign, self.piece.begin_mm
        near_found = False  # a state near the curve, whatever its clearance
        proj = self.q_ref(s_from)  # the configuration last searched around
        for gap in (0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4):
            s0 = s_from + sign * gap
            E, n, b = self.target(s0)
            ref = self.q_ref(s0)
            bases = [ref]
            q = self.fam.configs(s0, self.fam.fine_dirs)
            if q.shape[0]:
                q = self.matched(q, ref)
                turn = (np.abs(q - ref) * self.deg_eq)[:, self.tip].max(axis=1)
                score = np.where(turn <= 30.0, self.fam.score(q), -np.inf)
                roomy = score >= body_buffer_mm
                pick = (
                    np.argmin(np.where(roomy, turn, np.inf)) if np.any(roomy) else np.argmax(score)
                )
                if np.isfinite(score[pick]):
                    bases.insert(0, q[pick])
            for base in bases:
                proj = self.project(base, E)
                cand = self.lattice_near(proj, n, b, self.grid.nearest_ticks(proj))
                if hold is not None and not self.tip.all():
                    held = cand.copy()
                    held[:, ~self.tip] = np.asarray(hold)[~self.tip]
                    cand = np.concatenate([held, cand])  # held first: kept where they do
                cand = cand[self.arm.within_limits(self.grid.to_joint(cand))]
                if cand.shape[0] == 0:
                    continue
                q_cand = self.grid.to_joint(cand)
                d, s, sd = self.tip_checks(tool_position(self.arm, q_cand), s0)
                ok = self.in_band(d, sd, 0.1)
                ok &= sign * (s - edge) >= -self.tol  # not before where the piece begins
                ok &= self.fam.axis_ok(q_cand, _AXIS_MARGIN_RAD)
                near_found |= bool(np.any(ok))
                ok &= self.world.satisfied(self.arm, self.grid.to_joint(cand), extra)
                if np.any(ok):
                    # the nearest after s_from (np.argmin: the first, a held one, of equals)
                    k = int(np.argmin(np.where(ok, sign * s, np.inf)))
                    if hold is not None and not self.tip.all():
                        kept = ok & np.all(cand[:, ~self.tip] == np.asarray(hold)[~self.tip], 1)
                        if np.any(kept):  # a state that keeps them, the nearest of those
                            k = int(np.argmin(np.where(kept, sign * s, np.inf)))
                    return cand[k], float(s[k])
        at_mm = float(self.fam.curve.wrap(s_from))  # a closed curve's arc lengths run on
        if near_found:
            raise PlanningError(
                f"no clear lattice state with the tip within {self.tol:g} mm of the curve near "
                f"{at_mm:.1f} mm"
            )
        # how far a tick moves the tool point, at the last configuration searched around
        tick_mm = float(np.linalg.norm(tick_jacobian(self.arm, proj), axis=0)[self.tip].max())
        raise PlanningError(
            f"no lattice state with the tip within {self.tol:g} mm of the curve near "
            f"{at_mm:.1f} mm ({int(self.tip.sum())} joints move the tool point, up to "
            f"{tick_mm:.2g} mm a tick: too coarse for this tolerance)"
        )

    def end_chain(
        self, goal: float, length_mm: float, hold: IntArray | None = None, listed: bool = True
    ) -> list[IntArray]:
        """Lattice states traced from arc length ``goal`` back along the piece for
        ``length_mm``: first a state that reaches the goal as a pass does (within
        :data:`GOAL_REACHED_MM` of it, or past it by at most the tolerance), then each one
        valid command (:meth:`valid_ends`) on from the last; empty when none is found at the
        goal. A pass that closes in on the tight end of an arc creeps (the family narrows, and
        the farthest command can end where the next ones cannot go on), one that leaves it goes
        on at full stride; :meth:`run` finishes along this chain, reversed, where that takes
        fewer commands. ``listed``: traced as :meth:`run` with ``listed`` (how many commands
        the listing took: :attr:`chain_listed_taken`)."""
        back = Tracer(
            self.fam,
            replace(self.piece, backward=not self.piece.backward),
            self.tol,
            self.band_share,
        )
        back.reference = self.reference
        self.chain_listed_taken = 0
        try:
            q, s = back.start_state(goal, hold=hold)
        except PlanningError:
            return []
        sign = self.piece.sign
        if sign * (goal - s) > GOAL_REACHED_MM:  # found a little inside: on onto the goal
            onto, s = back.run(q, s, goal, listed=listed)
            self.chain_listed_taken += back.listed_taken
            if sign * (goal - s) > GOAL_REACHED_MM:
                return []
            q = onto[-1]
        chain, _ = back.run(q, s, goal - self.piece.sign * length_mm, listed=listed)
        self.chain_listed_taken += back.listed_taken
        return chain

    def follow(self, chain: list[IntArray]) -> None:
        """Take the joint path of ``chain`` (:meth:`end_chain`) as the reference where it runs:
        a pass that follows it can reach one of its states and finish along it."""
        if len(chain) < 2:
            return
        q = self.grid.to_joint(np.array(chain))
        _, s, _ = self.tip_checks(tool_position(self.arm, q), self.piece.finish_mm)
        order = np.argsort(s, kind="stable")
        s, q = s[order], q[order]
        before, after = self.layers < s[0], self.layers > s[-1]
        self.reference = (
            np.concatenate([self.layers[before], s, self.layers[after]]),
            np.vstack([self.ref[before], q, self.ref[after]]),
        )

    @property
    def reference(self) -> tuple[FloatArray, FloatArray]:
        """The reference path: its layers' arc lengths (mm) and the joints there (rad, as
        :meth:`q_ref` reads them)."""
        return self.layers, self.ref

    @reference.setter
    def reference(self, path: tuple[FloatArray, FloatArray]) -> None:
        self.layers, self.ref = path
        self._found.clear()

    def _joined(self, qk: IntArray, sk: float, goal: float, chain: list[IntArray]) -> int | None:
        """The least ``i`` whose chain state ``chain[i]`` (see :meth:`end_chain`) one valid
        command from ``qk`` (tip at arc length ``sk``) reaches, or None."""
        if not chain:
            return None
        ends = np.array(chain)
        legal = np.flatnonzero(self.grid.legal(ends - qk))
        if legal.size == 0:
            return None
        found, _ = self.valid_ends(qk, sk, ends[legal], goal)
        if found.shape[0] == 0:
            return None
        hit = (ends[legal][:, None, :] == found[None, :, :]).all(axis=-1).any(axis=1)
        return int(legal[hit].min())

    def run(
        self,
        q_start: IntArray,
        s_start: float,
        goal: float,
        chain: list[IntArray] | None = None,
        listed: bool = True,
    ) -> tuple[list[IntArray], float]:
        """Trace from ``q_start`` toward arc length ``goal`` (as far as it goes); ``listed``:
        whether mid-pass commands are also sought among every lattice state the band holds
        a little past the farthest near the reference (:meth:`_find_options`).

        With an end ``chain`` (:meth:`end_chain`: states from the goal back toward the pass;
        once round a closed curve, the state the pass began from), the pass may finish with a
        command onto one of its states and the chain reversed; of those finishes and its own,
        the one of fewest commands is kept.

        Where no command continues within :data:`_BACKTRACK_WITHIN_MM` of the goal, the last
        command is taken back and the tip turned toward the family member with the most slack
        instead (at most :data:`_MAX_BACKTRACKS` times a pass): the farthest command can end
        in a corner no lattice state leads out of.

        Terminates by design: the direction is fixed at the start, every accepted command
        advances the tip by more than :data:`_MIN_ADVANCE_MM` in that direction or ends within
        :data:`GOAL_REACHED_MM` of the goal (see :meth:`valid_ends`), and the pass ends there.
        So between take-backs the distance left decreases strictly, and the
        commands tried are at most ``(backtracks + 1) * (|goal - s_start| + tolerance) /
        _MIN_ADVANCE_MM``.
        """
        self.listed = listed
        self.listed_taken = self._fruitless_boxes = 0
        direction = 1.0 if goal >= s_start else -1.0
        states, reached = [q_start], [s_start]
        budget = int(np.ceil((abs(goal - s_start) + self.tol) / _MIN_ADVANCE_MM)) + 1
        backtracks = 0
        # finishes along the chain: (commands in all, the pass's states up to the join; a
        # copy, since a take-back may replace the states after it)
        joins: list[tuple[int, list[IntArray]]] = []
        for _ in range((_MAX_BACKTRACKS + 1) * budget):
            qk, sk = states[-1], reached[-1]
            if direction * (goal - sk) <= GOAL_REACHED_MM:
                break
            i = self._joined(qk, sk, goal, chain) if chain else None
            if i is not None:
                joins.append((len(states) + i, list(states)))
            check_time(f"tracing {self.arc.start_mm:.1f}..{self.arc.end_mm:.1f} mm of the curve")
            nxt = self.step(qk, sk, goal)
            if nxt is None:
                nxt = self._bridge(qk, sk, goal)
            if nxt is None:
                if (
                    backtracks == _MAX_BACKTRACKS
                    or len(states) == 1
                    or direction * (goal - sk) > _BACKTRACK_WITHIN_MM
                ):
                    break
                backtracks += 1
                taken_back = states.pop(), reached.pop()
                nxt = self._toward_best(states[-1], reached[-1], goal)
                if nxt is None:  # no other way on: keep what was reached
                    states.append(taken_back[0])
                    reached.append(taken_back[1])
                    break
            q_next, s_next = nxt
            moved = direction * (s_next - reached[-1])
            if moved <= _MIN_ADVANCE_MM and direction * (goal - s_next) > GOAL_REACHED_MM:
                raise AssertionError("tracer made no progress: step rule broken")  # valid_ends
            states.append(q_next)
            reached.append(s_next)
        own = len(states) - 1 if direction * (goal - reached[-1]) <= GOAL_REACHED_MM else np.inf
        if chain and joins:
            total, before = min(joins, key=lambda j: j[0])
            if total < own:
                states = before + list(chain[: total - len(before) + 1][::-1])
                end = tool_position(self.arm, self.grid.to_joint(chain[0]))
                reached = [float(self.tip_checks(end[None], goal)[1][0])]
        return states, reached[-1]
