"""What both observer kinds share: FDI samples in, estimate and residual out.

:class:`ObserverNode` takes the plant's tcv and reaction torque at the
control rate, makes FDI samples with :class:`FdiSampler`, calls the
subclass' ``observe`` once per sample and publishes the estimate and the
residual (gated until their readers are matched, so no sample is lost).
"""
from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import Vector3Stamped

from ..core.detection import WINDOW
from ..core.sampling import FdiSampler
from . import topics as T
from .convert import vector_msg
from .gate import GatedPublisher
from .runtime import EXIT_BAD_INPUT, GraphNode, NodeError
from .sync import StampSync


class ObserverNode(GraphNode):
    """Base of elman_observer and linear_observer; subclasses implement ``observe``."""

    def __init__(self, name: str):
        super().__init__(name)
        self.declare_parameter("fdi_period", 1.0)       # [s] FDI sample period (and discretisation period)
        self.declare_parameter("fdi_sampling", "mean")  # mean over the FDI period, or 'instant' (thesis)
        self.declare_parameter("window", WINDOW)        # residual moving-average length [samples]
        self.declare_parameter("min_subscribers", 0)    # readers of the residual before the first sample goes
        self.compute, self.callback, self.callback_cpu = [], [], []   # s: observe() / callback wall / CPU
        try:
            self.sampler = FdiSampler(self.param("fdi_period"), self.param("fdi_sampling"))
        except ValueError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None

    def start(self, estimate_topic: str, residual_topic: str):
        """Publishers and subscriptions, once the subclass knows its topics."""
        need = self.param("min_subscribers")
        self.pub_estimate = GatedPublisher(self.create_publisher(Vector3Stamped, estimate_topic, T.RELIABLE),
                                           need - 1)
        self.pub_residual = GatedPublisher(self.create_publisher(Vector3Stamped, residual_topic, T.RELIABLE), need)
        sync = StampSync(("tcv", "torque"), self._on_pair)
        sync.subscribe(self, "tcv", T.TCV, T.RELIABLE)
        sync.subscribe(self, "torque", T.REACTION_TORQUE, T.RELIABLE)
        self.follow_run_end(period=self.param("fdi_period"))

    def observe(self, tcv, torque):
        """(estimate, residual) as 3-vectors for one FDI sample."""
        raise NotImplementedError

    def _on_pair(self, stamp, values):
        t0, c0 = time.perf_counter(), time.thread_time()
        sample = self.sampler.add(stamp, values["tcv"], values["torque"])
        if sample is None:
            return
        stamp, tcv, torque = sample
        if not (np.all(np.isfinite(tcv)) and np.all(np.isfinite(torque))):
            # a NaN would silently disable the alarm (NaN > threshold is False): stop instead
            self.fail(f"non-finite input at t={stamp * 1e-9:g} s: tcv={tcv.tolist()}, "
                      f"reaction torque={torque.tolist()}", EXIT_BAD_INPUT)
            return
        estimate, residual = self.observe(tcv, torque)
        self.compute.append(time.perf_counter() - t0)
        self.pub_estimate.publish(vector_msg(stamp, estimate))
        self.pub_residual.publish(vector_msg(stamp, residual))
        self.last_handled = stamp
        self.callback.append(time.perf_counter() - t0)
        self.callback_cpu.append(time.thread_time() - c0)

    def poll(self):
        if not hasattr(self, "pub_estimate"):
            return
        flushed = self.pub_estimate.flush() & self.pub_residual.flush()
        if flushed and self.run_ended():
            self.finish()

    def timing(self):
        from .timing import summary
        return summary(compute=self.compute, callback=self.callback, callback_cpu=self.callback_cpu)
