"""Forward kinematics and Jacobians of the seed arm against SPEC and an independent model."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import independent
from armpath.errors import InvalidInputError
from armpath.kinematics import (
    displacement_bounds,
    forward_frames,
    landmark_positions,
    position_jacobian,
    tool_pose,
    tool_position,
)
from armpath.model import SeedArmGeometry, seed_arm, seed_geometry_of

# SPEC section 1 test vectors: theta (deg) -> C, D, E (mm)
SPEC_VECTORS = [
    ((0, -90, 0, 0, -90, 0), (0, 255, 140), (0, 510, 140), (0, 510, 75)),
    (
        (30, -45, 60, 0, -30, 0),
        (-90.1561, 156.1550, 320.3122),
        (-57.1567, 98.9983, 566.6233),
        (-65.5683, 113.5676, 629.4085),
    ),
    (
        (-120, 20, -100, 45, 80, 10),
        (-75.5305, 43.6076, 379.6216),
        (141.9510, -81.9554, 423.9019),
        (122.1386, -122.7828, 470.4379),
    ),
    (
        (400, -125, 138, -270, 133.5, 0),
        (-134.2679, 160.0143, -6.2620),
        (-97.3960, 116.0720, 242.2024),
        (-67.7472, 154.0893, 198.6061),
    ),
]

ARM = seed_arm()


@pytest.mark.parametrize(("theta", "C", "D", "E"), SPEC_VECTORS)
def test_spec_vectors(theta, C, D, E):
    pts = landmark_positions(ARM, np.radians(theta))
    np.testing.assert_allclose(pts[0], [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(pts[1], [0, 0, 140], atol=1e-9)
    np.testing.assert_allclose(pts[2], C, atol=1e-4)
    np.testing.assert_allclose(pts[3], D, atol=1e-4)
    np.testing.assert_allclose(pts[4], E, atol=1e-4)


def test_all_spec_vectors_in_one_batch():
    thetas = np.radians([v[0] for v in SPEC_VECTORS])
    pts = landmark_positions(ARM, thetas)
    assert pts.shape == (4, 5, 3)
    np.testing.assert_allclose(pts[:, 4], [v[3] for v in SPEC_VECTORS], atol=1e-4)


angles = arrays(np.float64, (6,), elements=st.floats(-720, 720, allow_nan=False))


@settings(max_examples=200, deadline=None)
@given(angles)
def test_fk_matches_independent_model(theta_deg):
    np.testing.assert_allclose(
        landmark_positions(ARM, np.radians(theta_deg)), independent.points(theta_deg), atol=1e-9
    )


def test_batched_shapes_and_tool_frame():
    rng = np.random.default_rng(1)
    q = rng.uniform(-np.pi, np.pi, (2, 3, 6))
    frames = forward_frames(ARM, q)
    assert frames.shape == (2, 3, 8, 4, 4)
    np.testing.assert_allclose(
        tool_position(ARM, q), landmark_positions(ARM, q)[..., 4, :], atol=1e-9
    )
    T = tool_pose(ARM, q)
    R = T[..., :3, :3]
    np.testing.assert_allclose(
        R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12
    )
    # the tool axis is DE's direction
    pts = landmark_positions(ARM, q)
    de = (pts[..., 4, :] - pts[..., 3, :]) / 65.0
    np.testing.assert_allclose(R[..., :, 2], de, atol=1e-12)


def test_joint6_does_not_move_the_fingertip():
    rng = np.random.default_rng(2)
    q = rng.uniform(-np.pi, np.pi, (50, 6))
    q2 = q.copy()
    q2[:, 5] += rng.uniform(-3, 3, 50)
    np.testing.assert_allclose(tool_position(ARM, q), tool_position(ARM, q2), atol=1e-9)


@settings(max_examples=100, deadline=None)
@given(arrays(np.float64, (6,), elements=st.floats(-np.pi, np.pi, allow_nan=False)))
def test_position_jacobian_matches_finite_differences(q):
    J = position_jacobian(ARM, q)
    h = 1e-6
    fd = np.stack(
        [
            (tool_position(ARM, q + h * e) - tool_position(ARM, q - h * e)) / (2 * h)
            for e in np.eye(6)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(J, fd, atol=1e-5)


def test_displacement_bound_holds():
    rng = np.random.default_rng(3)
    R = displacement_bounds(ARM)
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    dq = rng.uniform(-0.05, 0.05, (2000, 6))
    moved = np.linalg.norm(landmark_positions(ARM, q + dq) - landmark_positions(ARM, q), axis=-1)
    assert np.all(moved.max(axis=-1) <= np.abs(dq) @ R + 1e-9)


def test_bad_joint_arrays_are_rejected():
    with pytest.raises(InvalidInputError, match="6 joints"):
        tool_position(ARM, [0.0, 1.0, 2.0])
    with pytest.raises(InvalidInputError, match="finite"):
        tool_position(ARM, [0, np.nan, 0, 0, 0, 0])


def test_seed_geometry_round_trip_and_variants():
    g = SeedArmGeometry(bc_mm=300.0, range_deg=(np.inf, 100.0, 120.0, np.inf, 90.0, np.inf))
    arm = seed_arm(g)
    assert seed_geometry_of(arm) == g
    pts = landmark_positions(arm, np.radians([0, -90, 0, 0, -90, 0]))
    np.testing.assert_allclose(pts[4], [0, 555, 75], atol=1e-9)
    with pytest.raises(InvalidInputError):
        SeedArmGeometry(ab_mm=-1)


def test_a_big_batch_of_frames_split_between_threads_equals_the_numpy_chain(monkeypatch):
    """Where threads pay, a batch of at least FRAMES_THREAD_BATCH poses is split into one
    slice per core; the frames and tool poses are the numpy chain's to rounding, in order."""
    import os

    from armpath import jit, kinematics
    from armpath.kinematics import _forward_frames_numpy, tool_pose
    from armpath.model.catalog import ur5

    arm = ur5()
    q = np.random.default_rng(7).uniform(-3.0, 3.0, (kinematics.FRAMES_THREAD_BATCH + 5, 6))
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    monkeypatch.setattr(jit, "threads_pay_off", lambda n, threshold: n >= threshold)
    slices = []
    real = jit.in_slices

    def spy(run, n, threshold):
        out = real(run, n, threshold)
        slices.append(len(out))
        return out

    monkeypatch.setattr(kinematics, "in_slices", spy)
    frames, T = forward_frames(arm, q), tool_pose(arm, q)
    assert slices == [3, 3]
    np.testing.assert_allclose(frames, _forward_frames_numpy(arm, q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(T, frames[:, -1], rtol=0, atol=1e-12)
    assert tool_pose(arm, q[:100]).shape == (100, 4, 4) and slices == [3, 3, 1]


@pytest.mark.parametrize("name", ["seed", "ur5", "iiwa14"])
def test_compiled_frames_and_jacobian_match_numpy_and_finite_differences(name):
    """Batches of more than a few poses take the compiled frames: they equal the numpy chain
    to rounding, the tool pose is their last frame, and the position Jacobian (compiled once
    numba is loaded) equals central differences of the tool position."""
    from armpath import jit
    from armpath.kinematics import _forward_frames_numpy, position_jacobian, tool_pose
    from armpath.model.catalog import BUILTIN_MODELS

    arm = BUILTIN_MODELS[name]()
    q = np.random.default_rng(4).uniform(-3.0, 3.0, (50, arm.n_joints))
    frames = forward_frames(arm, q)
    np.testing.assert_allclose(frames, _forward_frames_numpy(arm, q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(tool_pose(arm, q), frames[:, -1], rtol=0, atol=1e-9)
    jit.load_numba()
    J = position_jacobian(arm, q)
    h = 1e-6
    for i in range(arm.n_joints):
        dq = np.zeros(arm.n_joints)
        dq[i] = h
        fd = (tool_pose(arm, q + dq)[:, :3, 3] - tool_pose(arm, q - dq)[:, :3, 3]) / (2 * h)
        np.testing.assert_allclose(J[:, :, i], fd, rtol=0, atol=1e-5)


def test_one_pose_by_the_compiled_loop_equals_numpy_to_rounding():
    """kinematics.pose_frames (the compiled loop for a single pose, the reach bound's solver)
    gives forward_frames' numpy frames of that pose to rounding, for several arms."""
    from armpath.kinematics import forward_frames, pose_frames
    from armpath.model.catalog import resolve_model

    rng = np.random.default_rng(11)
    for name in ("seed", "ur5", "puma560", "iiwa14"):
        arm = resolve_model(name, None)
        for q in rng.uniform(-3.0, 3.0, (20, arm.n_joints)):
            np.testing.assert_allclose(
                pose_frames(arm, q), forward_frames(arm, q[None])[0], rtol=0, atol=1e-9
            )


def test_tool_point_with_jacobian_equals_the_numpy_position_and_jacobian():
    """kinematics.tool_point_with_jacobian (the reach solvers' single-pose evaluation, by the
    compiled loop) gives tool_position and position_jacobian's numpy values to rounding, and
    its Jacobian matches central differences of the tool point, for several arms."""
    from armpath.kinematics import position_jacobian, tool_point_with_jacobian, tool_position
    from armpath.model.catalog import resolve_model

    rng = np.random.default_rng(12)
    h = 1e-6
    for name in ("seed", "ur5", "puma560", "iiwa14"):
        arm = resolve_model(name, None)
        for q in rng.uniform(-3.0, 3.0, (10, arm.n_joints)):
            tip, J = tool_point_with_jacobian(arm, q)
            assert tip.shape == (3,) and J.shape == (3, arm.n_joints)
            np.testing.assert_allclose(tip, tool_position(arm, q), rtol=0, atol=1e-9)
            np.testing.assert_allclose(J, position_jacobian(arm, q), rtol=0, atol=1e-9)
            for i in range(arm.n_joints):
                dq = np.zeros(arm.n_joints)
                dq[i] = h
                fd = (tool_position(arm, q + dq) - tool_position(arm, q - dq)) / (2 * h)
                np.testing.assert_allclose(J[:, i], fd, rtol=0, atol=1e-4)
