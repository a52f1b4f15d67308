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
from .residuals import SignedResidual
from .threshold_file import ThresholdCurves
from .identification import FaultIdentifier
from .isolation import LatchedVerdict, ObserverChannel, in_envelope
from .telemetry import TelemetrySampler


class OnboardVerdict:
    """The latched verdict of wheels ``names`` for ``batch`` runs from control-rate telemetry."""

    def __init__(self, names, curves: ThresholdCurves, batch: int, fdi_period: float = 1.0,
                 calibration_samples: int = 0, persistence: int | None = None, identification: bool = False):
        self.names = tuple(names)
        self.fdi_period_ns = int(round(fdi_period * 1e9))
        self.sampler = TelemetrySampler(fdi_period, "mean", identification=identification)
        # lazy: FDIR does not act on the identification; the run's answer is read at its end (identified)
        self.identifiers = ([FaultIdentifier(self.names, calibration_samples, lazy=True) for _ in range(batch)]
                            if identification else None)
        self.calibration_samples = calibration_samples
        self.filters = [[SignedResidual(calibration=UnitCalibration(calibration_samples) if calibration_samples
                                        else None) for _ in self.names] for _ in range(batch)]
        self.channels = [ObserverChannel("model", curves, persistence, self.names) for _ in range(batch)]
        self.verdicts = [LatchedVerdict(True, self.names) for _ in range(batch)]

    def add(self, stamp_ns: int, tcv, reaction_torque, wheel_speed):
        """Control-rate sample (B, N) arrays in; on an FDI stamp, per run {wheel: first alarm [s] of a
        confirmed failure} (None elsewhere)."""
        sample = self.sampler.add(stamp_ns, tcv, reaction_torque, wheel_speed)
        if sample is None:
            return None
        x = (regressors(sample.motor_torque, sample.friction_torque, sample.wheel_speed, sample.ripple_phasor,
                        sample.free_motor_torque) if self.calibration_samples else None)
        judged = in_envelope(sample.wheel_speed)
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
