"""Residuals, threshold curves and the alarm rule (thesis 3.2, 4.3.3; evaluation.md).

residual_k   = mean(|r_j - r^_j|, j = k-W+1..k)           moving average, W = 40 FDI samples
threshold_k  = mean_n(residual_k) + 3 std_n(residual_k)   over N fault-free runs n (eq. 4.11)
alarm        = residual above threshold for P consecutive samples
The first W-1 samples average what exists so far (the thesis leaves it open).
"""
from __future__ import annotations

import json
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

WINDOW = 40
SIGMAS = 3.0
# P: the smallest persistence whose Elman false-alarm rate on the 20 held-out fault-free runs is
# <= 5 % (config/fdi/defaults_report.md: 15 / 10 / 10 / 5 / 5 % for P = 1 / 2 / 3 / 5 / 8); it costs
# P - 1 seconds of detection delay.
PERSISTENCE = 5


class ThresholdError(ValueError):
    """Threshold curves that cannot be used; one line naming the file and the fix."""


REFIT = "regenerate with `rw-fdi fit-thresholds --bags DIR --out DIR` (or `rw-fdi defaults` for the shipped set)"


class ResidualFilter:
    """The same moving average, one sample at a time (the observer nodes)."""

    def __init__(self, window: int = WINDOW):
        self.buffer = deque(maxlen=window)
        self.total = 0.0

    def update(self, actual, estimate):
        err = abs(float(actual) - float(estimate))
        if len(self.buffer) == self.buffer.maxlen:
            self.total -= self.buffer[0]
        self.buffer.append(err)
        self.total += err
        return self.total / len(self.buffer)


def fit_threshold_curve(residuals, sigmas: float = SIGMAS):
    """mean + k sigma over runs, per time index; residuals shaped (runs, samples, ...)."""
    r = np.asarray(residuals, float)
    return r.mean(axis=0) + sigmas * r.std(axis=0)


class AlarmRule:
    """The persistence rule sample by sample (the isolation node), with first-alarm bookkeeping."""

    def __init__(self, persistence: int = PERSISTENCE):
        self.persistence = persistence
        self.run = 0
        self.active = False
        self.first_alarm = None

    def update(self, residual: float, threshold: float, t: float) -> bool:
        self.run = self.run + 1 if residual > threshold else 0
        self.active = self.run >= self.persistence
        if self.active and self.first_alarm is None:
            self.first_alarm = t
        return self.active


def residual_series(actual, estimate, window: int = WINDOW):
    """Residuals of whole series (time first, one column per axis) through :class:`ResidualFilter`."""
    actual, estimate = np.atleast_2d(np.asarray(actual, float).T).T, np.atleast_2d(np.asarray(estimate, float).T).T
    out = np.empty(actual.shape)
    for j in range(actual.shape[1]):
        f = ResidualFilter(window)
        out[:, j] = [f.update(a, e) for a, e in zip(actual[:, j], estimate[:, j])]
    return out


def alarm_series(residual, threshold, times, persistence: int = PERSISTENCE):
    """(alarm flags, first alarm time or None) of one axis through :class:`AlarmRule`."""
    rule = AlarmRule(persistence)
    flags = np.array([rule.update(r, c, t) for r, c, t in zip(residual, threshold, times)], bool)
    return flags, rule.first_alarm


@dataclass
class ThresholdCurves:
    """Curves per observer and axis, indexed by FDI sample, with the conditions they were fitted under."""

    observer: str
    curves: dict                     # axis -> np.ndarray (samples,)
    sample_period: float = 1.0
    window: int = WINDOW
    sigmas: float = SIGMAS
    seeds: list = field(default_factory=list)
    plant: dict = field(default_factory=dict)   # emf_limit, control_period, ... of the fitting runs
    model: str = ""                  # the model card the residuals came from

    def at(self, axis: str, k: int) -> float:
        c = self.curves[axis]
        return float(c[min(k, len(c) - 1)])   # past the fitted horizon the last value holds

    def save(self, path):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({
            "observer": self.observer, "sample_period": self.sample_period, "window": self.window,
            "sigmas": self.sigmas, "runs": len(self.seeds), "seeds": self.seeds, "plant": self.plant,
            "model": self.model, "curves": {a: [float(v) for v in c] for a, c in self.curves.items()}}, indent=1))

    @classmethod
    def load(cls, path) -> "ThresholdCurves":
        path = Path(path)
        if not path.is_file():
            raise ThresholdError(f"threshold file not found: {path}; {REFIT}")
        try:
            raw = json.loads(path.read_text())
            curves = {a: np.asarray(c, float) for a, c in raw["curves"].items()}
            out = cls(observer=raw["observer"], curves=curves, sample_period=float(raw["sample_period"]),
                      window=int(raw["window"]), sigmas=float(raw["sigmas"]), seeds=list(raw["seeds"]),
                      plant=dict(raw["plant"]), model=str(raw.get("model", "")))
        except (ValueError, KeyError, TypeError) as exc:
            raise ThresholdError(f"{path}: not a readable threshold file ({type(exc).__name__}: {exc}); {REFIT}") from None
        if set(out.curves) != {"x", "y", "z"} or any(len(c) == 0 or not np.all(np.isfinite(c))
                                                     for c in out.curves.values()):
            raise ThresholdError(f"{path}: needs finite curves for axes x, y, z; {REFIT}")
        return out

    def check_compatible(self, plant: dict, origin: str = "thresholds"):
        """Refuse curves fitted under other plant choices than the running graph's."""
        for key, value in plant.items():
            fitted = self.plant.get(key)
            if fitted is not None and fitted != value:
                raise ThresholdError(f"{origin}: fitted with {key}={fitted!r} but the graph runs {key}={value!r}; "
                                     f"{REFIT}")
