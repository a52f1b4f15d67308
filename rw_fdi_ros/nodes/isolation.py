"""isolation: residuals against thresholds, persistence, which wheel is faulty and since when.

For each observer (elman, linear) and axis it compares |residual| of FDI
sample k with the threshold at k plus the observer's ripple bound and raises
the axis' alarm after ``persistence`` consecutive samples above
(core/isolation.py, evaluation.md). Alarmed axes are the faulty wheels. It
publishes per observer the thresholds, the alarm flags and a DiagnosticArray
with residual, threshold, margin and first alarm per wheel, and /diagnostics
with one status per wheel, decided by the ``decision_observer`` (Elman by
default) and stamped with the sim clock. Every output of stamp k is made from
the inputs of stamp k alone, so the same run gives the same messages.
"""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped

from ..core.detection import METHODS, ThresholdCurves, ThresholdError
from ..core.isolation import ObserverChannel
from ..core.plant_choices import DEFAULT as DEFAULT_CHOICES, PlantChoiceError, PlantChoices
from ..core.scenario import AXES
from ..paths import fdi_dir
from . import topics as T
from .convert import time_msg, vector_msg
from .runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for
from .gate import GatedPublisher
from .sync import StampSync


def default_thresholds(observer: str, method: str = "speed_aware") -> str:
    return str(fdi_dir(method) / f"thresholds_{observer}.json")


def _status(name, axis, residual, threshold, alarm, first, extra=()):
    s = DiagnosticStatus(name=name, hardware_id=f"reaction_wheel_{axis}")
    s.level = DiagnosticStatus.ERROR if alarm else DiagnosticStatus.OK
    s.message = f"faulty since {first:g} s" if alarm else ("recovered" if first is not None else "nominal")
    s.values = [KeyValue(key="residual", value=f"{residual:.6g}"), KeyValue(key="threshold", value=f"{threshold:.6g}"),
                KeyValue(key="margin", value=f"{threshold - abs(residual):.6g}"),
                KeyValue(key="first_alarm", value="none" if first is None else f"{first:g}"), *extra]
    return s


class IsolationNode(GraphNode):
    node_name = "isolation"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("thresholds_elman", "")     # empty: config/fdi/thresholds_elman.json
        self.declare_parameter("thresholds_linear", "")
        self.declare_parameter("fdi_method", "speed_aware")  # speed_aware (ours) or thesis
        self.declare_parameter("persistence", 0)            # samples above the threshold; 0: the file's
        self.declare_parameter("decision_observer", "elman")
        self.declare_parameter("min_subscribers", 0)        # readers (the recorder) before output goes
        # the running graph's plant choices: curves fitted under others are refused
        for key, value in DEFAULT_CHOICES.as_dict().items():
            self.declare_parameter(key, value)
        try:
            plant = PlantChoices(**{k: self.param(k) for k in DEFAULT_CHOICES.as_dict()})
        except PlantChoiceError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        method = self.param("fdi_method")
        if method not in METHODS:
            raise NodeError(f"parameter fdi_method must be one of {', '.join(METHODS)}, got {method!r}", EXIT_BAD_INPUT)
        self.channels = {}
        self.compute, self.compute_cpu = [], []
        for obs in T.OBSERVERS:
            path = self.param(f"thresholds_{obs}") or default_thresholds(obs, method)
            try:
                curves = ThresholdCurves.load(path)
                curves.check_method(method, origin=path)
                curves.check_compatible(plant, origin=path)
                if abs(curves.sample_period - plant.fdi_period) > 1e-12:
                    raise ThresholdError(f"{path}: sample period {curves.sample_period} s differs from the "
                                         f"FDI period {plant.fdi_period} s")
            except ThresholdError as exc:
                raise NodeError(str(exc), EXIT_BAD_INPUT) from None
            self.channels[obs] = ObserverChannel(obs, curves, self.param("persistence") or None)
        self.decision = self.param("decision_observer")
        if self.decision not in self.channels:
            raise NodeError(f"decision_observer must be one of {', '.join(T.OBSERVERS)}", EXIT_BAD_INPUT)
        gate = lambda msg_type, name: GatedPublisher(self.create_publisher(msg_type, name, T.RELIABLE),
                                                     self.param("min_subscribers"))
        self.pubs = {obs: {k: gate(DiagnosticArray if k == "status" else Vector3Stamped, name)
                           for k, name in T.fdi_output_topics(obs).items()} for obs in T.OBSERVERS}
        self.pub_diag = gate(DiagnosticArray, T.DIAGNOSTICS)
        self.gates = [self.pub_diag] + [p for pubs in self.pubs.values() for p in pubs.values()]
        self.done_samples = {}   # stamp -> observer -> rows of that stamp
        bound = lambda a: f"bound_{a}"
        elman = StampSync(AXES + tuple(bound(a) for a in AXES), lambda stamp, v: self._on_residual(
            "elman", stamp, [v[a][i] for i, a in enumerate(AXES)], [v[bound(a)][i] for i, a in enumerate(AXES)]))
        for a in AXES:
            elman.subscribe(self, a, T.residual_topic("elman", a), T.RELIABLE)
            elman.subscribe(self, bound(a), T.bound_topic("elman", a), T.RELIABLE)
        linear = StampSync(("all", "bound"), lambda stamp, v: self._on_residual("linear", stamp, v["all"], v["bound"]))
        linear.subscribe(self, "all", T.residual_topic("linear"), T.RELIABLE)
        linear.subscribe(self, "bound", T.bound_topic("linear"), T.RELIABLE)
        self.follow_run_end(period=plant.fdi_period)

    def _on_residual(self, observer, stamp, residual, bound):
        t0, c0 = time.perf_counter(), time.thread_time()
        rows = self.channels[observer].update(stamp, residual, bound)
        pubs = self.pubs[observer]
        pubs["threshold"].publish(vector_msg(stamp, [rows[a][1] for a in AXES]))
        pubs["alarm"].publish(vector_msg(stamp, [float(rows[a][2]) for a in AXES]))
        status = DiagnosticArray()
        status.header.stamp = time_msg(stamp)
        status.status = [_status(f"{observer} observer: wheel {a}", a, *rows[a]) for a in AXES]
        pubs["status"].publish(status)
        handled = self.done_samples.setdefault(stamp, {})
        handled[observer] = rows
        if len(handled) == len(self.channels):
            del self.done_samples[stamp]
            self._publish_diagnostics(stamp, handled)
            self.last_handled = stamp
        self.compute.append(time.perf_counter() - t0)   # the whole callback, publishing included
        self.compute_cpu.append(time.thread_time() - c0)

    def _publish_diagnostics(self, stamp, rows_of):
        """/diagnostics of one stamp from both observers' rows of that same stamp."""
        msg = DiagnosticArray()
        msg.header.stamp = time_msg(stamp)
        main = rows_of[self.decision]
        for a in AXES:
            extra = []
            for obs in self.channels:
                if obs != self.decision:
                    r, c, alarm, first = rows_of[obs][a]
                    extra += [KeyValue(key=f"{obs}_residual", value=f"{r:.6g}"),
                              KeyValue(key=f"{obs}_threshold", value=f"{c:.6g}"),
                              KeyValue(key=f"{obs}_alarm", value=str(bool(alarm)).lower())]
            msg.status.append(_status(f"rw_fdi: reaction wheel {a} ({self.decision} observer)", a, *main[a],
                                      extra=extra))
        self.pub_diag.publish(msg)

    def poll(self):
        flushed = all([g.flush() for g in self.gates])
        if flushed and self.run_ended():
            self.finish()

    def timing(self):
        from .timing import summary
        return summary(callback=self.compute, callback_cpu=self.compute_cpu)


main = main_for(IsolationNode)

if __name__ == "__main__":
    main()
