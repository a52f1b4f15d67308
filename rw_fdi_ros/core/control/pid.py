"""PID attitude controller, one per axis (thesis 2.2.5, eq. 2.36).

The thesis form F_c = K_d (s + z_c1)(s + z_c2) / s is a PID on the attitude
error with K_p = K_d (z_c1 + z_c2), K_i = K_d z_c1 z_c2. Three standard
refinements make it meet overshoot < 20 % under the +-5 V limit
(physics.md, Control): derivative on the measured body rate, set-point
weighting b on the proportional term, and an integrator that starts in
equilibrium (it already supplies the voltage that cancels wheel friction).
Anti-windup by conditional integration: the integrator stops while the
output is saturated and the error would push it further.

Gain design (see :func:`design_gains`): with the ideal wheel (reaction
torque = -G_d k_t V) and F_b = 1/(I s^2) the closed loop is
    I s^3 + k_d s^2 + k_p s + k_i,
placed at a real pole -alpha w_n and a pair w_n, zeta. The defaults
(w_n = 0.3 rad/s, zeta = 0.8, alpha = 1.0, b = 0.35) came from a grid
search of the closed-loop core simulation over the Table 2.3 envelope
(steps -5..5 deg, wheels 20..30 rad/s, inertias 15/17/22), keeping the one
with the smallest error at 30 s among those settling fastest (the
+-5 V limit, not the poles, sets the ~25 s settling of a 5 deg step);
``test/test_pointing.py`` proves them over 24 seeds. Eq. 2.42 needs
|K_d| z_c1 z_c2 > 0.147; these gains give 73 on the smallest axis (Y).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics.spacecraft import INERTIA, nearest_setpoint
from ..physics.wheel import WheelParams


@dataclass(frozen=True)
class PidGains:
    """Body-torque gains per axis (N m per rad, per rad s, per rad/s) and set-point weight."""

    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray
    setpoint_weight: float = 0.35


def design_gains(inertia=INERTIA, natural_frequency=0.3, damping=0.8, real_pole_ratio=1.0,
                 setpoint_weight=0.35) -> PidGains:
    """Pole placement of I s^3 + k_d s^2 + k_p s + k_i = I (s + a w)(s^2 + 2 z w s + w^2).

    Parameters
    ----------
    inertia : array_like, shape (3,)
        Principal inertia I per axis [kg m^2].
    natural_frequency : float, optional
        w [rad/s].
    damping : float, optional
        z, dimensionless.
    real_pole_ratio : float, optional
        a: the real pole at -a w.
    setpoint_weight : float, optional
        b on the proportional term, dimensionless.

    Returns
    -------
    PidGains
        kp [N m/rad], ki [N m/(rad s)], kd [N m s/rad], each of ``inertia``'s shape.
    """
    inertia = np.asarray(inertia, float)
    w, z, a = natural_frequency, damping, real_pole_ratio
    return PidGains(kp=inertia * (w * w + 2 * z * a * w * w), ki=inertia * a * w**3,
                    kd=inertia * (a * w + 2 * z * w), setpoint_weight=setpoint_weight)


def thesis_form(gains: PidGains, wheel: WheelParams = WheelParams()):
    """(K_d, z_c1, z_c2) of eq. 2.36 for the command voltage (K_d < 0: the wheel inverts torque).

    Parameters
    ----------
    gains : PidGains
        Body-torque gains, arrays (3,).
    wheel : WheelParams
        The wheel type (G_d k_t turns torque into volts), scalar fields.

    Returns
    -------
    K_d : ndarray, shape (3,)
        [V s/rad].
    z_c1, z_c2 : ndarray of complex, shape (3,)
        The zeros [1/s] (a complex pair for well-damped designs).
    """
    gk = wheel.driver_gain * wheel.torque_constant
    k_d = -np.asarray(gains.kd) / gk
    s, p = gains.kp / gains.kd, gains.ki / gains.kd  # z1 + z2, z1 z2
    disc = np.sqrt(s * s - 4 * p + 0j)  # complex zeros for well-damped designs
    return k_d, (s + disc) / 2, (s - disc) / 2


class PidController:
    """Discrete PID giving torque command voltages; arrays broadcast over axes and runs."""

    def __init__(self, gains: PidGains, period=0.1, initial_tcv=0.0, wheel: WheelParams = WheelParams()):
        self.gains = gains
        self.period = float(period)
        self.volts_per_torque = -1.0 / (wheel.driver_gain * wheel.torque_constant)  # eq. 2.21, inverted
        self.limit = wheel.command_limit
        self.integral = np.array(initial_tcv, float)  # [V], starts in equilibrium
        self.origin = None  # attitude held before the first command: set-point weighting acts on deviations

    def update(self, setpoint, attitude, body_rate):
        """Command voltage for this step from the set-point, attitude and measured rate.

        Parameters
        ----------
        setpoint : array_like
            (..., 3) attitude set-point [rad].
        attitude : array_like
            (..., 3) attitude [rad].
        body_rate : array_like
            (..., 3) measured body rate [rad/s].

        Returns
        -------
        numpy.ndarray
            (..., 3) body-axis torque command voltages [V], within the limit (anti-windup).
        """
        g = self.gains
        attitude = np.asarray(attitude, float)
        setpoint = nearest_setpoint(setpoint, attitude)   # the short way round
        if self.origin is None:
            self.origin = attitude.copy()
        error = setpoint - attitude
        weighted = g.setpoint_weight * (setpoint - self.origin) - (attitude - self.origin)
        torque = g.kp * weighted - g.kd * np.asarray(body_rate, float)
        unclamped = self.volts_per_torque * torque + self.integral
        tcv = np.clip(unclamped, -self.limit, self.limit)
        step = self.period * self.volts_per_torque * g.ki * error
        winding = (unclamped != tcv) & (np.sign(step) == np.sign(unclamped))
        self.integral = np.where(winding, self.integral, self.integral + step)
        return tcv
