"""The residual r_k of an observer's estimate (thesis 3.2, 4.3.3; docs/fdi.md): the thesis' moving mean of
|r - r^|, and ours, signed, with the ripple's aliased reach and the model's error as its bound."""
from __future__ import annotations

from collections import deque

import numpy as np

from .detection import FALSE_ALARM_RATE, WINDOW
from .threshold_fit import gumbel_fit, gumbel_quantile

# Ripple gains up to g_max are a disturbance the bound covers (a +60 % ripple must not alarm; thesis 5.3).
RIPPLE_GAIN_MAX = 2.0
CALIBRATION_SIGMAS = 3.0      # z: a calibrated correction's own uncertainty u_k enters the bound as z u_k
class ResidualFilter:
    """The same moving average, one sample at a time (the observer nodes)."""

    def __init__(self, window: int = WINDOW):
        self.buffer = deque(maxlen=window)
        self.total = 0.0

    def update(self, actual, estimate):
        """The thesis' residual after this sample: the mean of |r - r^| over the window.

        Parameters
        ----------
        actual : float
            Measured reaction torque r [N m].
        estimate : float
            The observer's estimate r^ [N m].

        Returns
        -------
        float
            The residual [N m].
        """
        err = abs(float(actual) - float(estimate))
        if len(self.buffer) == self.buffer.maxlen:
            self.total -= self.buffer[0]
        self.buffer.append(err)
        self.total += err
        return self.total / len(self.buffer)


class SignedResidual:
    """Speed-aware residual of one wheel: signed moving mean of r - r^ and what it may hold unfaulted.

    ``update(actual, estimate, ripple_phasor[, regressors])`` -> (residual, bound) with
    bound = (B/2) g_max reach(p) / n + kappa mean(|r|) + z mean(u) + s / n: the aliased ripple's largest
    contribution for any gain up to g_max that is constant or monotone over the window
    (:func:`ripple_reach`; ripple_phasor: the FDI sample's mean of tau_m e^{i N theta}, telemetry.py)
    plus the observer's own model error, which grows with the torque the wheel is asked for
    (``uncertainty_gain`` kappa: 0 for the nominal wheel model, measured on the training runs
    for an Elman network, tools/design/train.py), plus, with a ``calibration`` to the wheel's own unit
    (core/fdi/calibration.py), the uncertainty u of its correction to the estimate, plus, for a torque
    derived from a noisy tachometer's speeds, its noise's reach s (:func:`speed_noise_reach`).
    """

    def __init__(self, window: int = WINDOW, share: float | None = None, ripple_gain_max: float = RIPPLE_GAIN_MAX,
                 uncertainty_gain: float = 0.0, calibration=None, noise_reach: float = 0.0):
        self.errors = deque(maxlen=window)
        self.phasors = deque(maxlen=window)
        self.torques = deque(maxlen=window)
        self.spreads = deque(maxlen=window)
        self.scale = (ripple_share() if share is None else share) * ripple_gain_max
        self.kappa = float(uncertainty_gain)
        self.noise_reach = float(noise_reach)
        self.calibration = calibration   # core.calibration.UnitCalibration, or None (the datasheet wheel)
        self.estimate = None             # the last estimate, calibrated: what the node publishes

    @classmethod
    def of_wheel(cls, wheel=None, period: float = 1.0, window: int = WINDOW, uncertainty_gain: float = 0.0,
                 calibration_samples: int = 0) -> "SignedResidual":
        """The residual of one wheel of type ``wheel``: its ripple share, its tachometer's noise reach at the FDI
        ``period`` and, with ``calibration_samples`` > 0, a calibration to its own unit over those samples.

        Parameters
        ----------
        wheel : WheelParams, optional
            The wheel type (None: the thesis').
        period : float
            [s] the FDI sample period.
        window : int
            W [samples].
        uncertainty_gain : float
            kappa of the observer's model error.
        calibration_samples : int
            FDI samples the wheel's unit is learned from; 0: the datasheet wheel.

        Returns
        -------
        SignedResidual
            The residual filter.
        """
        from .calibration import UnitCalibration
        from ..physics.wheel import WheelParams
        calibration = (UnitCalibration(calibration_samples, params=wheel or WheelParams(), period=period)
                       if calibration_samples else None)
        return cls(window, ripple_share(wheel), uncertainty_gain=uncertainty_gain, calibration=calibration,
                   noise_reach=speed_noise_reach(wheel, period))

    def update(self, actual, estimate, ripple_phasor, regressors=None):
        """(residual, bound) after this sample; ``regressors``: calibration.regressors of the sample,
        needed with a calibration (which corrects the estimate and widens the bound by z u_k).

        Parameters
        ----------
        actual : float
            Measured reaction torque r [N m].
        estimate : float
            The observer's estimate r^ [N m].
        ripple_phasor : complex
            The sample's commutation ripple phasor.
        regressors : array_like or None
            The sample's calibration regressors.

        Returns
        -------
        tuple of float
            (mean of r - r^ over the window, its ripple and uncertainty bound) [N m]; both NaN for a sample
            whose r or r^ is not finite, which leaves the window as it was.
        """
        actual, estimate, spread = float(actual), float(estimate), 0.0
        if not (np.isfinite(actual) and np.isfinite(estimate)):   # a blind sample: not judged (the channel
            return float("nan"), float("nan")                     # says so), the window kept clean of it
        if self.calibration is not None:
            correction, uncertainty = self.calibration.update(actual - estimate, regressors)
            estimate += correction
            spread = CALIBRATION_SIGMAS * uncertainty
        self.estimate = estimate
        self.errors.append(actual - estimate)
        self.phasors.append(complex(ripple_phasor))
        self.torques.append(abs(actual))
        self.spreads.append(spread)
        n = len(self.errors)
        # sums over a deque of <= 40 values: exact, and no drift from running totals
        bound = (self.scale * ripple_reach(self.phasors) / n + self.kappa * sum(self.torques) / n
                 + sum(self.spreads) / n + self.noise_reach / n)
        return sum(self.errors) / n, bound


def speed_noise_reach(params=None, period: float = 1.0) -> float:
    """The reach s [N m] of a tachometer's noise in a window of torques derived from its speeds.

    A torque derived from speeds, r_k = -J (Omega_k - Omega_(k-1)) / T, telescopes over the n samples of the
    window: their mean is -J (Omega_k - Omega_(k-n)) / (n T), so speeds read with noise of sigma_Omega put
    sqrt(2) J sigma_Omega / (n T) into the residual (1 sigma), whatever n. The bound takes
    s / n = z sqrt(2) J sigma_Omega / (n T) with z = CALIBRATION_SIGMAS: wide on the window's first samples,
    a fortieth of it once the window is full, where the band is fitted on what is left.

    Parameters
    ----------
    params : WheelParams, optional
        The wheel type: its ``inertia`` J and ``speed_noise`` sigma_Omega (None: the thesis', exact speeds).
    period : float
        [s] T, the FDI sample period.

    Returns
    -------
    float
        s [N m]; 0 for an exact tachometer.
    """
    if params is None:
        return 0.0
    return CALIBRATION_SIGMAS * np.sqrt(2.0) * params.inertia * params.speed_noise / period


def ripple_reach(phasors) -> float:
    """max_j max(|S_j|, |S_n - S_j|), S_j = p_1 + ... + p_j (S_0 = 0): the largest |sum g_k p_k| over
    every ripple gain g_k in [0, 1] that is monotone across the window.

    By Abel summation, sum g_k p_k = sum_j (g_j - g_j-1) (S_n - S_j-1) for a non-decreasing g
    (weights >= 0 that add up to g_n <= 1), and likewise with the head sums S_j for a
    non-increasing one. A constant gain gives |S_n|; a ripple that steps up inside the window
    (a bearing wearing) can reach further: with |S_n| alone, +100 % ripple from t = 248 s gave
    a residual of 7.2e-4 N m against a bound of 4.5e-4 at t = 277 s (seed 10200092).

    Parameters
    ----------
    phasors : iterable of complex
        The window's ripple phasors p_1..p_n [N m] (telemetry.py), oldest first.

    Returns
    -------
    float
        The reach [N m] (|S_n| <= reach; 0 for an empty window).
    """
    partial = np.concatenate([[0.0], np.cumsum(np.fromiter(phasors, complex))])
    return float(np.maximum(np.abs(partial), np.abs(partial[-1] - partial)).max())


def ripple_share(params=None) -> float:
    """(B/2): the ripple amplitude per unit motor torque at ripple gain 1 (wheel.torque_ripple).

    Parameters
    ----------
    params : WheelParams, optional
        The wheel type; None for the datasheet wheel.

    Returns
    -------
    float
        B/2 (dimensionless: ripple torque per motor torque).
    """
    from ..physics.wheel import WheelParams
    p = params or WheelParams()
    return p.ripple_amplitude_share * p.ripple_coefficient


def residual_series(actual, estimate, window: int = WINDOW):
    """Residuals of whole series (time first, one column per axis) through :class:`ResidualFilter`.

    Parameters
    ----------
    actual : array_like, shape (n,) or (n, N)
        Measured reaction torque r [N m]: samples, wheels.
    estimate : array_like, shape (n,) or (n, N)
        The observer's estimate r^ [N m], same shape.
    window : int, optional
        W [samples].

    Returns
    -------
    ndarray, shape (n, N)
        The moving mean of |r - r^| [N m] ((n, 1) for 1-D input).
    """
    actual, estimate = np.atleast_2d(np.asarray(actual, float).T).T, np.atleast_2d(np.asarray(estimate, float).T).T
    out = np.empty(actual.shape)
    for j in range(actual.shape[1]):
        f = ResidualFilter(window)
        out[:, j] = [f.update(a, e) for a, e in zip(actual[:, j], estimate[:, j])]
    return out


def window_mean(values, window: int = WINDOW):
    """Moving mean over the last ``window`` samples (time first); the first W-1 average what exists.

    Parameters
    ----------
    values : array_like, shape (n, ...)
        The series, time on axis 0 (any unit).
    window : int, optional
        W [samples].

    Returns
    -------
    ndarray, shape (n, ...)
        The moving mean, in the unit of ``values``.
    """
    v = np.asarray(values, float)
    c = np.cumsum(v, axis=0)
    n = np.minimum(np.arange(1, len(v) + 1), window).reshape((-1,) + (1,) * (v.ndim - 1))
    lagged = np.concatenate([np.zeros((window,) + v.shape[1:]), c[:-window]]) if len(v) > window else np.zeros_like(c)
    return (c - lagged[:len(v)]) / n


def signed_residual_series(actual, estimate, ripple_phasor, window: int = WINDOW, uncertainty_gains=None,
                           regressors=None, calibration_samples: int = 0, params=None, period: float = 1.0):
    """(residuals, bounds) of whole series (time first, one column per axis) through :class:`SignedResidual`;
    with ``calibration_samples`` > 0 each wheel learns its unit from its first samples (``regressors``:
    (n, axes, 6), calibration.regressors).

    Parameters
    ----------
    actual : array_like, shape (n, N)
        Measured reaction torque r [N m]: samples, wheels.
    estimate : array_like, shape (n, N)
        The observer's estimate r^ [N m].
    ripple_phasor : array_like of complex, shape (n, N)
        The FDI samples' ripple phasors [N m] (telemetry.py).
    window : int, optional
        W [samples].
    uncertainty_gains : sequence of float, optional
        kappa per wheel (dimensionless), N of them; default 0 for every wheel.
    regressors : array_like, shape (n, N, 6), optional
        calibration.regressors of the samples [N m]; needed with ``calibration_samples`` > 0.
    calibration_samples : int, optional
        FDI samples each wheel learns its unit from; 0: no calibration.
    params : WheelParams, optional
        The wheel type (its ripple B/2, :func:`ripple_share`, its tachometer's noise and its calibration);
        None: the thesis'.
    period : float, optional
        [s] the FDI sample period (:func:`speed_noise_reach`).

    Returns
    -------
    residuals : ndarray, shape (n, N)
        The signed moving mean of r - r^ (calibrated) [N m].
    bounds : ndarray, shape (n, N)
        What each may hold unfaulted [N m].
    """
    actual, estimate, phasor = (np.asarray(x) for x in (actual, estimate, ripple_phasor))
    res, bound = np.empty(actual.shape), np.empty(actual.shape)
    uncertainty_gains = np.zeros(actual.shape[1]) if uncertainty_gains is None else uncertainty_gains
    for j in range(actual.shape[1]):
        f = SignedResidual.of_wheel(params, period, window, uncertainty_gains[j], calibration_samples)
        x = regressors[:, j] if calibration_samples else [None] * len(actual)
        rows = [f.update(a, e, p, r) for a, e, p, r in zip(actual[:, j], estimate[:, j], phasor[:, j], x)]
        res[:, j], bound[:, j] = [r[0] for r in rows], [r[1] for r in rows]
    return res, bound


def demand_ratio(actual, estimate, ripple_phasor, active: float | None = None, params=None) -> float | None:
    """One fault-free run of one wheel: the largest (|residual| - ripple bound) / mean(|r|) over the
    samples where mean(|r|) > ``active`` N m (a manoeuvre), i.e. how much the observer erred per unit of
    the torque it was asked for (series (n,) of r, r^ and the ripple phasor); None: no manoeuvre.

    Parameters
    ----------
    actual : array_like, shape (n,)
        Measured reaction torque r [N m].
    estimate : array_like, shape (n,)
        The observer's estimate r^ [N m].
    ripple_phasor : array_like of complex, shape (n,)
        The FDI samples' ripple phasors [N m].
    active : float, optional
        Torque demand mean(|r|) above which a sample counts [N m]; None: 1e-3 N m for the Type A, scaled by
        another type's torque (wheel.torque_scale).
    params : WheelParams, optional
        The wheel type (its ripple bound and torques); None: the thesis'.

    Returns
    -------
    float or None
        The largest ratio (dimensionless), None when no sample is active.
    """
    from ..physics.wheel import WheelParams, torque_scale
    active = 1e-3 * torque_scale(params or WheelParams()) if active is None else active
    r = np.asarray(actual, float)[:, None]
    res, bound = signed_residual_series(r, np.asarray(estimate, float)[:, None],
                                        np.asarray(ripple_phasor)[:, None], params=params)
    demand = window_mean(np.abs(r))
    busy = demand > active
    return float(((np.abs(res) - bound)[busy] / demand[busy]).max()) if busy.any() else None


def demand_gain(ratios, false_alarm_rate: float = FALSE_ALARM_RATE) -> float:
    """kappa of :class:`SignedResidual`'s bound from the runs' :func:`demand_ratio`: the (1 - alpha / 6)
    quantile of a Gumbel law fitted to them (:func:`gumbel_fit`), never below the largest (twice the
    largest for fewer than 4 runs: too few for a tail). An observer whose error grows with the torque
    demand gets a bound that does too; alpha / 6: half the designed per-run false-alarm rate over three
    axes, the band c (:func:`fit_band`) gets the other half.

    Parameters
    ----------
    ratios : iterable of float
        :func:`demand_ratio` of each fault-free run (the Nones left out), dimensionless.
    false_alarm_rate : float, optional
        Designed per-run false-alarm probability alpha.

    Returns
    -------
    float
        kappa >= 0 (dimensionless; 0 for no ratios).
    """
    ratios = list(ratios)
    if len(ratios) < 4:
        kappa = 2.0 * max(ratios, default=0.0)
    else:
        kappa = max(gumbel_quantile(*gumbel_fit(ratios), 1.0 - false_alarm_rate / 6.0), max(ratios))
    return max(kappa, 0.0)
