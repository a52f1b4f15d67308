"""The isolation logic of one observer over three wheels, sample by sample (evaluation.md).

The isolation node and the offline tools (screen, evaluation, calibration
checks) both step :class:`ObserverChannel`, so a verdict computed offline is
the node's verdict.
"""
from __future__ import annotations

import math

from .detection import AlarmRule, ThresholdCurves

AXES = ("x", "y", "z")
# The observer whose alarms make the wheel's /diagnostics status and start fault identification.
DECISION_OBSERVER = "elman"


def stamp_seconds(stamp_ns: int) -> float:
    """Sim time [s] of a stamp; exact for whole seconds."""
    return stamp_ns // 10**9 + (stamp_ns % 10**9) * 1e-9


class ObserverChannel:
    """One observer's alarms: |residual_k| against threshold(k) + bound_k for P consecutive samples.

    ``update`` returns axis -> (residual, threshold + bound, alarm, first alarm time or None).
    A non-finite residual or bound is not judged: the axis' alarm state is held (NaN > threshold
    is False, it would clear an alarm) and the axis is in ``unjudged`` until its next finite sample.
    """

    def __init__(self, observer: str, curves: ThresholdCurves, persistence: int | None = None):
        self.observer = observer
        self.curves = curves
        self.persistence = persistence or curves.persistence
        self.reset()

    def reset(self):
        """Forget every alarm: a new run starts."""
        self.rules = {a: AlarmRule(self.persistence) for a in AXES}
        self.beyond_horizon = False
        self.unjudged = set()   # axes whose last sample could not be judged (non-finite input)

    def update(self, stamp_ns: int, residual, bound=(0.0, 0.0, 0.0)):
        t = stamp_seconds(stamp_ns)
        self.beyond_horizon = t > self.curves.horizon   # the curves cannot judge this moment (health)
        k = int(round(t / self.curves.sample_period))
        rows = {}
        for i, axis in enumerate(AXES):
            rule, r, b = self.rules[axis], float(residual[i]), float(bound[i])
            threshold = self.curves.at(axis, k) + b
            if math.isfinite(r) and math.isfinite(b):
                self.unjudged.discard(axis)
                rule.update(abs(r), threshold, t)
            else:
                self.unjudged.add(axis)
            rows[axis] = (r, threshold, rule.active, rule.first_alarm)
        return rows
