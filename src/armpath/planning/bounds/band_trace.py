"""The band bound of a trace along a circle, or a curve that is locally one (issue 21): the
least approach to the curve plus its traced length over the longest arc one command can
follow, where each part of it lies, in the family.

A pass keeps the tool point within the tolerance of the curve at every instant (the trace's
deviation is that of the continuous tool path). Where the traced spans lie on a circle (to
within a small share of the tolerance, :func:`fitted_circle`; the band taken that much wider),
every command of a pass has its middle configuration in the family, and by
:mod:`~armpath.planning.bounds.band` the circle points nearest the tool point over any part of
that command span an arc of at most the command's limit there. So if no member's limit exceeds
``U``, a pass covering a span of length ``L`` needs at least ``(L - 2 e) / U`` commands,
``e = 2 R asin(tol / R)`` the arc a tool point within the tolerance covers beyond the circle
point nearest it at either end (a second pass over a span would add a command between the
passes to save ``2 e / U``, less than one). Where the limits differ along the circle, each
part of it is counted with the largest limit of the members near enough to cover it in one
command: the integral of ``1 / u(s)`` over the span (:func:`along_commands`; at least
``(L - 2 e) / U``). Before the first pass the tool point has to reach the band: at least the
least largest-joint distance from the start to any member at any point of the spans
(:func:`least_approach`). The bound is the sum.

``U``, and ``u`` between points, is the largest limit over the family sampled at points along
the spans (:func:`family_arc_limit`), each sample's limit widened by how far it differs from its
neighbours' (the nearest member of each neighbouring tool direction, and the nearest at the
neighbouring points along the curve): the same assumption the family's sampling errors make
(:mod:`~armpath.planning.bounds`), that the family varies no faster within a sample's cell
than between neighbouring samples. The least approach samples the family with the tolerance
raised by half the spacing of its points, so every member at a point between them lies within
a sample's cell; where the nearest lies, it splits the cells of tool directions and of the
curve (:func:`_split_nearest`), until its whole commands reach those of the nearest sample
that is clear itself.

A curve that is no circle (an ellipse where a plane cuts a cone) is bounded by windows
(:class:`LocalBand`): each layer's members against the circle fitted to the curve within
:data:`WINDOW_HALF_MM` of the layer, the band taken wider by how far the curve strays from
it there; the arcs the lemma gives between circle points are measured along the curve by
how it runs against the circle there (:func:`_curve_arcs`). A command's arc lies within the
windows of the layers its middle lies between as long as the largest limit plus the widest
gap between layers stays within the half-width (a longer arc would hold a part of that
length, whose command broke its own layers' limit); the bound is given only then. Where the
curve lies on the face of a solid the tool tip may touch but not enter, the band is also
narrower inside the circle than out (the half band, :func:`_inner_half`).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.geometry.curves import Curve
from armpath.geometry.primitives import orthonormal_frame
from armpath.jit import njit
from armpath.kinematics import tool_point_joints
from armpath.model.serial_arm import SerialArm
from armpath.planning.bounds.band import (
    Circle,
    TaylorBounds,
    arc_limits,
    command_arc_limit,
    lemma_applies,
    taylor_bounds,
)
from armpath.planning.bounds.chart import BlowUp
from armpath.planning.bounds.sampling import (
    BRANCH_GAP,
    MIN_SPACING,
    FamilySampler,
    Layer,
    _allowed_at,
    _delaunay_neighbours,
    _direction_neighbours,
    _Samples,
    nearest_row,
)
from armpath.planning.bounds.value import CommandBound
from armpath.planning.trace.family import TOUCH_MM, CurveFamily, fibonacci_directions

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: The traced spans count as a circle where every point of them lies within this share of the
#: tolerance of the circle fitted to them (the band is then taken that much wider).
FIT_SHARE = 0.05
#: Points of the curve the circle is fitted to and checked against, per mm of the spans, and
#: at least and at most.
FIT_POINTS_PER_MM, FIT_POINTS_MIN, FIT_POINTS_MAX = 4.0, 512, 20_000
#: Points along a whole circle where the family is sampled for the limit (a span gets its
#: share, at least two), and tool directions at each. Seed arm's 25 mm circle, 250
#: directions: 8 points 7.99 mm, 12 7.87, 16 7.73, 24 7.66 (sampled members' own largest: 7.52);
#: 16 points and 100 directions 7.72 mm (15,044 members, about 10 s).
LIMIT_LAYERS, LIMIT_DIRECTIONS = 16, 100
#: Spacing (mm) of the points along the spans where the family is sampled for the least
#: approach, and tool directions at each. Seed circle from home: 5 mm 34.1 commands, 2 mm
#: 34.3, 10 mm 33.8.
APPROACH_GAP_MM, APPROACH_DIRECTIONS = 5.0, 2000
#: Most times :func:`family_arc_limit` makes its samples denser where its largest cell lies, and
#: how far that cell may lie above its own sample's limit (a share of it) for it to stop. UR5
#: cell's 80 mm circle: 0 times 20.59 mm (21 s), 6 times 19.56 (27 s), 12 times 19.16 (40 s),
#: 40 times 20.10 (new samples bring new wide cells); seed 25 mm circle: 7.72, 7.67, 7.67.
LIMIT_SPLITS, SPLIT_GOAL = 6, 0.02
#: Tool directions of the least approach's coarser samplings: every point at the first, the
#: nearest ones at the next (UR5 cell's 80 mm circle, points 5 mm apart, 300 then 2,000: 50.0
#: commands in 79 s; 300, 800 and 2,000 95 s; 8 mm apart 46.3 in 36 s).
APPROACH_LEVELS: tuple[int, ...] = (300,)
#: At the finest sampling of a point of the least approach, the cells of directions whose
#: samples lie within :data:`APPROACH_SPLIT_WINDOW` commands of the point's nearest are split
#: in four, up to :data:`APPROACH_SPLIT_ROUNDS` times, while the point's bound rises by at
#: least :data:`APPROACH_SPLIT_STALL` commands in two rounds and it keeps at most
#: :data:`APPROACH_SPLIT_DIRECTIONS` directions: the nearest samples are those whose errors
#: (their neighbours' members lying far apart: the UR5 cell's 80 mm circle near the wrist's
#: straight pose, 17 commands at 300 directions, 10 at 2,000, 8 at 8,000 evenly) hold the bound
#: down. The samples but the nearest are kept unchecked for clearance (a relaxation).
APPROACH_SPLIT_ROUNDS, APPROACH_SPLIT_WINDOW = 12, 1.0
APPROACH_SPLIT_STALL, APPROACH_SPLIT_DIRECTIONS = 0.05, 12_000
#: Where the point of the least approach nearest the start is at its finest sampling, its
#: cell of the curve is split in two (each half's tolerance raised by half as much: near the
#: wrist's straight pose the tolerance's joint change sets the sampling errors), at most this
#: many times in all and down to cells this long (mm). UR5 cell's 80 mm circle from its home:
#: 48.0 commands (50 s) without splits, 54.0 (115 s) with both, the nearest clear sample
#: 54.27 (so at least 55 whole commands); the seed 25 mm circle 34.2 either way (its
#: nearest clear sample lies within 35).
APPROACH_SPLIT_POINTS, APPROACH_MIN_GAP_MM = 40, 1.0
#: Spacing (mm) of the points where the family is sampled to foretell the least approach
#: (:func:`_nearest_member`).
FORECAST_GAP_MM = 12.0
#: Most points of the least approach (a longer curve gets them farther apart).
APPROACH_POINTS_MAX = 120
#: Boxes the branch and bound may bound for one configuration's limit when it is refined.
REFINE_NODES = 200
#: A curve that is no circle (an ellipse where a plane cuts a cone) is bounded by windows:
#: each layer's commands against the circle fitted to the curve within this arc length (mm)
#: either side of it, where the curve lies within :data:`WINDOW_FIT_SHARE` of the tolerance of
#: it; layers at most :data:`WINDOW_GAP_MM` apart. A command's arc must lie within its layers'
#: windows: the largest limit plus the largest gap must not exceed the half-width (else no
#: band bound). UR5 cell's seam (an ellipse of radii 88-94 mm): +-36 mm lie within 0.023 mm
#: of their circle, its limits 14.3-22.4 mm; +-30 mm within 0.011, but the largest limit,
#: 21.6 mm, and the widest gap, 11.9, do not fit within 30.
WINDOW_HALF_MM, WINDOW_GAP_MM, WINDOW_FIT_SHARE = 36.0, 12.0, 0.25
#: Spacing (mm) of the points of a window where the curve's bend and the surface's normal are
#: read.
WINDOW_STEP_MM = 1.0


def fitted_circle(curve: Curve, spans_mm: list[tuple[float, float]]) -> tuple[Circle, float]:
    """The circle fitted to the points of ``curve`` along ``spans_mm`` (arc lengths, mm) and
    the largest distance (mm) of those points from it: the plane through them (least
    squares), the circle in it (algebraic fit), the distance in space."""
    total = sum(b - a for a, b in spans_mm)
    count = int(np.clip(FIT_POINTS_PER_MM * total, FIT_POINTS_MIN, FIT_POINTS_MAX))
    s = np.concatenate(
        [np.linspace(a, b, max(int(count * (b - a) / max(total, 1e-300)), 3)) for a, b in spans_mm]
    )
    p = np.asarray(curve.at_arc_length(s), dtype=np.float64)
    middle = p.mean(axis=0)
    axes = np.linalg.svd(p - middle, full_matrices=False)[2]  # widest first, normal last
    normal, e1 = axes[2], axes[0]
    e2 = np.cross(normal, e1)
    x, y = (p - middle) @ e1, (p - middle) @ e2
    M = np.column_stack([x, y, np.ones_like(x)])
    coef = np.linalg.lstsq(M, -(x**2 + y**2), rcond=None)[0]
    cx, cy = -coef[0] / 2.0, -coef[1] / 2.0
    r2 = cx**2 + cy**2 - coef[2]
    if not (np.isfinite(r2) and r2 > 0.0):
        return Circle(middle, normal, math.inf), math.inf
    radius = math.sqrt(r2)
    rho = np.hypot(x - cx, y - cy)
    height = (p - middle) @ normal
    deviation = float(np.max(np.hypot(rho - radius, height)))
    return Circle(middle + cx * e1 + cy * e2, normal, radius), deviation


@dataclass(frozen=True)
class LocalBand:
    """The band about one part of the curve that :mod:`~armpath.planning.bounds.band`'s lemma
    bounds commands in: the circle fitted there, how far (mm) the curve's points there lie from
    it at most (``deviation_mm``), the band's half-width outside the circle (the tolerance
    plus the deviation) and inside it (``inner_mm``: the same, or less where the tool point
    must stay out of the solid the curve lies on: :func:`_inner_half`), how the curve's arcs
    there compare with the circle's (``stretch``, ``slop_mm``: :func:`_curve_arcs`) and the
    half-width of the window (arc length mm; inf: the whole curve)."""

    circle: Circle
    deviation_mm: float
    outer_mm: float
    inner_mm: float
    stretch: float
    slop_mm: float
    window_mm: float

    @classmethod
    def of_circle(cls, circle: Circle, tolerance_mm: float) -> LocalBand:
        """The band ``tolerance_mm`` either side of ``circle``, the curve being the circle."""
        tol = float(tolerance_mm)
        return cls(circle, 0.0, tol, tol, 1.0, 0.0, math.inf)


def _stretch_and_slop(
    points: FloatArray, s_mm: FloatArray, circle: Circle, tolerance_mm: float, outer_mm: float
) -> tuple[float, float]:
    """How the curve's arcs compare with its fitted circle's, from its ``points (K, 3)`` at
    arc lengths ``s_mm``: the most arc length it runs per arc of the circle between the
    angles (about its centre, in its plane) of neighbouring points (inf where it does not
    wind one way round the centre); and how far (mm of the circle's arc) the curve point
    nearest a point within ``tolerance_mm`` of it may lie round the centre from that point:
    ``2 R asin(tol sin(psi) / (R - outer))`` either way, ``psi`` the largest angle between
    the curve's chords and the circle's tangent (the nearest point lies along the curve's
    normal: radial where the curve follows the circle, at most ``psi`` off it at a polygon's
    corner)."""
    R = float(circle.radius_mm)
    e1, e2 = orthonormal_frame(circle.normal / np.linalg.norm(circle.normal))
    d = points - circle.centre
    phi = np.unwrap(np.arctan2(d @ e2, d @ e1))
    turn = np.diff(phi)
    if not (np.all(turn > 0.0) or np.all(turn < 0.0)):
        return math.inf, math.inf
    stretch = float(np.max(np.diff(s_mm) / (R * np.abs(turn))))
    chord = np.diff(points, axis=0)
    chord /= np.linalg.norm(chord, axis=1)[:, None]
    middle = 0.5 * (phi[1:] + phi[:-1])
    tangent = -np.sin(middle)[:, None] * e1 + np.cos(middle)[:, None] * e2
    sin_psi = np.sqrt(np.clip(1.0 - np.einsum("ij,ij->i", chord, tangent) ** 2, 0.0, 1.0))
    x = tolerance_mm * float(sin_psi.max()) / max(R - outer_mm, 1e-300)
    return stretch, 2.0 * R * math.asin(min(x, 1.0))


def _inner_half(fam: CurveFamily, points: FloatArray, circle: Circle, tolerance_mm: float) -> float:
    """How far inside ``circle`` (towards its axis, in its plane) a tool point within
    ``tolerance_mm`` of one of the curve's ``points`` may lie, at most (mm): the tolerance,
    or less where the tool point must stay out of the solid the curve lies on (its tip is
    checked against it: the clearance rule lets it touch, not enter). There, within ``tol``
    of a point ``p`` of a smooth face of normal curvature at most ``kappa``, a point outside
    lies at most ``e = kappa tol^2 / 2`` behind the tangent plane (:data:`TOUCH_MM` added);
    with ``alpha`` the outward normal's share along the circle's outward direction at ``p``,
    it then lies at most ``(e + sqrt(1 - alpha^2) tol) / alpha`` inward of ``p``."""
    surface = fam.surface
    if surface is None or not np.any(fam.touch_pairs):
        return tolerance_mm
    kappa = surface.face_curvature_bound(points, tolerance_mm)
    normal = surface.outward_normal(points)
    b = circle.normal / np.linalg.norm(circle.normal)
    a = points - circle.centre
    a = a - (a @ b)[:, None] * b
    outward = a / np.maximum(np.linalg.norm(a, axis=-1), 1e-300)[:, None]
    alpha = np.einsum("ij,ij->i", normal, outward)
    if not (np.all(np.isfinite(kappa)) and np.all(alpha > 0.0)):
        return tolerance_mm
    behind = kappa * tolerance_mm**2 / 2.0 + TOUCH_MM
    inward = (behind + np.sqrt(np.maximum(1.0 - alpha**2, 0.0)) * tolerance_mm) / alpha
    return float(min(tolerance_mm, inward.max()))


def _band_over(
    fam: CurveFamily,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    fit_share: float,
    window_mm: float,
) -> LocalBand | None:
    """:class:`LocalBand` of the curve along ``spans_mm`` (arc lengths, mm): None where it
    does not lie within ``fit_share`` of the tolerance of the circle fitted to it."""
    circle, deviation = fitted_circle(fam.curve, spans_mm)
    if not deviation <= fit_share * tolerance_mm:
        return None
    outer = tolerance_mm + deviation
    stretch, slop, inner = 0.0, 0.0, 0.0
    for a, b in spans_mm:
        s = np.linspace(a, b, max(math.ceil((b - a) / WINDOW_STEP_MM), 2) + 1)
        points = np.asarray(fam.curve.at_arc_length(s), dtype=np.float64)
        span_stretch, span_slop = _stretch_and_slop(points, s, circle, tolerance_mm, outer)
        stretch, slop = max(stretch, span_stretch), max(slop, span_slop)
        inner = max(inner, _inner_half(fam, points, circle, tolerance_mm))
    if not math.isfinite(stretch):
        return None
    return LocalBand(circle, deviation, outer, inner + deviation, stretch, slop, window_mm)


def _curve_arcs(arcs_mm: FloatArray, band: LocalBand) -> FloatArray:
    """The lemma's arcs of the band's circle (mm, between the circle points nearest a
    command's start and end) measured along the curve, between the curve points nearest
    them: those lie round the centre at most ``band.slop_mm`` (of the circle's arc) beyond
    the circle points either way, and the curve runs at most ``band.stretch`` times the
    circle's arc between them (:func:`_stretch_and_slop`)."""
    arcs = np.asarray(arcs_mm, dtype=np.float64)
    if band.stretch == 1.0 and band.slop_mm == 0.0:
        return arcs
    out = band.stretch * (arcs + band.slop_mm)
    return np.asarray(np.where(np.isfinite(arcs) & (arcs > 0.0), out, arcs))


@njit(cache=True)
def _nearest(u: FloatArray, v: FloatArray, period: FloatArray) -> IntArray:  # pragma: no cover
    """For each sample of ``u``, the nearest of ``v`` (largest-joint distance; -1 if none)."""
    out = np.full(u.shape[0], -1, dtype=np.int64)
    for i in range(u.shape[0]):
        out[i] = nearest_row(u[i], v, 0, v.shape[0], -1, period)[0]
    return out


def _largest_cell(
    coarse: FloatArray, neighbours: IntArray, refined: Callable[[int], float]
) -> tuple[float, int]:
    """The largest cell limit (:func:`_cell_limit`) over samples whose limits are ``coarse``
    (one box's dual: upper bounds on ``refined``'s, the branch and bound's) with neighbours
    ``neighbours (M, W)`` (-1 pads), and the sample whose cell it is (see
    :func:`_largest_cells`, all samples one group)."""
    best, where = _largest_cells(coarse, neighbours, refined, np.zeros(coarse.size, np.int64))
    return float(best[0]), int(where[0])


def _largest_cells(
    coarse: FloatArray,
    neighbours: IntArray,
    refined: Callable[[int], float],
    groups: IntArray,
    count: int | None = None,
) -> tuple[FloatArray, IntArray]:
    """The largest cell limit (:func:`_cell_limit`) within each group of samples (``groups
    (M,)``: 0 .. ``count`` - 1, a layer of the family each), and the sample whose cell it is
    (-inf and -1 for an empty group): each cell taken at the lower of its limit from the ``coarse``
    values and from the ``refined`` ones, the refined ones computed from the group's highest
    coarse cell down until the largest found is at least the next coarse one (which bounds
    that cell's). A sample with no neighbour (a sliver of the family) has its cell widened by
    the largest widening of the others'."""
    cells = np.array(
        [_cell_limit(coarse[i], coarse[row[row >= 0]]) for i, row in enumerate(neighbours)]
    )
    alone = ~np.any(neighbours >= 0, axis=1)
    widest = float(np.max(np.where(alone, 0.0, cells - coarse), initial=0.0))
    cells[alone] += widest
    count = int(groups.max(initial=-1)) + 1 if count is None else count
    best, where = np.full(count, -math.inf), np.full(count, -1, dtype=np.int64)
    for i in np.argsort(-cells, kind="stable"):
        g = int(groups[i])
        if cells[i] <= best[g]:
            continue
        row = neighbours[i][neighbours[i] >= 0]
        if row.size == 0:
            cell = min(cells[i], refined(int(i)) + widest)
        else:
            fine = _cell_limit(refined(int(i)), np.array([refined(int(k)) for k in row]))
            cell = min(cells[i], fine)
        if cell > best[g]:
            best[g], where[g] = cell, int(i)
    return best, where


@dataclass(frozen=True)
class FamilyLimit:
    """The longest arc (mm) one command can follow anywhere in the family
    (:func:`family_arc_limit`): ``arc_mm``, the sample whose cell gives it (configuration rad /
    mm, arc length mm of its curve point) and that sample's own limit; ``samples`` bounded,
    ``refined`` of them by branch and bound; and at each layer the family was sampled at (arc
    length mm, the span it belongs to) the largest limit over its samples' cells (mm; -inf
    where it has none), in the order the layers lie along each span."""

    arc_mm: float
    q: FloatArray
    s_mm: float
    sample_arc_mm: float
    samples: int
    refined: int
    layer_s_mm: FloatArray = field(default_factory=lambda: np.zeros(0))
    layer_span: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    layer_arc_mm: FloatArray = field(default_factory=lambda: np.zeros(0))
    layer_bands: tuple[LocalBand, ...] = ()


def _cell_limit(own: float, neighbours: FloatArray) -> float:
    """The largest limit in a sample's cell: its own limit widened by the most it differs from
    its neighbours' (the highest of ``max(neighbours)`` and ``2 own - min(neighbours)``)."""
    if neighbours.size == 0:
        return own
    return max(float(neighbours.max()), 2.0 * own - float(neighbours.min()))


@dataclass
class _LimitLayer:
    """The family at one point of the curve for :func:`family_arc_limit`: its arc length (mm)
    and span, every member sampled (and the direction triangles, to split them), the samples
    kept sorted by direction with the nearest of each neighbouring direction (-1 pads), and
    their one-box limits (mm)."""

    s_mm: float
    span: int
    acc: _Samples
    triangles: IntArray
    layer: Layer
    near: IntArray
    coarse: FloatArray
    band: LocalBand


def _limit_layer(
    sampler: FamilySampler,
    s_mm: float,
    span: int,
    acc: _Samples,
    band: LocalBand,
    tb: TaylorBounds,
    tip: BoolArray,
) -> _LimitLayer:
    """:class:`_LimitLayer` of the members ``acc`` sampled at ``s_mm`` (``tip``: the joints
    that move the tool point, ``tb`` their Taylor bounds), their limits in ``band``."""
    layer, _, _, triangles = sampler._filtered(acc)
    nb_ptr, nb, _ = _delaunay_neighbours(acc.dirs, acc.caps)
    assert layer.direction is not None
    layer = layer.subset(np.argsort(layer.direction, kind="stable"))
    assert layer.direction is not None
    dir_ptr = np.searchsorted(layer.direction, np.arange(acc.dirs.shape[0] + 1))
    near = _direction_neighbours(
        layer.u, layer.direction, dir_ptr.astype(np.int64), nb_ptr, nb, sampler.period,
        BRANCH_GAP, sampler.turns > 1,
    )  # fmt: skip
    coarse = _curve_arcs(
        arc_limits(
            sampler.fam.arm, layer.q, band.circle, band.outer_mm, tb, tip, anywhere=True,
            inner_mm=band.inner_mm,
        ),
        band,
    )  # fmt: skip
    return _LimitLayer(s_mm, span, acc, triangles, layer, near, coarse, band)


def _band_limit(
    arm: SerialArm, q: FloatArray, band: LocalBand, tb: TaylorBounds, tip: BoolArray, nodes: int
) -> float:
    """:func:`~armpath.planning.bounds.band.command_arc_limit` of ``q`` in ``band`` (its middle
    anywhere in it), along the curve (:func:`_curve_arcs`)."""
    limit = command_arc_limit(
        arm, q, band.circle, band.outer_mm, tb, tip, nodes=nodes, anywhere=True,
        inner_mm=band.inner_mm,
    )  # fmt: skip
    return float(_curve_arcs(np.array([limit]), band)[0])


def family_arc_limit(
    sampler: FamilySampler,
    band_at: Callable[[float], LocalBand],
    s_layers: list[FloatArray],
    cyclic: bool,
    directions: int = LIMIT_DIRECTIONS,
    nodes: int = REFINE_NODES,
    splits: int = LIMIT_SPLITS,
) -> FamilyLimit:
    """The largest limit (:func:`~armpath.planning.bounds.band.command_arc_limit`, its middle
    anywhere in the band ``band_at`` gives at the layer's arc length, along the curve:
    :func:`_band_limit`) over the cells of the family sampled along
    ``directions`` tool directions at the arc lengths of each span's layers ``s_layers`` (mm,
    ascending; ``cyclic``: one span round a closed curve, its last layer next to its first).
    Each sample's cell limit is its own widened by how far it differs from its neighbours
    (:func:`_cell_limit`): the nearest member of each neighbouring direction
    (:func:`_direction_neighbours`) and the nearest at the neighbouring layers of its span.
    Every limit is first one box's dual each round
    (:func:`~armpath.planning.bounds.band.arc_limits`); from the highest cell down, a cell's
    sample and neighbours are refined by branch and bound (``nodes`` boxes) and the cell taken
    at the lower of the two, until the highest refined cell is at least the next unrefined
    one (:func:`_largest_cell`). Then, up to ``splits`` times while the largest cell lies
    more than :data:`SPLIT_GOAL` above its own sample's limit, the samples are made denser
    where it is: the direction triangles about its sample split in four where a neighbouring
    direction widens it most, else a layer added halfway to the neighbouring layer that
    does. Last, the largest cell of each layer, refined the same way
    (:func:`along_commands` integrates over the curve with them)."""
    fam = sampler.fam
    arm = fam.arm
    tip = tool_point_joints(arm)
    tb = taylor_bounds(arm, tip)
    dirs = fibonacci_directions(directions)
    layers: list[_LimitLayer] = []

    def sampled(s: float, span: int) -> _LimitLayer:
        check_time("bounding the commands along the band")
        acc = sampler.sampled(fam.frame(s)[0], dirs, _allowed_at(fam, s), levels=0)[0]
        return _limit_layer(sampler, s, span, acc, band_at(s), tb, tip)

    for k, positions in enumerate(s_layers):
        layers += [sampled(float(s), k) for s in positions]
    sampler.audit_sites(
        [fam.frame(lay.s_mm)[0] for lay in layers],
        [lay.layer for lay in layers],
        [_allowed_at(fam, lay.s_mm) for lay in layers],
    )
    fine: dict[bytes, float] = {}
    samples = 0
    for split in range(splits + 1):
        offsets = np.cumsum([0] + [lay.layer.size for lay in layers])
        samples = max(samples, int(offsets[-1]))
        if offsets[-1] == 0:
            return FamilyLimit(0.0, np.zeros(arm.n_joints), math.nan, 0.0, 0, 0)
        # every sample's neighbours, as global indices (-1 pads)
        rows, across = [], []
        for i, lay in enumerate(layers):
            cols = [np.where(lay.near >= 0, lay.near + offsets[i], -1)]
            for step in (-1, 1):
                j = (i + step) % len(layers) if cyclic and len(layers) > 2 else i + step
                if 0 <= j < len(layers) and j != i and layers[j].span == lay.span:
                    near_j = _nearest(lay.layer.u, layers[j].layer.u, sampler.period)
                    cols.append(np.where(near_j >= 0, near_j + offsets[j], -1)[:, None])
            rows.append(np.column_stack(cols))
            across.append(lay.near.shape[1])
        width = max(r.shape[1] for r in rows)
        neighbours = np.vstack(
            [np.pad(r, ((0, 0), (0, width - r.shape[1])), constant_values=-1) for r in rows]
        )
        q = np.vstack([lay.layer.q for lay in layers])
        coarse = np.concatenate([lay.coarse for lay in layers])

        def refined(
            i: int,
            q: FloatArray = q,
            coarse: FloatArray = coarse,
            offsets: IntArray = offsets,
            bands: list[LocalBand] = [lay.band for lay in layers],  # noqa: B006 - this split's
        ) -> float:
            band = bands[int(np.searchsorted(offsets, i, side="right") - 1)]
            key = q[i].tobytes() + band.circle.centre.tobytes()
            if key not in fine:
                check_time("bounding the commands along the band")
                limit = _band_limit(arm, q[i], band, tb, tip, nodes)
                fine[key] = min(float(coarse[i]), limit)
            return fine[key]

        best, best_i = _largest_cell(coarse, neighbours, refined)
        own = refined(best_i)
        li = int(np.searchsorted(offsets, best_i, side="right") - 1)
        if split == splits or best - own <= SPLIT_GOAL * best:
            break
        # which neighbour widens the cell most: one of its layer's directions, or a layer's
        row = neighbours[best_i]
        widening = np.where(row >= 0, np.abs(np.array([refined(int(k)) for k in row]) - own), -1.0)
        k = int(np.argmax(widening))
        lay = layers[li]
        if k < across[li]:  # denser directions about the sample
            refine = np.zeros(lay.acc.dirs.shape[0], dtype=bool)
            assert lay.layer.direction is not None
            refine[int(lay.layer.direction[best_i - offsets[li]])] = True
            E = fam.frame(lay.s_mm)[0]
            acc = sampler.split(lay.acc, E, refine, lay.triangles, _allowed_at(fam, lay.s_mm))
            layers[li] = _limit_layer(sampler, lay.s_mm, lay.span, acc, lay.band, tb, tip)
        else:  # a layer halfway to the neighbouring one
            lj = int(np.searchsorted(offsets, row[k], side="right") - 1)
            a, b = lay.s_mm, layers[lj].s_mm
            if cyclic and abs(b - a) > fam.curve.length / 2.0:
                b += fam.curve.length if b < a else -fam.curve.length
            middle = float(fam.curve.wrap(0.5 * (a + b))) if cyclic else 0.5 * (a + b)
            where = li + 1 if (lj == li + 1 or (lj == 0 and li == len(layers) - 1)) else li
            layers.insert(where, sampled(middle, lay.span))
    # the largest cell of each layer (the largest's refinements kept)
    groups = np.repeat(np.arange(len(layers)), [lay.layer.size for lay in layers])
    per_layer = _largest_cells(coarse, neighbours, refined, groups, len(layers))[0]
    return FamilyLimit(
        best, q[best_i], layers[li].s_mm, own, samples, len(fine),
        np.array([lay.s_mm for lay in layers]), np.array([lay.span for lay in layers]),
        per_layer, tuple(lay.band for lay in layers),
    )  # fmt: skip


def _limit_intervals(
    limit: FamilyLimit, cyclic: bool, start_mm: float, length_mm: float
) -> list[tuple[float, float, float]]:
    """The intervals between neighbouring layers of each span of ``limit`` (arc lengths, mm)
    and the larger of their two layers' largest cells (mm); ``cyclic``: the layers lie round
    the closed curve of ``length_mm`` from ``start_mm``, and the intervals are given a turn
    before and after too."""
    out: list[tuple[float, float, float]] = []
    for span in np.unique(limit.layer_span):
        on = limit.layer_span == span
        x, w = limit.layer_s_mm[on], limit.layer_arc_mm[on]
        if cyclic:
            x = start_mm + np.mod(x - start_mm, length_mm)
        order = np.argsort(x, kind="stable")
        x, w = x[order], w[order]
        if cyclic:
            x, w = np.append(x, x[0] + length_mm), np.append(w, w[0])
        for i in range(x.size - 1):
            width = max(float(w[i]), float(w[i + 1]))
            if math.isfinite(width) and width > 0.0:
                out.append((float(x[i]), float(x[i + 1]), width))
    return _turned(out, length_mm) if cyclic else out


def _turned(
    intervals: list[tuple[float, float, float]], length_mm: float
) -> list[tuple[float, float, float]]:
    """``intervals`` ``(lo, hi, w)`` round a closed curve of ``length_mm`` and their copies a
    turn before and a turn after (so that reaches across the curve's start are seen)."""
    return intervals + [(lo + k * length_mm, hi + k * length_mm, w)
                        for lo, hi, w in intervals for k in (-1, 1)]  # fmt: skip


def _widest_reaching(
    intervals: list[tuple[float, float, float]], s_mm: FloatArray, fallback: float
) -> FloatArray:
    """At each arc length of ``s_mm`` the largest width ``w`` of the ``intervals`` ``(lo, hi,
    w)`` (mm) that lie within ``w`` of it, ``fallback`` where none does."""
    s = np.asarray(s_mm, dtype=np.float64)
    out = np.full(s.shape, -math.inf)
    for lo, hi, w in intervals:
        out = np.where((lo - w <= s) & (s <= hi + w), np.maximum(out, w), out)
    return np.where(np.isfinite(out), out, fallback)


def _reciprocal_integral(
    intervals: list[tuple[float, float, float]],
    spans_mm: list[tuple[float, float]],
    end_mm: float,
    fallback: float,
) -> float:
    """The integral over each span, less ``end_mm`` at either end, of ``1 / u`` with ``u``
    :func:`_widest_reaching` (exact: it is constant between the ends of the reaches)."""
    total = 0.0
    for a, b in spans_mm:
        lo, hi = a + end_mm, b - end_mm
        if not hi > lo:
            continue
        cuts = {lo, hi} | {c for x0, x1, w in intervals for c in (x0 - w, x1 + w) if lo < c < hi}
        edges = np.array(sorted(cuts))
        u = _widest_reaching(intervals, 0.5 * (edges[:-1] + edges[1:]), fallback)
        total += float(np.sum(np.diff(edges) / u))
    return total


def local_arc_limits(
    limit: FamilyLimit, s_mm: FloatArray, cyclic: bool, start_mm: float, length_mm: float
) -> FloatArray:
    """``u(s)`` of :func:`along_commands` at the arc lengths ``s_mm`` (mm; round a closed
    curve, ``cyclic``, from ``start_mm`` on): the largest limit of the intervals between
    layers that lie within it of ``s``, ``limit.arc_mm`` where none does."""
    intervals = _limit_intervals(limit, cyclic, start_mm, length_mm)
    return _widest_reaching(intervals, s_mm, limit.arc_mm)


def along_commands(
    limit: FamilyLimit,
    spans_mm: list[tuple[float, float]],
    end_mm: float,
    cyclic: bool,
    length_mm: float,
) -> float:
    """The fewest commands (fractional) that carry the tool point along ``spans_mm`` (arc
    lengths, mm; ``cyclic``: one span round the closed curve of ``length_mm``) by the limits
    of ``limit``'s layers: the integral over each span, less ``end_mm`` at either end, of
    ``1 / u(s)`` (:func:`local_arc_limits`). Between neighbouring layers of a span lies an
    interval ``I`` whose members' limits are at most ``W_I``, the larger of the two layers'
    largest cells; ``u(s)`` is the largest ``W_I`` of the intervals that lie within ``W_I``
    of ``s``. A command's nearest circle points span an arc decided by two instants of it, and
    the command between them has its middle configuration in some interval ``I``, so that arc
    is at most ``W_I`` long and lies within ``W_I`` of ``I``: along it ``u >= W_I``, and the
    integral of ``1 / u`` over it is at most 1. A pass's nearest points cover its span but
    ``end_mm`` at either end, so the integral over that is at most its commands. Where the
    limits are all alike it is the traced length over the largest."""
    start = spans_mm[0][0] if spans_mm else 0.0
    intervals = _limit_intervals(limit, cyclic, start, length_mm)
    return _reciprocal_integral(intervals, spans_mm, end_mm, limit.arc_mm)


def _along_at_most(
    limits_mm: FloatArray,
    s_mm: FloatArray,
    spans_mm: list[tuple[float, float]],
    end_mm: float,
    cyclic: bool,
    length_mm: float,
) -> float:
    """How high :func:`along_commands` comes at most, foretold from members of the family
    whose limits ``limits_mm`` at arc lengths ``s_mm`` (mm) are known: a member's limit is at
    most its interval's, so ``u(s)`` is at least the largest limit of the members within it
    of ``s``; where none is, their largest is taken (a forecast there, not a bound: the
    family's path has a few members per span)."""
    s = np.asarray(s_mm, dtype=np.float64)
    if cyclic:
        start = spans_mm[0][0]
        s = start + np.mod(s - start, length_mm)
    points = [(float(x), float(x), float(w)) for x, w in zip(s, limits_mm, strict=True)]
    if cyclic:
        points = _turned(points, length_mm)
    return _reciprocal_integral(points, spans_mm, end_mm, float(np.max(limits_mm)))


def _points_along(spans_mm: list[tuple[float, float]], gap_mm: float) -> tuple[FloatArray, float]:
    """Arc lengths (mm) along each span, evenly, every point of it within half the spacing
    returned (mm) of one of them: ``gap_mm``, or more where :data:`APPROACH_POINTS_MAX` points
    would not do it (a long curve)."""
    total = sum(b - a for a, b in spans_mm)
    gap = max(gap_mm, total / APPROACH_POINTS_MAX)
    out = []
    for a, b in spans_mm:
        count = max(math.ceil((b - a) / gap), 1)
        out.append(a + (np.arange(count) + 0.5) * (b - a) / count)
    return np.concatenate(out), gap


def _nearest_member(
    fam: CurveFamily, q_start: FloatArray, spans_mm: list[tuple[float, float]]
) -> float:
    """The largest-joint distance (commands) from ``q_start`` to the nearest member of the
    family sampled along :data:`APPROACH_LEVELS`' first count of tool directions at points
    :data:`FORECAST_GAP_MM` apart along the spans, the samples' own (no sampling errors, no
    blow-ups): what the least approach comes to at most, about (a forecast, not a bound)."""
    s_all, _ = _points_along(spans_mm, FORECAST_GAP_MM)
    sampler = FamilySampler(fam, 0.0, APPROACH_LEVELS[0], q_start, blow_ups=False)
    nearest = math.inf
    for s in s_all:
        check_time("bounding the approach to the band")
        layer = sampler.layer(
            fam.frame(float(s))[0], sampler.base, _allowed_at(fam, float(s)), levels=0
        )
        if layer.size:
            nearest = min(
                nearest, float(sampler.distance_from(q_start, layer.without_errors()).min())
            )
    return nearest


def _split_nearest(
    sampler: FamilySampler,
    q_start: FloatArray,
    E: FloatArray,
    dirs: FloatArray,
    allowed: Callable[[FloatArray], BoolArray],
    enough: float = math.inf,
) -> tuple[float, float]:
    """The least commands from ``q_start`` to the family at tool point ``E`` sampled along
    ``dirs`` (those ``allowed``), less the sampling errors, with the cells of directions
    nearest the start split (see :data:`APPROACH_SPLIT_ROUNDS`): each sampling's least
    distance is a bound, the highest is returned (inf where no sample is kept; the splits
    stop once it reaches ``enough``); and the distance to the nearest sample that is clear
    itself (:func:`_nearest_clear`)."""
    acc, filtered = sampler.sampled(E, dirs, allowed, levels=0)
    first = acc.dirs.shape[0]
    best, history, clear = -math.inf, [], math.inf

    def distance(u: FloatArray, err: FloatArray) -> FloatArray:
        return sampler.box_distance(q_start, u, err)

    for _ in range(APPROACH_SPLIT_ROUNDS + 1):
        layer, _, spacing, triangles = filtered
        if not layer.size:
            return math.inf, clear
        assert layer.direction is not None
        clear = min(clear, _nearest_clear(sampler, q_start, layer))
        d = sampler.distance_from(q_start, layer)
        least = float(d.min())
        best = max(best, least)
        history.append(best)
        if best >= enough or (
            len(history) > 2 and history[-1] < history[-3] + APPROACH_SPLIT_STALL
        ):
            break
        refine = np.zeros(acc.dirs.shape[0], dtype=bool)
        refine[layer.direction[d <= least + APPROACH_SPLIT_WINDOW]] = True
        refine &= spacing / 2.0 >= MIN_SPACING
        if not np.any(refine) or acc.dirs.shape[0] - first >= APPROACH_SPLIT_DIRECTIONS:
            break
        check_time("bounding the approach to the band")
        acc = sampler.split(acc, E, refine, triangles, allowed)
        # only the nearest samples' clearance is checked (the others lie farther)
        filtered = sampler._filtered(acc, (distance, APPROACH_SPLIT_WINDOW))
    return best, clear


def _nearest_clear(sampler: FamilySampler, q_start: FloatArray, layer: Layer) -> float:
    """The largest-joint distance (commands) from ``q_start`` to the nearest of ``layer``'s
    samples that keep the clearance rule themselves (inf where none does): a member the
    least approach cannot lie beyond."""
    assert layer.clear is not None
    if not np.any(layer.clear):
        return math.inf
    exact = layer.subset(layer.clear).without_errors()
    return float(sampler.distance_from(q_start, exact).min())


def least_approach(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    gap_mm: float = APPROACH_GAP_MM,
    directions: int = APPROACH_DIRECTIONS,
    on_progress: Callable[[str], None] | None = None,
) -> float:
    """The fewest commands (fractional: the largest-joint distance) from ``q_start`` to any
    member of the family at any point of the spans, less the sampling errors: the family is
    sampled at points every ``gap_mm`` (:func:`_points_along`; the spacing used is
    ``gap_mm`` or more) with the tolerance raised by half the spacing, so that a member at any
    point of the spans is a member there, within a sample's cell. Obstacles are ignored on
    the way (a relaxation); the members kept are those that may be clear. Each point is
    first sampled along the first of :data:`APPROACH_LEVELS` directions (wider cells, the
    singular directions not blown up: a lower distance, found fast), then the nearest point
    (by its latest bound) along more, up to ``directions``, where the cells of directions
    nearest the start are split (:func:`_split_nearest`); a point still the nearest after
    that is split in two along the curve, each half sampled with the tolerance raised by half
    as much (:data:`APPROACH_SPLIT_POINTS`); until the nearest point can be split no more
    (each sampling's distance is a bound for its points: the higher is taken), or its bound,
    in whole commands, reaches the distance to the nearest sample that is clear itself (a
    member: no bound can lie beyond it). The value returned is a bound; the fewest whole
    commands, its ceiling. ``on_progress`` is told each whole command the bound passes."""
    s_all, spacing = _points_along(spans_mm, gap_mm)
    levels = sorted({min(c, directions) for c in APPROACH_LEVELS} | {directions})
    found: dict[bytes, tuple[BlowUp, ...]] = {}  # the blow-ups at each point, found once
    # (each point's directions allowed are _allowed_at's there, at every sampling)
    samplers: dict[tuple[int, float], FamilySampler] = {}
    clear = math.inf  # the distance to the nearest sample clear itself so far (commands)
    fine = 0  # the points (not halves) sampled at the finest so far

    def nearest(level: int, s: float, gap: float) -> float:
        """The bound of the curve's points within ``gap / 2`` of ``s`` at ``level``."""
        nonlocal clear, fine
        check_time("bounding the approach to the band")
        count = levels[level]
        fine += level == finest and gap == spacing
        if (count, gap) not in samplers:  # the tolerance raised by half the point's cell;
            # the coarser samplings without blow-ups (finding them took 0.38 s a point on the
            # UR5 cell's circle, sampling it along 300 directions 0.05 s; most points never
            # reach the finest)
            samplers[count, gap] = FamilySampler(
                fam, tolerance_mm + gap / 2.0, count, q_start,
                blow_ups=level == finest, blow_up_cache=found,
            )  # fmt: skip
        sampler = samplers[count, gap]
        E, allowed = fam.frame(float(s))[0], _allowed_at(fam, float(s))
        dirs = fibonacci_directions(count)
        if level == finest:
            # split no further than the bound's whole commands need to reach the nearest
            # clear sample's (see below)
            enough = math.ceil(clear - 1e-9) - 1.0 + 1e-6
            value, its_clear = _split_nearest(sampler, q_start, E, dirs, allowed, enough)
            clear = min(clear, its_clear)
            return value
        layer = sampler.layer(E, dirs, allowed, levels=0)
        if not layer.size:
            return math.inf
        clear = min(clear, _nearest_clear(sampler, q_start, layer))
        return float(sampler.distance_from(q_start, layer).min())

    # each point's distance at its coarsest sampling first; the nearest point so far sampled
    # again more finely (each sampling's distance is a bound for its point: the higher kept)
    # until the nearest is at the finest, its nearest cells of directions split; then its
    # cell of the curve split in two, each half a point sampled at the finest with the
    # tolerance raised by half as much (the parent's bound holds for both halves), at most
    # APPROACH_SPLIT_POINTS times: every other point's bound is then no lower than the
    # nearest's. It stops early where the bound, in whole commands, reaches the nearest
    # clear sample's distance (no member can lie farther)
    finest = len(levels) - 1
    heap = [(nearest(0, float(s), spacing), 0, float(s), spacing) for s in s_all]
    heapq.heapify(heap)
    halvings = APPROACH_SPLIT_POINTS
    told = -math.inf  # the whole commands last told
    while heap:
        value, level, s, gap = heapq.heappop(heap)
        if on_progress is not None and math.isfinite(value) and math.floor(value) > told:
            told = math.floor(value)
            member = f" (a member within {clear:.2f})" if math.isfinite(clear) else ""
            on_progress(
                f"bounding the approach to the band: at least {value:.2f} commands{member}, "
                f"{fine} of {len(s_all)} points sampled finely, "
                f"{APPROACH_SPLIT_POINTS - halvings} halved"
            )
        if not math.isfinite(value) or math.ceil(value - 1e-9) >= math.ceil(clear - 1e-9):
            return value
        if level < finest:
            heapq.heappush(heap, (max(value, nearest(level + 1, s, gap)), level + 1, s, gap))
        elif halvings > 0 and gap / 2.0 >= APPROACH_MIN_GAP_MM:
            halvings -= 1
            for half in (s - gap / 4.0, s + gap / 4.0):
                # the finest sampling only: the parent's bound is above a coarser one's
                halved = max(value, nearest(finest, half, gap / 2.0))
                heapq.heappush(heap, (halved, finest, half, gap / 2.0))
        else:
            return value
    return math.inf


def _limit_layers(
    spans_mm: list[tuple[float, float]], gap_mm: float, cyclic: bool
) -> list[FloatArray]:
    """Arc lengths (mm) of each span's layers for the limit, at most ``gap_mm`` apart: at
    least two, at its ends (round a closed curve evenly from its start, at least three)."""
    if cyclic:
        ((a, b),) = spans_mm
        count = max(math.ceil((b - a) / gap_mm - 1e-9), 3)
        return [a + (b - a) * np.arange(count) / count]
    out = []
    for a, b in spans_mm:
        count = max(math.ceil((b - a) / gap_mm - 1e-9) + 1, 2)
        out.append(np.linspace(a, b, count))
    return out


class _NoBandError(Exception):
    """A window of the curve lies on no circle closely enough for the lemma."""


def _widest_gap(limit: FamilyLimit, cyclic: bool, length_mm: float) -> float:
    """The largest arc length (mm) between neighbouring layers of a span of ``limit``."""
    widest = 0.0
    for span in np.unique(limit.layer_span):
        x = np.sort(limit.layer_s_mm[limit.layer_span == span])
        if cyclic:
            x = np.sort(np.mod(x - x[0], length_mm))
            x = np.append(x, length_mm)
        if x.size > 1:
            widest = max(widest, float(np.diff(x).max()))
    return widest


@dataclass(frozen=True)
class _Setup:
    """What the band bound of some spans is computed with: the Taylor bounds of the joints
    that move the tool point (``tip``), the band at an arc length (``band_at``; raises
    :class:`_NoBandError` where there is none) and the layers' largest gap (mm)."""

    tb: TaylorBounds
    tip: BoolArray
    band_at: Callable[[float], LocalBand]
    gap_mm: float


def _setup(
    fam: CurveFamily, spans_mm: list[tuple[float, float]], tolerance_mm: float
) -> _Setup | None:
    """:class:`_Setup` of ``spans_mm``: one circle where they lie within :data:`FIT_SHARE` of
    the tolerance of it, else windows; None where the lemma does not apply to that circle."""
    arm, curve = fam.arm, fam.curve
    tip = tool_point_joints(arm)
    tb = taylor_bounds(arm, tip)
    whole = _band_over(fam, spans_mm, tolerance_mm, FIT_SHARE, math.inf)
    if whole is not None:
        if not lemma_applies(arm, whole.circle, whole.outer_mm, tb):
            return None
        gap = 2.0 * math.pi * whole.circle.radius_mm / LIMIT_LAYERS
        return _Setup(tb, tip, lambda _s: whole, gap)

    def band_at(s: float) -> LocalBand:
        a, b = s - WINDOW_HALF_MM, s + WINDOW_HALF_MM
        if not curve.closed:
            a, b = max(a, 0.0), min(b, curve.length)
        band = _band_over(fam, [(a, b)], tolerance_mm, WINDOW_FIT_SHARE, WINDOW_HALF_MM)
        if band is None or not lemma_applies(arm, band.circle, band.outer_mm, tb):
            raise _NoBandError
        return band

    return _Setup(tb, tip, band_at, WINDOW_GAP_MM)


def _ends(bands: list[LocalBand]) -> float:
    """The arc of the curve a tool point within the tolerance covers beyond the curve point
    nearest it, at either end of a span, twice (mm): two points of it within the tolerance of
    one tool point lie at most ``2 asin(tol / (R - deviation))`` apart round the centre, and
    the curve runs at most ``stretch`` times the circle's arc between them."""
    out = 0.0
    for b in bands:
        R, tol = float(b.circle.radius_mm), b.outer_mm - b.deviation_mm
        x = min(tol / max(R - b.deviation_mm, 1e-300), 1.0)
        out = max(out, 4.0 * b.stretch * R * math.asin(x))
    return out


def _forecast(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    loop: bool,
    family: CommandBound,
    setup: _Setup,
) -> tuple[float, float]:
    """:func:`band_forecast`'s two parts, approach and along (-inf where the family bound
    has no path to foretell the along part from); raises :class:`_NoBandError`."""
    approach = min(family.parts.get("approach", math.inf), _nearest_member(fam, q_start, spans_mm))
    guide_s, guide_q = family.guide_s_mm, family.guide_q
    if guide_q is None or guide_s is None or not 0 < len(guide_q) == len(guide_s):
        return approach, -math.inf
    bands = [setup.band_at(float(x)) for x in guide_s]
    path = np.array([
        _band_limit(fam.arm, q, band, setup.tb, setup.tip, REFINE_NODES)
        for q, band in zip(guide_q, bands, strict=True)
    ])  # fmt: skip
    ends = _ends(bands) / 2.0
    return approach, _along_at_most(path, guide_s, spans_mm, ends, loop, fam.curve.length)


def band_forecast(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    loop: bool,
    family: CommandBound,
) -> float:
    """What :func:`band_trace_bound` comes to at most, about, foretold cheaply from the
    ``family`` bound's path (a forecast, not a bound; -inf where the band bound does not
    apply or the family bound has no path): the least approach at most the family bound's
    approach part, or the distance to the nearest member of the family sampled coarsely
    along the spans where that is less (:func:`_nearest_member`: the part counts the approach
    to where its pass begins, which may lie farther: round the UR5 cell's seam 75 commands
    against a least approach of 47), plus the along part foretold from the limits at the
    path's members (:func:`_along_at_most`)."""
    setup = _setup(fam, spans_mm, tolerance_mm)
    if setup is None:
        return -math.inf
    try:
        approach, along = _forecast(fam, q_start, spans_mm, loop, family, setup)
    except _NoBandError:
        return -math.inf
    return math.ceil(approach - 1e-9) + along


def band_trace_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    loop: bool = False,
    family: CommandBound | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> CommandBound | None:
    """The band bound (see the module) of any plan whose passes trace ``spans_mm`` (arc
    lengths, mm) within ``tolerance_mm`` from ``q_start`` (rad); ``loop``: one span round
    the whole closed curve. The spans are bounded against one circle where they lie within
    :data:`FIT_SHARE` of the tolerance of it; otherwise each layer against the circle fitted
    to the curve within :data:`WINDOW_HALF_MM` of it (:class:`LocalBand`), which must lie
    within :data:`WINDOW_FIT_SHARE` of the tolerance of it, and the longest limit plus the
    widest gap between layers within that half-width (a command's arc then lies within the
    windows of the layers it lies between: a longer one would hold a shorter part that broke
    its own layers' limit). None where that fails, where the lemma does not apply (too
    tight, or an arm not measured in mm) or where the family has no member on the spans;
    and, given the ``family`` bound (:func:`~armpath.planning.bounds.trace_bound`), where
    this one would not be higher: foretold (:func:`band_forecast`), or its along part
    computed with the approach foretold, or both computed. ``on_progress`` is told what it
    computes."""
    curve = fam.curve
    setup = _setup(fam, spans_mm, tolerance_mm)
    if setup is None:
        return None
    if on_progress is not None:
        on_progress("bounding the commands along the band")
    approach_at_most = -math.inf

    def lower(along: float, approach: float) -> bool:
        # whether the band bound would be no higher than the family's
        return family is not None and math.ceil(approach - 1e-9) + along <= family.value

    try:
        if family is not None:
            approach_at_most, along_at_most = _forecast(fam, q_start, spans_mm, loop, family, setup)
            if math.isfinite(along_at_most) and lower(along_at_most, approach_at_most):
                return None
        sampler = FamilySampler(fam, tolerance_mm, LIMIT_DIRECTIONS, q_start)
        layers = _limit_layers(spans_mm, setup.gap_mm, loop)
        if on_progress is not None:
            on_progress(
                "bounding the commands along the band: the longest arc one command can "
                f"follow, at {sum(a.size for a in layers)} layers"
            )
        limit = family_arc_limit(
            sampler, setup.band_at, layers, loop,
            LIMIT_DIRECTIONS, splits=LIMIT_SPLITS,
        )  # fmt: skip
    except _NoBandError:
        return None
    if limit.samples == 0 or not math.isfinite(limit.arc_mm):
        return None
    bands = list(limit.layer_bands)
    ends = _ends(bands)
    window = max(b.window_mm for b in bands)  # inf: one circle for the whole spans
    if not limit.arc_mm > ends or limit.arc_mm + _widest_gap(limit, loop, curve.length) > window:
        return None
    along = along_commands(limit, spans_mm, ends / 2.0, loop, curve.length)
    if lower(along, approach_at_most):
        return None
    approach = least_approach(fam, q_start, spans_mm, tolerance_mm, on_progress=on_progress)
    if not math.isfinite(approach) or lower(along, approach):
        return None
    value = math.ceil(approach - 1e-9) + along
    finite = limit.layer_arc_mm[np.isfinite(limit.layer_arc_mm)]
    least = float(finite.min()) if finite.size else limit.arc_mm
    deviation = max(b.deviation_mm for b in bands)
    radii = [b.circle.radius_mm for b in bands]
    inner = [b.inner_mm - b.deviation_mm for b in bands]
    if math.isfinite(window):
        where = (
            f"each part of the spans lies within {deviation:.2g} mm of the circle fitted to the "
            f"curve within {window:g} mm of it (radii {min(radii):.4g}-{max(radii):.4g} mm)"
        )
    else:
        where = f"the spans lie within {deviation:.2g} mm of a circle of radius {radii[0]:.4g} mm"
    # the half band (a band's inner half narrower than its outer: both are the tolerance plus
    # the same deviation where the tool point may lie on either side)
    if fam.surface is not None and any(b.inner_mm < b.outer_mm for b in bands):
        where += (
            f", and the tool point, kept out of the {fam.surface.name} it lies on, at most "
            f"{min(inner):.3g}-{max(inner):.3g} mm inside it (the half band)"
        )
    return CommandBound(
        unproven_because=sampler.unproven_because(),
        commands=math.ceil(value - 1e-9),
        value=value,
        method=(
            "least approach to the band plus the traced length over the longest arc one command "
            f"can follow within it: {where}; a command's middle configuration anywhere in the "
            f"family follows at most {limit.arc_mm:.3f} mm of it, at some points along it "
            f"{least:.3f} mm (Taylor along the joint line and a Lagrangian dual per sampled "
            "member, widened by how far neighbouring members differ), each part of the spans "
            "counted over the largest limit of the members that can cover it; the approach the "
            "least largest-joint distance from the start to the "
            "family sampled along the spans, less the sampling errors"
        ),
        parts={"approach": float(math.ceil(approach - 1e-9)), "along": along},
        sampling={
            "circle_radius_mm": min(radii),
            "circle_deviation_mm": deviation,
            "band_window_mm": window,
            "band_inner_mm": max(inner),
            "command_arc_limit_mm": limit.arc_mm,
            "command_arc_limit_least_mm": least,
            "least_approach_commands": approach,
            "limit_samples": float(limit.samples),
            "limit_refined": float(limit.refined),
        },
    )


def with_band(family: CommandBound | None, band: CommandBound | None) -> CommandBound | None:
    """The higher of the family bound and the band bound (its value, parts and method; the
    family bound's guide and sampling kept, its value named in the sampling)."""
    if band is None or family is None or not band.value > family.value:
        return family
    return replace(
        family,
        commands=band.commands,
        value=band.value,
        method=f"{band.method}; the family's shortest path alone, {family.value:.1f}: "
        + family.method,
        parts=band.parts,
        sampling={**family.sampling, **band.sampling, "family_bound_commands": family.value},
        unproven_because=family.unproven_because or band.unproven_because,
    )
