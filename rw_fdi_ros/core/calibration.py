"""Calibration of an observer to its own wheel: the unit's deviation from the datasheet, learnt from
the first healthy minutes of a run (issue 17).

Wheels of one type differ (wheel.DEFAULT_UNIT_SPREAD): to first order a unit whose torque constant
times driver gain is (1 + b_m) times the datasheet's, whose viscous and coulomb friction are
(1 + b_v) and (1 + b_c) times, leaves in any observer's error e = r - r^ (r: measured reaction torque,
r^: the observer's estimate of the datasheet wheel's) the linear term

    e_k = b_m (-tau_m,k) + b_v tau_v Omega_k + b_c tau_c tanh(Omega_k / w_c)
          + a_re Re p_k + a_im Im p_k + noise                                    (x_k . b + noise)

with every term the FDI period's mean the wheel electronics report (telemetry.py): tau_m the nominal
motor torque, tau_v Omega and tau_c tanh(.) the nominal viscous and coulomb friction, p the ripple
phasor (its gain and phase are unknown: nuisance regressors, kept out of the fit's bias and out of
the correction, which the ripple bound covers).

b is estimated by Bayesian least squares with the unit spreads as prior, b ~ N(0, P0),
P0 = diag(s_kt^2 + s_Gd^2, s_v^2, s_c^2, (g_max B/2)^2, (g_max B/2)^2):

    Sigma = (P0^-1 + X'X / s^2)^-1,    b^ = Sigma X'e / s^2,    s^2 = c max(RSS / (n - 5), sigma_floor^2)

(c: serial correlation of 1 s samples, as in identification.py). What the data cannot tell apart
(viscous from coulomb friction while the speed barely moves; the motor torque scale from the
friction while the wheel only holds, tau_m ~ tau_f) stays near the prior, and the correction's own
uncertainty at the present operating point,

    u_k = sqrt(x_k' Sigma x_k)     (physical regressors only),

widens the bound: the observer never judges a wheel more sharply than it knows it.

The first ``samples`` FDI periods of a run are learnt from (assumed healthy: a fault inside them
would be taken as the unit's own); meanwhile the wheel is judged against its type: the datasheet
model with the type's tolerance box, u_k = sum_i t_i |x_k,i| (t: :func:`tolerances`; z u_k is the
largest error of any unit whose every parameter lies within z sigma, wide: a 1-sigma unit is
2e-3 N m off while holding, so only gross faults show); from then on against its own unit, b^
frozen. Judging with a half-learnt b^ alarmed 4 of 300 fault-free varied wheels inside the window
(one-step predictions of a b^ still moving along the motor/friction collinearity); the quadrature
sqrt(x_k' P0 x_k) alarmed on units near the 3-sigma cut in two parameters at once (6 of 1000).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import wheel as wm

PARAMETERS = ("motor_torque", "viscous_friction", "coulomb_friction")   # b_m, b_v, b_c
NUISANCE = ("ripple_re", "ripple_im")
CORRELATION = 10.0     # noise variance widening for serially correlated 1 s samples (identification.py)
SIGMA_FLOOR = 5e-5     # [N m] per FDI sample: bearing torque noise and what the models leave out
DEFAULT_SAMPLES = 150  # FDI samples learnt from: 150 s at 1 s, before the evaluation's faults at 200 s


def calibration_samples(seconds: float, period: float = 1.0) -> int:
    """FDI samples learnt from in ``seconds`` of a run at FDI period ``period``."""
    return int(round(float(seconds) / float(period)))


def prior_variances(spread: dict | None = None, ripple_gain_max: float = 2.0,
                    params: wm.WheelParams = wm.WheelParams()) -> np.ndarray:
    """diag(P0): the unit spreads (shares, wheel.DEFAULT_UNIT_SPREAD) and the ripple's largest phasor gain."""
    s = dict(wm.DEFAULT_UNIT_SPREAD if spread is None else spread)
    ripple = (params.ripple_amplitude_share * params.ripple_coefficient * ripple_gain_max) ** 2
    return np.array([s.get("torque_constant", 0.0) ** 2 + s.get("driver_gain", 0.0) ** 2,
                     s.get("viscous_friction", 0.0) ** 2, s.get("coulomb_friction", 0.0) ** 2, ripple, ripple])


def tolerances(spread: dict | None = None) -> np.ndarray:
    """The 1-sigma tolerance of each physical share (b_m, b_v, b_c) as a box: b_m = (1 + d_kt)(1 + d_Gd) - 1
    reaches s_kt + s_Gd when both sit at the same end (the plant draws each within 3 sigma)."""
    s = dict(wm.DEFAULT_UNIT_SPREAD if spread is None else spread)
    return np.array([s.get("torque_constant", 0.0) + s.get("driver_gain", 0.0), s.get("viscous_friction", 0.0),
                     s.get("coulomb_friction", 0.0)])


def regressors(motor_torque, friction_torque, wheel_speed, ripple_phasor,
               params: wm.WheelParams = wm.WheelParams()) -> np.ndarray:
    """x_k (..., 5) from the FDI sample's nominal terms (any leading shape, one wheel per element)."""
    viscous = wm.viscous_coefficient(wm.NOMINAL.temperature, params) * np.asarray(wheel_speed, float)
    p = np.asarray(ripple_phasor, complex)
    return np.stack([-np.asarray(motor_torque, float), viscous, np.asarray(friction_torque, float) - viscous,
                     p.real, p.imag], axis=-1)


@dataclass(frozen=True)
class UnitEstimate:
    """b^ and its posterior covariance, the physical part (b_m, b_v, b_c) first."""

    mean: np.ndarray        # (5,)
    covariance: np.ndarray  # (5, 5)
    samples: int
    noise: float            # s [N m] the posterior used

    def scales(self) -> dict:
        """The unit over the datasheet: 1 + b for each physical parameter, with its 1-sigma."""
        sd = np.sqrt(np.diag(self.covariance))
        return {name: (1.0 + float(self.mean[i]), float(sd[i])) for i, name in enumerate(PARAMETERS)}


class UnitCalibration:
    """One wheel's calibration, sample by sample (the observer nodes and the offline tools alike).

    ``update(error, x)`` -> (correction, uncertainty): add ``correction`` = x_phys . b^_phys to the
    observer's estimate, add z ``uncertainty`` (u_k) to the bound's per-sample terms. ``error`` is
    the observer's uncorrected error r - r^ of this sample, learnt from while calibrating.
    """

    def __init__(self, samples: int = DEFAULT_SAMPLES, prior: np.ndarray | None = None,
                 sigma_floor: float = SIGMA_FLOOR, correlation: float = CORRELATION, tolerance=None):
        self.samples = int(samples)
        p0 = prior_variances() if prior is None else np.asarray(prior, float)
        if p0.shape != (5,) or np.any(p0 <= 0) or not np.all(np.isfinite(p0)):
            raise ValueError(f"calibration prior variances must be 5 finite positive numbers, got {p0.tolist()}")
        self.prior_information = np.diag(1.0 / p0)
        self.tolerance = tolerances() if tolerance is None else np.asarray(tolerance, float)
        self.floor2 = float(sigma_floor) ** 2
        self.correlation = float(correlation)
        self.xtx = np.zeros((5, 5))
        self.xte = np.zeros(5)
        self.ete = 0.0
        self.n = 0
        self.estimate = self._posterior()

    @property
    def frozen(self) -> bool:
        return self.n >= self.samples

    def _posterior(self) -> UnitEstimate:
        """b^ and Sigma for s^2 from the residual of a first fit at the noise floor (one refinement)."""
        def fit(s2):
            information = self.prior_information + self.xtx / (self.correlation * s2)
            cov = np.linalg.inv(information)
            return cov @ self.xte / (self.correlation * s2), cov
        mean, _ = fit(self.floor2)
        rss = self.ete - 2.0 * mean @ self.xte + mean @ self.xtx @ mean
        s2 = max(rss / (self.n - 5), self.floor2) if self.n > 5 else self.floor2
        mean, cov = fit(s2)
        return UnitEstimate(mean, cov, self.n, float(np.sqrt(s2)))

    def update(self, error: float, x) -> tuple:
        x = np.asarray(x, float)
        phys = x[:3]
        if not self.frozen:   # learning: judge against the type's tolerances, and learn
            self.xtx += np.outer(x, x)
            self.xte += x * float(error)
            self.ete += float(error) ** 2
            self.n += 1
            if self.frozen:
                self.estimate = self._posterior()
            return 0.0, float(np.abs(phys) @ self.tolerance)
        est = self.estimate
        return float(phys @ est.mean[:3]), float(np.sqrt(max(phys @ est.covariance[:3, :3] @ phys, 0.0)))
