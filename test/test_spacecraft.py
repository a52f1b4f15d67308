"""Rigid body (eq. 2.27) against closed-form answers."""
import numpy as np
import pytest

from rw_fdi_ros.core.spacecraft import INERTIA, body_acceleration, disturbance_torque


def test_principal_axis_spin_is_steady():
    for axis in range(3):
        w = np.zeros(3)
        w[axis] = 0.3
        np.testing.assert_allclose(body_acceleration(w, np.zeros(3)), 0.0, atol=1e-15)


def test_euler_coupling_terms_eq_2_27():
    w = np.array([0.1, -0.2, 0.3])
    acc = body_acceleration(w, np.zeros(3))
    ixx, iyy, izz = INERTIA
    expected = [-w[1] * w[2] * (izz - iyy) / ixx, -w[2] * w[0] * (ixx - izz) / iyy, -w[0] * w[1] * (iyy - ixx) / izz]
    np.testing.assert_allclose(acc, expected, rtol=1e-12)


def test_torque_free_motion_conserves_momentum_and_energy():
    w = np.array([0.01, 0.02, -0.015])
    h0, e0 = np.linalg.norm(INERTIA * w), 0.5 * np.sum(INERTIA * w * w)
    dt = 0.05
    for _ in range(4000):  # RK4
        k1 = body_acceleration(w, 0)
        k2 = body_acceleration(w + dt / 2 * k1, 0)
        k3 = body_acceleration(w + dt / 2 * k2, 0)
        k4 = body_acceleration(w + dt * k3, 0)
        w = w + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert np.linalg.norm(INERTIA * w) == pytest.approx(h0, rel=1e-9)
    assert 0.5 * np.sum(INERTIA * w * w) == pytest.approx(e0, rel=1e-9)


def test_disturbance_statistics_eq_2_34():
    d = disturbance_torque(np.random.default_rng(0), shape=(200000, 3))
    assert abs(d.mean()) < 1e-6
    assert d.std() == pytest.approx(5.68e-5, rel=0.01)
