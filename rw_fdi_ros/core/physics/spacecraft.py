"""Rigid spacecraft body (thesis 2.2.3, 2.3) and its external disturbance (2.2.4)."""
from __future__ import annotations

import numpy as np

BODY_AXES = ("x", "y", "z")   # the body frame's axes: attitude, set-points, the per-axis controllers
# Thesis Table 2.3: principal inertia diag(17, 15, 22) kg m^2.
INERTIA = np.array([17.0, 15.0, 22.0])
# Eq. 2.34: sum of the four worst-case environmental torques [N m].
DISTURBANCE_SIGMA = 5.68e-5


def nearest_setpoint(setpoint, attitude) -> np.ndarray:
    """The set-point's equivalent angle (r + 2 pi k per axis) nearest the attitude: a rotation about an axis is
    periodic, so the attitude error r - y is taken the short way, within [-pi, pi] (two +180 deg set-point
    changes ask for the attitude of the start, not a full turn). Unchanged, bit for bit, where |r - y| <= pi.

    Parameters
    ----------
    setpoint : array_like, shape (..., 3)
        r, per body axis [rad].
    attitude : array_like, shape (..., 3)
        y, per body axis [rad].

    Returns
    -------
    ndarray, shape (..., 3)
        The set-point to steer to [rad].
    """
    r, y = np.asarray(setpoint, float), np.asarray(attitude, float)
    e = r - y
    return np.where(np.abs(e) > np.pi, y + (e + np.pi) % (2.0 * np.pi) - np.pi, r)


def cross(a, b) -> np.ndarray:
    """a x b over the last axis of (..., 3) arrays, written out: np.cross costs 10x on 3-vectors.

    Parameters
    ----------
    a, b : ndarray, shape (..., 3)
        The two vectors (any unit); their leading axes broadcast.

    Returns
    -------
    ndarray, shape (..., 3)
        a x b, in the product of their units.
    """
    return np.stack((a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=-1)


def inertia_times(inertia, vector) -> np.ndarray:
    """I v over the last axis of (..., 3) vectors for an inertia given as its diagonal (3,) (principal body
    axes, the thesis') or as the full matrix (3, 3).

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        I [kg m^2], body axes.
    vector : array_like, shape (..., 3)
        v, body axes (a rate gives the momentum I w [N m s]).

    Returns
    -------
    ndarray, shape (..., 3)
        I v.
    """
    inertia = np.asarray(inertia, float)
    return inertia * vector if inertia.ndim == 1 else np.asarray(vector, float) @ inertia.T


def body_acceleration(body_rate, torque, inertia=INERTIA, wheel_momentum=None, wheel_inertia=0.0):
    """Euler's equations of a rigid body carrying reaction wheels; arrays of shape (..., 3).

    With wheel i spinning about g_i at Omega_i relative to the body (what a tachometer
    reads), the stored momentum h_w = sum_i J g_i Omega_i and the rotational equations of
    body and wheels are (Hughes, Spacecraft Attitude Dynamics, ch. 7; Basilisk's
    BalancedWheels model)

        (I - J_s) dw/dt = tau - w x (I w + h_w)       J_s = sum_i J g_i g_i^T, the spinning part
        J (dOmega_i/dt + g_i^T dw/dt) = tau_n,i        (the wheel side, see Plant)

    where I is the inertia with the wheels locked (its diagonal (3,) on principal body axes, or the
    full matrix (3, 3) of a vehicle file) and tau the external plus the reaction torques.
    ``wheel_inertia`` is J_s: its diagonal (..., 3) when the wheels spin
    about body axes, else the (..., 3, 3) matrix. ``wheel_momentum=None`` drops h_w and
    J_s: eq. 2.27 as the thesis writes it, I dw/dt = tau - w x (I w).

    Parameters
    ----------
    body_rate : array_like, shape (..., 3)
        Body rate w [rad/s], body frame, e.g. (B, 3).
    torque : array_like, shape (..., 3)
        External plus reaction torque tau [N m], body frame.
    inertia : array_like, shape (3,) or (3, 3)
        Inertia I with the wheels locked [kg m^2], one for the batch: its diagonal on principal axes, else
        the matrix.
    wheel_momentum : array_like, shape (..., 3), optional
        The wheels' stored momentum h_w [N m s], body frame; None for eq. 2.27 as written.
    wheel_inertia : float or array_like, shape (..., 3) or (..., 3, 3)
        J_s [kg m^2]: its diagonal or the full matrix; used only with ``wheel_momentum``.

    Returns
    -------
    ndarray, shape (..., 3)
        dw/dt [rad/s^2], body frame.
    """
    w = np.asarray(body_rate, float)
    inertia = np.asarray(inertia, float)
    full = inertia.shape == (3, 3)   # a full inertia: products of inertia couple the axes
    h = inertia_times(inertia, w)
    spun = np.asarray(wheel_inertia, float) if wheel_momentum is not None else np.zeros(())
    matrix = spun.ndim == w.ndim + 1   # (..., 3, 3) beside (..., 3) rates
    if wheel_momentum is not None:
        h = h + wheel_momentum
        if not matrix and not full:
            inertia = inertia - spun
    rhs = np.asarray(torque, float) - cross(w, h)
    if full or matrix:   # a wheel off the body axes, or products of inertia, couple the axes
        spun = spun if matrix else spun[..., None] * np.eye(3)
        locked = inertia if full else inertia[..., None] * np.eye(3)
        return np.linalg.solve(locked - spun, rhs[..., None])[..., 0]
    return rhs / inertia


def disturbance_torque(rng: np.random.Generator, shape=(3,), sigma=DISTURBANCE_SIGMA):
    """Zero-mean Gaussian disturbance, std 5.68e-5 N m per axis (eq. 2.34).

    [choice] one draw per control period, held over the period.

    Parameters
    ----------
    rng : numpy.random.Generator
        The run's disturbance stream.
    shape : tuple of int, optional
        Shape of the draw, (3,) for one body.
    sigma : float, optional
        Standard deviation per axis [N m].

    Returns
    -------
    ndarray
        Disturbance torque [N m] of ``shape``, body frame.
    """
    return rng.normal(0.0, sigma, size=shape)
