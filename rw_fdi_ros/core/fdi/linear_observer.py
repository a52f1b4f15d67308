"""Full-order Luenberger observer of the linearised wheel (thesis 3.3, eq. 3.1).

    dx^/dt = A x^ + B u + L (y - y^),   y^ = C x^ + D u

u is the torque command voltage, y the measured reaction torque. L puts the
observer pole at 4x the wheel pole (A - L C = 4 A). The node runs it at its
sample period, so it is discretised here (zero-order hold on u and y).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..physics.wheel import LinearWheel, linearised_wheel

# kappa per wheel of the speed-aware residual bound (residuals.SignedResidual): the linearised model
# knows no speed, back-EMF or friction law, so its error grows with the torque the wheel is asked for
# (up to 8e-4 N m in the first slew, 1e-5 N m while holding). residuals.demand_gain of this observer
# on the fault-free runs 1000-1139 (the shipped Elman network's training and fitting seeds) gave
# 0.3426 / 0.2159 / 0.4371, rounded up here; test_linear_observer checks held-out runs stay inside.
UNCERTAINTY_GAIN = {"x": 0.343, "y": 0.216, "z": 0.438}


def uncertainty_gain(wheel: str) -> float:
    """kappa of a wheel: its axis' measured one; a wheel off the body axes (the redundant s), of the same
    type, gets the largest of them.

    Parameters
    ----------
    wheel : str
        The wheel's name in its set (x, y, z, or another).

    Returns
    -------
    float
        kappa, dimensionless.
    """
    return UNCERTAINTY_GAIN.get(wheel, max(UNCERTAINTY_GAIN.values()))


def observer_gain(wheel: LinearWheel, speed_up: float = 4.0) -> float:
    """L with eig(A - L C) = speed_up x eig(A), by pole placement (the dual of state feedback).

    Parameters
    ----------
    wheel : LinearWheel
        The linearised wheel (A [1/s], C).
    speed_up : float, optional
        How many times faster than the wheel's pole the observer's is.

    Returns
    -------
    float
        L, the observer gain.
    """
    placed = signal.place_poles(np.array([[wheel.A]]), np.array([[wheel.C]]), [speed_up * wheel.A])
    return float(placed.gain_matrix[0, 0])


@dataclass(frozen=True)
class DiscreteObserver:
    """x^_{k+1} = Phi x^_k + Gu u_k + Gy y_k ;  y^_k = C x^_k + D u_k (ZOH of eq. 3.1)."""

    phi: float
    gamma_u: float
    gamma_y: float
    C: float
    D: float
    L: float
    period: float


def discretise(wheel: LinearWheel, period: float, speed_up: float = 4.0) -> DiscreteObserver:
    """Exact ZOH discretisation of the observer with inputs [u, y].

    Parameters
    ----------
    wheel : LinearWheel
        The linearised wheel (input tcv [V], output reaction torque [N m]).
    period : float
        Sample period [s].
    speed_up : float, optional
        Observer pole over the wheel's (:func:`observer_gain`).

    Returns
    -------
    DiscreteObserver
        Phi, Gamma_u, Gamma_y, C, D, L and ``period`` [s].
    """
    L = observer_gain(wheel, speed_up)
    a = np.array([[wheel.A - L * wheel.C]])
    b = np.array([[wheel.B - L * wheel.D, L]])
    ad, bd, *_ = signal.cont2discrete((a, b, np.eye(1), np.zeros((1, 2))), period, method="zoh")
    return DiscreteObserver(phi=float(ad[0, 0]), gamma_u=float(bd[0, 0]), gamma_y=float(bd[0, 1]),
                            C=wheel.C, D=wheel.D, L=L, period=period)


def steady_fault_gain(model: DiscreteObserver) -> float:
    """The share of a steady torque error Delta (y = y_nominal + Delta from some sample on) that stays in the
    residual r = y - y^ once the observer has settled: r_inf / Delta = 1 - C Gamma_y / (1 - Phi).

    The output injection L (y - y^) pulls the estimate onto the faulty measurement. ZOH keeps the DC gain, so
    this is the continuous observer's A / (A - L C): 1 / speed_up for the pole placed at speed_up x the wheel's
    (:func:`observer_gain`). A current loss or a hot wheel is such a steady error while the command holds.

    Parameters
    ----------
    model : DiscreteObserver
        The discretised observer (:func:`discretise`).

    Returns
    -------
    float
        r_inf / Delta, dimensionless.
    """
    return 1.0 - model.C * model.gamma_y / (1.0 - model.phi)


class LinearObserver:
    """Reaction-torque estimator for any number of wheels (arrays broadcast)."""

    def __init__(self, period: float = 1.0, wheel: LinearWheel | None = None, speed_up: float = 4.0):
        self.model = discretise(wheel or linearised_wheel(), period, speed_up)
        self.state = None

    def update(self, tcv, reaction_torque):
        """Estimate y^_k from u_k and the state, then advance the state with the measured y_k.

        Parameters
        ----------
        tcv : array_like
            (N,) torque command voltages u_k [V].
        reaction_torque : array_like
            (N,) measured reaction torques y_k [N m].

        Returns
        -------
        numpy.ndarray
            (N,) estimates y^_k [N m].
        """
        m = self.model
        u = np.asarray(tcv, float)
        y = np.asarray(reaction_torque, float)
        if self.state is None:  # start on the measurement: no initial transient
            self.state = (y - m.D * u) / m.C
        estimate = m.C * self.state + m.D * u
        self.state = m.phi * self.state + m.gamma_u * u + m.gamma_y * y
        return estimate


def estimate_series(tcv, reaction_torque, period: float = 1.0, wheel: LinearWheel | None = None):
    """Estimates for whole sampled series (time first); the offline tools use this.

    Parameters
    ----------
    tcv : array_like, shape (n, ...)
        Torque command voltage u [V], e.g. (n, N): samples, wheels.
    reaction_torque : array_like, shape (n, ...)
        Measured reaction torque y [N m], the shape of ``tcv``.
    period : float, optional
        Sample period [s].
    wheel : LinearWheel, optional
        The linearised wheel type (wheel.linearised_wheel); None: the thesis'.

    Returns
    -------
    ndarray, shape (n, ...)
        The estimate y^ [N m] at each sample (from the state before that sample's y).
    """
    obs = LinearObserver(period, wheel)
    return np.array([obs.update(u, y) for u, y in zip(tcv, reaction_torque)])
