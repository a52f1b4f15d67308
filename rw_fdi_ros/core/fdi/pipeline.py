"""The FDI pipeline, wired once: residuals -> channels -> decision -> latched verdict -> identification.

Every FDI sample k goes through the same stages, in the isolation node, in the
core loop (FDIR's verdict) and in the offline judge alike:

1. each observer j estimates the reaction torque r^_j and its SignedResidual gives
   e_j(k) = r(k) - r^_j(k) with its ripple bound b_j(k) (residuals.py; the nodes compute
   this stage in the observer nodes, the core loop in :class:`FdiPipeline`);
2. each observer's :class:`~.isolation.ObserverChannel` compares |e_j(k)| with c_j(k) + b_j(k) for P samples;
3. the :class:`~.isolation.DecisionRule` (one observer, or a vote K of N) makes the alarm of each wheel;
4. :class:`~.isolation.LatchedVerdict` holds a confirmed failure, a wheel outside the operating envelope
   (|Omega| > envelope) not judged;
5. the :class:`~.identification.FaultIdentifier` names each alarmed wheel's fault.

:class:`Isolation` is stages 2-5 for one run; :class:`FdiPipeline` is stages 1-5 for a batch of runs.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np

from .calibration import regressors
from .identification import IDENTIFICATION_WORK, FaultIdentifier
from .verdict import (WHEEL_SPEED_ENVELOPE, DecisionRule, LatchedVerdict, ObserverChannel, decision_of,
                        in_envelope, speed_envelope)
from .observer_plugin import PluginRun
from .residuals import SignedResidual
from .wheel_reports import ReportSampler
from ..physics.wheel import WheelParams


class Verdict(LatchedVerdict):
    """Stages 3-4: the decision's rows of the observers' channel rows, latched, judged within the envelope.

    Parameters
    ----------
    names : sequence of str
        The wheels, in the order of the rows.
    decision : DecisionRule
        Who decides (one observer, or a vote).
    latch : bool
        A confirmed failure stays until :meth:`reset`.
    envelope : float
        The largest |wheel speed| judged [rad/s] (isolation.speed_envelope).
    """

    def __init__(self, names, decision: DecisionRule, latch: bool = True, envelope: float = WHEEL_SPEED_ENVELOPE):
        super().__init__(latch, names)
        self.decision = decision
        self.envelope = envelope

    def judged(self, wheel_speed) -> dict:
        """wheel -> whether its sample lies in the operating envelope (every wheel where the speed is unknown).

        Parameters
        ----------
        wheel_speed : array_like or None
            (N,) wheel speeds [rad/s] of the sample.

        Returns
        -------
        dict
            wheel -> bool.
        """
        if wheel_speed is None:
            return dict.fromkeys(self.wheels, True)
        return dict(zip(self.wheels, (bool(v) for v in in_envelope(wheel_speed, self.envelope))))

    def decide(self, rows_of: dict, wheel_speed=None) -> dict:
        """The verdict of one sample.

        Parameters
        ----------
        rows_of : dict
            observer -> its ObserverChannel rows of the sample (every observer of the decision).
        wheel_speed : array_like or None
            (N,) wheel speeds [rad/s] (None: every wheel judged).

        Returns
        -------
        dict
            wheel -> (residual, threshold, alarm, first alarm [s] or None), latched.
        """
        return self.update(self.decision.combine(rows_of), self.judged(wheel_speed))


class Isolation:
    """Stages 2-5 for one run: each observer's channel, the decision, the latched verdict, the identification.

    Parameters
    ----------
    names : sequence of str
        The wheels of the set, the redundant one included.
    curves : dict
        observer -> ThresholdCurves, one channel each.
    decision : DecisionRule or None
        Who decides; None: the method's decision observer.
    persistence : int or None
        P; None: each curve's own.
    latch : bool
        A confirmed failure stays until reset.
    wheel : WheelParams
        The wheel type: its operating envelope and the identification's model.
    calibration_samples : int
        FDI samples the identification learns each wheel's unit from (0: the datasheet wheel).
    identification : bool
        Whether stage 5 runs.
    lazy : bool
        The identification answers only when asked (:meth:`identified`), not every sample.

    The identification takes IDENTIFICATION_WORK steps a sample (FaultIdentifier's ``work``), in the isolation node,
    the core loop and the offline judge alike: the node's time per FDI period is bounded, and all three answer the
    same.
    """

    def __init__(self, names, curves: dict, decision: DecisionRule | None = None, persistence: int | None = None,
                 latch: bool = True, wheel: WheelParams = WheelParams(), calibration_samples: int = 0,
                 identification: bool = False, lazy: bool = False):
        self.names = tuple(names)
        method = next(iter(curves.values())).method
        self.decision = decision or decision_of("", method)
        missing = set(self.decision.observers) - set(curves)
        if missing:
            raise ValueError(f"the decision {self.decision.label} needs the bands of {', '.join(sorted(missing))}")
        self.channels = {slot: ObserverChannel(slot, c, persistence, self.names) for slot, c in curves.items()}
        self.verdict = Verdict(self.names, self.decision, latch, speed_envelope(wheel))
        self.identifier = (FaultIdentifier(self.names, calibration_samples, lazy=lazy, params=wheel,
                                           work=IDENTIFICATION_WORK) if identification else None)

    def observe(self, slot: str, stamp_ns: int, residual, bound=None) -> dict:
        """Stage 2 for one observer's sample.

        Parameters
        ----------
        slot : str
            The observer.
        stamp_ns : int
            The sample's stamp [ns].
        residual, bound : array_like
            (N,) residual and ripple bound [N m] (bound None: 0).

        Returns
        -------
        dict
            wheel -> (residual, threshold + bound, alarm, first alarm or None).
        """
        return self.channels[slot].update(stamp_ns, residual, bound)

    def identify(self, sample, decided: dict) -> dict:
        """Stage 5: wheel -> Identification or None, from the sample and the verdict's alarms ({} without it).

        Parameters
        ----------
        sample : FdiSample
            The sample with the identification terms.
        decided : dict
            The verdict's rows of that sample (:meth:`decide`).

        Returns
        -------
        dict
            wheel -> Identification or None.
        """
        if self.identifier is None:
            return {}
        return self.identifier.update(sample, {a: row[2] for a, row in decided.items()})

    def step(self, stamp_ns: int, residuals: dict, sample=None) -> tuple:
        """Stages 2-5 for one sample.

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp [ns].
        residuals : dict
            observer -> ((N,) residual, (N,) bound) of every observer with a channel.
        sample : FdiSample, optional
            Its telemetry: the wheel speeds for the envelope, the terms for the identification.

        Returns
        -------
        rows_of : dict
            observer -> its channel rows.
        decided : dict
            wheel -> the verdict's row.
        """
        rows_of = {slot: self.observe(slot, stamp_ns, *residuals[slot]) for slot in self.channels}
        decided = self.verdict.decide(rows_of, None if sample is None else sample.wheel_speed)   # stages 3-4
        if sample is not None:
            self.identify(sample, decided)
        return rows_of, decided

    def identified(self) -> dict:
        """wheel -> the last Identification or None ({} without identification).

        Returns
        -------
        dict
            wheel -> Identification or None.
        """
        return {} if self.identifier is None else self.identifier.identifications()


@dataclass(frozen=True)
class LoadedFdi:
    """An FDI loaded from its files (FdiConfig.loaded): what a pipeline runs.

    Attributes
    ----------
    curves : dict
        observer -> ThresholdCurves.
    models : ObserverModels or dict
        The Elman networks by wheel (and the plug-ins with their states).
    decision : DecisionRule or None
        Who decides; None: the method's decision observer.
    persistence : int or None
        P; None: each curve's own.
    calibration_samples : int
        FDI samples each observer learns its wheel's unit from (0: the datasheet wheel).
    """

    curves: dict
    models: object = None
    decision: DecisionRule | None = None
    persistence: int | None = None
    calibration_samples: int = 0

    @property
    def method(self) -> str:
        return next(iter(self.curves.values())).method


class ObserverBank:
    """Stage 1 for a batch of runs: each observer's estimate and SignedResidual per wheel, learning the
    wheel's unit when calibrating.

    Parameters
    ----------
    names : sequence of str
        The wheels of the set.
    fdi : LoadedFdi
        The models (Elman networks, plug-ins) and the unit calibration.
    slots : sequence of str
        The observers run.
    batch : int
        Runs stepped at once.
    fdi_period : float
        The FDI period [s].
    wheel : WheelParams
        The datasheet wheel type.
    """

    def __init__(self, names, fdi: LoadedFdi, slots, batch: int, fdi_period: float, wheel: WheelParams):
        estimators = observer_estimators(names, fdi.models, slots, fdi_period, fdi.calibration_samples, wheel)
        self.estimators = {slot: make(batch) for slot, (make, _) in estimators.items()}
        self.filters = {slot: [[SignedResidual.of_wheel(wheel, fdi_period, uncertainty_gain=gains[i],
                                                        calibration_samples=fdi.calibration_samples)
                                for i in range(len(names))] for _ in range(batch)]
                        for slot, (_, gains) in estimators.items()}

    def residuals(self, sample, x=None) -> list:
        """Per run: observer -> ((N,) residual, (N,) bound) of one FDI sample of the batch.

        Parameters
        ----------
        sample : FdiSample
            Fields (B, N).
        x : ndarray, optional
            (B, N, 6) calibration regressors (calibration.regressors), when calibrating.

        Returns
        -------
        list of dict
            One per run.
        """
        estimates = {slot: estimate(sample) for slot, estimate in self.estimators.items()}
        out = []
        for b in range(sample.tcv.shape[0]):
            residuals = {}
            for slot, r_hat in estimates.items():
                rows = [f.update(sample.reaction_torque[b, i], r_hat[b, i], sample.ripple_phasor[b, i],
                                 None if x is None else x[b, i]) for i, f in enumerate(self.filters[slot][b])]
                residuals[slot] = (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))
            out.append(residuals)
        return out


class Judged(NamedTuple):
    """One FDI sample of a batch as :class:`FdiPipeline` judged it."""

    stamp_ns: int
    sample: object          # telemetry.FdiSample, fields (B, N)
    confirmed: list | None  # per run {wheel: first alarm [s] of a confirmed failure}; None: not judged (not finite)
    rows: list | None       # per run the Isolation's rows (observer -> channel rows, wheel -> verdict row)


class FdiPipeline:
    """Stages 1-5 for a batch of runs from the wheels' reports: the FDI of the core loop.

    wheel_reports.ReportSampler (the wheel_telemetry node's) -> :class:`ObserverBank` -> :class:`Isolation` per
    run, with the observers the decision needs. ``watch``: another FDI's observers judged beside, acted on by
    nothing (each its own channel and bands; their alarm intervals per run in :attr:`intervals`).

    Parameters
    ----------
    names : sequence of str
        The wheels of the set.
    fdi : LoadedFdi
        Bands, models, decision, persistence and unit calibration (speed_aware).
    batch : int
        Runs stepped at once.
    fdi_period : float
        The FDI period [s].
    identification : bool
        Each run's alarmed wheels identified (lazily: :attr:`identified` at the end).
    watch : LoadedFdi, optional
        The observers judged beside (every one of its bands).
    wheel : WheelParams
        The datasheet wheel type (the nominal model, its ripple, calibration and envelope).
    control_period : float
        dt [s], the grid the reports are put on.
    max_gap : float
        [s] speed reports further apart leave the FDI periods between them not judged.
    """

    def __init__(self, names, fdi: LoadedFdi, batch: int, fdi_period: float = 1.0, identification: bool = False,
                 watch: LoadedFdi | None = None, wheel: WheelParams = WheelParams(), control_period: float = 0.1,
                 max_gap: float = 2.5):
        if fdi.method != "speed_aware":
            raise ValueError("FDIR in the core loop runs the speed_aware FDI (the thesis' residual is unsigned)")
        self.names = tuple(names)
        self.wheel = wheel
        self.fdi_period_ns = int(round(fdi_period * 1e9))
        self.calibration_samples = fdi.calibration_samples
        decision = fdi.decision or decision_of("", fdi.method)
        self.reports = ReportSampler(wheel, fdi_period, control_period, max_gap, identification)
        self.observers = ObserverBank(self.names, fdi, decision.observers, batch, fdi_period, wheel)
        curves = {slot: fdi.curves[slot] for slot in decision.observers}
        self.runs = [Isolation(self.names, curves, decision, fdi.persistence, wheel=wheel,
                               calibration_samples=fdi.calibration_samples, identification=identification,
                               lazy=True) for _ in range(batch)]
        self.rows = [None] * batch   # per run: (observer -> channel rows, wheel -> verdict row) of the last sample
        self.watch = None
        if watch is not None:
            self.watch = ObserverBank(self.names, watch, tuple(watch.curves), batch, fdi_period, wheel)
            self.watch_channels = [{slot: ObserverChannel(slot, c, watch.persistence, self.names)
                                    for slot, c in watch.curves.items()} for _ in range(batch)]
        self.intervals = [{slot: {a: [] for a in self.names} for slot in (watch.curves if watch else ())}
                          for _ in range(batch)]

    def add_speed(self, stamp_ns: int, wheel_speed, reaction_torque=None) -> list:
        """A speed report of the batch (with its reaction torque where the wheels report it).

        Parameters
        ----------
        stamp_ns : int
            The report's stamp [ns].
        wheel_speed, reaction_torque : ndarray
            (B, N) wheel speeds [rad/s] and reaction torques [N m] (None: from the speed).

        Returns
        -------
        list of Judged
            The FDI samples the report completes (wheel_reports.ControlGrid: a speed report waits for the command
            sent at its stamp).
        """
        torque = None if reaction_torque is None else self._batch(reaction_torque)
        return [self._judge(s) for s in self.reports.add_speed(stamp_ns, self._batch(wheel_speed), torque)]

    def add_command(self, stamp_ns: int, tcv) -> list:
        """The commands sent at ``stamp_ns``, in force over the next step.

        Parameters
        ----------
        stamp_ns : int
            The commands' stamp [ns].
        tcv : ndarray
            (B, N) torque command voltages u [V].

        Returns
        -------
        list of Judged
            The FDI samples they complete.
        """
        return [self._judge(s) for s in self.reports.add_command(stamp_ns, self._batch(tcv))]

    def add_housekeeping(self, stamp_ns: int, bus_voltage=None, temperature=None):
        """The batch's bus voltages [V] and temperatures [C] from ``stamp_ns`` on (ReportSampler.add_housekeeping).

        Parameters
        ----------
        stamp_ns : int
            The report's stamp [ns].
        bus_voltage, temperature : ndarray or None
            (B, N) values, NaN for a wheel not reported.
        """
        self.reports.add_housekeeping(stamp_ns, *(None if v is None else self._batch(v)
                                                  for v in (bus_voltage, temperature)))

    def flush(self) -> list:
        """The FDI samples of the reports still waiting: the streams have ended.

        Returns
        -------
        list of Judged
            Those samples, judged.
        """
        return [self._judge(s) for s in self.reports.flush()]

    def _batch(self, values):
        """(B, N) of a batch's values; a run's (N,) where the batch is one run."""
        return np.reshape(np.asarray(values, float), (len(self.runs), len(self.names)))

    def _judge(self, sample) -> Judged:
        if not all(np.isfinite(x).all() for x in (sample.tcv, sample.reaction_torque, sample.wheel_speed)):
            # a period without reports (wheel_reports: NaN) is not judged: the observers' states wait for the next,
            # as the observer nodes do with a sample that is not finite
            return Judged(sample.stamp_ns, sample, None, None)
        x = (regressors(sample.motor_torque, sample.friction_torque, sample.wheel_speed, sample.ripple_phasor,
                        sample.free_motor_torque, params=self.wheel) if self.calibration_samples else None)
        if self.watch is not None:
            for b, residuals in enumerate(self.watch.residuals(sample, x)):
                rows_of = {slot: channel.update(sample.stamp_ns, *residuals[slot])
                           for slot, channel in self.watch_channels[b].items()}
                self._note_intervals(b, sample.stamp_ns * 1e-9, rows_of)
        out = []
        for b, (run, residuals) in enumerate(zip(self.runs, self.observers.residuals(sample, x))):
            self.rows[b] = run.step(sample.stamp_ns, residuals, run_of(sample, b))
            out.append({a: t for a, t in run.verdict.confirmed.items() if t is not None})
        return Judged(sample.stamp_ns, sample, out, list(self.rows))

    def _note_intervals(self, b: int, t: float, rows_of: dict):
        for slot, rows in rows_of.items():
            for a, row in rows.items():
                spans = self.intervals[b][slot][a]
                up = bool(row[2])
                if up and (not spans or spans[-1][1] is not None):
                    spans.append([t, None])
                elif not up and spans and spans[-1][1] is None:
                    spans[-1][1] = t

    @property
    def identified(self) -> list:
        """Per run: wheel -> its Identification on the samples so far (None: never alarmed)."""
        return [run.identified() for run in self.runs]


def run_of(sample, b: int):
    """The FDI sample of run ``b`` of a batch: every (B, N, ...) field at ``b``.

    Parameters
    ----------
    sample : FdiSample
        A batch's sample, fields (B, N, ...).
    b : int
        The run.

    Returns
    -------
    FdiSample
        Its fields (N, ...).
    """
    values = {f.name: getattr(sample, f.name) for f in fields(sample)}
    return type(sample)(**{k: v[b] if getattr(v, "ndim", 0) >= 2 else v for k, v in values.items()})


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
        return np.array([run.step(run_of(sample, b)) for b, run in enumerate(self.runs)])


def observer_estimators(names, models, slots, period: float, calibration_samples: int = 0,
                        wheel: WheelParams | None = None) -> dict:
    """Stage 1's estimators of the observers ``slots`` on the wheel set ``names``.

    The model observer (the sample's nominal model torque), the Luenberger observer (linear_observer.py,
    every run at once), the Elman network of each wheel (elman.WheelRecall) and the plug-ins of ``models``
    (observer_plugin.ObserverModels).

    Parameters
    ----------
    names : sequence of str
        The wheels.
    models : ObserverModels or dict or None
        The Elman networks by wheel and the plug-ins (needed only for those slots).
    slots : sequence of str
        The observers wanted.
    period : float
        The FDI period [s].
    calibration_samples : int
        A plug-in's calibration samples.
    wheel : WheelParams, optional
        The wheel type the Luenberger observer linearises (None: the thesis').

    Returns
    -------
    dict
        slot -> (``make(batch)``, a factory of a callable ``(sample) -> (B, N) r^``, kappa per wheel).
    """
    from .linear_observer import LinearObserver, uncertainty_gain
    from ..physics.wheel import linearised_wheel

    def elman():
        from functools import partial
        from .elman import network_wheel
        nets = [models[network_wheel(a, models)] for a in names]
        return partial(_ElmanRecalls, nets), [n.uncertainty_gain for n in nets]

    def linear():
        def make(batch):
            observer = LinearObserver(period, None if wheel is None else linearised_wheel(params=wheel))
            return lambda sample: observer.update(sample.tcv, sample.reaction_torque)
        return make, [uncertainty_gain(a) for a in names]

    def model():
        return (lambda batch: (lambda sample: sample.model_torque)), [0.0] * len(names)

    def plugin(cls, state):
        return ((lambda batch: _PluginRuns(cls, names, period, state, calibration_samples, batch)),
                PluginRun(cls, names, period, state).uncertainty_gains())

    table = {"elman": elman, "linear": linear, "model": model,
             **{cls.slot: (lambda cls=cls, state=state: plugin(cls, state))
                for cls, state in getattr(models, "plugins", ())}}
    unknown = [s for s in slots if s not in table]
    if unknown:
        raise ValueError(f"no observer {', '.join(unknown)} among {', '.join(table)}")
    return {slot: table[slot]() for slot in slots}
