"""elman_observer: one wheel's Elman network in recall mode (thesis Fig. 4.8), started once per axis.

Every FDI sample (1 s) it estimates the reaction torque from the command
voltage and its own previous estimate, and publishes the estimate and the
residual (40-sample moving average of |r - r^|). numpy only, no torch.
"""
from __future__ import annotations

import time

from geometry_msgs.msg import Vector3Stamped

from ..core.detection import WINDOW, ResidualFilter
from ..core.elman import ElmanObserver, ElmanWeights, ModelError
from ..core.scenario import AXES
from ..paths import config_dir
from . import topics as T
from .convert import vector_msg
from .fdi_sampling import subscribe_fdi_samples
from .gate import GatedPublisher
from .runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for


def default_model(axis: str) -> str:
    return str(config_dir() / "fdi" / f"elman_{axis}.npz")


class ElmanObserverNode(GraphNode):
    node_name = "elman_observer"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("axis", "x")
        self.declare_parameter("model", "")            # npz; empty: config/fdi/elman_<axis>.npz
        self.declare_parameter("fdi_period", 1.0)      # [s] sample period the network was trained at
        self.declare_parameter("window", WINDOW)
        self.declare_parameter("fdi_sampling", "mean")  # mean over the FDI period, or 'instant' (thesis)
        self.declare_parameter("min_subscribers", 0)   # readers of the residual before the first sample goes       # residual moving-average length [samples]
        axis = self.param("axis")
        if axis not in AXES:
            raise NodeError(f"parameter axis must be one of x, y, z, got {axis!r}", EXIT_BAD_INPUT)
        try:
            weights = ElmanWeights.load(self.param("model") or default_model(axis))
        except ModelError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        self.index = AXES.index(axis)
        self.axis = axis
        self.observer = ElmanObserver(weights)
        self.residual = ResidualFilter(self.param("window"))
        self.started = False
        self.compute, self.callback = [], []   # seconds: core update / whole callback
        self.pub_estimate = GatedPublisher(self.create_publisher(Vector3Stamped, T.estimate_topic("elman", axis), T.RELIABLE), self.param("min_subscribers") - 1)
        self.pub_residual = GatedPublisher(self.create_publisher(Vector3Stamped, T.residual_topic("elman", axis), T.RELIABLE), self.param("min_subscribers"))
        try:
            subscribe_fdi_samples(self, self._on_sample, self.param("fdi_period"), self.param("fdi_sampling"))
        except ValueError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        self.follow_run_end()

    def _on_sample(self, stamp, tcv, torque):
        t0 = time.perf_counter()
        u, r = float(tcv[self.index]), float(torque[self.index])
        if not self.started:  # recall mode starts from the first measured torque
            self.observer.reset(r)
            self.started = True
        estimate = self.observer.update(u)
        residual = self.residual.update(r, estimate)
        self.compute.append(time.perf_counter() - t0)
        own = [0.0, 0.0, 0.0]
        own[self.index] = estimate
        self.pub_estimate.publish(vector_msg(stamp, own))
        own[self.index] = residual
        self.pub_residual.publish(vector_msg(stamp, own))
        self.last_handled = stamp
        self.callback.append(time.perf_counter() - t0)

    def poll(self):
        flushed = self.pub_estimate.flush() & self.pub_residual.flush()
        if flushed and self.run_ended():
            self.finish()

    def timing(self):
        from .timing import summary
        return summary(compute=self.compute, callback=self.callback)


main = main_for(ElmanObserverNode)

if __name__ == "__main__":
    main()
