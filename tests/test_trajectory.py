"""Minimum-snap / minimum-jerk trajectories against closed forms and an independent QP solve."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import polynomial as npoly
from scipy.linalg import null_space
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from armpath.errors import InvalidInputError
from armpath.trajectory import MotionLimits, allocate_times, minimum_snap
from armpath.trajectory.retime import (
    compare_retimings,
    ruckig_retime,
    scaled,
    shortest_bounded,
    slowest_factor,
    toppra_retime,
)


@pytest.mark.parametrize(
    ("kind", "closed_form"),
    [
        ("jerk", lambda s: 10 * s**3 - 15 * s**4 + 6 * s**5),
        ("snap", lambda s: 35 * s**4 - 84 * s**5 + 70 * s**6 - 20 * s**7),
    ],
)
def test_single_rest_to_rest_segment_is_the_classic_polynomial(kind, closed_form):
    traj = minimum_snap([[0.0], [2.0]], [1.0, 3.0], kind=kind)  # 2 s, amplitude 2
    t = np.linspace(1.0, 3.0, 41)
    assert np.allclose(traj.evaluate(t)[:, 0], 2.0 * closed_form((t - 1.0) / 2.0), atol=1e-12)


def _pieces(traj, i, joint):
    """Segment i of a joint as a polynomial in absolute time offset from its start."""
    T = traj.times[i + 1] - traj.times[i]
    return traj.coefficients[i, :, joint] / T ** np.arange(traj.coefficients.shape[1])


@pytest.mark.parametrize("kind", ["jerk", "snap"])
def test_waypoints_and_continuity_up_to_2r_minus_2(kind):
    rng = np.random.default_rng(1)
    W = rng.uniform(-2, 2, (7, 3))
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.5, 6))])
    traj = minimum_snap(W, t, kind=kind)
    r = traj.order
    assert np.allclose(traj.evaluate(t), W, atol=1e-10)
    for j in range(3):
        for i in range(5):
            left, right = _pieces(traj, i, j), _pieces(traj, i + 1, j)
            T = t[i + 1] - t[i]
            for d in range(0, 2 * r - 1):  # the optimum is C^(2r-2) by itself
                lv = npoly.polyval(T, npoly.polyder(left, d)) if d else npoly.polyval(T, left)
                rv = right[d] * np.prod(np.arange(1, d + 1))
                scale = 1.0 + abs(lv)
                assert abs(lv - rv) < 1e-7 * scale, (kind, j, i, d, lv, rv)
    start = traj.evaluate([t[0]], 1)
    assert np.allclose(start, 0.0, atol=1e-9)  # rest to rest


def _independent_problem(w, t, r, cont):
    """The same problem in absolute-time monomials: cost matrix, equality constraints and a
    function giving the row of a derivative at an absolute time offset within a segment."""
    n_seg, n = len(w) - 1, 2 * r
    T = np.diff(t)
    Q = np.zeros((n_seg * n, n_seg * n))
    rows, rhs = [], []
    for i in range(n_seg):
        for k in range(n):
            for m in range(n):
                ek = np.zeros(n)
                em = np.zeros(n)
                ek[k] = em[m] = 1.0
                prod = npoly.polymul(npoly.polyder(ek, r), npoly.polyder(em, r))
                integral = npoly.polyint(prod)
                Q[i * n + k, i * n + m] = npoly.polyval(T[i], integral)

    def deriv_row(i, d, x):
        row = np.zeros(n_seg * n)
        for k in range(d, n):
            row[i * n + k] = np.prod(np.arange(k - d + 1, k + 1)) * x ** (k - d)
        return row

    for i in range(n_seg):
        rows += [deriv_row(i, 0, 0.0), deriv_row(i, 0, T[i])]
        rhs += [w[i], w[i + 1]]
    for i in range(n_seg - 1):
        for d in range(1, cont + 1):
            rows.append(deriv_row(i, d, T[i]) - deriv_row(i + 1, d, 0.0))
            rhs.append(0.0)
    for d in range(1, r):
        rows += [deriv_row(0, d, 0.0), deriv_row(n_seg - 1, d, T[-1])]
        rhs += [0.0, 0.0]
    return Q, np.array(rows), np.array(rhs), deriv_row


def _independent_qp(w, t, r, cont):
    """The equality-only optimum by a dense null-space method: its cost."""
    Q, A, b, _ = _independent_problem(w, t, r, cont)
    x0 = np.linalg.lstsq(A, b, rcond=None)[0]
    N = null_space(A)
    z = np.linalg.solve(N.T @ Q @ N, -N.T @ Q @ x0)
    x = x0 + N @ z
    return float(x @ Q @ x)


def _independent_bounded_qp(w, t, r, cont, vmax, amax, points=200):
    """The velocity/acceleration-bounded optimum by SLSQP over the null space of the equality
    constraints, with the bounds imposed at ``points`` evenly spaced times per segment: its cost
    and its velocity / acceleration values at those points."""
    Q, A, b, deriv_row = _independent_problem(w, t, r, cont)
    x0 = np.linalg.lstsq(A, b, rcond=None)[0]
    N = null_space(A)
    T = np.diff(t)
    V = np.array([deriv_row(i, 1, x) for i in range(len(T)) for x in np.linspace(0, T[i], points)])
    Acc = np.array(
        [deriv_row(i, 2, x) for i in range(len(T)) for x in np.linspace(0, T[i], points)]
    )
    scale = 1.0 / float(x0 @ Q @ x0 + 1.0)
    res = minimize(
        lambda z: scale * float((x0 + N @ z) @ Q @ (x0 + N @ z)),
        np.zeros(N.shape[1]),
        jac=lambda z: scale * 2.0 * N.T @ Q @ (x0 + N @ z),
        constraints=[
            {
                "type": "ineq",
                "fun": lambda z: np.concatenate(
                    [
                        1.0 - (V @ (x0 + N @ z)) ** 2 / vmax**2,
                        1.0 - (Acc @ (x0 + N @ z)) ** 2 / amax**2,
                    ]
                ),
            }
        ],
        method="SLSQP",
        options={"maxiter": 500, "ftol": 1e-14},
    )
    assert res.success, res.message
    x = x0 + N @ res.x
    return float(x @ Q @ x), V @ x, Acc @ x


@pytest.mark.parametrize(("kind", "cont"), [("snap", 3), ("jerk", 2), ("snap", 5)])
def test_cost_matches_an_independent_qp(kind, cont):
    rng = np.random.default_rng(7)
    w = rng.uniform(-1, 1, 5)
    t = np.array([0.0, 0.7, 1.5, 1.9, 3.0])
    traj = minimum_snap(w, t, kind=kind, continuity=cont)
    ours = float(traj.cost()[0])
    theirs = _independent_qp(w, t, traj.order, cont)
    assert ours == pytest.approx(theirs, rel=1e-6)


def test_given_boundary_derivatives_and_time_allocation():
    W = np.array([[0.0, 0.0], [1.0, -2.0], [3.0, 0.5]])
    start = np.array([[0.5, 0.0], [0.0, 0.1], [0.0, 0.0]])  # velocity, acceleration, jerk
    t = allocate_times(W, max_velocity=[1.0, 2.0], max_acceleration=[2.0, 2.0])
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    # segment 1: joint 0 moves 1 (trapezoid 1/1 + 1/2 = 1.5 s), joint 1 moves 2 (2/2 + 2/2 = 2 s)
    assert t[1] == pytest.approx(2.0)
    traj = minimum_snap(W, t, start_derivatives=start)
    for d in (1, 2, 3):
        assert np.allclose(traj.evaluate([0.0], d)[0], start[d - 1], atol=1e-9)
        assert np.allclose(traj.evaluate([t[-1]], d)[0], 0.0, atol=1e-9)


@pytest.mark.parametrize("solver", ["clarabel", "osqp"])
def test_bounded_optimum_matches_an_independent_constrained_solve(solver):
    w = np.array([0.0, 1.0, -0.5, 2.0, 1.5])
    t = np.array([0.0, 0.8, 1.5, 2.6, 3.4])
    vmax, amax = 4.0, 13.5
    free = minimum_snap(w, t)
    dense = np.linspace(0.0, t[-1], 20001)
    # The limits bind: the unbounded optimum exceeds both.
    assert np.abs(free.evaluate(dense, 1)).max() > 1.05 * vmax
    assert np.abs(free.evaluate(dense, 2)).max() > 1.05 * amax
    traj = minimum_snap(w, t, limits=MotionLimits(velocity=vmax, acceleration=amax), solver=solver)
    assert np.allclose(traj.evaluate(t)[:, 0], w, atol=1e-7)
    assert np.abs(traj.evaluate(dense, 1)).max() <= vmax * (1 + 2e-5)
    assert np.abs(traj.evaluate(dense, 2)).max() <= amax * (1 + 2e-5)
    cost, v, a = _independent_bounded_qp(w, t, 4, 3, vmax, amax)
    assert np.abs(v).max() <= vmax * (1 + 1e-6) and np.abs(a).max() <= amax * (1 + 1e-6)
    # SLSQP imposes the bounds at 200 points a segment only, so its optimum may be a hair lower
    # (3e-5 relative in this case); ours holds them everywhere.
    assert cost * (1 - 1e-9) <= float(traj.cost()[0]) <= cost * (1 + 2e-4)
    assert float(traj.cost()[0]) > float(free.cost()[0]) * 1.01


@pytest.mark.parametrize("solver", ["clarabel", "osqp"])
def test_position_and_jerk_limits_hold_everywhere(solver):
    w = np.array([[0.0, 0.0], [0.95, 1.0], [1.0, -1.0], [0.0, 0.0]])
    t = np.array([0.0, 1.0, 1.4, 2.6])
    lower, upper, jerk = np.array([-0.2, -1.5]), np.array([1.05, 1.5]), np.array([30.0, 90.0])
    free = minimum_snap(w, t)
    dense = np.linspace(0.0, t[-1], 20001)
    # The unbounded optimum overshoots joint 0's upper and joint 1's lower limit and joint 1's jerk.
    assert free.evaluate(dense)[:, 0].max() > upper[0] + 0.02
    assert free.evaluate(dense)[:, 1].min() < lower[1] - 0.1
    assert np.abs(free.evaluate(dense, 3)[:, 1]).max() > jerk[1] * 1.05
    traj = minimum_snap(
        w, t, limits=MotionLimits(lower=lower, upper=upper, jerk=jerk), solver=solver
    )
    q = traj.evaluate(dense)
    assert np.all(q <= upper + 1e-5) and np.all(q >= lower - 1e-5)
    assert np.all(np.abs(traj.evaluate(dense, 3)) <= jerk * (1 + 2e-5))
    assert np.allclose(traj.evaluate(t), w, atol=1e-7)
    # Joint 1 sits on its bounds, so it must cost more than the free optimum.
    assert traj.cost()[1] > free.cost()[1] * 1.01


def test_position_limits_on_one_side_of_zero_hold_everywhere():
    # A joint limited to [1, 2] (rad, or a carriage in mm): its minima lie above zero, where the
    # largest magnitude of the position is not; each side is checked at its own extremes.
    w = np.array([[1.5], [1.05], [1.02], [1.9], [1.1]])
    t = np.array([0.0, 1.0, 1.6, 2.4, 3.5])
    dense = np.linspace(0.0, t[-1], 40001)
    assert minimum_snap(w, t).evaluate(dense).min() < 1.0 - 0.1
    traj = minimum_snap(w, t, limits=MotionLimits(lower=1.0, upper=2.0))
    q = traj.evaluate(dense)
    assert q.min() >= 1.0 - 1e-5 and q.max() <= 2.0 + 1e-5
    assert np.allclose(traj.evaluate(t)[:, 0], w[:, 0], atol=1e-7)
    # The shortest bounded duration keeps them too (the scaled optimum, which meets the rates,
    # overshoots the lower limit: no time scale mends that).
    limits = MotionLimits(velocity=2.0, acceleration=5.0, lower=1.0, upper=2.0)
    fastest = shortest_bounded(w, t, limits)
    q = fastest.evaluate(fastest.start + np.linspace(0.0, fastest.duration, 40001))
    assert q.min() >= 1.0 - 1e-5 and q.max() <= 2.0 + 1e-5
    assert fastest.peak(1)[0] <= 2.0 * (1 + 2e-5) and fastest.peak(2)[0] <= 5.0 * (1 + 2e-5)
    # Down to the lower limit and back: the scaled optimum, which meets the rates, cannot turn
    # round at the limit in its time (the QP is infeasible there); the search slows it first.
    w, t = np.array([[2.0], [1.0], [2.0]]), np.array([0.0, 1.0, 3.0])
    scaled_end = slowest_factor(minimum_snap(w, t), limits) * t[-1]
    with pytest.raises(InvalidInputError, match="cannot be met"):
        minimum_snap(w, t * scaled_end / t[-1] * (1 + 1e-9), limits=limits)
    fastest = shortest_bounded(w, t, limits)
    assert fastest.duration > scaled_end
    q = fastest.evaluate(fastest.start + np.linspace(0.0, fastest.duration, 40001))
    assert q.min() >= 1.0 - 1e-5 and q.max() <= 2.0 + 1e-5
    assert fastest.peak(1)[0] <= 2.0 * (1 + 2e-5) and fastest.peak(2)[0] <= 5.0 * (1 + 2e-5)


def test_limits_that_cannot_be_met_are_reported():
    with pytest.raises(InvalidInputError, match="lengthen the segments"):
        minimum_snap([0.0, 10.0], [0.0, 1.0], limits=MotionLimits(velocity=5.0))
    with pytest.raises(InvalidInputError, match="velocity limits must be > 0"):
        minimum_snap([0.0, 1.0], [0.0, 1.0], limits=MotionLimits(velocity=0.0))
    with pytest.raises(InvalidInputError, match="solver must be one of"):
        minimum_snap([0.0, 1.0], [0.0, 1.0], limits=MotionLimits(velocity=5.0), solver="cvx")


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        (([0.0], [0.0]), {}, "at least 2 waypoints"),
        (([0.0, 1.0], [1.0, 1.0]), {}, "strictly increasing"),
        (([0.0, 1.0], [0.0, 1.0]), {"kind": "crackle"}, "kind must be"),
        (([0.0, 1.0], [0.0, 1.0]), {"continuity": 9}, "continuity must be"),
        (([0.0, 1.0], [0.0, 1.0]), {"continuity": 1}, "not unique"),
    ],
)
def test_bad_trajectory_requests(args, kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        minimum_snap(*args, **kwargs)


def _seed_trajectory(speed_deg_s=30.0):
    W = np.radians(
        [
            [0, -90, 0, 0, -90, 0],
            [40, -60, 30, 90, -45, 10],
            [-30, -20, 90, -60, 30, 0],
            [10, -90, 10, 0, -90, 20],
        ]
    )
    t = allocate_times(W, np.radians(speed_deg_s), np.radians(60.0))
    return minimum_snap(W, t)


def test_commands_follow_the_trajectory_without_drift():
    """Replayed independently (integer ticks), the lattice state is within half a tick of the
    smooth trajectory at every controller period, over thousands of commands."""
    import independent
    from armpath.trajectory import quantize

    traj = _seed_trajectory()
    q = quantize(traj, 0.004)
    assert q.split_periods == 0 and q.sequence.n_commands == len(q.sample_times) - 1 > 2000
    assert np.abs(q.sequence.commands).max() <= 20
    states_deg = independent.replay(q.sequence.start_ticks / 10.0, q.sequence.commands)
    smooth_deg = np.degrees(traj.evaluate(q.sample_times))
    assert np.abs(states_deg - smooth_deg).max() <= 0.05 + 1e-9
    assert q.max_tick_error <= 0.5


def test_too_fast_periods_are_split_into_legal_commands():
    from armpath.trajectory import quantize

    traj = _seed_trajectory(speed_deg_s=60.0)
    q = quantize(traj, 0.2)  # up to ~12 deg a period
    assert q.split_periods > 0
    assert np.abs(q.sequence.commands).max() <= 20
    states = q.sequence.states()[q.state_index] / 10.0
    assert np.abs(states - np.degrees(traj.evaluate(q.sample_times))).max() <= 0.05 + 1e-9


def test_tip_deviation_matches_the_independent_kinematics():
    import independent
    from armpath.model import seed_arm
    from armpath.trajectory import quantize, tip_deviation

    traj = _seed_trajectory()
    q = quantize(traj, 0.01)
    ours = tip_deviation(seed_arm(), traj, q, substeps=4)
    states = np.degrees(q.sequence.states()[q.state_index] * np.pi / 1800.0)
    s = np.arange(4) / 4
    t = np.concatenate(
        [
            (q.sample_times[:-1, None] + s * np.diff(q.sample_times)[:, None]).ravel(),
            q.sample_times[-1:],
        ]
    )
    lattice = np.vstack(
        [
            (states[:-1, None] + s[None, :, None] * np.diff(states, axis=0)[:, None]).reshape(
                -1, 6
            ),
            states[-1:],
        ]
    )
    smooth = np.degrees(traj.evaluate(t))
    theirs = np.linalg.norm(
        independent.points(smooth)[:, 4] - independent.points(lattice)[:, 4], axis=1
    ).max()
    assert ours == pytest.approx(theirs, rel=1e-9)
    assert 0.0 < ours < 2.0  # mm: half a tick on every joint moves the tip well under 2 mm


def test_fixed_point_rotation_keeps_the_tip_on_the_point():
    """Seed 003's fixed-point rotation: the tip is on C0 = (900, 0, 0) mm at every waypoint
    (checked by the textbook modified D-H product), the tool axis points from the wrist to C0,
    and between waypoints the deviation shrinks like h^2 as the circle is sampled more finely."""
    from armpath.model.catalog import welder003
    from armpath.trajectory.rcm import fixed_point_rotation
    from independent_dh import dh_pose

    arm = welder003()
    a, alpha, d = [0, 500, 0, 0, 0, 0], np.radians([0, -90, 90, 0, -90, 90]), [0, 0, 0, 0, 0, 200]
    devs = []
    for n in (24, 48):
        rot = fixed_point_rotation(arm, [900.0, 0.0, 0.0], n_points=n)
        for q, wrist in zip(
            rot.waypoints, np.vstack([rot.wrist_points, rot.wrist_points[:1]]), strict=True
        ):
            T = dh_pose(
                a, alpha, d, q, modified=True, prismatic=[False, False, True, False, False, False]
            )
            assert np.allclose(T[:3, 3], [900.0, 0.0, 0.0], atol=1e-6)
            assert np.allclose(T[:3, 2], ([900.0, 0.0, 0.0] - wrist) / 200.0, atol=1e-9)
        t = np.linspace(0.0, rot.trajectory.duration, 3000)
        tips = np.array(
            [
                dh_pose(
                    a,
                    alpha,
                    d,
                    q,
                    modified=True,
                    prismatic=[False, False, True, False, False, False],
                )[:3, 3]
                for q in rot.trajectory.evaluate(t)
            ]
        )
        devs.append(np.linalg.norm(tips - [900.0, 0.0, 0.0], axis=1).max())
        assert devs[-1] == pytest.approx(rot.max_tip_deviation, rel=0.05)
    assert devs[1] < devs[0] / 3.0 and devs[1] < 2.0  # mm


def test_cli_trajectory_writes_samples_commands_and_plots(tmp_path):
    import subprocess
    import sys

    import independent

    wp = tmp_path / "wp.csv"
    wp.write_text(
        "t,q1,q2,q3,q4,q5,q6\n0,0,-90,0,0,-90,0\n2,40,-60,30,90,-45,10\n4,10,-90,10,0,-90,20\n"
    )
    out = tmp_path / "tr"
    armpath = [sys.executable, "-m", "armpath", "trajectory"]
    proc = subprocess.run(
        [*armpath, "--waypoints", str(wp), "--period", "0.02", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    samples = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    at = [np.argmin(np.abs(samples[:, 0] - t)) for t in (0.0, 2.0, 4.0)]
    assert np.allclose(
        samples[at, 1:],
        [[0, -90, 0, 0, -90, 0], [40, -60, 30, 90, -45, 10], [10, -90, 10, 0, -90, 20]],
        atol=1e-6,
    )
    cmds = np.loadtxt(out / "commands.csv", delimiter=",", skiprows=1, dtype=int)[:, 1:]
    assert cmds.shape == (200, 6) and np.abs(cmds).max() <= 20
    replayed = independent.replay([0, -90, 0, 0, -90, 0], cmds)
    assert np.abs(replayed[::10] - samples[::10, 1:]).max() <= 0.05 + 1e-9
    assert (out / "trajectory.png").stat().st_size > 20_000
    bad = subprocess.run(
        [*armpath, "--waypoints", str(tmp_path / "none.csv")], capture_output=True, text=True
    )
    assert bad.returncode == 1 and bad.stderr.startswith("error: cannot read waypoints file")


def _run_trajectory(*args):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-m", "armpath", "trajectory", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_cli_trajectory_takes_the_arm_its_lattice_units_and_limits(tmp_path):
    # A UR5 on a linear track: joint 1 a carriage in mm, the rest in deg, 0.1 mm / 0.1 deg ticks.
    track = Path(__file__).resolve().parents[1] / "examples" / "track_ur5.json"
    wp = tmp_path / "wp.csv"
    rows = [
        [0, 0, -90, 0, 0, -90, 0],
        [500, 30, -60, 20, 0, -60, 10],
        [1800, 60, -45, 45, 10, -30, 20],
    ]
    wp.write_text("\n".join(",".join(map(str, r)) for r in rows) + "\n")
    out = tmp_path / "tr"
    proc = _run_trajectory("--waypoints", wp, "--model", track, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr
    # the carriage's rate is in mm/s, the joints' in deg/s, each allocated by its own limit
    assert "largest joint speed (prismatic)" in proc.stdout and "mm/s" in proc.stdout
    header = (out / "trajectory.csv").read_text().splitlines()[0]
    assert header == "t_s,q1_mm,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,q7_deg"
    samples = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    cmds = np.loadtxt(out / "commands.csv", delimiter=",", skiprows=1, dtype=int)[:, 1:]
    assert cmds.shape[1] == 7 and np.abs(cmds).max() <= 20
    # Replayed in integer ticks of 0.1 (mm or deg) from the first waypoint, one command a period
    # (none split: the table says 0), the commands stay within half a tick of every sample and
    # end on the last waypoint.
    assert cmds.shape[0] == samples.shape[0] - 1
    states = np.vstack([np.zeros((1, 7), int), np.cumsum(cmds, axis=0)]) + np.rint(
        np.array(rows[0]) * 10
    ).astype(int)
    assert np.abs(states / 10.0 - samples[:, 1:]).max() <= 0.05 + 1e-6
    assert np.array_equal(states[-1], np.rint(np.array(rows[-1]) * 10).astype(int))
    # The carriage moves 1800 mm: at 30 mm/s and 60 mm/s^2 (the default rates read in mm) that
    # takes at least 1800 / 30 s; in deg/rad it would have been refused or taken far longer.
    assert samples[-1, 0] >= 1800 / 30


def test_cli_trajectory_warns_where_the_commands_leave_the_limits_and_bounded_keeps_them(
    tmp_path,
):
    # The seed arm: |joint 2| <= 125 deg (the specification). The free minimum-snap curve dips
    # below -125 deg between waypoints at -120 and -124 deg.
    wp = tmp_path / "wp.csv"
    wp.write_text(
        "0,-90,0,0,-90,0\n40,-120,20,0,-60,10\n60,-124,45,10,-30,20\n80,-60,45,10,-30,20\n"
    )
    free_out, bounded_out = tmp_path / "free", tmp_path / "bounded"
    free = _run_trajectory("--waypoints", wp, "--model", "seed", "--out", free_out)
    assert free.returncode == 0, free.stderr
    lowest = _replayed_lowest(free_out, [0, -90, 0, 0, -90, 0])
    assert lowest[1] < -125.0 - 1.0
    said = " ".join(free.stderr.split())
    assert f"joint 2 {-125.0 - lowest[1]:.4g} deg past its lower limit (-125 deg)" in said
    bounded = _run_trajectory(
        "--waypoints", wp, "--model", "seed", "--bounded", "--out", bounded_out
    )
    assert bounded.returncode == 0, bounded.stderr
    assert "past its" not in bounded.stderr
    lowest = _replayed_lowest(bounded_out, [0, -90, 0, 0, -90, 0])
    assert lowest[1] >= -125.0
    # Waypoints on the limit itself, twice.
    on = tmp_path / "on.csv"
    on.write_text(
        "0,-90,0,0,-90,0\n40,-125,20,0,-60,10\n60,-100,45,10,-30,20\n80,-125,45,10,-30,20\n"
    )
    on_out = tmp_path / "on"
    bounded = _run_trajectory("--waypoints", on, "--model", "seed", "--bounded", "--out", on_out)
    assert bounded.returncode == 0, bounded.stderr
    assert _replayed_lowest(on_out, [0, -90, 0, 0, -90, 0])[1] == -125.0
    # Bad input on a model: one error line each.
    wrong = tmp_path / "six.csv"
    wrong.write_text("0,0,0,0,0,0\n10,0,0,0,0,0\n")
    track = Path(__file__).resolve().parents[1] / "examples" / "track_ur5.json"
    for args, needle in (
        (["--waypoints", wrong, "--model", track], "has 7 joints"),
        (["--waypoints", wp, "--model", "seed", "--tip-link", "tool"], "built in"),
        (["--waypoints", wp, "--tip-link", "tool"], "give --model"),
    ):
        proc = _run_trajectory(*args)
        assert proc.returncode != 0 and proc.stderr.startswith("error:"), proc.stderr
        assert needle in proc.stderr and "Traceback" not in proc.stderr
    beyond = tmp_path / "beyond.csv"
    beyond.write_text("0,0,0,0,0,0\n0,130,0,0,0,0\n")
    proc = _run_trajectory("--waypoints", beyond, "--model", "seed")
    assert proc.returncode == 1 and proc.stderr.startswith("error:")
    assert "waypoint 2: joint 2" in proc.stderr and "125" in proc.stderr


def _replayed_lowest(out, first_deg):
    cmds = np.loadtxt(out / "commands.csv", delimiter=",", skiprows=1, dtype=int)[:, 1:]
    import independent

    return independent.replay(first_deg, cmds).min(axis=0)


# --- retiming -------------------------------------------------------------------------------


def _retiming_case():
    rng = np.random.default_rng(11)
    W = np.cumsum(rng.uniform(-30.0, 30.0, (8, 3)), axis=0)  # deg
    t = allocate_times(W, 60.0, 120.0)
    return W, t, MotionLimits(velocity=60.0, acceleration=120.0, jerk=600.0)


def _dense_peaks(traj, n=40001):
    t = traj.start + np.linspace(0.0, traj.duration, n)
    return [np.abs(traj.evaluate(t, d)).max(axis=0) for d in (1, 2, 3)]


def test_scaled_and_bounded_retimings_meet_the_limits():
    W, t, limits = _retiming_case()
    lim = np.array([60.0, 120.0, 600.0])
    free = minimum_snap(W, t)
    slow = scaled(free, limits)
    peaks = _dense_peaks(slow)
    ratios = [p.max() / m for p, m in zip(peaks, lim, strict=True)]
    # Uniform scaling: the tightest limit is met exactly, the others hold.
    assert max(ratios) == pytest.approx(1.0, abs=1e-6)
    assert np.allclose(slow.evaluate(slow.times), W, atol=1e-9)
    best = shortest_bounded(W, t, limits, rtol=1e-3)
    assert best.duration < slow.duration * 0.97  # the QP uses the limits better
    for p, m in zip(_dense_peaks(best), lim, strict=True):
        assert p.max() <= m * (1 + 2e-5)
    assert np.allclose(best.evaluate(best.times), W, atol=1e-7)
    # Shortest: 1 % faster on the same relative times is infeasible.
    faster = best.times[0] + 0.99 * (best.times - best.times[0])
    with pytest.raises(InvalidInputError, match="cannot be met"):
        minimum_snap(W, faster, limits=limits)


def test_toppra_retimes_the_same_path_faster():
    W, t, limits = _retiming_case()
    slow = scaled(minimum_snap(W, t), limits)
    fast = toppra_retime(slow, limits)
    v, a, _ = _dense_peaks(fast)
    assert v.max() <= 60.0 * 1.002 and a.max() <= 120.0 * 1.002
    # Time-optimal under velocity and acceleration: never slower than uniform scaling.
    assert fast.duration < slow.duration
    # Same geometric path: every toppra sample lies on the minimum-snap curve.
    curve = slow.evaluate(np.linspace(slow.times[0], slow.times[-1], 200001))
    q = fast.evaluate(np.linspace(0.0, fast.duration, 500))
    gaps, _ = cKDTree(curve).query(q)
    assert gaps.max() < 0.02  # deg; the dense curve's own spacing is ~0.01 deg
    assert np.allclose(fast.evaluate([0.0, fast.duration]), W[[0, -1]], atol=1e-6)


def test_ruckig_is_time_optimal_between_the_same_waypoint_states():
    W, t, limits = _retiming_case()
    slow = scaled(minimum_snap(W, t), limits)
    jerky = ruckig_retime(slow, limits)
    knots = jerky._knots
    # Passes every waypoint with the minimum-snap trajectory's velocity and acceleration.
    for d in (0, 1, 2):
        assert np.allclose(
            jerky.evaluate(knots[1:-1] + 1e-12, d), slow.evaluate(slow.times[1:-1], d), atol=1e-6
        )
    assert np.allclose(jerky.evaluate(knots, 0), W, atol=1e-8)
    v, a, j = _dense_peaks(jerky)
    assert v.max() <= 60.0 * (1 + 1e-6) and a.max() <= 120.0 * (1 + 1e-6)
    assert j.max() <= 600.0 * (1 + 1e-3)
    # Each piece joins the same states under the same limits as the minimum-snap segment, which
    # meets them too: time-optimal means it is never longer.
    assert np.all(np.diff(knots) <= np.diff(slow.times) + 1e-9)
    assert jerky.duration < slow.duration


def test_compare_retimings_reports_every_method():
    W, t, limits = _retiming_case()
    rows = {r.method: r for r in compare_retimings(W, t, limits)}
    assert set(rows) == {"scaled", "bounded", "toppra", "ruckig"}
    assert rows["bounded"].within(limits) == {"velocity": True, "acceleration": True, "jerk": True}
    assert rows["toppra"].within(limits)["acceleration"]
    assert rows["toppra"].duration_s < rows["scaled"].duration_s
    with pytest.raises(InvalidInputError, match="unknown retiming"):
        compare_retimings(W, t, limits, methods=("magic",))


def test_cli_trajectory_bounded_and_retimed(tmp_path):
    import subprocess
    import sys

    wp = tmp_path / "wp.csv"
    wp.write_text("q1,q2,q3\n0,-90,0\n40,-60,30\n-30,-20,90\n10,-90,10\n")
    out = tmp_path / "tr"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "armpath",
            "trajectory",
            "--waypoints",
            str(wp),
            "--bounded",
            "--max-velocity",
            "30",
            "--max-acceleration",
            "60",
            "--max-jerk",
            "300",
            "--retime",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    samples = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    t, q = samples[:, 0], samples[:, 1:]
    # Finite differences of the sampled trajectory respect the limits (deg/s, deg/s^2).
    v = np.diff(q, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / np.diff(t)[1:, None]
    assert np.abs(v).max() <= 30.0 * (1 + 1e-3) and np.abs(a).max() <= 60.0 * (1 + 1e-2)
    rows = {
        line.split(",")[0]: line.split(",")
        for line in (out / "retiming.csv").read_text().splitlines()[1:]
    }
    assert set(rows) == {"scaled", "bounded", "toppra", "ruckig"}
    # The bounded trajectory written is the shortest bounded one in the comparison.
    assert float(rows["bounded"][1]) == pytest.approx(t[-1], abs=0.011)
    assert float(rows["ruckig"][4]) <= 300.0 * 1.001 and rows["ruckig"][5:8] == ["True"] * 3
    assert float(rows["toppra"][1]) < float(rows["scaled"][1])


@pytest.mark.slow
def test_cli_rcm_writes_the_rotation_and_its_commands(tmp_path):
    import subprocess
    import sys

    from PIL import Image

    from independent_dh import dh_pose

    out = tmp_path / "rcm"
    proc = subprocess.run(
        [sys.executable, "-m", "armpath", "rcm", "--points", "24", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    data = np.loadtxt(out / "rcm.csv", delimiter=",", skiprows=1)
    assert data.shape == (801, 1 + 6 + 4)  # 8 s every 0.01 s
    q_show, tips, dev = data[:, 1:7], data[:, 7:10], data[:, 10]
    a, alpha, d = [0, 500, 0, 0, 0, 0], np.radians([0, -90, 90, 0, -90, 90]), [0, 0, 0, 0, 0, 200]
    prismatic = [False, False, True, False, False, False]
    q = np.where(prismatic, q_show, np.radians(q_show))
    theirs = np.array(
        [dh_pose(a, alpha, d, row, modified=True, prismatic=prismatic)[:3, 3] for row in q]
    )
    assert np.allclose(tips, theirs, atol=1e-4)
    assert np.allclose(dev, np.linalg.norm(theirs - [900.0, 0.0, 0.0], axis=1), atol=1e-4)
    assert 2.0 < dev.max() < 6.0  # mm: 4.4 mm with 24 waypoints
    # Commands: 0.1 deg ticks for revolute joints, 0.1 mm for the prismatic one; replayed from
    # the first sample rounded to ticks they stay within half a tick of every sample.
    cmds = np.loadtxt(out / "commands.csv", delimiter=",", skiprows=1, dtype=int)[:, 1:]
    assert cmds.shape == (800, 6) and np.abs(cmds).max() <= 20
    states = np.rint(q_show[0] / 0.1) + np.vstack([np.zeros(6), np.cumsum(cmds, axis=0)])
    assert np.abs(states * 0.1 - q_show).max() <= 0.05 + 1e-6
    gif = Image.open(out / "rcm.gif")
    assert gif.n_frames == 64 and gif.size[0] >= 400
    assert (out / "rcm_tip_deviation.png").stat().st_size > 20_000
    assert "largest tip deviation, smooth trajectory" in proc.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "armpath", "rcm", "--centre", "900,0", "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 1 and "--centre" in bad.stderr and not (tmp_path / "x").exists()


# --- bounds on the work (issue 17, item 4) ----------------------------------------------------


def test_quantize_at_the_command_limit_and_one_command_past():
    """One period carrying 20,000,000 ticks (2,000,000 deg) is split into exactly
    ceil(20,000,000 / 20) = MAX_COMMANDS commands of 20 ticks; 21 ticks more need one command
    too many and are refused before any command is built."""
    import math

    from armpath.budget import MAX_COMMANDS
    from armpath.trajectory import quantize

    span = 20_000_000  # ticks of 0.1 deg
    traj = minimum_snap(np.radians([[0.0], [span / 10.0]]), [0.0, 1.0])
    q = quantize(traj, 10.0)
    assert q.sequence.n_commands == math.ceil(span / 20) == MAX_COMMANDS
    assert q.split_periods == 1 and np.all(q.sequence.commands == 20)
    assert q.state_index.tolist() == [0, MAX_COMMANDS]
    over = minimum_snap(np.radians([[0.0], [(span + 21) / 10.0]]), [0.0, 1.0])
    with pytest.raises(
        InvalidInputError, match=r"commands.*20,000,021 ticks.*the limit is 1,000,000.*--period"
    ):
        quantize(over, 10.0, option="--period")


def test_quantize_refuses_periods_before_sampling():
    """A 2 s trajectory in periods of 1e-9 s would be 2e9 samples (16 GB a joint): refused from
    the arithmetic, naming the option."""
    from armpath.trajectory import quantize

    traj = minimum_snap([[0.0], [1.0]], [0.0, 2.0])
    with pytest.raises(
        InvalidInputError, match=r"controller periods.*2,000,000,000.*change --period"
    ):
        quantize(traj, 1e-9, option="--period")
    with pytest.raises(InvalidInputError, match="controller periods"):
        quantize(traj, 1e-300)  # 2e300 periods: the ratio itself is beyond any integer
    one = quantize(traj, 1e300)  # a period longer than the trajectory: one period, to its end
    assert one.sample_times.tolist() == [0.0, 2.0] and one.n_periods == 1
    assert one.sequence.final_ticks.tolist() == [round(np.degrees(1.0) * 10)]


def test_quantize_refuses_joint_values_beyond_exact_ticks():
    from armpath.trajectory import quantize

    traj = minimum_snap([[1e15], [1e15 + 1e-3]], [0.0, 1.0])  # rad: ~5.7e20 ticks
    with pytest.raises(InvalidInputError, match="ticks to be quantized"):
        quantize(traj, 0.5)


def test_commands_of_all_periods_at_once_match_split_move():
    """The vectorised split of every period equals commands.split_move period by period."""
    from armpath.commands import commands_needed, split_move
    from armpath.trajectory.quantize import _split_periods

    rng = np.random.default_rng(5)
    delta = rng.integers(-700, 700, (300, 6))
    delta[::7] = rng.integers(-20, 21, (len(delta[::7]), 6))  # some periods need one command
    m = np.array([max(commands_needed(d), 1) for d in delta])
    expected = np.vstack([split_move(d, k) for d, k in zip(delta, m, strict=True)])
    got = _split_periods(delta, m)
    assert np.array_equal(got, expected)
    assert np.abs(got).max() <= 20 and got.shape[0] == m.sum()


def test_commanded_motion_in_parts_joins_up_to_the_whole(monkeypatch):
    qz = importlib.import_module("armpath.trajectory.quantize")  # the function shadows it
    from armpath.model import seed_arm
    from armpath.trajectory import lattice_motion, quantize, tip_deviation

    traj = _seed_trajectory(speed_deg_s=60.0)
    q = quantize(traj, 0.02)
    t_all, q_all = lattice_motion(q, 8)
    n = q.n_periods
    parts = [lattice_motion(q, 8, a, min(a + 37, n)) for a in range(0, n, 37)]
    assert np.array_equal(np.concatenate([p[0] for p in parts]), t_all)
    assert np.array_equal(np.vstack([p[1] for p in parts]), q_all)
    assert t_all.size == 8 * n + 1
    whole = tip_deviation(seed_arm(), traj, q)
    monkeypatch.setattr(qz, "MOTION_CHUNK", 5)
    assert tip_deviation(seed_arm(), traj, q) == whole
    with pytest.raises(InvalidInputError, match="substeps"):
        lattice_motion(q, 0)


def test_shortest_bounded_search_has_a_step_budget(monkeypatch):
    """The finest tolerance still ends within 1 + 1 + MAX_HALVINGS + MAX_BISECTIONS QP solves;
    rtol of 0 (which used to bisect forever once hi and lo were neighbouring floats) or NaN is
    refused."""
    import armpath.trajectory.retime as rt

    W, t, limits = _retiming_case()
    calls = []
    real = rt.minimum_snap

    def counting(*args, **kwargs):
        calls.append(kwargs.get("limits") is not None)
        return real(*args, **kwargs)

    coarse = shortest_bounded(W, t, limits, rtol=1e-3)
    monkeypatch.setattr(rt, "minimum_snap", counting)
    best = shortest_bounded(W, t, limits, rtol=rt.MIN_RTOL)
    assert sum(calls) <= 1 + rt.MAX_HALVINGS + rt.MAX_BISECTIONS
    # the finer search ends within the coarse one's bracket
    assert coarse.duration * (1 - 1.1e-3) <= best.duration <= coarse.duration
    for rtol in (0.0, float("nan"), 1e-12, 1.5):
        with pytest.raises(InvalidInputError, match="rtol"):
            shortest_bounded(W, t, limits, rtol=rtol)


def test_motionless_and_barely_moving_waypoints():
    """Waypoints that do not move meet any limit at any duration: the free optimum comes back
    (the scale factor used to be 0 and the error spoke of missing limits); waypoints that move
    1e-200 rad would need segments of 1e-100 s, beyond what the solve can take: named."""
    limits = MotionLimits(velocity=1.0, acceleration=1.0)
    still = shortest_bounded([[0.5], [0.5], [0.5]], [0.0, 1.0, 3.0], limits)
    assert still.duration == 3.0 and np.all(still.evaluate(np.linspace(0, 3, 7)) == 0.5)
    assert scaled(still, limits).duration == 3.0
    with pytest.raises(InvalidInputError, match="move so little"):
        shortest_bounded([[0.0], [1e-200]], [0.0, 1.0], limits)


@pytest.mark.parametrize(
    ("limits", "message"),
    [
        (MotionLimits(velocity=float("nan")), "velocity limits must be > 0 and finite"),
        (MotionLimits(velocity=1.0, acceleration=float("inf")), "acceleration limits"),
        (MotionLimits(velocity=1.0, jerk=-1.0), "jerk limits"),
    ],
)
def test_bad_limits_are_refused(limits, message):
    with pytest.raises(InvalidInputError, match=message):
        minimum_snap([[0.0], [1.0]], [0.0, 1.0], limits=limits)


def test_trajectory_sizes_and_durations_are_refused_before_the_solve():
    from armpath.budget import MAX_JOINTS, MAX_WAYPOINTS

    with pytest.raises(InvalidInputError, match="waypoints: this would need 10,001 "):
        minimum_snap(np.zeros((MAX_WAYPOINTS + 1, 1)), np.arange(MAX_WAYPOINTS + 1.0))
    with pytest.raises(InvalidInputError, match="joints"):
        minimum_snap(np.zeros((2, MAX_JOINTS + 1)), [0.0, 1.0])
    with pytest.raises(InvalidInputError, match="segment durations"):
        minimum_snap([[0.0], [1.0]], [0.0, 1e-300])  # T^-7 overflows
    with pytest.raises(InvalidInputError, match="segment durations"):
        minimum_snap([[0.0], [1.0]], [0.0, 1e60])  # T^7 overflows
    with pytest.raises(InvalidInputError, match="finite"):
        allocate_times([[0.0], [1.0]], float("nan"), 1.0)
    with pytest.raises(InvalidInputError, match="samples_per_segment"):
        minimum_snap(
            [[0.0], [1.0]], [0.0, 1.0], limits=MotionLimits(velocity=9.0), samples_per_segment=10**6
        )


def test_time_limit_ends_the_retiming_searches():
    import time

    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    W, t, limits = _retiming_case()
    for run in (
        lambda: shortest_bounded(W, t, limits),
        lambda: compare_retimings(W, t, limits, methods=("ruckig",)),
        lambda: minimum_snap(W, t, limits=limits),
    ):
        with (
            time_limit(0.01),
            pytest.raises(TimeLimitError, match=r"time limit of 0\.01 s ran out"),
        ):
            time.sleep(0.02)
            run()


def test_fixed_point_rotation_bounds_and_a_huge_axis():
    """The number of points is bounded; an axis of 1e308 (whose norm overflows) gives the same
    circle as the same direction written small."""
    from armpath.budget import MAX_WAYPOINTS
    from armpath.model.catalog import welder003
    from armpath.trajectory.rcm import fixed_point_rotation

    arm = welder003()
    with pytest.raises(InvalidInputError, match="waypoints of the circle"):
        fixed_point_rotation(arm, (900, 0, 0), n_points=MAX_WAYPOINTS)
    with pytest.raises(InvalidInputError, match="duration"):
        fixed_point_rotation(arm, (900, 0, 0), duration_s=float("inf"))
    small = fixed_point_rotation(arm, (900, 0, 0), circle_axis=(1.0, 1.0, 0.0), n_points=8)
    huge = fixed_point_rotation(arm, (900, 0, 0), circle_axis=(1e308, 1e308, 0.0), n_points=8)
    assert np.allclose(huge.wrist_points, small.wrist_points, atol=1e-9)
    assert huge.max_tip_deviation == pytest.approx(small.max_tip_deviation, rel=1e-9)


@pytest.mark.parametrize(
    ("model", "why"),
    [
        ("scara", "its 4 joints cannot set the tool's whole pose"),
        ("iiwa14", "its 7 joints reach each pose in a continuous family of solutions"),
    ],
)
def test_an_arm_without_all_solutions_ik_is_told_why(model, why):
    """Turning the tool about a point and the dexterous workspace need every IK solution of a
    pose; a SCARA or a 7-axis arm answered only 'model has no all-solutions IK'. The refusal
    now says what needs it, which arms have it and why this one has none (its joints counted
    here)."""
    from armpath.model.catalog import resolve_model
    from armpath.model.dh import dh_arm
    from armpath.trajectory.rcm import fixed_point_rotation
    from armpath.workspace.dexterous import dexterity, dexterous_workspace
    from arms import scara_rows

    arm = dh_arm(scara_rows(), name="scara") if model == "scara" else resolve_model(model)
    assert arm.n_joints == int(why.split()[1])
    calls = [
        ("turning the tool about a fixed point", lambda: fixed_point_rotation(arm, [400, 0, 300])),
        ("dexterity", lambda: dexterity(arm, np.zeros(3), np.eye(3)[None])),
        (
            "the dexterous workspace",
            lambda: dexterous_workspace(arm, 10, np.eye(3)[None], -np.ones(3), np.ones(3)),
        ),
    ]
    for what, call in calls:
        with pytest.raises(InvalidInputError) as err:
            call()
        assert str(err.value).startswith(f"{what} needs every inverse-kinematics solution")
        assert str(err.value).endswith(f"model {arm.name!r} has none: {why}")


def test_cli_trajectory_drops_an_untimed_waypoint_repeated_with_a_warning(tmp_path):
    """A waypoint written twice in a row, without times: its repeat got a millisecond in the
    timing, so the free solve crossed it in one (the speed peaking at 61.6 deg/s against 43.75
    without it) and --bounded stopped without a solution. It is dropped with one warning line
    naming it, and both solves run: the replayed commands pass every waypoint given, keep the
    speed limit when bounded, and each solve is the one without the repeat."""
    rows = [[0, -90, 0, 0, -90, 0], [30, -60, 20, 10, -80, 5], [60, -45, 30, 0, -70, 0]]
    once, twice = tmp_path / "once.csv", tmp_path / "twice.csv"
    once.write_text("\n".join(",".join(map(str, r)) for r in rows) + "\n")
    twice.write_text("\n".join(",".join(map(str, r)) for r in [rows[0], *rows[1:2] * 2, rows[2]]))
    for flag in ([], ["--bounded"]):
        outs = []
        for wp in (twice, once):
            out = tmp_path / f"{wp.stem}{len(flag)}"
            proc = _run_trajectory("--waypoints", wp, "--out", out, *flag)
            assert proc.returncode == 0, proc.stderr
            outs.append(out)
            warned = [ln for ln in proc.stderr.splitlines() if ln.startswith("warning:")]
            if wp is twice:
                assert len(warned) == 1 and "(waypoints 3, counted from 1)" in warned[0]
            else:
                assert not warned
        a, b = (np.loadtxt(o / "trajectory.csv", delimiter=",", skiprows=1) for o in outs)
        np.testing.assert_allclose(a, b, atol=1e-9)
        cmds = np.loadtxt(outs[0] / "commands.csv", delimiter=",", skiprows=1, dtype=int)[:, 1:]
        states = (
            np.vstack([np.zeros((1, 6), int), np.cumsum(cmds, axis=0)]) + np.array(rows[0]) * 10
        )
        # the commands within half a tick of the samples (one a period), which pass every
        # waypoint given within one period's move (under 0.5 deg at these speeds)
        assert np.abs(states / 10.0 - a[: states.shape[0], 1:]).max() <= 0.05 + 1e-6
        for r in rows:
            assert np.abs(a[:, 1:] - np.array(r)).max(axis=1).min() <= 0.5
        if flag:  # the speed limit kept (30 deg/s, the default), sampled
            speed = np.abs(np.diff(a[:, 1:], axis=0) / np.diff(a[:, :1], axis=0)).max()
            assert speed <= 30.0 * (1 + 1e-3)


def test_cli_trajectory_whose_retiming_fails_prints_no_table_and_writes_nothing(
    tmp_path, monkeypatch
):
    """--retime computed the retimings after printing the trajectory's table, so one that
    failed left that table on stdout above its error line, the run half done. Now it fails
    first: one error line, nothing on stdout, no folder written; without --retime the same
    waypoints succeed."""
    import armpath.trajectory
    from cli_in_process import run_in_process

    wp = tmp_path / "wp.csv"
    wp.write_text("0,-90,0,0,-90,0\n30,-60,20,10,-80,5\n60,-45,30,0,-70,0\n")

    def fails(*args, **kwargs):
        raise InvalidInputError("the retiming failed here")

    monkeypatch.setattr(armpath.trajectory, "compare_retimings", fails)
    proc = run_in_process(
        ["trajectory", "--waypoints", str(wp), "--retime", "--out", "tr"], tmp_path
    )
    assert proc.returncode == 1 and proc.stdout == "", proc.stdout
    assert proc.stderr.strip() == "error: the retiming failed here"
    assert not (tmp_path / "tr").exists()
    ok = run_in_process(["trajectory", "--waypoints", str(wp), "--out", "tr"], tmp_path)
    assert ok.returncode == 0 and (tmp_path / "tr" / "commands.csv").is_file()
