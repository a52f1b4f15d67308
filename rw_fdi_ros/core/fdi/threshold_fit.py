"""Fitting thresholds from fault-free runs: the thesis' mean + 3 sigma curves (eq. 4.11), and our bands c for a
designed per-run false-alarm rate (the Gumbel tail of the run statistic), with the runs a rate needs."""
from __future__ import annotations

import math

import numpy as np

from .detection import FALSE_ALARM_RATE, SIGMAS
from .threshold_file import ThresholdError

def run_statistic(excess, persistence: int):
    """max_k of min(excess_j, j = k-P+1..k): the largest level the alarm rule would have crossed.

    ``excess``: |residual| - bound per sample (time on axis 0). An alarm with band c fires in a
    run exactly when its statistic exceeds c.

    Parameters
    ----------
    excess : array_like, shape (n, ...)
        |residual| - bound [N m], samples first, e.g. (n, N) for a run's wheels.
    persistence : int
        P [samples].

    Returns
    -------
    ndarray, shape excess.shape[1:]
        The run statistic [N m] per column; -inf throughout when the run has fewer than P samples.
    """
    e = np.asarray(excess, float)
    if len(e) < persistence:
        return np.full(e.shape[1:], -np.inf)
    from numpy.lib.stride_tricks import sliding_window_view
    return sliding_window_view(e, persistence, axis=0).min(axis=-1).max(axis=0)


def gumbel_fit(maxima, upper: float = 0.5):
    """(mu, beta) of a Gumbel law fitted to the upper ``upper`` share of ``maxima`` on a Gumbel
    probability plot: x_(i) = mu + beta y_i, y_i = -ln(-ln p_i), Gringorten's p_i = (i - 0.44) / (n + 0.12).

    Only the upper tail sets a threshold. A run whose wheel sits near an alias speed carries a
    large ripple bound all run long and a very negative statistic; such runs say nothing about
    the tail, and in a fit by moments they inflated beta five-fold (the Elman bands of
    2026-11-23, c = 0.7-1.9e-3 N m against fitting maxima below 0.08e-3).

    Parameters
    ----------
    maxima : array_like, shape (runs,)
        One maximum per run (e.g. :func:`run_statistic`, [N m]).
    upper : float, optional
        Share of the sorted maxima, from the top, fitted; with fewer than 3 of them, a fit by moments.

    Returns
    -------
    mu : float
        Location, in the unit of ``maxima``.
    beta : float
        Scale (at least 1e-12), in the unit of ``maxima``.
    """
    x = np.sort(np.asarray(maxima, float))
    n = len(x)
    if n * upper < 3:   # no tail to fit a line to: moments (beta = s sqrt(6) / pi)
        beta = max(float(x.std(ddof=1)) * np.sqrt(6.0) / np.pi if n > 1 else 0.0, 1e-12)
        return float(x.mean()) - 0.5772156649 * beta, beta
    y = -np.log(-np.log((np.arange(1, n + 1) - 0.44) / (n + 0.12)))
    top = slice(int(np.floor(n * (1.0 - upper))), n)
    beta, mu = np.polyfit(y[top], x[top], 1)
    return float(mu), max(float(beta), 1e-12)


def gumbel_quantile(mu: float, beta: float, probability: float) -> float:
    """x with P(M <= x) = probability: mu - beta ln(-ln p).

    Parameters
    ----------
    mu, beta : float
        The law's location and scale (:func:`gumbel_fit`).
    probability : float or array_like
        p, in (0, 1).

    Returns
    -------
    float or ndarray
        x, in the unit of ``mu``, the shape of ``probability``.
    """
    return mu - beta * np.log(-np.log(probability))


# A band's Gumbel tail fit reaches at most this far beyond the level its runs show themselves (1/n of n runs),
# and is never fitted on fewer than MIN_FIT_RUNS (the upper half it fits: 5 maxima): 1e-3 per run then needs 60
# runs for an Elman band (half of alpha over three axes), 30 for the model observer's; the shipped bands are fitted
# on 100.
EXTRAPOLATION = 100.0
MIN_FIT_RUNS = 10


def fitting_runs_needed(false_alarm_rate: float, share: float = 1.0, axes: int = 3) -> int:
    """Fault-free runs a band for per-run ``false_alarm_rate`` needs (its per-axis level alpha = share x rate /
    axes at most EXTRAPOLATION times beyond 1/n), never fewer than MIN_FIT_RUNS.

    Parameters
    ----------
    false_alarm_rate : float
        Designed per-run false-alarm probability over all axes.
    share : float, optional
        Share of it the band spends (0.5 for an Elman or Luenberger band, 1 for the model observer's).
    axes : int, optional
        Number of axes (wheels) it is split over.

    Returns
    -------
    int
        Fault-free fitting runs needed.
    """
    return max(MIN_FIT_RUNS, math.ceil(axes / (share * false_alarm_rate * EXTRAPOLATION)))


def rate_carried(runs: int, share: float = 0.5, axes: int = 3) -> float:
    """The smallest per-run false-alarm rate ``runs`` fitting runs can carry (:func:`fitting_runs_needed` the other
    way round; share 0.5: an Elman band's, the most demanding).

    Parameters
    ----------
    runs : int
        Fault-free fitting runs at hand.
    share : float, optional
        Share of the rate the band spends.
    axes : int, optional
        Number of axes (wheels) it is split over.

    Returns
    -------
    float
        The per-run false-alarm probability.
    """
    return axes / (share * max(runs, 1) * EXTRAPOLATION)


def fit_band(statistics, false_alarm_rate: float = FALSE_ALARM_RATE, axes=("x", "y", "z"), share: float = 1.0,
             floor: float = -np.inf) -> dict:
    """Band c per axis for a per-run false-alarm probability ``share`` x ``false_alarm_rate`` over all axes.

    ``statistics``: (runs, axes) run statistics of fault-free fitting runs (run_statistic). Each
    axis gets share x alpha / n_axes (Bonferroni; an Elman network spends the other half of
    alpha on its uncertainty gain kappa, tools/design/train.uncertainty_gain); the upper half of its run
    maxima is fitted with a Gumbel law (the limit law of maxima of light-tailed sequences; :func:`gumbel_fit`), whose
    (1 - alpha/n) quantile is c: an empirical quantile of a few hundred runs cannot reach 1e-3.
    Never below the largest fitting-run statistic, nor below ``floor``.

    Parameters
    ----------
    statistics : array_like, shape (runs, len(axes))
        :func:`run_statistic` of each fault-free run and axis [N m].
    false_alarm_rate : float, optional
        Designed per-run false-alarm probability over all axes.
    axes : sequence of str, optional
        The axes' (wheels') names, in the columns' order.
    share : float, optional
        Share of ``false_alarm_rate`` the bands spend.
    floor : float, optional
        The smallest band [N m]: what no residual can promise less than (its observer's unmodelled noise,
        wheel.bearing_noise_mean); fitting runs whose ripple bound always covered it do not show it.

    Returns
    -------
    dict of str to dict
        Per axis: ``band`` c, ``gumbel_mu``, ``gumbel_beta``, ``fitting_max`` [N m].
    """
    s = np.asarray(statistics, float)
    needed = fitting_runs_needed(false_alarm_rate, share, len(axes))
    if len(s) < MIN_FIT_RUNS:   # no rate helps: a Gumbel fit needs that many maxima
        raise ThresholdError(f"{len(s)} fitting run(s): a band needs at least {MIN_FIT_RUNS} fault-free runs, "
                             "whatever the false-alarm rate")
    if len(s) < needed:
        raise ThresholdError(f"{len(s)} fitting run(s) cannot promise a per-run false-alarm rate of "
                             f"{false_alarm_rate:g}: a band needs at least {needed} fault-free runs (or ask for a "
                             f"rate of {rate_carried(len(s), share, len(axes)):.2g} or more)")
    per_axis = share * false_alarm_rate / len(axes)
    out = {}
    for i, a in enumerate(axes):
        mu, beta = gumbel_fit(s[:, i])
        out[a] = {"band": max(gumbel_quantile(mu, beta, 1.0 - per_axis), float(s[:, i].max()), floor),
                  "gumbel_mu": mu, "gumbel_beta": beta, "fitting_max": float(s[:, i].max())}
    return out


def fit_threshold_curve(residuals, sigmas: float = SIGMAS):
    """mean + k sigma over runs, per time index; residuals shaped (runs, samples, ...).

    Parameters
    ----------
    residuals : array_like, shape (runs, n, ...)
        Fault-free runs' residuals [N m], all of one length n.
    sigmas : float, optional
        k.

    Returns
    -------
    ndarray, shape (n, ...)
        The threshold curve [N m].
    """
    r = np.asarray(residuals, float)
    return r.mean(axis=0) + sigmas * r.std(axis=0)
