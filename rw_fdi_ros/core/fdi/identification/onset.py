"""Where a fault's effect in a wheel's model error begins: the first sample the identifier counts."""
from __future__ import annotations

import numpy as np

from .families import SIGMA_FLOOR

ONSET_HEALTHY = 4   # samples before a fault's onset its healthy fit needs (onset_index: a constant, the ripple)


def onset_index(errors, ripple_phasors, floor: float = SIGMA_FLOOR) -> int:
    """Where a fault's effect in the model error ``errors`` begins (the index of its first sample).

    First the single change point of a step in white noise with the aliased commutation ripple and a
    constant (what the model leaves of a unit not yet calibrated) as nuisance (Basseville & Nikiforov,
    Detection of Abrupt Changes, 1993, sec. 2.2):

        e_j = c + alpha Im p_j + beta Re p_j + delta 1[j >= k] + noise,    k^ = argmin_k RSS_k

    then, as a fault's effect is a step only while the spacecraft holds (a large one grows over the
    seconds before its alarm, a ramp over minutes), the change point of a growing effect lies inside
    it: back from k^ while the sample before leaves the healthy fit (c, alpha, beta) of the samples
    before it by more than 3 max(s, sigma_floor) (s: their residual's rms), and forward from there to
    the first sample that leaves the fit of the samples before it. Without the ripple terms the change
    point followed the ripple: near an alias speed it swings a healthy wheel's error by as much as a
    small fault for tens of seconds; without the walk back a wheel given up seconds after its onset
    lost one of its three or four driven samples (docs/fdir.md).

    Parameters
    ----------
    errors : array_like, shape (n,)
        Model error r - r^ of each FDI sample [N m].
    ripple_phasors : array_like of complex, shape (n,)
        The samples' ripple phasors p [N m].
    floor : float, optional
        The smallest misfit taken for real [N m] (SIGMA_FLOOR times the type's wheel.torque_scale).

    Returns
    -------
    int
        Index of the first sample of the fault's effect, 0 <= index < n (0 for n < 2).
    """
    e = np.asarray(errors, float)
    p = np.asarray(ripple_phasors, complex)
    n = e.size
    if n < 2:
        return 0
    healthy = np.column_stack([np.ones(n), p.imag, p.real])
    fewest = min(ONSET_HEALTHY, n - 1)   # samples before the step: the healthy fit needs them
    best = _step_change_point(e, healthy, fewest)
    while best > fewest:
        left, level = _departure(e, healthy, best - 1, floor)
        if left[best - 1] <= level:
            break
        best -= 1
    left, level = _departure(e, healthy, best, floor)
    away = np.nonzero(left[best:] > level)[0]
    return best + int(away[0]) if away.size else best


def _step_change_point(e, healthy, fewest: int) -> int:
    """k^ = argmin_k RSS_k over k >= ``fewest``: the least-squares step of ``e`` beside the ``healthy`` columns H,
    every k at once: with P the projection off H's columns and s_k = 1[j >= k],

        RSS_k = |P e|^2 - (s_k^T P e)^2 / (s_k^T P s_k),

    s_k^T P e a suffix sum of P e and s_k^T P s_k = (n - k) - |B^T s_k|^2, B an orthonormal basis of H's columns
    (each scaled to unit length first: a ripple of 1e-8 N m is a column as good as any; rank as lstsq takes it),
    B^T s_k the suffix sums of B's rows; a step H already holds leaves RSS_k = |P e|^2."""
    n = e.size
    norms = np.linalg.norm(healthy, axis=0)
    columns = healthy / np.where(norms > 0.0, norms, 1.0)
    u, singular, _ = np.linalg.svd(columns, full_matrices=False)
    basis = u[:, singular > singular.max() * max(columns.shape) * np.finfo(float).eps]
    residual = e - basis @ (basis.T @ e)                            # P e
    suffix_e = np.cumsum(residual[::-1])[::-1]                      # s_k^T P e for k = 0..n-1
    suffix_b = np.cumsum(basis[::-1], axis=0)[::-1]                 # B^T s_k, (n, rank)
    size = (n - np.arange(n)) - np.sum(suffix_b ** 2, axis=1)
    scale = np.arange(n, 0, -1)   # s_k^T s_k: a step left of it by rounding alone is none
    held = size > 1e-9 * scale
    gain = np.where(held, suffix_e ** 2 / np.where(held, size, 1.0), 0.0)
    return fewest + int(np.argmax(gain[fewest:]))   # the least RSS is the largest gain


def _departure(e, healthy, k: int, floor: float) -> tuple:
    """|e - the healthy fit of the samples before k| and the level a sample must pass to leave it."""
    fit, *_ = np.linalg.lstsq(healthy[:k], e[:k], rcond=None)
    left = np.abs(e - healthy @ fit)
    return left, 3.0 * max(float(np.sqrt(np.mean(left[:k] ** 2))), floor)
