"""The isolation logic of one observer over three wheels, sample by sample (evaluation.md).

The isolation node and the offline tools (screen, evaluation, calibration
checks) both step :class:`ObserverChannel`, so a verdict computed offline is
the node's verdict.
"""
from __future__ import annotations

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

    def update(self, stamp_ns: int, residual, bound=(0.0, 0.0, 0.0)):
        t = stamp_seconds(stamp_ns)
        self.beyond_horizon = t > self.curves.horizon   # the curves cannot judge this moment (health)
        k = int(round(t / self.curves.sample_period))
        rows = {}
        for i, axis in enumerate(AXES):
            threshold = self.curves.at(axis, k) + float(bound[i])
            alarm = self.rules[axis].update(abs(float(residual[i])), threshold, t)
            rows[axis] = (float(residual[i]), threshold, alarm, self.rules[axis].first_alarm)
        return rows
