"""Rigid spacecraft body (thesis 2.2.3, 2.3) and its external disturbance (2.2.4)."""
from __future__ import annotations

import numpy as np

# Thesis Table 2.3: principal inertia diag(17, 15, 22) kg m^2.
INERTIA = np.array([17.0, 15.0, 22.0])
# Eq. 2.34: sum of the four worst-case environmental torques [N m].
DISTURBANCE_SIGMA = 5.68e-5


def body_acceleration(body_rate, torque, inertia=INERTIA):
    """Euler's equations for principal axes, eq. 2.27.

    I_xx dw_x/dt = tau_x - w_y w_z (I_zz - I_yy), and cyclic; arrays of shape (..., 3).
    """
    w = np.asarray(body_rate, float)
    inertia = np.asarray(inertia, float)
    h = inertia * w
    # w x (I w): the gyroscopic terms of eq. 2.27 (written out: np.cross costs 10x on 3-vectors)
    coupling = np.stack((w[..., 1] * h[..., 2] - w[..., 2] * h[..., 1],
                         w[..., 2] * h[..., 0] - w[..., 0] * h[..., 2],
                         w[..., 0] * h[..., 1] - w[..., 1] * h[..., 0]), axis=-1)
    return (np.asarray(torque, float) - coupling) / inertia


def disturbance_torque(rng: np.random.Generator, shape=(3,), sigma=DISTURBANCE_SIGMA):
    """Zero-mean Gaussian disturbance, std 5.68e-5 N m per axis (eq. 2.34).

    [choice] one draw per control period, held over the period.
    """
    return rng.normal(0.0, sigma, size=shape)
