"""Closed-form solution family of the seed arm, verified by forward kinematics."""

import numpy as np
import pytest

from armpath.errors import InvalidInputError
from armpath.ik import FIXED_PAIRS, family_from_wrist, solve_with_fixed_pair
from armpath.kinematics import landmark_positions, tool_position
from armpath.model import SeedArmGeometry, seed_arm

ARM = seed_arm()
G = SeedArmGeometry()


def _with_j6(q5):
    return np.concatenate([q5, np.zeros((*q5.shape[:-1], 1))], axis=-1)


def _angle_gap(a, b):
    return np.abs((a - b + np.pi) % (2 * np.pi) - np.pi).max(axis=-1)


@pytest.fixture(scope="module")
def random_poses():
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    return q, tool_position(ARM, q), landmark_positions(ARM, q)[:, 3]


def test_family_from_wrist_solves_and_contains_the_generator(random_poses):
    q, E, D = random_poses
    sol = family_from_wrist(G, E, D)
    assert sol.shape == (2000, 8, 5)
    ok = np.all(np.isfinite(sol), axis=-1)
    err = np.linalg.norm(tool_position(ARM, _with_j6(np.nan_to_num(sol))) - E[:, None], axis=-1)
    assert np.all(err[ok] < 1e-8)
    # every branch also puts the wrist at D
    wrist = landmark_positions(ARM, _with_j6(np.nan_to_num(sol)))[..., 3, :]
    assert np.all(np.linalg.norm(wrist - D[:, None], axis=-1)[ok] < 1e-8)
    assert np.all(np.nanmin(np.where(ok, _angle_gap(sol, q[:, None, :5]), np.nan), axis=1) < 1e-7)


@pytest.mark.parametrize("pair", FIXED_PAIRS)
def test_fixed_pair_solutions(random_poses, pair):
    q, E, _ = random_poses
    sol = solve_with_fixed_pair(G, E, pair, q[:, pair[0]], q[:, pair[1]])
    assert sol.shape == (2000, 4, 5)
    ok = np.all(np.isfinite(sol), axis=-1)
    err = np.linalg.norm(tool_position(ARM, _with_j6(np.nan_to_num(sol))) - E[:, None], axis=-1)
    assert np.all(err[ok] < 1e-8)
    np.testing.assert_allclose(
        sol[..., pair[0]][ok], np.broadcast_to(q[:, pair[0], None], ok.shape)[ok]
    )
    found = np.nanmin(np.where(ok, _angle_gap(sol, q[:, None, :5]), np.nan), axis=1)
    assert np.all(found < 1e-7)


def test_wrist_off_the_sphere_gives_no_solution():
    sol = family_from_wrist(G, [20, -200, 120], [20, -200, 120 + 70])
    assert np.all(np.isnan(sol))


def test_bad_pair_is_refused():
    with pytest.raises(InvalidInputError, match="pair"):
        solve_with_fixed_pair(G, [0, 300, 300], (1, 2), 0.0, 0.0)
