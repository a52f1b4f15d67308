"""linear_observer: the model-based observer of the three wheels at once.

thesis: the Luenberger observer of thesis 3.3, poles 4x the linearised wheel
pole, discretised (ZOH) at the node's FDI period; residual 40-sample mean of
|r - r^|. speed_aware: with the tachometer measuring the wheel's state, the
observer needs no state estimate: r^ is the nominal wheel model's reaction
torque at the measured command and speed (core/telemetry.py), residual the
signed 40-sample mean of r - r^ with its ripple bound; with unit_calibration_time
the model learns the wheel's own unit first (core/calibration.py).
"""
from __future__ import annotations

import numpy as np

from ..core.detection import ResidualFilter
from ..core.linear_observer import LinearObserver
from . import topics as T
from .observer_node import ObserverNode
from .runtime import main_for


class LinearObserverNode(ObserverNode):
    node_name = "linear_observer"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("speed_up", 4.0)      # observer pole / wheel pole (thesis method)
        self.reset()
        self.start(T.estimate_topic("linear"), T.residual_topic("linear"), T.bound_topic("linear"))

    def reset(self):
        self.observer = LinearObserver(self.param("fdi_period"), speed_up=self.param("speed_up"))
        window = self.param("window")
        self.filters = [self.signed_residual() if self.speed_aware else ResidualFilter(window) for _ in range(3)]

    def observe(self, sample):
        torque = sample.reaction_torque
        if self.speed_aware:
            rows = [f.update(torque[i], sample.model_torque[i], sample.ripple_phasor[i], self.regressors(sample, i))
                    for i, f in enumerate(self.filters)]
            estimate = np.array([f.estimate for f in self.filters])   # calibrated when the node calibrates
            return estimate, np.array([x[0] for x in rows]), np.array([x[1] for x in rows])
        estimate = self.observer.update(sample.tcv, torque)
        return estimate, np.array([f.update(r, e) for f, r, e in zip(self.filters, torque, estimate)]), np.zeros(3)


main = main_for(LinearObserverNode)

if __name__ == "__main__":
    main()
