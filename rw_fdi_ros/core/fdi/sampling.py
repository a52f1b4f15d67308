"""From the control-rate signals to FDI samples (thesis 4.3.3: 1 s samples).

[choice] ``mean`` (default): each FDI sample at t is the mean of the
control-period samples in (t - T, t], a box anti-alias filter before
decimation. The sampled reaction torque carries the ~143 Hz commutation
ripple (physics.md item 7); taken instantaneously once a second it aliases
into slow beats whose amplitude depends on the wheel speed, which the
fault-free threshold curves cannot bound. Same 100 fitting / 20 held-out runs,
same training: Elman held-out false alarms 30 % (instant) against 0 % (mean)
at P = 3, threshold reliability 87-90 % against 92-99 %.
``instant`` is the thesis' plain sampling, kept for comparison.
"""
from __future__ import annotations

import numpy as np

from ..mission.plant_choices import SAMPLINGS



class FdiSampler:
    """Feed (stamp_ns, *signals) at the control rate; get (stamp_ns, signals) back on every FDI stamp.

    ``signals`` are arrays (real or complex); the result holds their means over the period
    (``mean``) or their values at the stamp (``instant``).
    """

    def __init__(self, period: float = 1.0, mode: str = "mean"):
        if mode not in SAMPLINGS:
            raise ValueError(f"FDI sampling must be one of {SAMPLINGS}, got {mode!r}")
        self.period_ns = int(round(period * 1e9))
        self.mode = mode
        self.sums = None
        self.count = 0

    def add(self, stamp_ns: int, *signals):
        """One control-rate sample; on an FDI stamp, the period's result.

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp [ns].
        *signals : array_like
            The signals' values (real or complex).

        Returns
        -------
        tuple or None
            (stamp_ns, list of arrays: period means or values at the stamp) on an FDI stamp, else None.
        """
        values = [np.asarray(s) for s in signals]
        self.sums = values if self.sums is None else [a + v for a, v in zip(self.sums, values)]
        self.count += 1
        if stamp_ns % self.period_ns:
            return None
        out = [a / self.count for a in self.sums] if self.mode == "mean" else [np.array(v) for v in values]
        self.sums = None
        self.count = 0
        return stamp_ns, out


def sample_series(stamps_ns, u, r, period: float = 1.0, mode: str = "mean"):
    """Whole control-rate series -> (stamps_ns, u, r) at the FDI period, through :class:`FdiSampler`.

    Parameters
    ----------
    stamps_ns : array_like of int, shape (n,)
        Control sample stamps [ns].
    u : array_like, shape (n, ...)
        Torque command voltage [V], e.g. (n, N): samples, wheels.
    r : array_like, shape (n, ...)
        Reaction torque [N m].
    period : float, optional
        FDI period T [s].
    mode : str, optional
        ``mean`` (over (t - T, t]) or ``instant``.

    Returns
    -------
    stamps_ns : ndarray of int64, shape (m,)
        FDI stamps [ns], the multiples of ``period`` among ``stamps_ns``.
    u : ndarray, shape (m, ...)
        FDI samples of the command [V].
    r : ndarray, shape (m, ...)
        FDI samples of the reaction torque [N m].
    """
    sampler = FdiSampler(period, mode)
    rows = [row for row in (sampler.add(int(s), np.asarray(ui, float), np.asarray(ri, float))
                            for s, ui, ri in zip(stamps_ns, u, r)) if row is not None]
    if not rows:
        return np.zeros(0, np.int64), np.zeros((0,) + np.shape(u)[1:]), np.zeros((0,) + np.shape(r)[1:])
    return (np.array([x[0] for x in rows], np.int64), np.array([x[1][0] for x in rows]),
            np.array([x[1][1] for x in rows]))
