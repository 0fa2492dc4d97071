"""Where a carriage stands along a curve: the schedule of a track or gantry axis that carries a
whole arm.

An arm on a linear track (a prismatic first joint under six joints or more that set the tool's
whole frame) has one degree of freedom more than a tool frame needs. Continued from the last
curve point, Levenberg-Marquardt moves the cheaper joints (the arm's, by radians against the
track's millimetres) and leaves the track where it stands until the arm runs out of reach: a
1.7 m seam beside a track was traced in two passes and 162 commands, one move of 52 commands
driving the track a metre back between them, or 562 in three passes with a slow track.

The carriage's schedule gives the track a value at every curve point instead, chosen once per
curve by dynamic programming over layers of the curve and a grid of track values:

* a track value is *comfortable* for a curve point when the point, seen from the carriage
  there, lies among the middle :data:`COMFORT_QUANTILES` of the arm's sampled tool positions
  along the track's axis that lie near it across the axis (a cloud of forward kinematics at
  random configurations within the limits, the carriage at zero); others pay
  :data:`_OUTSIDE_COST` a layer;
* a step between layers costs what commands cost, the larger of the track's change in its
  commands and the tool's move relative to the carriage in commands of the arm (its first
  joint's step swept at :data:`ARM_REACH_FRACTION` of the cloud's reach), plus a little for
  the square of the track's (:data:`_EVEN_WEIGHT`: an even pace where the costs tie);
* where the carriage's start is known and the curve is open, the pass is taken to begin at
  the end nearer it, and the arm may reach farther ahead of the carriage, toward the end it
  travels to, than behind it (:data:`AHEAD_QUANTILE`): the carriage, which moves on at its
  full pace through the approach and the pass, stops where the arm reaches the far end from
  as far back as it comfortably can.

A slow track so moves as little as its reach allows (the arm sweeps the rest); a fast one
shares the move. The family (:class:`~armpath.planning.trace.family.GenericCurveFamily`)
solves each tool frame with the carriage at its scheduled value beside the free continuation,
and the reference path picks between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.geometry.curves import Curve
from armpath.kinematics import position_jacobian, tool_position
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: The arm's tool positions sampled for its reach (forward kinematics, random configurations).
_CLOUD_SAMPLES = 50000
#: The part of the tool positions near a point across the track's axis that counts as
#: comfortable along it (quantiles of their coordinate along the axis).
COMFORT_QUANTILES = (0.05, 0.95)
#: Where the carriage's start is known and the curve is open (its ends farther apart along the
#: track than _NEAR_FRACTION of the arm's reach), the pass is taken to begin at the end nearer
#: it and the carriage to travel toward the other: the arm may then reach this far ahead of
#: the carriage (the quantile on the side it travels toward; behind, the lower of
#: COMFORT_QUANTILES), so that the carriage's travel ends where the arm reaches the curve's far
#: end from as far back as it comfortably can. The track cell's 1.7 m seam from the carriage at
#: 500 mm (500,000 samples each): 292 commands with (0.05, 0.95), 275 with (0.02, 0.98), 245
#: with (0.05, 0.99), 248 with (0.05, 0.995); its proven bound 240.
AHEAD_QUANTILE = 0.99
#: Samples of that cloud for such a directed schedule: the quantiles far out need them (50,000
#: put 122 tool positions near the seam's line, and their 0.05 and 0.95 quantiles at -621 and
#: +547 mm where the arm's reach is symmetric; 500,000 put 1353 there, at -589 and +586).
_DIRECTED_CLOUD_SAMPLES = 500_000
#: Fewest samples near a point across the axis for its comfortable range to be judged.
_FEWEST_NEAR = 12
#: How far across the axis (a fraction of the cloud's reach) samples count as near a point.
_NEAR_FRACTION = 0.06
#: Where along its reach the arm's first joint is taken to sweep the tool (its commands' worth).
ARM_REACH_FRACTION = 0.6
#: What a layer outside the comfortable range costs (commands): the schedule leaves it only
#: where no comfortable value can be kept.
_OUTSIDE_COST = 50.0
#: The weight of the square of the carriage's commands a layer beside what the layer costs:
#: where the commands alone tie (a slow track's whole travel costs the same however it is
#: spread, the arm sweeping alongside for free), the carriage moves evenly. Without it a 1.7 m
#: seam's schedule drove the track with the tool (1 mm a mm) for 400 mm, then crept; the
#: reference left it there for the family's other members and the seam took two passes.
_EVEN_WEIGHT = 0.25
#: Layers of the schedule at most, and their spacing at least (mm of arc).
_MAX_LAYERS = 1000
_LAYER_MM = 5.0
#: Track values of the grid at most (a quarter of a command apart where they fit: 4000 along
#: a 2 m track at 2 mm a command); with the layers, the DP's back pointers take 16 MB at most.
_MAX_VALUES = 4000


def carriage_joint(arm: SerialArm, tip: BoolArray) -> int | None:
    """The carriage: a prismatic joint that is the first of ``tip`` (the joints that move the
    tool point) with six joints or more after it (they set the tool's frame), or None."""
    moving = np.flatnonzero(tip)
    if moving.size == 0:
        return None
    first = int(moving[0])
    if arm.n_joints - first - 1 < 6 or arm.joints[first].kind is not JointKind.PRISMATIC:
        return None
    return first


@dataclass(frozen=True)
class CarriageSchedule:
    """The carriage's value (model units) at curve points: joint ``joint``, layers at
    ``points`` (mm) with the value ``value`` on each."""

    joint: int
    points: FloatArray
    value: FloatArray

    def at(self, E: FloatArray) -> float:
        """The scheduled value at the layer nearest the point ``E`` (mm)."""
        k = int(np.argmin(np.sum((self.points - np.asarray(E)) ** 2, axis=1)))
        return float(self.value[k])


def carriage_schedule(
    arm: SerialArm, curve: Curve, joint: int, start_value: float | None = None
) -> CarriageSchedule:
    """The carriage ``joint``'s schedule along ``curve`` (see the module's docstring);
    ``start_value``: where the carriage starts (model units), which directs the schedule of an
    open curve (:data:`AHEAD_QUANTILE`)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(0)
    lo, hi = arm.sampling_box()
    directed = start_value is not None and not curve.closed
    samples = _DIRECTED_CLOUD_SAMPLES if directed else _CLOUD_SAMPLES
    q = rng.uniform(lo, hi, (samples, arm.n_joints))
    q[:, joint] = 0.0
    cloud = tool_position(arm, q)
    axis = position_jacobian(arm, q[:1])[0][:, joint]
    per_unit = float(np.linalg.norm(axis))  # mm the tool moves per unit of the carriage
    axis = axis / per_unit
    along = cloud @ axis
    across = cloud - along[:, None] * axis
    reach = max(float(np.max(np.linalg.norm(cloud - np.mean(cloud, axis=0), axis=1))), 1e-6)

    n_layers = int(min(_MAX_LAYERS, max(2, np.ceil(curve.length / _LAYER_MM) + 1)))
    s = np.linspace(0.0, curve.length, n_layers)
    points = curve.at_arc_length(s)
    # the comfortable range of the carriage at each layer (model units), NaN where none
    p_along = points @ axis
    p_across = points - p_along[:, None] * axis
    comfort = np.full((n_layers, 2), np.nan)
    near = _NEAR_FRACTION * reach
    quantiles = COMFORT_QUANTILES
    if directed:
        assert start_value is not None
        # the tool's place along the axis with the carriage at its start, the arm in the middle
        # of its reach; the pass begins at the curve's end nearer it
        start_along = start_value * per_unit + float(np.median(along))
        ends = p_along[[0, -1]]
        near_end = int(np.argmin(np.abs(ends - start_along)))
        ahead = ends[1 - near_end] - ends[near_end]
        behind = COMFORT_QUANTILES[0]
        if ahead > near:  # (a curve that spans less along the axis travels nowhere)
            quantiles = (behind, AHEAD_QUANTILE)
        elif ahead < -near:
            quantiles = (1.0 - AHEAD_QUANTILE, 1.0 - behind)
    # the samples near each layer's point across the axis (a tree: 500,000 samples by 341
    # layers took 5 s compared one by one)
    for k, close in enumerate(cKDTree(across).query_ball_point(p_across, near)):
        if len(close) >= _FEWEST_NEAR:
            u_lo, u_hi = np.quantile(along[close], quantiles)
            comfort[k] = ((p_along[k] - u_hi) / per_unit, (p_along[k] - u_lo) / per_unit)

    grid = arm.lattice
    step = float(grid.max_step[joint])  # one command of the carriage
    arm_joint = int(np.flatnonzero(np.arange(arm.n_joints) > joint)[0])
    arm_mm = float(grid.max_step[arm_joint]) * ARM_REACH_FRACTION * reach
    judged = comfort[~np.isnan(comfort[:, 0])]
    if judged.size == 0:  # no layer judged anywhere: the carriage stays where it is at home
        judged = np.full((1, 2), float(arm.home[joint]))
    v_lo = float(arm.lower[joint]) if np.isfinite(arm.lower[joint]) else float(judged.min())
    v_hi = float(arm.upper[joint]) if np.isfinite(arm.upper[joint]) else float(judged.max())
    spacing = max(step / 4.0, (v_hi - v_lo) / _MAX_VALUES, 1e-9)
    values = np.linspace(v_lo, v_hi, int(np.floor((v_hi - v_lo) / spacing)) + 1)

    def outside(k: int) -> FloatArray:
        c0, c1 = comfort[k]
        if np.isnan(c0):
            return np.zeros(values.size)
        return np.where((values >= c0) & (values <= c1), 0.0, _OUTSIDE_COST)

    cost = outside(0)
    back = np.zeros((n_layers, values.size), dtype=np.int32)
    for k in range(1, n_layers):
        check_time("scheduling the carriage along the curve")
        move = points[k] - points[k - 1]
        # a step's cost from every value to every value within reach of one layer
        reach_cells = int(np.ceil((np.linalg.norm(move) / per_unit + step) / spacing)) + 1
        best = np.full(values.size, np.inf)
        arg = np.zeros(values.size, dtype=np.int32)
        for shift in range(-reach_cells, reach_cells + 1):
            src = np.arange(values.size) - shift
            ok = (src >= 0) & (src < values.size)
            dv = shift * spacing
            rel = float(np.linalg.norm(move - dv * per_unit * axis))
            c = np.full(values.size, np.inf)
            rate = abs(dv) / step
            c[ok] = cost[src[ok]] + max(rate, rel / arm_mm) + _EVEN_WEIGHT * rate * rate
            better = c < best
            best[better], arg[better] = c[better], src[better]
        cost = best + outside(k)
        back[k] = arg
    path = np.zeros(n_layers, dtype=np.int64)
    path[-1] = int(np.argmin(cost))
    for k in range(n_layers - 1, 0, -1):
        path[k - 1] = back[k, path[k]]
    return CarriageSchedule(joint, points, values[path])


__all__ = ["CarriageSchedule", "carriage_joint", "carriage_schedule"]
