"""The FDI verdict of /diagnostics computed inside the core loop, so that FDIR can act on it there.

The graph's model observer node and isolation node make the verdict from
the plant's FDI telemetry; :class:`OnboardVerdict` steps the same pieces in
the same order for a batch of runs, one FDI sample at a time:
TelemetrySampler (telemetry.py) -> the nominal model's SignedResidual per
wheel, learning the wheel's unit when calibrating (residuals.py,
calibration.py) -> ObserverChannel against the model observer's bands ->
LatchedVerdict with the operating envelope (isolation.py). The verdict is
per wheel of the set, the redundant one included (its band: the widest of
its type's, threshold_file.ThresholdCurves.at). With ``identification`` the
isolation node's FaultIdentifier names each alarmed wheel's fault as well.
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np

from .calibration import UnitCalibration, regressors
from .residuals import SignedResidual, ripple_share
from .threshold_file import ThresholdCurves
from .identification import FaultIdentifier
from .observer_plugin import PluginRun
from .isolation import LatchedVerdict, ObserverChannel, in_envelope, speed_envelope
from .telemetry import TelemetrySampler
from .wheel import WheelParams


class OnboardVerdict:
    """The latched verdict of wheels ``names`` for ``batch`` runs from control-rate telemetry."""

    def __init__(self, names, curves: ThresholdCurves, batch: int, fdi_period: float = 1.0,
                 calibration_samples: int = 0, persistence: int | None = None, identification: bool = False,
                 watched: dict | None = None, wheel: WheelParams = WheelParams()):
        self.names = tuple(names)
        self.wheel = wheel   # the wheel type: the nominal model, its ripple, its calibration and its envelope
        self.envelope = speed_envelope(wheel)
        self.fdi_period_ns = int(round(fdi_period * 1e9))
        self.sampler = TelemetrySampler(fdi_period, "mean", wheel, identification=identification)
        # lazy: FDIR does not act on the identification; the run's answer is read at its end (identified)
        self.identifiers = ([FaultIdentifier(self.names, calibration_samples, lazy=True, params=wheel)
                             for _ in range(batch)] if identification else None)
        self.calibration_samples = calibration_samples
        self.filters = [[SignedResidual(share=ripple_share(wheel),
                                        calibration=UnitCalibration(calibration_samples, params=wheel)
                                        if calibration_samples else None) for _ in self.names] for _ in range(batch)]
        self.channels = [ObserverChannel("model", curves, persistence, self.names) for _ in range(batch)]
        self.verdicts = [LatchedVerdict(True, self.names) for _ in range(batch)]
        # observers judged beside the decision, acted on by nothing (their figures in service)
        self.watch = (ObserverWatch(self.names, watched, batch, calibration_samples, persistence, wheel)
                      if watched else None)

    def add(self, stamp_ns: int, tcv, reaction_torque, wheel_speed):
        """Control-rate sample (B, N) arrays in; on an FDI stamp, per run {wheel: first alarm [s] of a
        confirmed failure} (None elsewhere)."""
        sample = self.sampler.add(stamp_ns, tcv, reaction_torque, wheel_speed)
        if sample is None:
            return None
        x = (regressors(sample.motor_torque, sample.friction_torque, sample.wheel_speed, sample.ripple_phasor,
                        sample.free_motor_torque, params=self.wheel) if self.calibration_samples else None)
        if self.watch is not None:
            self.watch.add(sample, x)
        judged = in_envelope(sample.wheel_speed, self.envelope)
        out = []
        for b, (filters, channel, verdict) in enumerate(zip(self.filters, self.channels, self.verdicts)):
            rows = [f.update(sample.reaction_torque[b, i], sample.model_torque[b, i], sample.ripple_phasor[b, i],
                             None if x is None else x[b, i]) for i, f in enumerate(filters)]
            residual, bound = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])
            rows = verdict.update(channel.update(stamp_ns, residual, bound), dict(zip(self.names, judged[b])))
            if self.identifiers is not None:
                self.identifiers[b].update(_run_of(sample, b), {a: row[2] for a, row in rows.items()})
            out.append({a: t for a, t in verdict.confirmed.items() if t is not None})
        return out

    @property
    def identified(self) -> list:
        """Per run: wheel -> its Identification on the samples so far (None: never alarmed); [] per run
        without identification."""
        if self.identifiers is None:
            return [{} for _ in self.verdicts]
        return [i.identifications() for i in self.identifiers]


def _run_of(sample, b: int):
    """The FDI sample of run ``b`` of a batch: every (B, N, ...) field at ``b``."""
    values = {f.name: getattr(sample, f.name) for f in fields(sample)}
    return type(sample)(**{k: v[b] if isinstance(v, np.ndarray) and v.ndim >= 2 else v for k, v in values.items()})


class ObserverWatch:
    """Observers judged beside the decision in the core loop and acted on by nothing (the figures of every
    observer in service): per FDI sample, each one's estimate, its SignedResidual per wheel (learning the unit
    when calibrating) and its ObserverChannel, as the observer and isolation nodes run them; per run, slot and
    wheel the alarm intervals [start, end or None] [s] (:attr:`intervals`).

    ``observers``: slot -> (estimator, uncertainty gain per wheel, ThresholdCurves), an estimator being
    ``make(batch)``, a callable ``(sample) -> (B, N) r^`` made once per batch (:func:`watched_observers`)."""

    def __init__(self, names, observers: dict, batch: int, calibration_samples: int = 0,
                 persistence: int | None = None, wheel: WheelParams = WheelParams()):
        self.names = tuple(names)   # wheel: the wheel type (its ripple bound and calibration)
        self.estimators = {slot: make(batch) for slot, (make, _, _) in observers.items()}
        self.filters = {slot: [[SignedResidual(share=ripple_share(wheel), uncertainty_gain=gains[i],
                                               calibration=UnitCalibration(calibration_samples, params=wheel)
                                               if calibration_samples else None)
                                for i in range(len(self.names))] for _ in range(batch)]
                        for slot, (_, gains, _) in observers.items()}
        self.channels = {slot: [ObserverChannel(slot, curves, persistence, self.names) for _ in range(batch)]
                         for slot, (_, _, curves) in observers.items()}
        self.calibration_samples = calibration_samples
        self.intervals = [{slot: {a: [] for a in self.names} for slot in observers} for _ in range(batch)]

    def add(self, sample, x=None):
        """One FDI sample of the batch (fields (B, N)); ``x``: its calibration regressors (B, N, 6) or None."""
        t = sample.stamp_ns * 1e-9
        for slot, estimate in self.estimators.items():
            r_hat = estimate(sample)
            for b, (filters, channel) in enumerate(zip(self.filters[slot], self.channels[slot])):
                rows = [f.update(sample.reaction_torque[b, i], r_hat[b, i], sample.ripple_phasor[b, i],
                                 None if x is None else x[b, i]) for i, f in enumerate(filters)]
                alarms = channel.update(sample.stamp_ns, np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))
                for a, row in alarms.items():
                    spans = self.intervals[b][slot][a]
                    up = bool(row[2])
                    if up and (not spans or spans[-1][1] is not None):
                        spans.append([t, None])
                    elif not up and spans and spans[-1][1] is None:
                        spans[-1][1] = t


class _ElmanRecalls:
    """The Elman network of each wheel recalled for each run of a batch, as the node recalls it."""

    def __init__(self, nets, batch: int):
        from .elman import WheelRecall
        self.recalls = [[WheelRecall(net) for net in nets] for _ in range(batch)]

    def __call__(self, sample) -> np.ndarray:
        out = np.empty(sample.tcv.shape)
        for b, row in enumerate(self.recalls):
            for i, recall in enumerate(row):
                out[b, i] = recall.update(sample.tcv[b, i], sample.reaction_torque[b, i], sample.wheel_speed[b, i],
                                          sample.model_torque[b, i])
        return out


class _PluginRuns:
    """A plug-in run for each run of a batch (observer_plugin.PluginRun), as the plug-in node steps it."""

    def __init__(self, cls, names, period: float, state, calibration_samples: int, batch: int):
        self.runs = [PluginRun(cls, names, period, state, calibration_samples) for _ in range(batch)]

    def __call__(self, sample) -> np.ndarray:
        return np.array([run.step(_run_of(sample, b)) for b, run in enumerate(self.runs)])


def watched_observers(names, models, curves: dict, period: float, calibration_samples: int = 0,
                      wheel: WheelParams | None = None) -> dict:
    """slot -> (estimator factory ``make(batch)``, kappa per wheel, curves) of the observers of ``curves`` on the
    wheel set ``names``: the model observer (the sample's nominal model torque), the Luenberger observer
    (linear_observer.py, every run at once), the Elman network of each wheel (elman.WheelRecall) and the
    plug-ins of ``models`` (observer_plugin.ObserverModels); ``wheel``: the wheel type the Luenberger observer
    linearises (None: the thesis')."""
    from functools import partial
    from .elman import network_wheel
    from .linear_observer import LinearObserver, uncertainty_gain
    from .wheel import linearised_wheel
    nets = [models[network_wheel(a, models)] for a in names]

    def linear(batch):
        observer = LinearObserver(period, None if wheel is None else linearised_wheel(params=wheel))
        return lambda sample: observer.update(sample.tcv, sample.reaction_torque)

    table = {"elman": (partial(_ElmanRecalls, nets), [n.uncertainty_gain for n in nets]),
             "linear": (linear, [uncertainty_gain(a) for a in names]),
             "model": (lambda batch: (lambda sample: sample.model_torque), [0.0] * len(names)),
             **{cls.slot: (lambda batch, cls=cls, state=state: _PluginRuns(cls, names, period, state,
                                                                           calibration_samples, batch),
                           PluginRun(cls, names, period, state).uncertainty_gains())
                for cls, state in getattr(models, "plugins", ())}}
    return {slot: (*table[slot], c) for slot, c in curves.items()}
