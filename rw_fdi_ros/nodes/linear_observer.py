"""linear_observer: the Luenberger observer of thesis 3.3 for the three wheels at once.

Poles 4x the linearised wheel pole, discretised (ZOH) at the node's FDI
period; publishes the estimated reaction torque and the residual per axis.
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
        self.declare_parameter("speed_up", 4.0)      # observer pole / wheel pole
        self.observer = LinearObserver(self.param("fdi_period"), speed_up=self.param("speed_up"))
        self.filters = [ResidualFilter(self.param("window")) for _ in range(3)]
        self.start(T.estimate_topic("linear"), T.residual_topic("linear"))

    def observe(self, tcv, torque):
        estimate = self.observer.update(tcv, torque)
        return estimate, np.array([f.update(r, e) for f, r, e in zip(self.filters, torque, estimate)])


main = main_for(LinearObserverNode)

if __name__ == "__main__":
    main()
