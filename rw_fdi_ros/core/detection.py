"""Residuals, thresholds and the alarm rule (thesis 3.2, 4.3.3; evaluation.md).

Two methods, chosen by ``fdi_method`` (one setting for the whole FDI):

``thesis`` (the thesis as written):
    residual_k   = mean(|r_j - r^_j|, j = k-W+1..k)           moving average, W = 40 FDI samples
    threshold_k  = mean_n(residual_k) + 3 std_n(residual_k)   over N fault-free runs n (eq. 4.11)
    alarm        = residual above threshold for P = 5 consecutive samples

``speed_aware`` (ours, docs/fdi.md):
    residual_k   = mean(r_j - r^_j, j = k-W+1..k)             signed: zero-mean ripple cancels
    bound_k      = (B/2) g_max reach(p_j) / W + kappa mean(|r_j|)   aliased ripple (telemetry.py) + model error
    threshold_k  = c_axis + bound_k                           c: designed false-alarm rate (fit_band)
    alarm        = |residual| above threshold for P consecutive samples
The first W-1 samples average what exists so far (the thesis leaves it open).
"""
from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

WINDOW = 40
SIGMAS = 3.0
METHODS = ("speed_aware", "thesis")
# The observers, by slot: 'elman' the Elman network (thesis 4), 'linear' the Luenberger observer of the
# linearised wheel (thesis 3.3), 'model' the nominal wheel model at the measured command and speed (needs
# the tachometer: speed-aware only). Their topics, threshold files and report columns go by slot.
OBSERVERS = ("elman", "linear", "model")


def observers_of(method: str) -> tuple:
    """The observers an FDI of ``method`` runs: all three speed-aware, the thesis' two (Elman, Luenberger)."""
    if method not in METHODS:
        raise ValueError(f"fdi_method must be one of {', '.join(METHODS)}, got {method!r}")
    return OBSERVERS if method == "speed_aware" else OBSERVERS[:2]

# Ripple gains up to g_max are a disturbance the bound covers (a +60 % ripple must not alarm; thesis 5.3).
RIPPLE_GAIN_MAX = 2.0
FALSE_ALARM_RATE = 1e-3       # designed per-run false-alarm probability of the speed-aware FDI
PERSISTENCE_SPEED_AWARE = 3
CALIBRATION_SIGMAS = 3.0      # z: a calibrated correction's own uncertainty u_k enters the bound as z u_k
# P: the smallest persistence whose Elman false-alarm rate on the 20 held-out fault-free runs is
# <= 5 % (config/fdi/defaults_report.md: 15 / 10 / 10 / 5 / 5 % for P = 1 / 2 / 3 / 5 / 8); it costs
# P - 1 seconds of detection delay.
PERSISTENCE = 5
PERSISTENCE_MAX = 1000        # [FDI samples] the most any command or node takes: over 16 min of waiting


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


class SignedResidual:
    """Speed-aware residual of one wheel: signed moving mean of r - r^ and what it may hold unfaulted.

    ``update(actual, estimate, ripple_phasor[, regressors])`` -> (residual, bound) with
    bound = (B/2) g_max reach(p) / n + kappa mean(|r|) + z mean(u): the aliased ripple's largest
    contribution for any gain up to g_max that is constant or monotone over the window
    (:func:`ripple_reach`; ripple_phasor: the FDI sample's mean of tau_m e^{i N theta}, telemetry.py)
    plus the observer's own model error, which grows with the torque the wheel is asked for
    (``uncertainty_gain`` kappa: 0 for the nominal wheel model, measured on the training runs
    for an Elman network, tools/design/train.py), plus, with a ``calibration`` to the wheel's own unit
    (core/calibration.py), the uncertainty u of its correction to the estimate.
    """

    def __init__(self, window: int = WINDOW, share: float | None = None, ripple_gain_max: float = RIPPLE_GAIN_MAX,
                 uncertainty_gain: float = 0.0, calibration=None):
        self.errors = deque(maxlen=window)
        self.phasors = deque(maxlen=window)
        self.torques = deque(maxlen=window)
        self.spreads = deque(maxlen=window)
        self.scale = (ripple_share() if share is None else share) * ripple_gain_max
        self.kappa = float(uncertainty_gain)
        self.calibration = calibration   # core.calibration.UnitCalibration, or None (the datasheet wheel)
        self.estimate = None             # the last estimate, calibrated: what the node publishes

    def update(self, actual, estimate, ripple_phasor, regressors=None):
        """(residual, bound) after this sample; ``regressors``: calibration.regressors of the sample,
        needed with a calibration (which corrects the estimate and widens the bound by z u_k)."""
        actual, estimate, spread = float(actual), float(estimate), 0.0
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
                 + sum(self.spreads) / n)
        return sum(self.errors) / n, bound


def ripple_reach(phasors) -> float:
    """max_j max(|S_j|, |S_n - S_j|), S_j = p_1 + ... + p_j (S_0 = 0): the largest |sum g_k p_k| over
    every ripple gain g_k in [0, 1] that is monotone across the window.

    By Abel summation, sum g_k p_k = sum_j (g_j - g_j-1) (S_n - S_j-1) for a non-decreasing g
    (weights >= 0 that add up to g_n <= 1), and likewise with the head sums S_j for a
    non-increasing one. A constant gain gives |S_n|; a ripple that steps up inside the window
    (a bearing wearing) can reach further: with |S_n| alone, +100 % ripple from t = 248 s gave
    a residual of 7.2e-4 N m against a bound of 4.5e-4 at t = 277 s (seed 10200092).
    """
    partial = np.concatenate([[0.0], np.cumsum(np.fromiter(phasors, complex))])
    return float(np.maximum(np.abs(partial), np.abs(partial[-1] - partial)).max())


def ripple_share(params=None) -> float:
    """(B/2): the ripple amplitude per unit motor torque at ripple gain 1 (wheel.torque_ripple)."""
    from .wheel import WheelParams
    p = params or WheelParams()
    return p.ripple_amplitude_share * p.ripple_coefficient


def run_statistic(excess, persistence: int):
    """max_k of min(excess_j, j = k-P+1..k): the largest level the alarm rule would have crossed.

    ``excess``: |residual| - bound per sample (time on axis 0). An alarm with band c fires in a
    run exactly when its statistic exceeds c.
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
    """x with P(M <= x) = probability: mu - beta ln(-ln p)."""
    return mu - beta * np.log(-np.log(probability))


# A band's Gumbel tail fit reaches at most this far beyond the level its runs show themselves (1/n of n runs),
# and is never fitted on fewer than MIN_FIT_RUNS (the upper half it fits: 5 maxima): 1e-3 per run then needs 60
# runs for an Elman band (half of alpha over three axes), 30 for the model observer's; the shipped bands are fitted
# on 100.
EXTRAPOLATION = 100.0
MIN_FIT_RUNS = 10


def fitting_runs_needed(false_alarm_rate: float, share: float = 1.0, axes: int = 3) -> int:
    """Fault-free runs a band for per-run ``false_alarm_rate`` needs (its per-axis level alpha = share x rate /
    axes at most EXTRAPOLATION times beyond 1/n), never fewer than MIN_FIT_RUNS."""
    return max(MIN_FIT_RUNS, math.ceil(axes / (share * false_alarm_rate * EXTRAPOLATION)))


def rate_carried(runs: int, share: float = 0.5, axes: int = 3) -> float:
    """The smallest per-run false-alarm rate ``runs`` fitting runs can carry (:func:`fitting_runs_needed` the other
    way round; share 0.5: an Elman band's, the most demanding)."""
    return axes / (share * max(runs, 1) * EXTRAPOLATION)


def fit_band(statistics, false_alarm_rate: float = FALSE_ALARM_RATE, axes=("x", "y", "z"), share: float = 1.0) -> dict:
    """Band c per axis for a per-run false-alarm probability ``share`` x ``false_alarm_rate`` over all axes.

    ``statistics``: (runs, axes) run statistics of fault-free fitting runs (run_statistic). Each
    axis gets share x alpha / n_axes (Bonferroni; an Elman network spends the other half of
    alpha on its uncertainty gain kappa, tools/train.uncertainty_gain); the upper half of its run maxima is fitted
    with a
    Gumbel law (the limit law of maxima of light-tailed sequences; :func:`gumbel_fit`), whose
    (1 - alpha/n) quantile is c: an empirical quantile of a few hundred runs cannot reach 1e-3.
    Never below the largest fitting-run statistic.
    """
    s = np.asarray(statistics, float)
    needed = fitting_runs_needed(false_alarm_rate, share, len(axes))
    if len(s) < needed:
        raise ThresholdError(f"{len(s)} fitting run(s) cannot promise a per-run false-alarm rate of "
                             f"{false_alarm_rate:g}: a band needs at least {needed} fault-free runs (or ask for a "
                             f"rate of {rate_carried(len(s), share, len(axes)):.2g} or more)")
    per_axis = share * false_alarm_rate / len(axes)
    out = {}
    for i, a in enumerate(axes):
        mu, beta = gumbel_fit(s[:, i])
        out[a] = {"band": max(gumbel_quantile(mu, beta, 1.0 - per_axis), float(s[:, i].max())),
                  "gumbel_mu": mu, "gumbel_beta": beta, "fitting_max": float(s[:, i].max())}
    return out


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


def window_mean(values, window: int = WINDOW):
    """Moving mean over the last ``window`` samples (time first); the first W-1 average what exists."""
    v = np.asarray(values, float)
    c = np.cumsum(v, axis=0)
    n = np.minimum(np.arange(1, len(v) + 1), window).reshape((-1,) + (1,) * (v.ndim - 1))
    lagged = np.concatenate([np.zeros((window,) + v.shape[1:]), c[:-window]]) if len(v) > window else np.zeros_like(c)
    return (c - lagged[:len(v)]) / n


def signed_residual_series(actual, estimate, ripple_phasor, window: int = WINDOW, uncertainty_gains=(0.0, 0.0, 0.0),
                           regressors=None, calibration_samples: int = 0):
    """(residuals, bounds) of whole series (time first, one column per axis) through :class:`SignedResidual`;
    with ``calibration_samples`` > 0 each wheel learns its unit from its first samples (``regressors``:
    (n, axes, 6), calibration.regressors)."""
    from .calibration import UnitCalibration
    actual, estimate, phasor = (np.asarray(x) for x in (actual, estimate, ripple_phasor))
    res, bound = np.empty(actual.shape), np.empty(actual.shape)
    for j in range(actual.shape[1]):
        f = SignedResidual(window, uncertainty_gain=uncertainty_gains[j],
                           calibration=UnitCalibration(calibration_samples) if calibration_samples else None)
        x = regressors[:, j] if calibration_samples else [None] * len(actual)
        rows = [f.update(a, e, p, r) for a, e, p, r in zip(actual[:, j], estimate[:, j], phasor[:, j], x)]
        res[:, j], bound[:, j] = [r[0] for r in rows], [r[1] for r in rows]
    return res, bound


def demand_ratio(actual, estimate, ripple_phasor, active: float = 1e-3) -> float | None:
    """One fault-free run of one wheel: the largest (|residual| - ripple bound) / mean(|r|) over the
    samples where mean(|r|) > ``active`` N m (a manoeuvre), i.e. how much the observer erred per unit of
    the torque it was asked for (series (n,) of r, r^ and the ripple phasor); None: no manoeuvre."""
    r = np.asarray(actual, float)[:, None]
    res, bound = signed_residual_series(r, np.asarray(estimate, float)[:, None],
                                        np.asarray(ripple_phasor)[:, None])
    demand = window_mean(np.abs(r))
    busy = demand > active
    return float(((np.abs(res) - bound)[busy] / demand[busy]).max()) if busy.any() else None


def demand_gain(ratios, false_alarm_rate: float = FALSE_ALARM_RATE) -> float:
    """kappa of :class:`SignedResidual`'s bound from the runs' :func:`demand_ratio`: the (1 - alpha / 6)
    quantile of a Gumbel law fitted to them (:func:`gumbel_fit`), never below the largest (twice the
    largest for fewer than 4 runs: too few for a tail). An observer whose error grows with the torque
    demand gets a bound that does too; alpha / 6: half the designed per-run false-alarm rate over three
    axes, the band c (:func:`fit_band`) gets the other half."""
    ratios = list(ratios)
    if len(ratios) < 4:
        kappa = 2.0 * max(ratios, default=0.0)
    else:
        kappa = max(gumbel_quantile(*gumbel_fit(ratios), 1.0 - false_alarm_rate / 6.0), max(ratios))
    return max(kappa, 0.0)


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
    method: str = "thesis"           # 'thesis': time-indexed curves; 'speed_aware': constant bands c
    persistence: int = PERSISTENCE   # P the curves are meant for (the band's false-alarm rate needs it)
    false_alarm_rate: float | None = None   # designed per-run rate (speed_aware)
    calibration: dict = field(default_factory=dict)  # how the bands were fitted (speed_aware)
    unit_calibration_time: float = 0.0   # [s] of each run the observers learnt their wheel from (calibration.py)

    def at(self, axis: str, k: int) -> float:
        """Threshold of wheel ``axis`` at FDI sample k. A wheel without a curve of its own (the redundant
        wheel off the body axes) is of the same type as those fitted: it gets the widest of their curves."""
        if axis not in self.curves:
            return max(self.at(a, k) for a in self.curves)
        c = self.curves[axis]
        return float(c[min(k, len(c) - 1)])   # past the fitted horizon the last value holds

    def save(self, path):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({
            "observer": self.observer, "sample_period": self.sample_period, "window": self.window,
            "sigmas": self.sigmas, "runs": len(self.seeds), "seeds": self.seeds, "plant": self.plant,
            "model": self.model, "method": self.method, "persistence": self.persistence,
            "false_alarm_rate": self.false_alarm_rate, "calibration": self.calibration,
            "unit_calibration_time": self.unit_calibration_time,
            "curves": {a: [float(v) for v in c] for a, c in self.curves.items()}}, indent=1))

    @classmethod
    def load(cls, path, observer: str | None = None) -> "ThresholdCurves":
        """The curves of ``path``; with ``observer``, refused unless fitted for that observer slot (a
        model observer's band on the Luenberger observer's residual would alarm on every run)."""
        path = Path(path)
        if not path.is_file():
            raise ThresholdError(f"threshold file not found: {path}; {REFIT}")
        try:
            raw = json.loads(path.read_text())
            curves = {a: np.asarray(c, float) for a, c in raw["curves"].items()}
            out = cls(observer=raw["observer"], curves=curves, sample_period=float(raw["sample_period"]),
                      window=int(raw["window"]), sigmas=float(raw["sigmas"]), seeds=list(raw["seeds"]),
                      plant=dict(raw["plant"]), model=str(raw.get("model", "")),
                      method=str(raw.get("method", "thesis")), persistence=int(raw.get("persistence", PERSISTENCE)),
                      false_alarm_rate=raw.get("false_alarm_rate"), calibration=dict(raw.get("calibration") or {}),
                      unit_calibration_time=float(raw.get("unit_calibration_time", 0.0)))
        except (ValueError, KeyError, TypeError) as exc:
            raise ThresholdError(f"{path}: not a readable threshold file ({type(exc).__name__}: {exc}); "
                                 f"{REFIT}") from None
        if set(out.curves) != {"x", "y", "z"} or any(len(c) == 0 or not np.all(np.isfinite(c))
                                                     for c in out.curves.values()):
            raise ThresholdError(f"{path}: needs finite curves for axes x, y, z; {REFIT}")
        if observer is not None and out.observer != observer:
            raise ThresholdError(f"{path}: curves of the {out.observer} observer, not of the {observer} "
                                 f"observer; {REFIT}")
        if out.method not in METHODS:
            raise ThresholdError(f"{path}: unknown method {out.method!r} (known: {', '.join(METHODS)}); {REFIT}")
        if out.persistence < 1:
            raise ThresholdError(f"{path}: persistence must be >= 1, got {out.persistence}; {REFIT}")
        if out.method == "thesis":
            for a, c in out.curves.items():
                if np.any(c < 0):   # a threshold on a mean of |r - r^| below 0 alarms at once, for ever
                    raise ThresholdError(f"{path}: curve {a} has negative values (min {c.min():.3g} at sample "
                                         f"{int(c.argmin())}); a threshold on |r - r^| is >= 0; {REFIT}")
        return out

    @property
    def horizon(self) -> float:
        """[s] up to which the curves say what the fault-free residual is: time-indexed (thesis) curves
        end at their last sample, a speed-aware band holds for any time."""
        if self.method != "thesis":
            return float("inf")
        return (min(len(c) for c in self.curves.values()) - 1) * self.sample_period

    def check_horizon(self, duration: float, origin: str = "thresholds"):
        """Refuse curves that end before the run does: past its last sample a time-indexed curve
        would hold a value fitted for another moment, and the observer could not judge (a 3-sample
        curve held its start-up peak and hid a 40 % current loss)."""
        if self.horizon < float(duration):
            raise ThresholdError(f"{origin}: the curves cover 0-{self.horizon:g} s but the run lasts "
                                 f"{float(duration):g} s; fit them on runs at least as long; {REFIT}")

    def check_method(self, method: str, origin: str = "thresholds"):
        """Refuse curves of another FDI method than the running graph's."""
        if self.method != method:
            raise ThresholdError(f"{origin}: fitted for fdi_method={self.method!r} but the graph runs "
                                 f"fdi_method={method!r}; {REFIT}")

    def check_unit_calibration(self, seconds: float, origin: str = "thresholds"):
        """Refuse bands fitted with another unit calibration than the running observers': a calibrated
        observer's bound holds its correction's uncertainty, so the bands of one do not fit the other."""
        if abs(float(seconds) - self.unit_calibration_time) > 1e-9:
            raise ThresholdError(f"{origin}: fitted with unit_calibration_time={self.unit_calibration_time:g} s but "
                                 f"the observers run unit_calibration_time={float(seconds):g} s; fit bands for it "
                                 f"with `rw-fdi fit-thresholds --simulate fault_free_units --unit-calibration "
                                 f"{float(seconds):g} --out DIR`, then pass `--thresholds DIR`")

    def check_compatible(self, plant, origin: str = "thresholds"):
        """Refuse curves fitted under other plant choices than the running graph's.

        ``plant``: the running :class:`PlantChoices`, or a mapping of the choices to check. A
        choice the file does not record was fitted under its legacy value (plant_choices.LEGACY).
        """
        from .plant_choices import PlantChoices
        fitted = PlantChoices.from_recorded(self.plant)
        if isinstance(plant, dict):
            keys, running = list(plant), PlantChoices(**{**fitted.as_dict(), **plant})
        else:
            keys, running = None, plant
        for key, was, now in running.differences(fitted, keys):
            raise ThresholdError(f"{origin}: fitted with {key}={was!r} but the graph runs {key}={now!r}; {REFIT}")
