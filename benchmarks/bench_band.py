"""How far one command can follow a curve within the tolerance band (issue 21): the closed
circles' proven bounds that see the band, the UR5 cell's seam beside them, and how far their
plans lie above them.

Run with ``python benchmarks/bench_band.py``. For the seed arm's 25 mm circle above the seed
workpiece (the README's), the UR5 cell's 80 mm circle (``bench_any_arm.py``'s) and the UR5
cell's seam round its workpiece (``examples/ur5_cell.toml``; the tool point must also stay
out of the workpiece, which the search keeps too), each curve is traced once with its lower
bound, and then:

* the plan's commands along the circle and the arc each covers (mm: the change of the arc
  length of the circle point nearest the tool point over the command);
* the longest arc one command was found to cover: the largest arc over a command's start
  configuration (any, within the joint limits) and its joint change (continuous, each joint
  within its largest step), its tool path at 33 evenly spaced instants within the tolerance
  of the circle, found by SLSQP from every third of the plan's commands along the circle, the
  same 1.3 times longer, and random ones (the plan's own commands counted too). A search, not
  a proof: an estimate of the most one command can cover;
* the arc per command of the longest chains of three commands found (continuous, each
  beginning where the last ended, the first start free; SLSQP from every sixth window of
  the plan's commands along the curve): whether commands in a row keep to what one can
  cover, or a lemma over several commands would prove fewer;
* the same from the plan's own start states (every third of its commands along the curve,
  the start held and the joint change searched, continuous): how much longer a command
  could be from where the tracer stands, against the plan's own commands there; and the
  longest lattice command within 3 ticks of that continuous one (or of it shortened to 93,
  86 or 80 %; 117,649 joint changes each), the plan's own counted too: how much of that
  the lattice leaves;
* the product's lower bound (with the tolerance band, ``planning/bounds/band_trace.py``):
  its approach and along parts, the proven limit on the arc one command can follow at the
  layers where the family was sampled (least and largest over the layers, each the largest
  over its sampled members' cells), and the family's shortest path
  alone (its search stopped once it could not pass the band's bound foretold); where the
  trace's bound is the family's (the seam), the band's bound round the whole curve computed
  on its own, its limits and value;
* the longest straight chord within the band (``4 sqrt(R tolerance)``, circles only): what a
  command whose tool path were straight could cover;
* the along part that longest arc implies (the traced length over it, rounded up), added to
  the proven bound's approach part (rounded up): an estimate of the fewest commands (not
  proven).

Writes ``benchmarks/results/band.md`` and prints it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import itertools
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import report
from bench_any_arm import CIRCLE_RADIUS_MM, _circle_scene
from report import table
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from armpath.kinematics import tool_position
from armpath.planning.bounds.band_trace import band_trace_bound
from armpath.planning.trace.tracer import _offsets as box_offsets
from armpath.scenes import load_scene
from armpath.scenes.arm import scene_arm
from armpath.tasks import trace_task

ROOT = Path(__file__).resolve().parents[1]
SEED_SCENE = ROOT / "src" / "armpath" / "scenes" / "seed.toml"
UR5_CELL = ROOT / "examples" / "ur5_cell.toml"
OUT = ROOT / "benchmarks" / "results" / "band.md"
#: Spacing (mm) of the polyline a curve that is no circle is measured against.
POLY_STEP_MM = 0.02
#: How far out of the solid the search keeps the tool point (mm; a command found is checked
#: against the solid itself).
OUT_MARGIN_MM = 0.002
#: Instants along a command at which its tool point must lie within the tolerance.
INSTANTS = np.linspace(0.0, 1.0, 33)
#: Every how many of the plan's commands along the curve one starts the search (with itself and
#: itself 1.3 times longer).
EVERY = 3
#: The search keeps the tool path within this share of the tolerance (it may end a little
#: outside what it keeps); a command found outside the tolerance is shortened by SHRINK up to
#: SHRINKS times until it lies within.
SEARCH_SHARE = 0.995
SHRINK, SHRINKS = 0.995, 20
#: Ticks either way about a continuous command's joint change (shortened by each share) where
#: :func:`lattice_near` looks for lattice commands: 7**6 = 117,649 changes at each share.
LATTICE_BOX, LATTICE_SHRINKS = 3, (1.0, 0.93, 0.86, 0.8)
#: Commands of the chains :func:`longest_chain` searches, every how many of the plan's
#: commands along the curve one begins, and the share of the tolerance its search keeps the
#: tool path within (UR5 cell's 80 mm circle: 12.28 mm a command with 0.995, 12.61 with 0.97;
#: SLSQP ends outside less often and its chains are shortened less).
CHAIN, CHAIN_EVERY, CHAIN_SHARE = 3, 6, 0.97


def _seed_circle_scene(folder: Path) -> Path:
    """The seed scene with the README's 25 mm circle at 260 mm as its trace."""
    text = SEED_SCENE.read_text(encoding="utf-8").split("[tasks.trace]")[0]
    path = folder / "seed_circle.toml"
    path.write_text(
        text
        + '[tasks.trace.curve]\ntype = "parametric"\nname = "circle"\n'
        + 'x = "330 + 25 * cos(t)"\ny = "60 + 25 * sin(t)"\nz = "260"\n'
        + f"t = [0, {2 * math.pi!r}]\n",
        encoding="utf-8",
    )
    return path


class Circle:
    """A horizontal circle (centre mm, radius mm): the distance of points from it and the arc
    length of their nearest points, in closed form (smooth, for the search's gradients)."""

    def __init__(self, centre: tuple[float, float, float], radius_mm: float) -> None:
        self.centre, self.radius = np.asarray(centre, dtype=np.float64), radius_mm

    def distance(self, p: np.ndarray) -> np.ndarray:
        d = p - self.centre
        return np.hypot(np.hypot(d[..., 0], d[..., 1]) - self.radius, d[..., 2])

    def arc(self, p: np.ndarray) -> np.ndarray:
        """Arc lengths (mm) of the nearest points of ``p (T, 3)``, unwrapped along them."""
        d = p - self.centre
        return self.radius * np.unwrap(np.arctan2(d[:, 1], d[:, 0]))

    def outside(self, p: np.ndarray) -> np.ndarray:
        """Signed distances (mm) from what the points must stay out of: a circle has nothing
        (no values, so no constraints: constraints that are zero everywhere stall SLSQP)."""
        return np.zeros(0)


class ClosedCurve:
    """A closed curve on a solid's face as a polyline (points every :data:`POLY_STEP_MM`):
    distance of points from it and arc length of their nearest points (projected onto the
    nearest polyline segments), and their signed distance from the solid."""

    radius = None

    def __init__(self, curve, solid) -> None:
        self.length = float(curve.length)
        count = math.ceil(self.length / POLY_STEP_MM)
        self.s = np.linspace(0.0, self.length, count + 1)
        self.points = np.asarray(curve.at_arc_length(self.s), dtype=np.float64)
        self.tree = cKDTree(self.points)
        self.solid = solid

    def _nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, k = self.tree.query(p)
        k = np.clip(k, 1, self.s.size - 2)
        dist, arc = np.full(p.shape[0], np.inf), np.zeros(p.shape[0])
        for a in (k - 1, k):  # the segments either side of the nearest point
            A, B = self.points[a], self.points[a + 1]
            t = np.einsum("ij,ij->i", p - A, B - A) / np.einsum("ij,ij->i", B - A, B - A)
            t = np.clip(t, 0.0, 1.0)
            d = np.linalg.norm(p - A - t[:, None] * (B - A), axis=1)
            nearer = d < dist
            dist[nearer] = d[nearer]
            arc[nearer] = (self.s[a] + t * (self.s[a + 1] - self.s[a]))[nearer]
        return dist, arc

    def distance(self, p: np.ndarray) -> np.ndarray:
        return self._nearest(p)[0]

    def arc(self, p: np.ndarray) -> np.ndarray:
        turns = np.unwrap(self._nearest(p)[1] * (2.0 * np.pi / self.length))
        return turns * self.length / (2.0 * np.pi)

    def outside(self, p: np.ndarray) -> np.ndarray:
        """Signed distance (mm) of points from the solid, negative inside."""
        return np.asarray(self.solid.signed_distance(p), dtype=np.float64)


Guide = Circle | ClosedCurve

#: The circles traced: the README's in the seed scene and bench_any_arm's in the UR5 cell.
SEED_CIRCLE = Circle((330.0, 60.0, 260.0), 25.0)
UR5_CIRCLE = Circle((330.0, -200.0, 150.0), CIRCLE_RADIUS_MM)


def _command_arc(arm, circle: Guide, q0: np.ndarray, dq: np.ndarray) -> tuple[float, float]:
    """The arc (mm, signed) a joint change ``dq`` from ``q0`` covers and the largest distance
    (mm) of its tool path from the curve at :data:`INSTANTS` (inf where one lies inside what
    it must stay out of)."""
    p = tool_position(arm, q0[None] + INSTANTS[:, None] * dq[None])
    s = circle.arc(p)
    off = np.inf if np.any(circle.outside(p) < 0.0) else float(np.max(circle.distance(p)))
    return float(s[-1] - s[0]), off


def _slack(circle: Guide, p: np.ndarray, tol: float, share: float = SEARCH_SHARE) -> np.ndarray:
    """The searches' constraints on tool points ``p (T, 3)`` (mm, each >= 0 where kept): within
    ``share`` of the tolerance of the curve, and out of the solid by its signed distance
    (smooth), :data:`OUT_MARGIN_MM` kept."""
    return np.concatenate([share * tol - circle.distance(p), circle.outside(p) - OUT_MARGIN_MM])


def _longest_from(
    arm, circle: Guide, tol: float, q0, dq, fixed_start: bool
) -> tuple[float, np.ndarray, np.ndarray]:
    """The longest arc (mm) SLSQP finds for one command searched from ``q0``, ``dq`` (the
    start configuration too unless ``fixed_start``), its tool path at :data:`INSTANTS` within
    the tolerance and out of what it must stay out of, with its start and joint change (rad);
    0 and the command it starts from if none found lies within. That command counts too."""
    n = arm.n_joints
    step = arm.lattice.max_step
    covered, off = _command_arc(arm, circle, q0, dq)
    best = (abs(covered) if off <= tol else 0.0, q0, dq)
    sign = 1.0 if covered >= 0.0 else -1.0

    def split(x):
        return (q0, x) if fixed_start else (x[:n], x[n:])

    def arc(x):
        return -sign * _command_arc(arm, circle, *split(x))[0]

    def within(x):
        q, d = split(x)
        return _slack(circle, tool_position(arm, q[None] + INSTANTS[:, None] * d[None]), tol)

    bounds = [(-s, s) for s in step]
    if not fixed_start:
        bounds = [
            (lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
            for lo, hi in zip(arm.lower, arm.upper, strict=True)
        ] + bounds
    found = minimize(
        arc,
        dq if fixed_start else np.concatenate([q0, dq]),
        method="SLSQP",
        bounds=bounds,
        constraints=[{"type": "ineq", "fun": within}],
        options={"maxiter": 300},
    )
    q, d = split(found.x)
    for _ in range(SHRINKS):  # a search that ends just outside: its command a little shorter
        covered, off = _command_arc(arm, circle, q, d)
        if off <= tol:
            return (abs(covered), q, d) if abs(covered) > best[0] else best
        d = SHRINK * d
    return best


def _kept(circle: Guide, p: np.ndarray, tol: float) -> np.ndarray:
    """Which tool points ``p (..., 3)`` lie within the tolerance and out of what they must
    stay out of."""
    flat = p.reshape(-1, 3)
    ok = circle.distance(flat) <= tol
    out = circle.outside(flat)
    if out.size:
        ok &= out >= 0.0
    return ok.reshape(p.shape[:-1])


def lattice_near(arm, circle: Guide, tol: float, q0: np.ndarray, dq: np.ndarray) -> float:
    """The longest arc (mm) of the lattice commands from the lattice state ``q0`` (rad) whose
    joint change lies within :data:`LATTICE_BOX` ticks of ``dq`` (rad; a continuous command
    found from it) shortened by each of :data:`LATTICE_SHRINKS`, their tool path at
    :data:`INSTANTS` within the tolerance and out of what it must stay out of; 0 if none."""
    grid = arm.lattice
    tick = np.asarray(grid.tick, dtype=np.float64)
    most = np.asarray(grid.max_ticks, dtype=np.int64)
    start = np.round(q0 / tick).astype(np.int64)
    offsets = box_offsets(arm.n_joints, LATTICE_BOX)
    best = 0.0
    for shrink in LATTICE_SHRINKS:
        cand = np.round(shrink * dq / tick).astype(np.int64) + offsets
        cand = cand[np.all(np.abs(cand) <= most, axis=1)]
        cand = cand[_kept(circle, tool_position(arm, (start + cand) * tick), tol)]
        if cand.size == 0:
            continue
        path = (start * tick)[None, None] + INSTANTS[None, :, None] * (cand * tick)[:, None]
        p = tool_position(arm, path.reshape(-1, arm.n_joints)).reshape(*path.shape[:2], 3)
        for i in np.flatnonzero(_kept(circle, p, tol).all(axis=1)):
            s = circle.arc(p[i])
            best = max(best, abs(float(s[-1] - s[0])))
    return best


def longest_chain(arm, circle: Guide, tol: float, passes: list[np.ndarray]) -> float:
    """The mean arc per command (mm) of the longest chains of :data:`CHAIN` consecutive
    commands SLSQP finds (each joint change continuous and within the largest step, each
    command beginning where the last ended, the first start free), their tool path at
    :data:`INSTANTS` of each command within the tolerance; searched from every
    :data:`CHAIN_EVERY`-th window of the plan's commands along the curve, as they are and 1.2
    times longer, in command units (the plan's own chain counts too)."""
    n, step = arm.n_joints, arm.lattice.max_step
    unit = np.tile(step, CHAIN + 1)

    def points(x):
        x = x * unit
        changes = x[n:].reshape(CHAIN, n)
        starts = x[:n] + np.concatenate([np.zeros((1, n)), np.cumsum(changes, axis=0)[:-1]])
        q = starts[:, None, :] + INSTANTS[None, :, None] * changes[:, None, :]
        return tool_position(arm, q.reshape(-1, n))

    def covered(x):
        s = circle.arc(points(x))
        return float(s[-1] - s[0])

    def within(x):  # in 0.1 mm, the arc in cm: SLSQP's steps then stay within the band
        return 10.0 * _slack(circle, points(x), tol, CHAIN_SHARE)

    found = []
    for states in passes:
        for k in range(0, len(states) - CHAIN, CHAIN_EVERY):
            changes = np.diff(states[k : k + CHAIN + 1], axis=0)
            own = np.concatenate([states[k], changes.ravel()]) / unit
            sign = 1.0 if covered(own) >= 0.0 else -1.0
            best = abs(covered(own))
            for scale in (1.0, 1.2):
                x0 = np.concatenate([states[k], np.clip(scale * changes, -step, step).ravel()])
                x = minimize(
                    lambda x, sign=sign: -sign * covered(x) / 10.0,
                    x0 / unit,
                    method="SLSQP",
                    bounds=[(None, None)] * n + [(-1.0, 1.0)] * (n * CHAIN),
                    constraints=[{"type": "ineq", "fun": within}],
                    options={"maxiter": 500},
                ).x
                for _ in range(SHRINKS):  # one that ends just outside: a little shorter
                    if _kept(circle, points(x), tol).all():
                        best = max(best, abs(covered(x)))
                        break
                    x = np.concatenate([x[:n], SHRINK * x[n:]])
            found.append(best / CHAIN)
    return float(np.mean(found))


def longest_command(arm, circle: Guide, tol: float, states: np.ndarray, seed: int, tries: int):
    """The longest arc (mm) one command was found to cover (see the module), and its search's
    starts: every :data:`EVERY`-th plan command along the curve, the same 1.3 times longer,
    and ``tries`` random ones from the plan's states (the plan's commands count too)."""
    step = arm.lattice.max_step
    rng = np.random.default_rng(seed)
    starts = []
    for a, b in list(itertools.pairwise(states))[::EVERY]:
        starts += [(a, b - a), (a, np.clip(1.3 * (b - a), -step, step))]
    for _ in range(tries):
        starts.append((states[rng.integers(len(states))], rng.uniform(-1.0, 1.0) * step))
    best = max(_longest_from(arm, circle, tol, q0, dq, fixed_start=False)[0] for q0, dq in starts)
    return best, len(starts)


def longest_from_own_starts(arm, circle: Guide, tol: float, passes: list[np.ndarray]):
    """Every :data:`EVERY`-th of the plan's commands along the curve: the longest arc (mm) a
    command from its own start state was found to cover (searched from it and from it 1.2
    times longer, the joint change continuous), and the longest of the lattice commands near
    that one (:func:`lattice_near`; the plan's own among them): the means of the plan's arcs,
    of those found and of those on the lattice."""
    step = arm.lattice.max_step
    own, found, lattice = [], [], []
    for states in passes:
        for a, b in list(itertools.pairwise(states))[::EVERY]:
            own.append(abs(_command_arc(arm, circle, a, b - a)[0]))
            arc, _, d = max(
                (
                    _longest_from(arm, circle, tol, a, np.clip(k * (b - a), -step, step), True)
                    for k in (1.0, 1.2)
                ),
                key=lambda f: f[0],
            )
            found.append(arc)
            lattice.append(max(own[-1], lattice_near(arm, circle, tol, a, d)))
    return float(np.mean(own)), float(np.mean(found)), float(np.mean(lattice))


def case(label: str, scene_path: Path, circle: Guide | None, seed: int, tries: int) -> list[str]:
    """The table's row of one curve (see the module); ``circle`` None: the scene's curve, on
    the face of the solid it lies on."""
    scene = load_scene(scene_path)
    arm = scene_arm(scene)
    if circle is None:
        curve = scene.trace_curve()
        circle = ClosedCurve(
            curve, next(o for o in scene.world.obstacles if o.name == curve.solid.name)
        )
    t0 = time.perf_counter()
    res = trace_task(scene, arm)
    q_all = res.sequence.states_joint()
    along, arcs, states = 0, [], []
    for p in res.passes:
        q = q_all[p.first : p.last + 1]
        arcs += list(np.abs(np.diff(circle.arc(tool_position(arm, q)))))
        along += p.last - p.first
        states.append(q)
    traced = sum(p.covered_mm for p in res.passes)
    tol = res.tolerance_mm
    best, starts = longest_command(arm, circle, tol, np.vstack(states), seed, tries)
    own_mean, from_own, on_lattice = longest_from_own_starts(arm, circle, tol, states)
    chain = longest_chain(arm, circle, tol, states)
    bound = res.lower_bound
    approach = bound.parts.get("approach", 0.0) if bound is not None else 0.0
    along_bound = 0.0 if bound is None else bound.value - approach
    along_estimate = math.ceil(traced / best - 1e-9)
    estimate = math.ceil(approach - 1e-9) + along_estimate
    sampling = {} if bound is None else bound.sampling
    limit = sampling.get("command_arc_limit_mm")
    family = sampling.get("family_bound_commands", None if bound is None else bound.value)
    alone = ""
    if limit is None and res.curve.closed and traced >= res.curve.length - 1e-6:
        # the trace's bound is the family's: the band's own, round the whole curve, to show
        # its limits and why it was not taken
        band = band_trace_bound(
            res.reachability.family, q_all[0], [(0.0, res.curve.length)], tol, loop=True
        )
        if band is not None:
            sampling = band.sampling
            limit = sampling["command_arc_limit_mm"]
            alone = (
                f"; the band's bound alone {band.value:.1f} = {band.parts['approach']:.0f} + "
                f"{band.parts['along']:.1f}, windows {sampling['band_window_mm']:g} mm, "
                f"inside the curve at most {sampling['band_inner_mm']:.3f} mm"
            )
    return [
        f"{label} ({res.curve.length:.0f} mm)",
        f"{res.n_commands} ({res.n_commands - along} + {along})",
        "-" if bound is None else f"{bound.commands} ({approach:.1f} + {along_bound:.1f})",
        "-" if family is None else f"{family:.1f}",
        f"{np.mean(arcs):.2f} / {np.max(arcs):.2f}",
        f"{best:.2f} ({starts} starts)",
        f"{chain:.2f}",
        f"{from_own:.2f} / {on_lattice:.2f} / {own_mean:.2f}",
        "-"
        if limit is None
        else f"{sampling.get('command_arc_limit_least_mm', limit):.2f} - {limit:.2f} "
        f"({sampling['limit_samples']:.0f} members{alone})",
        "-" if circle.radius is None else f"{4.0 * math.sqrt(circle.radius * tol):.2f}",
        f"{along_estimate}",
        f"{estimate}",
        f"{100.0 * (res.n_commands - estimate) / estimate:.0f} %",
        f"{time.perf_counter() - t0:.0f}",
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tries", type=int, default=40, help="random starts per curve (default 40)")
    ap.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    ap.add_argument("--out", type=Path, default=OUT, help=f"report file (default {OUT})")
    args = ap.parse_args()
    if not 0 <= args.tries <= 10_000:
        sys.exit("error: --tries must be in 0..10000")
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    knobs = (args.seed, args.tries)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = [
            case("seed: 25 mm circle", _seed_circle_scene(folder), SEED_CIRCLE, *knobs),
            case("UR5 cell: 80 mm circle", _circle_scene(folder), UR5_CIRCLE, *knobs),
            case("UR5 cell: seam, tool point kept out of the workpiece", UR5_CELL, None, *knobs),
        ]
    v = report.versions(("numpy", "scipy"))
    lines = [
        "# One command along a curve within the tolerance band",
        "",
        f"`python benchmarks/bench_band.py --tries {args.tries} --seed {args.seed}` — armpath at "
        f"{v['armpath']}; Python {v['python']}, numpy {v['numpy']}, scipy {v['scipy']}; "
        f"{started}. Tolerance 0.1 mm.",
        "",
        table(
            [
                "curve",
                "plan [commands] (approach + along)",
                "proven bound (approach + along)",
                "the family's shortest path alone",
                "plan's arc per command along [mm] (mean / largest)",
                "longest arc of one command found [mm]",
                f"a chain of {CHAIN} commands found: arc per command (mean) [mm]",
                "from the plan's own start states (mean) [mm]: longest found / the longest "
                "lattice command near it / the plan's",
                "proven limit per command, least - largest over the layers [mm]",
                "straight chord in the band [mm]",
                "along, estimated",
                "fewest, estimated (not proven)",
                "plan above the estimate",
                "wall [s]",
            ],
            rows,
        ),
        "",
        "The estimate is the proven bound's approach part plus the traced length over the "
        "longest arc one command was found to cover (a search, not a proof: see "
        "`benchmarks/bench_band.py`). The proven bound is the band's "
        "(`planning/bounds/band_trace.py`): the least approach to any point of the circle "
        "plus the traced length, less the tolerance's reach at the ends, each part of it "
        "counted over the proven limit per command of the layers near it (at each layer the "
        "largest over the family's sampled members, each widened by how far its neighbours' "
        "differ; a part is counted over the largest limit of the layers a command covering it "
        "could lie between); the family's shortest path, the largest-joint length "
        "along the circle, is a fraction of it (its search stopped after the round whose clear "
        "path could not pass what the band's bound was foretold to come to). Within the 0.1 "
        "mm band a joint-linear command "
        "follows a circle a few millimetres, not much farther than a straight chord would. "
        "Between the estimate and the plan lies what the tracer leaves: its commands along "
        "the circle cover less than the longest found (the command lattice; where in the band "
        "each begins: the column from the plan's own start states shows how much of it a "
        "command from where the tracer stands could still gain, and the longest lattice "
        "command near that one how much of it the lattice leaves; the chains, whether "
        "commands in a row keep to what one covers). The seam is no circle: the "
        "band bounds it by windows (each layer against the circle fitted to the curve within "
        "the window either side of it) and by the half band (its commands must also keep the "
        "tool point out of the workpiece, about a convex face, which the search keeps too); "
        "its proven bound is still the family's, which lies higher than the band's alone "
        "(the least approach to the seam lies far below the family bound's approach part to "
        "where its pass begins), so the trace skips the band there and its limits are "
        "computed here on their own.",
        "",
    ]
    return report.write(args.out, lines)


if __name__ == "__main__":
    raise SystemExit(main())
