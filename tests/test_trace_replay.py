"""Task 2 (trace the crack): the CLI's trace.json checked by the independent checker.

``independent_trace`` replays the commands exactly, samples the continuous motion, and decides
reachability of crack points by its own search of the arm's solution family; nothing here
imports armpath.
"""

import json
import re

import numpy as np
import pytest

import independent_trace as it

# each reported end of an unreachable arc lies within this distance of the independent boundary
# (the independent boundaries are bisected to 0.02 mm; the margin search converges to ~1e-4,
# i.e. a few thousandths of a mm of arc)
BOUNDARY_TOL = 0.5
COVER_TOL = 1.5  # the covered part reaches each boundary of the reachable part within this
N_DIRS = 20000


@pytest.fixture(scope="module")
def trace(seed_run):
    out, _ = seed_run
    return json.loads((out / "trace.json").read_text())


@pytest.fixture(scope="module")
def crack(trace):
    return it.Crack.aligned_to(trace["curve"]["points_mm"])


@pytest.fixture(scope="module")
def replayed(trace, crack):
    return it.replay_trace(trace, crack, substeps=100)


def _arcs(items):
    return [(float(a["start_mm"]), float(a["end_mm"])) for a in items]


def _circ(a, b, length):
    """Distance between arc-length positions on the closed curve."""
    d = (a - b) % length
    return min(d, length - d)


@pytest.fixture(scope="module")
def boundaries(trace, crack):
    """Independent reach boundaries next to every reported end of an unreachable arc:
    [(start, end)] per unreachable arc: from each reported end, 2 mm steps to the nearest change
    of the independent mask, then bisection to 0.02 mm."""
    out = []
    for a, b in _arcs(trace["unreachable"]):
        a_mine = it.boundary_near(a, -1, crack, tol=0.02, n_dirs=N_DIRS)
        b_mine = it.boundary_near(b, +1, crack, tol=0.02, n_dirs=N_DIRS)
        out.append((a_mine, b_mine))
    return out


def test_curve_is_the_crack(trace, crack):
    curve = trace["curve"]
    assert trace["task"] == "trace" and trace["surface"] == "workpiece"
    assert curve["closed"] is True
    assert curve["length_mm"] == pytest.approx(crack.length, abs=1e-3)
    pts = np.array(curve["points_mm"])
    s = np.array(curve["arc_length_mm"])
    assert pts.shape == (len(s), 3) and len(s) >= 1000
    np.testing.assert_allclose(s, np.linspace(0.0, curve["length_mm"], len(s)), atol=1e-6)
    np.testing.assert_allclose(pts, crack.at(s), atol=1e-3)
    np.testing.assert_allclose(pts[:, 0], 2 * pts[:, 2], atol=1e-6)
    assert np.abs(it.signed_distance(pts)).max() <= 1e-6


def test_commands_are_legal_and_keep_the_limits(trace, replayed):
    cmds = np.array(trace["commands"])
    assert cmds.dtype.kind == "i" and cmds.shape == (trace["n_commands"], 6)
    assert trace["n_commands"] <= 139  # the README's Task 2, replayed and judged below
    assert np.abs(cmds).max() <= 20
    assert replayed.problems == []
    states = replayed.states_ticks
    assert np.all(np.abs(states) <= it.TICK_LIMITS)  # linear motion: the states bound it
    np.testing.assert_allclose(states[-1] / 10, trace["final_deg"], atol=1e-9)
    assert trace["tolerance_mm"] == pytest.approx(0.1)


def test_every_pass_follows_the_crack_within_tolerance(trace, replayed):
    passes = trace["passes"]
    assert len(passes) >= 1
    assert all(0 <= i < j <= trace["n_commands"] for i, j in passes)
    tol = trace["tolerance_mm"]
    for (i, j), dev in zip(passes, replayed.pass_max_deviation, strict=True):
        assert dev <= tol + 1e-9, f"pass {i}-{j} leaves the crack by {dev:.4f} mm"
    assert replayed.max_deviation == pytest.approx(trace["max_deviation_mm"], abs=2e-3)


def test_no_collision_over_the_whole_motion(trace, replayed):
    worst = replayed.min_body_clearance
    assert worst >= it.MARGIN - 1e-3, f"a link body comes within {worst:.4f} mm"
    reported = trace["clearance"]["min_body_clearance_mm"]
    assert reported == pytest.approx(replayed.min_body_clearance, abs=2e-2)
    # non-adjacent links keep apart too
    assert replayed.min_self_distance >= it.MARGIN, f"links {replayed.min_self_distance:.3f} apart"
    if "min_self_clearance_mm" in trace["clearance"]:
        reported = trace["clearance"]["min_self_clearance_mm"]
        assert reported == pytest.approx(replayed.min_self_distance, abs=2e-2)


def test_tool_tip_never_penetrates(trace, replayed):
    worst = replayed.min_tip_clearance
    assert worst >= -1e-6, f"the tool tip enters the workpiece by {-worst:.2e} mm"
    reported = trace["clearance"]["min_tool_tip_clearance_mm"]
    assert reported == pytest.approx(replayed.min_tip_clearance, abs=2e-3)


def test_covered_arcs_are_what_the_tip_swept(trace, crack, replayed):
    covered = _arcs(trace["covered"])
    assert len(covered) == len(trace["passes"]) == len(replayed.covered)
    for (a, b), mine in zip(covered, replayed.covered, strict=True):
        assert 0 <= a < crack.length + 1e-9 and a < b <= a + crack.length + 1e-9
        assert len(mine) == 1, f"a pass covers several separate arcs: {mine}"
        (ma, mb) = mine[0]
        # the tip is within 0.1 mm of the crack: its projection is within ~0.1 mm of the target
        assert _circ(a, ma, crack.length) <= 0.1, f"start {a:.3f} vs swept {ma:.3f}"
        assert _circ(b, mb, crack.length) <= 0.1, f"end {b:.3f} vs swept {mb:.3f}"
    cov = trace["coverage"]
    total = sum(b - a for a, b in it.union_arcs(covered, crack.length))
    assert cov["covered_mm"] == pytest.approx(total, abs=1e-3)
    assert cov["curve_mm"] == pytest.approx(crack.length, abs=1e-3)
    assert cov["of_curve"] == pytest.approx(total / crack.length, abs=1e-6)
    # of the reachable arcs, only what lies within them counts (a pass may run a hair past an
    # arc's end): the covered arcs' union met with the reachable arcs', measured on a fine grid
    reachable = it.union_arcs(_arcs(trace["reachable"]), crack.length)
    s = np.linspace(0.0, crack.length, 400_001)[:-1]

    def inside(arcs: list[tuple[float, float]]) -> np.ndarray:
        hit = np.zeros(s.size, dtype=bool)
        for a, b in arcs:
            hit |= ((s - a) % crack.length) <= (b - a)
        return hit

    both = np.count_nonzero(inside(it.union_arcs(covered, crack.length)) & inside(reachable))
    within = both * crack.length / s.size
    assert cov["of_reachable"] == pytest.approx(within / cov["reachable_mm"], abs=1e-3)
    assert cov["of_reachable"] <= 1.0


def test_reported_arcs_partition_the_crack(trace, crack):
    reach, unreach = _arcs(trace["reachable"]), _arcs(trace["unreachable"])
    L = crack.length
    assert sum(b - a for a, b in reach + unreach) == pytest.approx(L, abs=1e-3)
    assert trace["coverage"]["reachable_mm"] == pytest.approx(
        sum(b - a for a, b in reach), abs=1e-3
    )
    for item in trace["reachable"] + trace["unreachable"]:
        assert item["length_mm"] == pytest.approx(item["end_mm"] - item["start_mm"], abs=1e-6)
    for item in trace["unreachable"]:
        np.testing.assert_allclose(item["start_point_mm"], crack.at(item["start_mm"]), atol=1e-3)
        np.testing.assert_allclose(item["end_point_mm"], crack.at(item["end_mm"]), atol=1e-3)
    # the arcs tile the curve: each one ends where the next begins, kinds alternating
    tiles = sorted(
        [(a % L, b - a, "r") for a, b in reach] + [(a % L, b - a, "u") for a, b in unreach]
    )
    for (a, n, kind), (a2, _, kind2) in zip(tiles, tiles[1:] + tiles[:1], strict=True):
        assert _circ(a + n, a2, L) <= 1e-3
        assert kind != kind2 or len(tiles) == 1


def test_unreachable_arcs_are_unreachable(trace, crack):
    assert trace["unreachable"], "the seed crack has an unreachable part around its low point"
    for a, b in _arcs(trace["unreachable"]):
        inner = np.linspace(a + BOUNDARY_TOL, b - BOUNDARY_TOL, 7)
        mask, _ = it.reachable_mask(inner, crack, n_dirs=N_DIRS, reasons=False)
        assert not mask.any(), f"reachable inside the reported unreachable arc: {inner[mask]}"


def test_reachable_arcs_are_reachable(trace, crack):
    for a, b in _arcs(trace["reachable"]):
        n = max(3, int((b - a) / 25.0))
        inner = np.linspace(a + COVER_TOL, b - COVER_TOL, n)
        mask, _ = it.reachable_mask(inner, crack, n_dirs=N_DIRS, reasons=False)
        assert mask.all(), f"no admissible configuration at s = {inner[~mask]}"


def test_unreachable_ends_match_the_independent_boundary(trace, crack, boundaries):
    L = crack.length
    for (a, b), (ma, mb) in zip(_arcs(trace["unreachable"]), boundaries, strict=True):
        assert _circ(a, ma, L) <= BOUNDARY_TOL, f"start {a:.3f} vs independent {ma:.3f}"
        assert _circ(b, mb, L) <= BOUNDARY_TOL, f"end {b:.3f} vs independent {mb:.3f}"


def test_covered_part_is_the_reachable_part(trace, crack, replayed, boundaries):
    """The passes cover every reachable arc up to COVER_TOL at its ends, and nothing else."""
    L = crack.length
    covered = it.union_arcs([arc for p in replayed.covered for arc in p], L)
    # the reachable part by the independent boundaries: the complement of the unreachable arcs
    cuts = sorted((a % L, a % L + (b - a)) for a, b in boundaries)
    reachable = [
        (cuts[k][1], cuts[(k + 1) % len(cuts)][0] + L * (k + 1 == len(cuts)))
        for k in range(len(cuts))
    ]
    assert len(covered) == len(reachable), f"covered {covered} vs reachable {reachable}"
    for ra, rb in reachable:
        # the covered arc that overlaps this reachable arc the most
        def overlap(arc, ra=ra, rb=rb):
            a, b = arc
            shift = L * np.round((ra - a) / L)
            return min(b + shift, rb) - max(a + shift, ra)

        a, b = max(covered, key=overlap)
        gaps = (_circ(a, ra, L), _circ(b, rb, L))
        assert max(gaps) <= COVER_TOL, (
            f"covered ({a:.3f}, {b:.3f}) vs independently reachable ({ra:.3f}, {rb:.3f}):"
            f" {gaps[0]:.3f} mm missed at the start, {gaps[1]:.3f} mm at the end"
        )


def _named(text):
    t = text.lower()
    joints = {int(m) for m in re.findall(r"(?:joint|theta|θ|j)\s*_?\s*(\d)", t)}
    limits = bool(joints) or "limit" in t
    collision = bool(re.search(r"collision|clearance|workpiece|table|obstacle|contact", t))
    return joints, limits, collision


def test_reason_of_the_arc_at_the_low_point(trace, crack):
    low = np.array([52.5, 0.0, 26.25])
    L = crack.length
    s_low = float(crack.closest(low)[1])
    arcs = [u for u in trace["unreachable"] if _inside(s_low, u, L)]
    assert len(arcs) == 1, "the low point lies in one reported unreachable arc"
    u = arcs[0]
    mid = 0.5 * (u["start_mm"] + u["end_mm"])
    mine = it.blocking_analysis(crack.at(mid), n_dirs=N_DIRS)
    # independently: joint 3's limit together with the clearance rule block it, neither alone
    assert mine["reason"] == "joint limits with collision"
    assert mine["relaxed"]["joint 3 limit"] and mine["relaxed"]["collision"]
    text = " ".join([u["reason"], *u.get("blocked_by", [])])
    joints, limits, collision = _named(text)
    assert "out of reach" not in text.lower()
    assert limits and collision, f"reported reason {text!r}: limits and collision block together"
    assert joints <= {3}, f"reported reason {text!r} names other joints than joint 3"


def _inside(s, item, length):
    """Whether arc-length position s lies on the arc of ``item`` (wrap convention of the doc)."""
    return (s - item["start_mm"]) % length <= item["end_mm"] - item["start_mm"]


@pytest.mark.extra
def test_independent_scan_finds_the_same_unreachable_arcs(trace, crack):
    """A full scan of the crack every ~2 mm: its unreachable runs are the reported arcs."""
    s, _ = crack.sample(2.0)
    mask, _ = it.reachable_mask(s, crack, n_dirs=N_DIRS, reasons=False)
    runs = it.arcs_of_mask(s, ~mask, crack.length)
    reported = _arcs(trace["unreachable"])
    assert len(runs) == len(reported)
    h = s[1] - s[0]
    for a, b in reported:
        near = [
            (ra, rb)
            for ra, rb in runs
            if _circ(a, ra, crack.length) <= h and _circ(b, rb, crack.length) <= h
        ]
        assert near, f"no independent unreachable run near ({a}, {b}): {runs}"
