"""The FDI's methods, observers and alarm rule (thesis 3.2, 4.3.3; evaluation.md); the residuals are in
residuals.py, the fitting of thresholds in threshold_fit.py, their file in threshold_file.py.

Two methods, chosen by ``fdi_method`` (one setting for the whole FDI):

``thesis`` (the thesis as written):
    residual_k   = mean(|r_j - r^_j|, j = k-W+1..k)           moving average, W = 40 FDI samples
    threshold_k  = mean_n(residual_k) + 3 std_n(residual_k)   over N fault-free runs n (eq. 4.11)
    alarm        = residual above threshold for P = 5 consecutive samples

``speed_aware`` (ours, docs/fdi.md):
    residual_k   = mean(r_j - r^_j, j = k-W+1..k)             signed: zero-mean ripple cancels
    bound_k      = (B/2) g_max reach(p_j) / W + kappa mean(|r_j|)   aliased ripple (telemetry.py) + model error
    threshold_k  = c_axis + bound_k                           c: designed false-alarm rate (threshold_fit)
    alarm        = |residual| above threshold for P consecutive samples
The first W-1 samples average what exists so far (the thesis leaves it open).
"""
from __future__ import annotations

import numpy as np

WINDOW = 40
SIGMAS = 3.0
METHODS = ("speed_aware", "thesis")
# The observers, by slot: 'elman' the Elman network (thesis 4), 'linear' the Luenberger observer of the
# linearised wheel (thesis 3.3), 'model' the nominal wheel model at the measured command and speed (needs
# the tachometer: speed-aware only). Their topics, threshold files and report columns go by slot.
OBSERVERS = ("elman", "linear", "model")


def observers_of(method: str) -> tuple:
    """The observers an FDI of ``method`` runs: all three speed-aware, the thesis' two (Elman, Luenberger).

    Parameters
    ----------
    method : str
        ``speed_aware`` or ``thesis`` (METHODS); ValueError otherwise.

    Returns
    -------
    tuple of str
        Observer slots, of OBSERVERS.
    """
    if method not in METHODS:
        raise ValueError(f"fdi_method must be one of {', '.join(METHODS)}, got {method!r}")
    return OBSERVERS if method == "speed_aware" else OBSERVERS[:2]

FALSE_ALARM_RATE = 1e-3       # designed per-run false-alarm probability of the speed-aware FDI
PERSISTENCE_SPEED_AWARE = 3
# P: the smallest persistence whose Elman false-alarm rate on the 20 held-out fault-free runs is
# <= 5 % (config/fdi/defaults_report.md: 15 / 10 / 10 / 5 / 5 % for P = 1 / 2 / 3 / 5 / 8); it costs
# P - 1 seconds of detection delay.
PERSISTENCE = 5
PERSISTENCE_MAX = 1000        # [FDI samples] the most any command or node takes: over 16 min of waiting


class AlarmRule:
    """The persistence rule sample by sample (the isolation node), with first-alarm bookkeeping."""

    def __init__(self, persistence: int = PERSISTENCE):
        self.persistence = persistence
        self.run = 0
        self.active = False
        self.first_alarm = None

    def update(self, residual: float, threshold: float, t: float) -> bool:
        """One sample: the alarm is active once the residual exceeded the threshold ``persistence`` samples in a row.

        Parameters
        ----------
        residual : float
            The residual [N m].
        threshold : float
            Its threshold [N m].
        t : float
            The sample's time [s] (the first alarm's).

        Returns
        -------
        bool
            Whether the alarm is active.
        """
        self.run = self.run + 1 if residual > threshold else 0
        self.active = self.run >= self.persistence
        if self.active and self.first_alarm is None:
            self.first_alarm = t
        return self.active


def alarm_series(residual, threshold, times, persistence: int = PERSISTENCE):
    """(alarm flags, first alarm time or None) of one axis through :class:`AlarmRule`.

    Parameters
    ----------
    residual : array_like, shape (n,)
        The residual [N m] (|residual| for the speed-aware method).
    threshold : array_like, shape (n,)
        The threshold [N m] at each sample.
    times : array_like, shape (n,)
        Sample times [s].
    persistence : int, optional
        P [samples].

    Returns
    -------
    flags : ndarray of bool, shape (n,)
        Whether the alarm is active at each sample.
    first_alarm : float or None
        Time of the first alarm [s], None without one.
    """
    rule = AlarmRule(persistence)
    flags = np.array([rule.update(r, c, t) for r, c, t in zip(residual, threshold, times)], bool)
    return flags, rule.first_alarm
