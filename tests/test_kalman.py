import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.kalman import (
    batch_predict,
    batch_update,
    initial_covariance,
    measurement_matrix,
    predict,
    process_noise,
    transition_matrix,
    update,
)

SEEDS = st.integers(0, 2**32 - 1)
FIXED = settings(derandomize=True, deadline=None, max_examples=40)


def _spd(rng, *shape, n=6):
    """Random symmetric positive-definite matrices of shape shape + (n, n)."""
    A = rng.normal(size=shape + (n, n))
    return A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(n)


def test_transition_matrix_eq2():
    expected = np.array(
        [
            [1, 0, 0, 0.05, 0, 0],
            [0, 1, 0, 0, 0.05, 0],
            [0, 0, 1, 0, 0, 0.05],
            [0, 0, 0, 1, 0, 0],
            [0, 0, 0, 0, 1, 0],
            [0, 0, 0, 0, 0, 1],
        ]
    )
    np.testing.assert_array_equal(transition_matrix(0.05), expected)
    # One step moves the position by dt times the velocity and keeps the velocity.
    x = transition_matrix(0.5) @ np.array([1.0, 2, 3, 0.2, -0.4, 2])
    np.testing.assert_allclose(x, [1.1, 1.8, 4.0, 0.2, -0.4, 2.0])


def test_measurement_matrix_eq3():
    expected = np.array(
        [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]], dtype=float
    )
    np.testing.assert_array_equal(measurement_matrix(), expected)


def test_process_noise_eq4():
    Q = process_noise(0.1, 0.3)
    np.testing.assert_allclose(Q, np.diag([0.01, 0.01, 0.01, 0.3, 0.3, 0.3]), rtol=1e-15)
    assert np.count_nonzero(Q - np.diag(np.diag(Q))) == 0


def test_initial_covariance_shape_and_values():
    P = initial_covariance(0.002, 1.5)
    assert P.shape == (6, 6)
    np.testing.assert_allclose(P, np.diag([4e-6] * 3 + [2.25] * 3))
    Pb = initial_covariance(0.002, 1.5, batch=(2, 4))
    assert Pb.shape == (2, 4, 6, 6)
    np.testing.assert_array_equal(Pb, np.broadcast_to(P, (2, 4, 6, 6)))
    # Every batch entry is its own writable copy.
    Pb[0, 0, 0, 0] = 99.0
    assert Pb[1, 3, 0, 0] == pytest.approx(4e-6)


@FIXED
@given(seed=SEEDS, dt=st.floats(1e-3, 0.2), q2=st.floats(0.0, 1.0), per_row=st.booleans())
def test_batch_predict_matches_filterpy(seed, dt, q2, per_row):
    rng = np.random.default_rng(seed)
    B = 5
    x, P = rng.normal(size=(B, 6)), _spd(rng, B)
    if per_row:  # a different sampling time per row
        dts = rng.uniform(1e-3, 0.2, B)
        F = np.stack([transition_matrix(d) for d in dts])
        Q = np.stack([process_noise(d, q2) for d in dts])
    else:
        F = np.broadcast_to(transition_matrix(dt), (B, 6, 6))
        Q = np.broadcast_to(process_noise(dt, q2), (B, 6, 6))
    x_b, P_b = batch_predict(x, P, F if per_row else F[0], Q if per_row else Q[0])
    for i in range(B):
        x_i, P_i = predict(x[i], P[i], F[i], Q[i])
        np.testing.assert_allclose(x_b[i], x_i, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(P_b[i], P_i, rtol=1e-10, atol=1e-12)


@FIXED
@given(seed=SEEDS, per_row_R=st.booleans())
def test_batch_update_matches_filterpy(seed, per_row_R):
    rng = np.random.default_rng(seed)
    B = 6
    x, P, z = rng.normal(size=(B, 6)), _spd(rng, B), rng.normal(size=(B, 3))
    R = _spd(rng, B, n=3) * 1e-2 if per_row_R else _spd(rng, n=3) * 1e-2
    x_b, P_b = batch_update(x, P, z, R)
    for i in range(B):
        x_i, P_i = update(x[i], P[i], z[i], R[i] if per_row_R else R)
        np.testing.assert_allclose(x_b[i], x_i, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(P_b[i], P_i, rtol=1e-8, atol=1e-10)
    # Independent form of the posterior residual: z - H x+ = R S^-1 (z - H x-).
    S = P[:, :3, :3] + R
    expected = R @ np.linalg.solve(S, (z - x[:, :3])[..., None])
    np.testing.assert_allclose(z - x_b[:, :3], expected[..., 0], rtol=1e-8, atol=1e-10)
    assert not np.allclose(x_b, x)


@FIXED
@given(seed=SEEDS, missing=st.lists(st.booleans(), min_size=6, max_size=6))
def test_batch_update_masked_and_nan_rows_unchanged(seed, missing):
    rng = np.random.default_rng(seed)
    B = 6
    x, P, z = rng.normal(size=(B, 6)), _spd(rng, B), rng.normal(size=(B, 3))
    R = 1e-3 * np.eye(3)
    # Rows 0-2: a NaN in one axis if `missing`; rows 3-5: masked out if `missing`.
    for i in range(3):
        if missing[i]:
            z[i, i] = np.nan
    valid_mask = np.array([True] * 3 + [not m for m in missing[3:]])
    x_b, P_b = batch_update(x, P, z, R, valid_mask=valid_mask)
    for i in range(B):
        if missing[i]:
            np.testing.assert_array_equal(x_b[i], x[i])
            np.testing.assert_array_equal(P_b[i], P[i])
            x_i, P_i = update(x[i], P[i], None if i >= 3 else z[i], R)  # the reference agrees
            np.testing.assert_array_equal(x_i, x[i])
            np.testing.assert_array_equal(P_i, P[i])
        else:
            x_i, P_i = update(x[i], P[i], z[i], R)
            np.testing.assert_allclose(x_b[i], x_i, rtol=1e-9, atol=1e-10)
            np.testing.assert_allclose(P_b[i], P_i, rtol=1e-8, atol=1e-10)
            assert not np.allclose(x_b[i], x[i])
    assert np.all(np.isfinite(x_b)) and np.all(np.isfinite(P_b))


def test_batch_update_does_not_modify_inputs():
    rng = np.random.default_rng(0)
    x, P, z = rng.normal(size=(3, 6)), _spd(rng, 3), rng.normal(size=(3, 3))
    x0, P0 = x.copy(), P.copy()
    batch_update(x, P, z, np.eye(3), valid_mask=[True, False, True])
    batch_predict(x, P, transition_matrix(0.1), process_noise(0.1, 0.1))
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(P, P0)


def test_update_reduces_position_variance():
    P = initial_covariance(0.1, 1.0)
    _, P_new = update(np.zeros(6), P, np.ones(3), 0.01 * np.eye(3))
    # Scalar Kalman gain per axis: 0.01 / (0.01 + 0.01) halves the variance.
    np.testing.assert_allclose(np.diag(P_new)[:3], [0.005] * 3)
    np.testing.assert_allclose(np.diag(P_new)[3:], [1.0] * 3)


def test_constant_velocity_track_converges_to_true_velocity():
    dt = 0.05
    F, Q, R = transition_matrix(dt), process_noise(dt, 1e-2), (1e-3) ** 2 * np.eye(3)
    p0 = np.array([[1.0, 2.0, 0.5], [-0.3, 0.0, 1.2]])
    v = np.array([[0.8, -0.3, 0.1], [0.0, 1.6, -0.2]])
    # Single-body reference (body 0) and the batch over both bodies, from rest.
    x1, P1 = np.r_[p0[0], 0, 0, 0], initial_covariance(1e-3, 2.0)
    xb = np.hstack([p0, np.zeros((2, 3))])
    Pb = initial_covariance(1e-3, 2.0, batch=(2,))
    errors = []
    for i in range(1, 201):
        z = p0 + v * i * dt
        x1, P1 = update(*predict(x1, P1, F, Q), z[0], R)
        xb, Pb = batch_update(*batch_predict(xb, Pb, F, Q), z, R)
        errors.append(np.abs(xb[:, 3:] - v).max())
    np.testing.assert_allclose(xb[:, 3:], v, atol=1e-8)
    np.testing.assert_allclose(xb[:, :3], p0 + v * 200 * dt, atol=1e-8)
    np.testing.assert_allclose(x1, xb[0], atol=1e-9)
    assert errors[0] > 0.1  # it really started from a wrong velocity
    # The velocity variance shrinks from its initial 4 (m/s)^2 to a steady state.
    assert np.all(np.diag(Pb[0])[3:] < 0.2)
