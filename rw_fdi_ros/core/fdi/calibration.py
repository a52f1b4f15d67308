"""Calibration of an observer to its own wheel: the unit's deviation from the datasheet, learnt from
the first healthy minutes of a run.

Wheels of one type differ (wheel.DEFAULT_UNIT_SPREAD): to first order a unit whose torque constant
and driver gain are (1 + d_kt) and (1 + d_Gd) times the datasheet's, whose viscous and coulomb
friction are (1 + b_v) and (1 + b_c) times, leaves in any observer's error e = r - r^ (r: measured
reaction torque, r^: the observer's estimate of the datasheet wheel's) the linear term

    e_k = d_kt (-tau_m,k) + d_Gd (-tau_m,k^free) + b_v tau_v Omega_k + b_c tau_c tanh(Omega_k / w_c)
          + a_re Re p_k + a_im Im p_k + noise                                    (x_k . b + noise)

with every term the FDI period's mean the wheel electronics report (telemetry.py): tau_m the nominal
motor torque, tau_m^free the same where the bridge does not clip the current (eq. 2.13; where it
clips, the torque is k_t I_max whatever the driver gain), tau_v Omega and tau_c tanh(.) the nominal
viscous and coulomb friction, p the ripple phasor (its gain and phase are unknown: nuisance
regressors, kept out of the fit's bias and out of the correction, which the ripple bound covers).
Two motor shares, as the clipped torque scales with d_kt alone (docs/fdi.md, "unit calibration").

b is estimated by Bayesian least squares with the unit spreads as prior, b ~ N(0, P0),
P0 = diag(s_kt^2, s_Gd^2, s_v^2, s_c^2, (g_max B/2)^2, (g_max B/2)^2):

    Sigma = (P0^-1 + X'X / s^2)^-1,    b^ = Sigma X'e / s^2,    s^2 = c max(RSS / (n - 6), sigma_floor^2)

(c: serial correlation of 1 s samples, as in identification/decision.py). A torque derived from a
tachometer's speeds (wheel.WheelParams.speed_noise sigma_Omega > 0) carries a noise that is no such
thing: r_k = -J (Omega(t_k) - Omega(t_k - T)) / T, so the speed noise enters as the difference
d_k - d_(k-1) of d_k = -J n(t_k) / T, sigma_d = J sigma_Omega / T, and cancels over a run of samples
where white noise would not. There the fit is generalised least squares with the noise covariance

    V = c s^2 I + sigma_d^2 D,    D = tridiag(-1, 2, -1) = Q diag(lambda) Q',  lambda_j = 2 - 2 cos(j pi / (n + 1)),
    Sigma = (P0^-1 + X' V^-1 X)^-1,    b^ = Sigma X' V^-1 e,

Q the sine transform, so that V^-1 = Q diag(1 / (c s^2 + sigma_d^2 lambda)) Q'; s^2 (the rest of the noise, at
least the floor) is the residual's maximum likelihood under V. Taken as white, the tachometer's 2 sigma_d^2
per sample (1.1e-3 N m on Basilisk's HR16 at 0.01 rad/s) would leave the posterior at the prior; and
RSS / (n - 6) - 2 sigma_d^2 would leave s^2 to that term's own scatter. What the data cannot tell apart
(viscous from coulomb friction while the speed barely moves; the motor torque scale from the
friction while the wheel only holds, tau_m ~ tau_f) stays near the prior, and the correction's own
uncertainty at the present operating point,

    u_k = sqrt(x_k' Sigma x_k)     (physical regressors only),

widens the bound: the observer never judges a wheel more sharply than it knows it.

The first ``samples`` FDI periods in which the wheel runs are learnt from (a standby wheel's from when
it is brought in; assumed healthy: a fault inside them
would be taken as the unit's own); meanwhile the wheel is judged against its type: the datasheet
model with the type's tolerance box, u_k = sum_i t_i |x_k,i| (t: :func:`tolerances`; z u_k is the
largest error of any unit whose every parameter lies within z sigma, wide: a 1-sigma unit is
2e-3 N m off while holding, so only gross faults show); from then on against its own unit, b^
frozen (why not a half-learnt b^, nor the quadrature sqrt(x_k' P0 x_k): docs/fdi.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics import wheel as wm

PARAMETERS = wm.UNIT_PARAMETERS   # d_kt, d_Gd, b_v, b_c
PHYSICAL = len(PARAMETERS)
NUISANCE = ("ripple_re", "ripple_im")
CORRELATION = 10.0     # noise variance widening for serially correlated 1 s samples (identification/decision.py)
# [N m] per FDI sample: the bearing noise (1.5e-5 N m peak, eq. 2.16) and what the unit model leaves out in
# slews; the posterior then holds the true unit in its 95 % region on 95.7 % of wheels (docs/fdi.md)
SIGMA_FLOOR = 2.5e-5
DEFAULT_SAMPLES = 150  # FDI samples learnt from: 150 s at 1 s, before the evaluation's faults at 200 s


def calibration_samples(seconds: float, period: float = 1.0) -> int:
    """FDI samples learnt from in ``seconds`` of a run at FDI period ``period``.

    Parameters
    ----------
    seconds : float
        Time learnt from [s].
    period : float, optional
        FDI period [s].

    Returns
    -------
    int
        Number of FDI samples (rounded).
    """
    return int(round(float(seconds) / float(period)))


def prior_variances(spread: dict | None = None, ripple_gain_max: float = 2.0,
                    params: wm.WheelParams = wm.WheelParams()) -> np.ndarray:
    """diag(P0): the unit spreads (shares, wheel.DEFAULT_UNIT_SPREAD) and the ripple's largest phasor gain.

    Parameters
    ----------
    spread : dict of str to float, optional
        1-sigma spread (a share) of each UNIT_PARAMETERS name; None for wheel.DEFAULT_UNIT_SPREAD, a missing
        name for 0.
    ripple_gain_max : float, optional
        g_max, the largest ripple gain the prior allows.
    params : WheelParams
        The wheel type (its ripple coefficient B and amplitude share).

    Returns
    -------
    ndarray, shape (6,)
        Prior variances of (d_kt, d_Gd, b_v, b_c, a_re, a_im), dimensionless.
    """
    s = dict(wm.DEFAULT_UNIT_SPREAD if spread is None else spread)
    ripple = (params.ripple_amplitude_share * params.ripple_coefficient * ripple_gain_max) ** 2
    return np.array([s.get(name, 0.0) ** 2 for name in PARAMETERS] + [ripple, ripple])


def tolerances(spread: dict | None = None) -> np.ndarray:
    """The 1-sigma tolerance of each physical share (d_kt, d_Gd, b_v, b_c), a box: sum_i t_i |x_i| is the
    largest error of a unit with every share at the same end (the plant draws each within 3 sigma).

    Parameters
    ----------
    spread : dict of str to float, optional
        1-sigma spread (a share) of each UNIT_PARAMETERS name; None for wheel.DEFAULT_UNIT_SPREAD.

    Returns
    -------
    ndarray, shape (4,)
        t for (d_kt, d_Gd, b_v, b_c), dimensionless.
    """
    s = dict(wm.DEFAULT_UNIT_SPREAD if spread is None else spread)
    return np.array([s.get(name, 0.0) for name in PARAMETERS])


def regressors(motor_torque, friction_torque, wheel_speed, ripple_phasor, free_motor_torque=None,
               params: wm.WheelParams = wm.WheelParams()) -> np.ndarray:
    """x_k (..., 6) from the FDI sample's nominal terms (any leading shape, one wheel per element);
    without ``free_motor_torque`` (telemetry from before it was reported) the bridge is taken as never
    clipping.

    Parameters
    ----------
    motor_torque : array_like, shape (...)
        The nominal motor torque tau_m [N m], e.g. (n, N): samples, wheels.
    friction_torque : array_like, shape (...)
        The nominal friction tau_f(Omega; 23 C) [N m].
    wheel_speed : array_like, shape (...)
        Omega [rad/s].
    ripple_phasor : array_like of complex, shape (...)
        The ripple phasor p [N m].
    free_motor_torque : array_like, shape (...), optional
        tau_m^free [N m], the motor torque where the bridge does not clip (0 where it does).
    params : WheelParams
        The wheel type whose viscous coefficient at 23 C splits the friction.

    Returns
    -------
    ndarray, shape (..., 6)
        x_k = (-tau_m, -tau_m^free, tau_v Omega, tau_f - tau_v Omega, Re p, Im p) [N m].
    """
    viscous = wm.viscous_coefficient(wm.NOMINAL.temperature, params) * np.asarray(wheel_speed, float)
    p = np.asarray(ripple_phasor, complex)
    motor = np.asarray(motor_torque, float)
    free = motor if free_motor_torque is None else np.asarray(free_motor_torque, float)
    return np.stack([-motor, -np.broadcast_to(free, motor.shape), viscous,
                     np.asarray(friction_torque, float) - viscous, p.real, p.imag], axis=-1)


@dataclass(frozen=True)
class UnitEstimate:
    """b^ and its posterior covariance, the physical part (d_kt, d_Gd, b_v, b_c) first."""

    mean: np.ndarray        # (6,)
    covariance: np.ndarray  # (6, 6)
    samples: int
    noise: float            # s [N m] the posterior used

    def scales(self) -> dict:
        """The unit over the datasheet: 1 + b for each physical parameter, with its 1-sigma.

        Returns
        -------
        dict
            Parameter name -> (1 + b, 1-sigma of b).
        """
        sd = np.sqrt(np.diag(self.covariance))
        return {name: (1.0 + float(self.mean[i]), float(sd[i])) for i, name in enumerate(PARAMETERS)}


class UnitCalibration:
    """One wheel's calibration, sample by sample (the observer nodes and the offline tools alike).

    ``update(error, x)`` -> (correction, uncertainty): add ``correction`` = x_phys . b^_phys to the
    observer's estimate, add z ``uncertainty`` (u_k) to the bound's per-sample terms. ``error`` is
    the observer's uncorrected error r - r^ of this sample, learnt from while calibrating.
    """

    def __init__(self, samples: int = DEFAULT_SAMPLES, prior: np.ndarray | None = None,
                 sigma_floor: float | None = None, correlation: float = CORRELATION, tolerance=None,
                 params: wm.WheelParams = wm.WheelParams(), period: float = 1.0):
        # params: the wheel type; its ripple sets the prior, its torques the noise floor (SIGMA_FLOOR is the
        # Type A's: wheel.torque_scale)
        self.samples = int(samples)
        p0 = prior_variances(params=params) if prior is None else np.asarray(prior, float)
        sigma_floor = SIGMA_FLOOR * wm.torque_scale(params) if sigma_floor is None else sigma_floor
        width = PHYSICAL + 2
        if p0.shape != (width,) or np.any(p0 < 0) or not np.all(np.isfinite(p0)):
            raise ValueError(f"calibration prior variances must be {width} finite numbers >= 0, got {p0.tolist()}")
        # a prior variance of 0 holds its term at 0: a wheel type without ripple (B = 0) has no phasor to learn
        self.free = p0 > 0
        self.prior_information = np.diag(np.where(self.free, 1.0 / np.where(self.free, p0, 1.0), 0.0))
        self.tolerance = tolerances() if tolerance is None else np.asarray(tolerance, float)
        self.floor2 = float(sigma_floor) ** 2
        self.correlation = float(correlation)
        # sigma_d^2 of a torque derived from the tachometer's speeds (module docstring); 0: exact speeds
        self.difference2 = (params.inertia * params.speed_noise / period) ** 2
        self.learnt = []   # (x, e) of the samples learnt from, for the generalised fit (difference2 > 0)
        self.xtx = np.zeros((width, width))
        self.xte = np.zeros(width)
        self.ete = 0.0
        self.n = 0
        self.estimate = self._posterior()

    @property
    def frozen(self) -> bool:
        return self.n >= self.samples

    def _posterior(self) -> UnitEstimate:
        """b^ and Sigma for s^2 from the residual of a first fit at the noise floor (one refinement)."""
        def fit(s2):
            free = np.ix_(self.free, self.free)
            cov = np.zeros_like(self.xtx)
            cov[free] = np.linalg.inv((self.prior_information + self.xtx / (self.correlation * s2))[free])
            return cov @ self.xte / (self.correlation * s2), cov
        if self.difference2 > 0 and self.learnt:
            return self._generalised_posterior()
        mean, _ = fit(self.floor2)
        rss = self.ete - 2.0 * mean @ self.xte + mean @ self.xtx @ mean
        dof = self.n - len(self.xte)
        s2 = max(rss / dof, self.floor2) if dof > 0 else self.floor2
        mean, cov = fit(s2)
        return UnitEstimate(mean, cov, self.n, float(np.sqrt(s2)))

    def _generalised_posterior(self) -> UnitEstimate:
        """b^ and Sigma under V = c s^2 I + sigma_d^2 tridiag(-1, 2, -1), s^2 by maximum likelihood (module
        docstring), in the sine basis where V is diagonal."""
        x = np.array([row[0] for row in self.learnt])
        e = np.array([row[1] for row in self.learnt])
        n = len(e)
        j = np.arange(1, n + 1)
        q = np.sqrt(2.0 / (n + 1)) * np.sin(np.pi * np.outer(j, j) / (n + 1))   # D = Q diag(lam) Q', Q' = Q
        lam = 2.0 - 2.0 * np.cos(np.pi * j / (n + 1))
        xq, eq = q @ x, q @ e
        free = np.ix_(self.free, self.free)

        def fit(s2):
            w = 1.0 / (self.correlation * s2 + self.difference2 * lam)
            cov = np.zeros_like(self.xtx)
            cov[free] = np.linalg.inv((self.prior_information + xq.T @ (w[:, None] * xq))[free])
            return cov @ (xq.T @ (w * eq)), cov

        residual = eq - xq @ fit(self.floor2)[0]
        grid = self.floor2 * np.logspace(0.0, 6.0, 61)   # s^2 from the floor up to 1000 floors (in rms)
        variance = self.correlation * grid[:, None] + self.difference2 * lam
        s2 = float(grid[np.argmin(np.sum(np.log(variance) + residual ** 2 / variance, axis=1))])
        mean, cov = fit(s2)
        return UnitEstimate(mean, cov, self.n, float(np.sqrt(s2)))

    def update(self, error: float, x) -> tuple:
        """One sample: learn from it while calibrating, and say how to correct the estimate and widen the bound.

        Parameters
        ----------
        error : float
            The observer's uncorrected error r - r^ of this sample [N m].
        x : array_like
            The sample's regressors (:func:`regressors`).

        Returns
        -------
        tuple of float
            (correction x_phys . b^_phys [N m], uncertainty u_k [N m]); while learning (0, the type's tolerance).
        """
        x = np.asarray(x, float)
        phys = x[:PHYSICAL]
        if not self.frozen and not np.any(x):
            # a wheel at rest and unpowered (a standby wheel not yet brought in) shows nothing of its unit:
            # it learns from its first running samples, whenever they come (judged by its type till then)
            return 0.0, 0.0
        if not self.frozen:   # learning: judge against the type's tolerances, and learn
            self.xtx += np.outer(x, x)
            self.xte += x * float(error)
            self.ete += float(error) ** 2
            self.n += 1
            if self.difference2 > 0:
                self.learnt.append((x, float(error)))
            if self.frozen:
                self.estimate = self._posterior()
            return 0.0, float(np.abs(phys) @ self.tolerance)
        est = self.estimate
        cov = est.covariance[:PHYSICAL, :PHYSICAL]
        return float(phys @ est.mean[:PHYSICAL]), float(np.sqrt(max(phys @ cov @ phys, 0.0)))

    def so_far(self) -> UnitEstimate:
        """The posterior of the samples learnt so far (the frozen estimate once frozen).

        Returns
        -------
        UnitEstimate
            The posterior.
        """
        return self.estimate if self.frozen else self._posterior()

    def unit(self) -> "UnitShares":
        """What is known of this wheel's unit now: the posterior once frozen, the type's spread while learning.

        Returns
        -------
        UnitShares
            The unit's shares b.
        """
        return UnitShares.of_estimate(self.estimate) if self.frozen else UnitShares.of_type()


@dataclass(frozen=True)
class UnitShares:
    """What is known of a wheel's unit over the datasheet: (d_kt, d_Gd, b_v, b_c) ~ N(mean, covariance)
    (fault identification judges the fault on this unit, with this uncertainty)."""

    mean: np.ndarray          # (4,)
    covariance: np.ndarray    # (4, 4)
    source: str               # 'calibrated' (learnt from the run) or 'type' (the unit spreads only)

    @classmethod
    def of_estimate(cls, estimate: UnitEstimate) -> "UnitShares":
        """A calibrated unit: the physical part of a calibration's posterior.

        Parameters
        ----------
        estimate : UnitEstimate
            The posterior.

        Returns
        -------
        UnitShares
            Its mean and covariance of b_phys, source 'calibrated'.
        """
        k = PHYSICAL
        return cls(estimate.mean[:k].copy(), estimate.covariance[:k, :k].copy(), "calibrated")

    @classmethod
    def of_type(cls, spread: dict | None = None) -> "UnitShares":
        """A unit nothing was learnt of: any unit of the type, b ~ N(0, diag(spread^2)).

        Parameters
        ----------
        spread : dict or None
            Parameter name -> the type's 1-sigma spread (None: the defaults).

        Returns
        -------
        UnitShares
            Zero mean, the spread's covariance, source 'type'.
        """
        return cls(np.zeros(PHYSICAL), np.diag(prior_variances(spread)[:PHYSICAL]), "type")

    def scales(self) -> np.ndarray:
        """1 + mean: the unit's torque constant, driver gain, viscous and coulomb friction over the datasheet's.

        Returns
        -------
        numpy.ndarray
            (4,) shares of the datasheet's values.
        """
        return 1.0 + self.mean
