"""linear_observer: the Luenberger observer of thesis 3.3 for the three wheels at once.

Poles 4x the linearised wheel pole, discretised (ZOH) at the node's FDI
period; publishes the estimated reaction torque and the residual per axis.
"""
from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import Vector3Stamped

from ..core.detection import WINDOW, ResidualFilter
from ..core.linear_observer import LinearObserver
from . import topics as T
from .convert import vector_msg
from .fdi_sampling import subscribe_fdi_samples
from .gate import GatedPublisher
from .runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for


class LinearObserverNode(GraphNode):
    node_name = "linear_observer"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("fdi_period", 1.0)    # [s] also the discretisation period
        self.declare_parameter("speed_up", 4.0)      # observer pole / wheel pole
        self.declare_parameter("window", WINDOW)
        self.declare_parameter("fdi_sampling", "mean")  # mean over the FDI period, or 'instant' (thesis)
        self.declare_parameter("min_subscribers", 0)   # readers of the residual before the first sample goes
        self.observer = LinearObserver(self.param("fdi_period"), speed_up=self.param("speed_up"))
        self.filters = [ResidualFilter(self.param("window")) for _ in range(3)]
        self.compute, self.callback = [], []   # seconds: core update / whole callback
        self.pub_estimate = GatedPublisher(self.create_publisher(Vector3Stamped, T.estimate_topic("linear"), T.RELIABLE), self.param("min_subscribers") - 1)
        self.pub_residual = GatedPublisher(self.create_publisher(Vector3Stamped, T.residual_topic("linear"), T.RELIABLE), self.param("min_subscribers"))
        try:
            subscribe_fdi_samples(self, self._on_sample, self.param("fdi_period"), self.param("fdi_sampling"))
        except ValueError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        self.follow_run_end()

    def _on_sample(self, stamp, tcv, torque):
        t0 = time.perf_counter()
        estimate = self.observer.update(tcv, torque)
        residual = np.array([f.update(r, e) for f, r, e in zip(self.filters, torque, estimate)])
        self.compute.append(time.perf_counter() - t0)
        self.pub_estimate.publish(vector_msg(stamp, estimate))
        self.pub_residual.publish(vector_msg(stamp, residual))
        self.last_handled = stamp
        self.callback.append(time.perf_counter() - t0)

    def poll(self):
        flushed = self.pub_estimate.flush() & self.pub_residual.flush()
        if flushed and self.run_ended():
            self.finish()

    def timing(self):
        from .timing import summary
        return summary(compute=self.compute, callback=self.callback)


main = main_for(LinearObserverNode)

if __name__ == "__main__":
    main()
