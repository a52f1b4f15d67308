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

SAMPLINGS = ("mean", "instant")


class FdiSampler:
    """Feed (stamp_ns, u, r) at the control rate; get (stamp_ns, u, r) back on every FDI stamp."""

    def __init__(self, period: float = 1.0, mode: str = "mean"):
        if mode not in SAMPLINGS:
            raise ValueError(f"FDI sampling must be one of {SAMPLINGS}, got {mode!r}")
        self.period_ns = int(round(period * 1e9))
        self.mode = mode
        self.sum_u = self.sum_r = 0.0
        self.count = 0

    def add(self, stamp_ns: int, u, r):
        u, r = np.asarray(u, float), np.asarray(r, float)
        self.sum_u, self.sum_r, self.count = self.sum_u + u, self.sum_r + r, self.count + 1
        if stamp_ns % self.period_ns:
            return None
        if self.mode == "mean":
            out = (stamp_ns, self.sum_u / self.count, self.sum_r / self.count)
        else:
            out = (stamp_ns, u, r)
        self.sum_u = self.sum_r = 0.0
        self.count = 0
        return out


def sample_series(stamps_ns, u, r, period: float = 1.0, mode: str = "mean"):
    """Whole control-rate series -> (stamps_ns, u, r) at the FDI period, through :class:`FdiSampler`."""
    sampler = FdiSampler(period, mode)
    rows = [row for row in (sampler.add(int(s), ui, ri) for s, ui, ri in zip(stamps_ns, u, r)) if row is not None]
    if not rows:
        return np.zeros(0, np.int64), np.zeros((0,) + np.shape(u)[1:]), np.zeros((0,) + np.shape(r)[1:])
    return (np.array([x[0] for x in rows], np.int64), np.array([x[1] for x in rows]), np.array([x[2] for x in rows]))
