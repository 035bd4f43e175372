import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.sensing.kalman import (
    axis_predict,
    axis_update,
    initial_covariance,
    measurement_matrix,
    process_noise,
    transition_matrix,
)
from kalman_reference import predict, update

SEEDS = st.integers(0, 2**32 - 1)
FIXED = settings(derandomize=True, deadline=None, max_examples=40)


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


def _isotropic(p, c, w):
    """The 6 x 6 covariance with the 2 x 2 (position, velocity) covariance on each axis."""
    return np.kron(np.array([[p, c], [c, w]]), np.eye(3))


@FIXED
@given(seed=SEEDS, dt=st.floats(1e-3, 0.4), q2=st.floats(0.0, 4.0))
def test_axis_equations_are_filterpys_on_an_isotropic_covariance(seed, dt, q2):
    # The tracker's per-axis prediction and update equal filterpy's 6-D filter.
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(2, 2))
    (p, c), (_, w) = a @ a.T + 0.01 * np.eye(2)
    r = rng.uniform(1e-8, 1e-2)
    x, z = rng.normal(size=6), rng.normal(size=3)
    x_ref, P_ref = predict(x, _isotropic(p, c, w), transition_matrix(dt), process_noise(dt, q2))
    p, c, w = axis_predict(p, c, w, dt, q2)
    np.testing.assert_allclose(_isotropic(p, c, w), P_ref, rtol=1e-12, atol=1e-15)
    x_ref, P_ref = update(x_ref, P_ref, z, r * np.eye(3))
    k_p, k_v, p, c, w = axis_update(p, c, w, r)
    np.testing.assert_allclose(_isotropic(p, c, w), P_ref, rtol=1e-9, atol=1e-15)
    x_pred = transition_matrix(dt) @ x
    innovation = z - x_pred[:3]
    np.testing.assert_allclose(np.r_[x_pred[:3] + k_p * innovation, x_pred[3:] + k_v * innovation],
                               x_ref, rtol=1e-9, atol=1e-12)


def test_update_reduces_position_variance():
    P = initial_covariance(0.1, 1.0)
    _, P_new = update(np.zeros(6), P, np.ones(3), 0.01 * np.eye(3))
    # Scalar Kalman gain per axis: 0.01 / (0.01 + 0.01) halves the variance.
    np.testing.assert_allclose(np.diag(P_new)[:3], [0.005] * 3)
    np.testing.assert_allclose(np.diag(P_new)[3:], [1.0] * 3)


def test_constant_velocity_track_converges_to_true_velocity():
    dt = 0.05
    F, Q, R = transition_matrix(dt), process_noise(dt, 1e-2), (1e-3) ** 2 * np.eye(3)
    p0, v = np.array([1.0, 2.0, 0.5]), np.array([0.8, -0.3, 0.1])
    x, P = np.r_[p0, 0, 0, 0], initial_covariance(1e-3, 2.0)  # from rest
    errors = []
    for i in range(1, 201):
        x, P = update(*predict(x, P, F, Q), p0 + v * i * dt, R)
        errors.append(np.abs(x[3:] - v).max())
    np.testing.assert_allclose(x[3:], v, atol=1e-8)
    np.testing.assert_allclose(x[:3], p0 + v * 200 * dt, atol=1e-8)
    assert errors[0] > 0.1  # it really started from a wrong velocity
    # The velocity variance shrinks from its initial 4 (m/s)^2 to a steady state.
    assert np.all(np.diag(P)[3:] < 0.2)
