"""A Kalman-filter residual as a plug-in observer of rw_fdi_ros: the worked example of docs/observers.md.

Each wheel is the thesis' linearised wheel (eq. 2.22, core/physics/wheel.linearised_wheel), held over the FDI
period (zero-order hold) and driven by noise:

    x_{k+1} = phi x_k + gamma u_k + w_k,     Var w = q
    r_k     = c x_k + d u_k + v_k,           Var v = rho

The estimate is the one-step prediction r^_k = c x^_k|k-1 + d u_k, made before r_k is seen, so a
fault shows in full in r_k - r^_k. ``train`` identifies q and rho per wheel from fault-free runs (the
steady-state gain depends on their ratio alone) and measures how much of the torque demand the filter's
error reaches (kappa, residuals.demand_gain), which widens its bound as for our Luenberger observer.
"""
from __future__ import annotations

import numpy as np
from scipy import signal

from rw_fdi_ros.core.fdi.observer_plugin import WheelObserver
from rw_fdi_ros.core.fdi.residuals import demand_gain, demand_ratio
from rw_fdi_ros.core.physics.wheel import linearised_wheel

def discrete_wheel(period: float) -> tuple:
    """(phi, gamma, c, d): the linearised wheel held over ``period`` [s] (ZOH)."""
    w = linearised_wheel()
    phi, gamma, *_ = signal.cont2discrete((np.array([[w.A]]), np.array([[w.B]]), np.array([[w.C]]),
                                           np.array([[w.D]])), period, method="zoh")
    return float(phi[0, 0]), float(gamma[0, 0]), w.C, w.D


def steady_state_gain(phi: float, c: float, q_over_rho: float) -> float:
    """The steady-state Kalman gain K = P c / (c^2 P + rho) of a scalar system, P the one-step prediction
    variance solving the discrete algebraic Riccati equation

        P = phi^2 P rho / (c^2 P + rho) + q   <=>   c^2 P^2 + (rho (1 - phi^2) - q c^2) P - q rho = 0,

    its positive root, here with rho = 1 (K depends on q / rho only)."""
    q, rho = q_over_rho, 1.0
    b = rho * (1.0 - phi ** 2) - q * c ** 2
    p = (-b + np.sqrt(b ** 2 + 4.0 * c ** 2 * q * rho)) / (2.0 * c ** 2)
    return float(p * c / (c ** 2 * p + rho))


def predictions(tcv, reaction_torque, period: float, gain) -> np.ndarray:
    """r^_k (n, N) of the filter with gains ``gain`` (N,) over whole series u, r (n, N), from the first r."""
    phi, gamma, c, d = discrete_wheel(period)
    u, r = np.asarray(tcv, float), np.asarray(reaction_torque, float)
    x = (r[0] - d * u[0]) / c          # start on the first measurement: no initial transient
    out = np.empty_like(r)
    for k in range(len(r)):
        out[k] = c * x + d * u[k]
        x = phi * (x + gain * (r[k] - out[k])) + gamma * u[k]
    return out


class KalmanObserver(WheelObserver):
    slot = "kalman"
    description = "steady-state Kalman filter of the linearised wheel, one-step prediction"

    def reset(self):
        self.phi, self.gamma, self.c, self.d = discrete_wheel(self.fdi_period)
        ratios = self.state.get("q_over_rho", {})
        default = max(ratios.values(), default=1e-2)   # a wheel not trained on (a standby one): the widest
        self.gain = np.array([steady_state_gain(self.phi, self.c, ratios.get(a, default)) for a in self.wheels])
        self.x = None

    def estimate(self, sample):
        u, r = np.asarray(sample.tcv, float), np.asarray(sample.reaction_torque, float)
        if self.x is None:
            self.x = (r - self.d * u) / self.c
        prediction = self.c * self.x + self.d * u
        self.x = self.phi * (self.x + self.gain * (r - prediction)) + self.gamma * u
        return prediction

    def uncertainty_gain(self, wheel: str) -> float:
        kappa = self.state.get("uncertainty_gain", {})
        return float(kappa.get(wheel, max(kappa.values(), default=0.0)))

    @classmethod
    def train(cls, runs, wheels, fdi_period):
        """q and rho per wheel in use, identified from the fault-free runs: q the variance of the state's
        one-step model error (the state read off r_k = c x_k + d u_k), rho that of r about its 3-sample mean;
        then kappa from the filter's error on the same runs."""
        phi, gamma, c, d = discrete_wheel(fdi_period)
        ratios, kappas = {}, {}
        for i, wheel in enumerate(wheels):
            if not any(np.abs(s.reaction_torque[:, i]).max() > 1e-6 for s in runs):
                continue   # a standby wheel, never driven: it takes the widest of the others
            q, rho = [], []
            for s in runs:
                u, r = s.tcv[:, i], s.reaction_torque[:, i]
                x = (r - d * u) / c
                q.append(np.var(x[1:] - phi * x[:-1] - gamma * u[:-1]))
                rho.append(np.var(r[1:-1] - (r[:-2] + r[1:-1] + r[2:]) / 3.0) * 1.5)   # 1.5: what the mean removes
            ratios[wheel] = float(np.mean(q) / max(np.mean(rho), 1e-30))
            k = steady_state_gain(phi, c, ratios[wheel])
            found = [demand_ratio(s.reaction_torque[:, i], predictions(s.tcv[:, [i]], s.reaction_torque[:, [i]],
                                                                         fdi_period, [k])[:, 0], s.ripple_phasor[:, i])
                     for s in runs]
            kappas[wheel] = demand_gain([f for f in found if f is not None])
        return {"q_over_rho": ratios, "uncertainty_gain": kappas}
