"""The ways a fault may have grown: a step or a ramp of the family's parameter from its healthy value, and how far
each ramp has come at a time since the first sample counted.
"""
from __future__ import annotations

import numpy as np


# The ways a fault may have grown (steps, and ramps of 50-300 s in service: rw-fdi bench service). A ramp is
# (a, D): the share of its way it had come at the first sample counted (a slow ramp's alarm lags its onset by
# more than the samples kept before an alarm) and the seconds from that sample to its end, so at ``elapsed``
# seconds from the first sample phi = a + (1 - a) min(elapsed / D, 1). The step (phi = 1 throughout) is first.
RAMP_START_SHARES = (0.0, 0.2, 0.4, 0.55, 0.7, 0.8, 0.9, 0.95)
RAMP_SECONDS = (10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 105.0, 120.0, 135.0, 150.0, 165.0,
                180.0, 200.0, 225.0, 250.0, 275.0, 300.0, 350.0, 400.0)
# a slow ramp whose first tenth or so passed unseen before the first sample counted (a wheel held at one operating
# point from its alarm on): between the step's 0 and 0.2, on the ramps of a minute and longer only, where a shorter
# one would let a current loss mimic a bus ramp's few driven samples (chosen on the tuning seeds: docs/fdir.md)
SLOW_START_SHARES = (0.03, 0.06, 0.1, 0.15)
SLOW_SECONDS = 60.0
_RAMPS = ([(a, d) for a in RAMP_START_SHARES for d in RAMP_SECONDS]
          + [(a, d) for a in SLOW_START_SHARES for d in RAMP_SECONDS if d >= SLOW_SECONDS])
RAMP_SHARE = np.array([1.0] + [a for a, _ in _RAMPS])
RAMP_LENGTH = np.array([0.0] + [d for _, d in _RAMPS])


def _ramp_neighbours() -> list:
    """Ramp index -> the ramps next to it (itself included): at its length and the lengths either side, the
    ramps of its share and of the shares either side of it there; the step (index 0) has none."""
    lengths = sorted(set(RAMP_LENGTH[1:]))
    out = [np.array([], int)]
    for a, d in zip(RAMP_SHARE[1:], RAMP_LENGTH[1:]):
        i, near = lengths.index(d), []
        for length in lengths[max(i - 1, 0):i + 2]:
            row = np.flatnonzero(RAMP_LENGTH == length)
            row = row[np.argsort(RAMP_SHARE[row])]
            k = int(np.searchsorted(RAMP_SHARE[row], a))
            near += list(row[max(k - 1, 0):k + 1 + int(k < row.size and RAMP_SHARE[row][k] == a)])
        out.append(np.unique(near))
    return out


_NEIGHBOURS = _ramp_neighbours()
RAMP_NOTED_S = 30.0   # [s] a shorter ramp is reported as the step it all but is


# ProfileSums keeps its ramps longest first, so the ramps still growing are always the first ones (a slice,
# updated in place; an index gather/scatter over them cost 7 ms a sample)
_LONGEST_FIRST = np.argsort(-RAMP_LENGTH, kind="stable")
_LENGTH_LONGEST_FIRST = RAMP_LENGTH[_LONGEST_FIRST]
_RAMP_ORDER = np.argsort(_LONGEST_FIRST)     # stored position -> RAMP_SHARE/RAMP_LENGTH order


def ramp_fractions(elapsed: float) -> np.ndarray:
    """phi of every ramp (RAMP_SHARE, RAMP_LENGTH) at ``elapsed`` seconds from the first sample counted.

    Parameters
    ----------
    elapsed : float
        Time from the first sample counted [s].

    Returns
    -------
    ndarray, shape (H,)
        phi in [0, 1] per ramp (1 for the step), H = len(RAMP_LENGTH).
    """
    grown = np.clip(float(elapsed) / np.maximum(RAMP_LENGTH, 1e-9), 0.0, 1.0)
    return np.where(RAMP_LENGTH > 0.0, RAMP_SHARE + (1.0 - RAMP_SHARE) * grown, 1.0)

