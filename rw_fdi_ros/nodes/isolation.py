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

It also identifies the fault of every alarmed wheel (core/identification.py):
it reads the FDI telemetry (with the identification terms) and from a
wheel's first alarm on estimates the fault's kind and size on every sample. The result goes into the wheel's
/diagnostics status (fault_kind, fault_size, fault_size_low/high and the
message) and onto /fdi/identification. Identification lives here, not in a
node of its own, because it refines this node's verdict: one status per wheel,
made of one stamp's alarm and telemetry.

An input stamped no later than the one before from the same source starts a
new run (bag replay feeds many runs through one graph): that source's alarms
or identification are forgotten.
"""
from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped

import numpy as np

from ..core.detection import METHODS, ThresholdCurves, ThresholdError
from ..core.identification import FaultIdentifier
from ..core.isolation import DECISION_OBSERVER, ObserverChannel
from ..core.plant_choices import DEFAULT as DEFAULT_CHOICES, PlantChoiceError, PlantChoices
from ..core.scenario import AXES
from ..paths import thresholds_dir
from . import topics as T
from .convert import fdi_sample_of, time_msg, vector_msg
from .runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for
from .gate import GatedPublisher
from .sync import StampSync


def default_thresholds(observer: str, method: str = "speed_aware", unit_calibration_time: float = 0.0) -> str:
    return str(thresholds_dir(method, unit_calibration_time) / f"thresholds_{observer}.json")


def _status(name, axis, residual, threshold, alarm, first, extra=(), identification=None):
    s = DiagnosticStatus(name=name, hardware_id=f"reaction_wheel_{axis}")
    s.level = DiagnosticStatus.ERROR if alarm else DiagnosticStatus.OK
    s.message = f"faulty since {first:g} s" if alarm else ("recovered" if first is not None else "nominal")
    if identification is not None:
        s.message += f": {identification.message()}"
        extra = [*extra, *(KeyValue(key=k, value=v) for k, v in identification.values().items())]
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
        self.declare_parameter("unit_calibration_time", 0.0)  # [s] the observers learn their wheel (as theirs)
        self.declare_parameter("decision_observer", DECISION_OBSERVER)
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
        calibration = self.calibration_time = self.param("unit_calibration_time")
        self.channels = {}
        self.compute, self.compute_cpu = [], []
        for obs in T.OBSERVERS:
            path = self.param(f"thresholds_{obs}") or default_thresholds(obs, method, calibration)
            try:
                curves = ThresholdCurves.load(path)
                curves.check_method(method, origin=path)
                curves.check_unit_calibration(calibration, origin=path)
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
        def gate(msg_type, name):
            return GatedPublisher(self.create_publisher(msg_type, name, T.RELIABLE),
                                                             self.param("min_subscribers"))
        self.pubs = {obs: {k: gate(DiagnosticArray if k == "status" else Vector3Stamped, name)
                           for k, name in T.fdi_output_topics(obs).items()} for obs in T.OBSERVERS}
        self.pub_diag = gate(DiagnosticArray, T.DIAGNOSTICS)
        self.pub_ident = gate(DiagnosticArray, T.IDENTIFICATION)
        self.gates = [self.pub_diag, self.pub_ident] + [p for pubs in self.pubs.values() for p in pubs.values()]
        self.done_samples = {}   # stamp -> observer (or 'telemetry') -> what arrived for that stamp
        self.identifier = FaultIdentifier(AXES)
        self.last_stamp = {}     # source -> its last stamp (a stamp that goes back starts a new run)
        self.create_subscription(DiagnosticArray, T.FDI_TELEMETRY, self._on_telemetry, T.RELIABLE)
        def bound(a):
            return f"bound_{a}"
        elman = StampSync(AXES + tuple(bound(a) for a in AXES), lambda stamp, v: self._on_residual(
            "elman", stamp, [v[a][i] for i, a in enumerate(AXES)], [v[bound(a)][i] for i, a in enumerate(AXES)]))
        for a in AXES:
            elman.subscribe(self, a, T.residual_topic("elman", a), T.RELIABLE)
            elman.subscribe(self, bound(a), T.bound_topic("elman", a), T.RELIABLE)
        linear = StampSync(("all", "bound"), lambda stamp, v: self._on_residual("linear", stamp, v["all"], v["bound"]))
        linear.subscribe(self, "all", T.residual_topic("linear"), T.RELIABLE)
        linear.subscribe(self, "bound", T.bound_topic("linear"), T.RELIABLE)
        self.follow_run_end(period=plant.fdi_period)

    def _new_run(self, source, stamp) -> bool:
        last = self.last_stamp.get(source)
        self.last_stamp[source] = stamp
        return last is not None and stamp <= last

    def _on_residual(self, observer, stamp, residual, bound):
        t0, c0 = time.perf_counter(), time.thread_time()
        if self._new_run(observer, stamp):
            self.channels[observer].reset()
        rows = self.channels[observer].update(stamp, residual, bound)
        pubs = self.pubs[observer]
        pubs["threshold"].publish(vector_msg(stamp, [rows[a][1] for a in AXES]))
        pubs["alarm"].publish(vector_msg(stamp, [float(rows[a][2]) for a in AXES]))
        status = DiagnosticArray()
        status.header.stamp = time_msg(stamp)
        status.status = [_status(f"{observer} observer: wheel {a}", a, *rows[a]) for a in AXES]
        pubs["status"].publish(status)
        self._arrived(stamp, observer, rows)
        self.compute.append(time.perf_counter() - t0)   # the whole callback, publishing included
        self.compute_cpu.append(time.thread_time() - c0)

    def _on_telemetry(self, msg):
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            sample = fdi_sample_of(msg, AXES)
        except ValueError as exc:
            self.fail(f"malformed {T.FDI_TELEMETRY}: {exc}", EXIT_BAD_INPUT)
            return
        if self._new_run("telemetry", sample.stamp_ns):
            self.identifier.reset()
        self._arrived(sample.stamp_ns, "telemetry", sample)
        self.compute.append(time.perf_counter() - t0)
        self.compute_cpu.append(time.thread_time() - c0)

    def _arrived(self, stamp, part, value):
        """Collect one stamp's parts; once both observers' rows and the telemetry are in, decide it."""
        handled = self.done_samples.setdefault(stamp, {})
        handled[part] = value
        if len(handled) < len(self.channels) + 1:
            return
        del self.done_samples[stamp]
        sample = handled.pop("telemetry")
        alarmed = {a: handled[self.decision][a][2] for a in AXES}
        finite = all(np.all(np.isfinite(x)) for x in (sample.tcv, sample.reaction_torque, sample.wheel_speed,
                                                        sample.ripple_phasor, sample.bus_motor_torque))
        # a non-finite sample stops the observers with a reason; it must not poison the estimate
        identified = self.identifier.update(sample, alarmed) if finite else dict(self.identifier.latest)
        self._publish_diagnostics(stamp, handled, identified)
        self.last_handled = stamp

    def _publish_diagnostics(self, stamp, rows_of, identified):
        """/diagnostics and /fdi/identification of one stamp from both observers' rows and the
        identification of that same stamp."""
        msg = DiagnosticArray()
        msg.header.stamp = time_msg(stamp)
        ident = DiagnosticArray()
        ident.header.stamp = time_msg(stamp)
        main = rows_of[self.decision]
        for a in AXES:
            found = identified.get(a)
            status = DiagnosticStatus(name=f"rw_fdi: identification wheel {a}", hardware_id=f"reaction_wheel_{a}")
            if found is None:
                status.level, status.message = DiagnosticStatus.OK, "no alarm"
                status.values = [KeyValue(key="fault_kind", value="none")]
            else:
                status.level = DiagnosticStatus.WARN if found.kind == "unknown" else DiagnosticStatus.ERROR
                status.message = found.message()
                status.values = [KeyValue(key=k, value=v) for k, v in found.values().items()]
                status.values.append(KeyValue(key="samples", value=str(found.samples)))
            ident.status.append(status)
            extra = []
            for obs in self.channels:
                if obs != self.decision:
                    r, c, alarm, first = rows_of[obs][a]
                    extra += [KeyValue(key=f"{obs}_residual", value=f"{r:.6g}"),
                              KeyValue(key=f"{obs}_threshold", value=f"{c:.6g}"),
                              KeyValue(key=f"{obs}_alarm", value=str(bool(alarm)).lower())]
            if self.calibration_time:
                learning = stamp <= self.calibration_time * 1e9
                extra.append(KeyValue(key="unit_calibration", value="learning" if learning else "calibrated"))
            status = _status(f"rw_fdi: reaction wheel {a} ({self.decision} observer)", a, *main[a],
                             extra=extra, identification=found)
            if self.calibration_time and learning and status.level == DiagnosticStatus.OK:
                # judged against the wheel type's spread until then: only gross faults show (calibration.py)
                status.message += f"; learning its unit until {self.calibration_time:g} s"
            channel = self.channels[self.decision]
            if channel.beyond_horizon and status.level == DiagnosticStatus.OK:   # never OK while it cannot judge
                status.level = DiagnosticStatus.STALE
                status.message = (f"cannot judge: the threshold curves end at {channel.curves.horizon:g} s "
                                  f"({self.param(f'thresholds_{self.decision}') or 'shipped'})")
            msg.status.append(status)
        self.pub_diag.publish(msg)
        self.pub_ident.publish(ident)

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
