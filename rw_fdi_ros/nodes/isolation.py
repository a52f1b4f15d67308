"""isolation: residuals against thresholds, persistence, which wheel is faulty and since when.

It runs stages 2-5 of the FDI pipeline (core/fdi/pipeline.Isolation, the very object the core loop and the
offline judge step): each observer's residual and ripple bound, as its node publishes them, against its
band for P consecutive samples (ObserverChannel); the decision (one observer, or a vote ``KofN``); the
latched verdict within the operating envelope; the identification. What it runs is the run's FDI, the
``fdi.*`` parameter set (graph/fdi_parameters.py, docs/graph.md "The FDI configuration"): its bands found
and checked by FdiConfig's one rule. It publishes per observer the thresholds, the alarm flags and a
DiagnosticArray with residual, threshold, margin and first alarm per wheel, and /diagnostics with one
status per wheel, decided by ``fdi.decision`` (the method's decision observer by default: the model
observer speed-aware, the Elman network for the thesis method; core/fdi/verdict.py says why), stamped with
the sim clock. A wheel the decision alarms is a confirmed failure: /diagnostics holds it (latched) until the
``~/reset`` service (std_srvs/Trigger) clears it. Every output of stamp k is made from the inputs of stamp k
alone, so the same run gives the same messages.

It also identifies the fault of every alarmed wheel (core/fdi/identification.py):
it reads the FDI telemetry (with the identification terms) and from the
fault's onset (found at a wheel's first alarm in the samples before it)
estimates the fault's kind and size on every sample, on the wheel's own unit
when the FDI calibrates. The result goes into the wheel's /diagnostics status
(fault_kind, fault_size, fault_size_low/high, fault_unit,
fault_size_unit_limited and the message) and onto /fdi/identification. Identification lives here, not in a
node of its own, because it refines this node's verdict: one status per wheel,
made of one stamp's alarm and telemetry.

It monitors its inputs (core/fdi/input_health.py) and never reports OK while it
could not raise an alarm: an input stamped back at a run's first sample starts
a new run (bag replay feeds many runs through one graph: that source's alarms
or identification are forgotten); a duplicate or late one is dropped and said
(WARN); a gap in the stamps is said (WARN); a non-finite residual is not
judged: the wheel reads STALE "cannot judge" with its alarm held; an observer
silent for ``input_timeout`` wall seconds while the telemetry goes on has its
samples decided without it, STALE; telemetry that stops for that long makes
/diagnostics say so, STALE.
"""
from __future__ import annotations

import math
import time

from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState, PointCloud2

import numpy as np

from ..core.fdi.calibration import calibration_samples
from ..core.fdi.input_health import ERROR, NEW_RUN, OK, OUT_OF_ORDER, STALE, WARN, InputMonitor
from ..core.fdi.verdict import stamp_seconds
from ..core.fdi.pipeline import Isolation
from ..core.mission.plant_choices import DEFAULT as DEFAULT_CHOICES, PlantChoiceError, PlantChoices
from ..core.physics.wheel_set import joint_name, wheel_set
from ..storage.cdr import Status, diagnostic_array_cdr, joint_state_cdr
from ..graph import topics as T
from ..graph.convert import fdi_sample_of, stamp_ns
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for
from ..graph.gate import GatedPublisher
from ..graph.report_pairing import ReportGridPairing
from ..graph.sync import StampSync
from ..graph.fdi_parameters import declare_fdi
from ..graph.wheel_type import declare_wheel_type


def _identification_status(wheel: str, found) -> Status:
    """/fdi/identification's status of ``wheel``: its Identification (None: no alarm)."""
    status = Status(name=f"rw_fdi: identification wheel {wheel}", hardware_id=f"reaction_wheel_{wheel}")
    if found is None:
        status.level, status.message = OK, "no alarm"
        status.values = [("fault_kind", "none")]
        return status
    status.level = WARN if found.kind == "unknown" else ERROR
    status.message = found.message()
    status.values = [*found.values().items(), ("samples", str(found.samples))]
    return status


def _status(name, axis, residual, threshold, alarm, first, extra=(), identification=None, unjudged=None, note=None,
            latched=False):
    """One wheel's status. ``unjudged``: why this sample could not be judged (STALE unless alarmed,
    the alarm held); ``note``: what the input stream did (WARN unless worse)."""
    s = Status(name=name, hardware_id=f"reaction_wheel_{axis}")
    level = ERROR if alarm else OK
    s.message = f"faulty since {first:g} s" if alarm else ("recovered" if first is not None else "nominal")
    if latched:   # confirmed, held although the residual is back under its threshold
        s.message += " (latched; residual under the threshold now; ~/reset clears it)"
    if unjudged:
        s.message = f"cannot judge: {unjudged}" + (f" (alarm held: {s.message})" if alarm else "")
        level = level if alarm else STALE
    if note is not None:
        s.message += f"; {note.message}"
        level = level if level == ERROR else max(level, note.level)
    s.level = level
    # what the FDI says of itself, as values a tool reads (bag_series.health_from_bag), not only as words
    extra = [*extra, *([("judged", "false")] if unjudged else []),
             *([("input", note.message)] if note is not None else [])]
    if identification is not None:
        s.message += f": {identification.message()}"
        extra = [*extra, *identification.values().items()]
    s.values = [("residual", f"{residual:.6g}"), ("threshold", f"{threshold:.6g}"),
                ("margin", f"{threshold - abs(residual):.6g}"),
                ("first_alarm", "none" if first is None else f"{first:g}"), *extra]
    return s


class IsolationNode(GraphNode):
    node_name = "isolation"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("latch", True)               # a confirmed failure stays until ~/reset
        self.declare_parameter("await_bus_grid", False)     # each report waits for its grid from the first on
        self.declare_parameter("input_timeout", 10.0)       # wall s an input may be silent before it is said
        self.declare_parameter("min_subscribers", 0)        # readers of each output (the recorder) before it goes
        self.declare_parameter("diagnostics_readers", 0)    # of /diagnostics: the recorder (+ a replay's player)
        # the running graph's plant choices: curves fitted under others are refused
        for key, value in DEFAULT_CHOICES.as_dict().items():
            self.declare_parameter(key, value)
        try:
            plant = PlantChoices(**{k: self.param(k) for k in DEFAULT_CHOICES.as_dict()})
        except PlantChoiceError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        try:   # the run's FDI (graph/fdi_parameters.py): its bands by FdiConfig's rule, checked against the plant
            fdi = declare_fdi(self)
            self.fdi = fdi = fdi.for_vehicle(fdi.vehicle or plant.vehicle)
            curves = fdi.load_thresholds(plant)
            decision = fdi.decision_rule
        except ValueError as exc:   # ThresholdError, ObserverError: one line naming the file or the plug-in
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        calibration = self.calibration_time = fdi.unit_calibration
        self.wheel_set = plant.wheel_set
        self.names = wheel_set(plant.wheel_set).names   # every wheel of the set, the redundant one included
        self.joints = tuple(joint_name(n) for n in self.names)
        self.compute, self.period_cpu = [], {}   # wall per callback; CPU per FDI stamp [s]
        self.wheel = declare_wheel_type(self)   # the wheel type: its identification and envelope
        # the FDI pipeline's stages 2-5 (core/fdi/pipeline.py), the core loop's and the offline judge's too
        self.isolation = Isolation(self.names, curves, decision, fdi.persistence, self.param("latch"), self.wheel,
                                   calibration_samples(calibration, plant.fdi_period), identification=True)
        self.channels, self.decision = self.isolation.channels, self.isolation.decision
        self.verdict, self.identifier = self.isolation.verdict, self.isolation.identifier
        # the operator's command that clears every confirmed failure (std_srvs/Trigger, as FDIR resets go)
        from std_srvs.srv import Trigger
        self.create_service(Trigger, "~/reset", self._on_reset)
        def gate(msg_type, name, readers="min_subscribers"):
            return GatedPublisher(self.create_publisher(msg_type, name, T.RELIABLE), self.param(readers))
        self.pubs = {obs: {k: gate(DiagnosticArray if k == "status" else JointState, name)
                           for k, name in T.fdi_output_topics(obs).items()} for obs in self.channels}
        self.pub_diag = gate(DiagnosticArray, T.DIAGNOSTICS, "diagnostics_readers")
        self.pub_ident = gate(DiagnosticArray, T.IDENTIFICATION)
        self.gates = [self.pub_diag, self.pub_ident] + [p for pubs in self.pubs.values() for p in pubs.values()]
        self.done_samples = {}   # stamp -> observer (or 'telemetry') -> what arrived for that stamp
        self.inputs = {part: InputMonitor(f"{part} residuals" if part in self.channels else "FDI telemetry",
                                          plant.fdi_period) for part in (*self.channels, "telemetry")}
        self.last_input = time.monotonic()
        self.last_row = {}   # observer -> wall time of its last row
        self.silent_said = False
        # the report and its bus-voltage grid come on two topics, in either order (graph/report_pairing.py)
        self.pairing = ReportGridPairing(self.inputs["telemetry"].period_ns, self._on_report)
        self.said_no_grid = False
        # else only once the grid's publisher is seen: discovery may bring the report's publisher first
        self.await_bus_grid = self.param("await_bus_grid")
        inputs = [self.create_subscription(JointState, T.FDI_TELEMETRY, self._on_telemetry, T.RELIABLE)]
        self.sub_bus_grid = self.create_subscription(PointCloud2, T.FDI_BUS_GRID, self._on_bus_grid, T.RELIABLE)
        for obs in self.channels:   # one row per stamp: residual and bound of each of the observer's topics
            inputs += self._follow_observer(obs)
        self.say_ready_when_heard([*inputs, self.sub_bus_grid] if self.await_bus_grid else inputs)
        self.follow_run_end(period=plant.fdi_period, inputs=(T.FDI_TELEMETRY,))
        self.live = bool(self.param("end_with_run"))   # a live run, where the input watchdog runs

    def _follow_observer(self, observer):
        """Subscribe to an observer's residual and bound topics (one per wheel for the Elman nodes, one for
        all the wheels otherwise) and decide its rows stamp by stamp once every topic of the stamp is in; returns
        the subscriptions."""
        axes = T.observer_axes(observer, self.wheel_set)
        topics = {(kind, a): T.observer_topic(observer, kind, a) for a in axes for kind in ("residual", "ripple_bound")}

        def row(stamp, v):
            def column(kind):   # a per-wheel node's messages carry its own wheel only
                return v[kind, None] if axes == (None,) else [v[kind, a][0] for a in self.names]
            self._on_residual(observer, stamp, column("residual"), column("ripple_bound"))
        sync = StampSync(tuple(topics), row)
        return [sync.subscribe(self, key, topic, T.RELIABLE) for key, topic in topics.items()]

    def _accept(self, source, stamp) -> bool:
        """Whether to use a source's input stamped ``stamp``; a new run resets what the source feeds."""
        self.last_input, self.silent_said = time.monotonic(), False
        if source in self.channels:
            self.last_row[source] = self.last_input
        order = self.inputs[source].accept(stamp)
        if order == OUT_OF_ORDER:
            self.get_logger().warn(self.inputs[source].last_note.message)
            return False
        if order == NEW_RUN:
            if source == "telemetry":
                self.identifier.reset()
            else:
                self.channels[source].reset()
                if source == self.decision.lead:   # a new run's verdict starts from no confirmed failure
                    self.verdict.reset()
        return True

    def _on_residual(self, observer, stamp, residual, bound):
        t0, c0 = time.perf_counter(), time.thread_time()
        if not self._accept(observer, stamp):
            return
        rows = self.isolation.observe(observer, stamp, residual, bound)
        self._publish_observer(observer, stamp, rows, note=self.inputs[observer].take_note(stamp))
        self._arrived(stamp, observer, rows)
        self._spent(stamp, t0, c0)

    def _on_telemetry(self, msg):
        # reports are decided in order, each with its grid: the two topics arrive in either order, and a report
        # may come before the grid of the one before it (a loaded machine)
        awaited = self.await_bus_grid or self.sub_bus_grid.get_publisher_count() > 0
        self.pairing.report(msg, stamp_ns(msg.header.stamp), awaited)

    def _on_bus_grid(self, msg):
        self.pairing.grid(msg, stamp_ns(msg.header.stamp))

    def _on_report(self, msg, bus_grid):
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            sample = fdi_sample_of(msg, self.names, bus_grid=bus_grid)
        except ValueError as exc:
            self.fail(f"malformed {T.FDI_TELEMETRY}: {exc}", EXIT_BAD_INPUT)
            return
        if not self._accept("telemetry", sample.stamp_ns):
            return
        self._arrived(sample.stamp_ns, "telemetry", sample)
        self._spent(sample.stamp_ns, t0, c0)

    def _spent(self, stamp, t0, c0):
        """One callback's wall time (publishing included) and its CPU, summed per FDI stamp: the node's budget is
        per FDI period, whatever callbacks make it up (each observer's rows, the telemetry)."""
        self.compute.append(time.perf_counter() - t0)
        self.period_cpu[stamp] = self.period_cpu.get(stamp, 0.0) + time.thread_time() - c0

    def _arrived(self, stamp, part, value):
        """Collect one stamp's parts; once every observer's rows and the telemetry are in, decide it."""
        handled = self.done_samples.setdefault(stamp, {})
        handled[part] = value
        if len(handled) < len(self.channels) + 1:
            return
        self._decide(stamp)

    def _decide(self, stamp, silent=()):
        """/diagnostics of one stamp; ``silent``: observers whose rows never came (judged without them)."""
        handled = self.done_samples.pop(stamp)
        sample = handled.pop("telemetry")
        for obs in silent:   # the alarm state held, every wheel unable to judge
            monitor = self.inputs[obs]   # its rows of this stamp, should they still come, are dropped as late
            monitor.last_ns = stamp if monitor.last_ns is None else max(monitor.last_ns, stamp)
            channel = self.channels[obs]
            k = int(round(stamp * 1e-9 / channel.curves.sample_period))
            rows = {a: (float("nan"), channel.curves.at(a, k), r.active, r.first_alarm)
                    for a, r in channel.rules.items()}
            self._publish_observer(obs, stamp, rows, silent=True)
            handled[obs] = rows
        # /diagnostics: latched, and not judged for a wheel outside the operating envelope
        self.envelope = self.verdict.judged(sample.wheel_speed)
        self.speeds = sample.wheel_speed
        decided = self.isolation.verdict.decide(handled, sample.wheel_speed)
        finite = all(np.all(np.isfinite(x)) for x in (sample.tcv, sample.reaction_torque, sample.wheel_speed,
                                                        sample.ripple_phasor, sample.bus_motor_torque,
                                                        sample.model_torque, sample.motor_torque,
                                                        sample.friction_torque, sample.free_motor_torque)
                     if x is not None)
        # a non-finite sample is not judged by the observers; it must not poison the estimate either
        if sample.bus_motor_torque is None and not self.said_no_grid:   # identification needs the grid
            self.said_no_grid = True
            self.get_logger().warn(f"{T.FDI_TELEMETRY} at {stamp * 1e-9:g} s without its {T.FDI_BUS_GRID}: fault "
                                   "identification skips the samples that lack it")
        identified = (self.isolation.identify(sample, decided) if finite and sample.bus_motor_torque is not None
                      else dict(self.identifier.latest))
        self._publish_diagnostics(stamp, handled, decided, identified,
                                  [o for o in self.decision.observers if o in silent])
        self.last_handled = stamp

    def _on_reset(self, request, response):
        """Forget every confirmed failure and identification: each wheel is judged afresh from the next
        sample (a fault still there is confirmed again after the persistence)."""
        confirmed = [a for a, t in self.verdict.confirmed.items() if t is not None]
        for channel in self.channels.values():
            channel.reset()
        self.verdict.reset()
        self.identifier.clear()   # the units learnt stay: the wheels are the same
        response.success = True
        response.message = (f"cleared the confirmed failures of wheels {', '.join(confirmed)}" if confirmed
                            else "no confirmed failure to clear")
        self.get_logger().warn(f"reset by command: {response.message}")
        return response

    def _publish_diagnostics(self, stamp, rows_of, main, identified, silent=()):
        """/diagnostics and /fdi/identification of one stamp from every observer's rows, the decision's
        (``main``, latched) and the identification of that same stamp; ``silent``: the deciding observers whose
        rows never came."""
        statuses, ident = [], []
        note = self.inputs["telemetry"].take_note(stamp)
        for a in self.names:
            found = identified.get(a)
            ident.append(_identification_status(a, found))
            extra = []
            for obs in self.channels:
                if self.decision.observers != (obs,):   # a vote shows every observer's row
                    r, c, alarm, first = rows_of[obs][a]
                    extra += [(f"{obs}_residual", f"{r:.6g}"), (f"{obs}_threshold", f"{c:.6g}"),
                              (f"{obs}_alarm", str(bool(alarm)).lower())]
            if self.calibration_time:
                learning = stamp <= self.calibration_time * 1e9
                extra.append(("unit_calibration", "learning" if learning else "calibrated"))
            if self.verdict.latched[a]:
                extra.append(("latched", "true"))
            # an observer beside the decision that cannot judge is named: the FDI is never silently blind
            blind = [o for o in self.channels if o not in self.decision.observers
                     and self._why_unjudged(o, stamp, rows_of[o][a]) is not None]
            if blind:
                extra.append(("blind_observers", ",".join(blind)))
            # a vote judges only where every voter could: one silent or non-finite, and it cannot say
            unjudged = next((why for why in (self._why_unjudged(o, stamp, rows_of[o][a], o in silent)
                                             for o in self.decision.observers) if why is not None), None)
            if unjudged is None and not self.envelope[a]:
                speed = self.speeds[self.names.index(a)]
                unjudged = (f"outside the operating envelope (wheel speed {speed:.1f} rad/s, "
                            f"judged within +-{self.verdict.envelope:.4g})")
            status = _status(f"{T.VERDICT_STATUS} {a} ({self.decision.phrase})", a, *main[a],
                             extra=extra, identification=found, note=note, unjudged=unjudged,
                             latched=self.verdict.latched[a])
            if blind:
                status.message += f"; {', '.join(blind)} observer{'s' if len(blind) > 1 else ''} cannot judge"
            if self.calibration_time and learning and status.level == OK:
                # judged against the wheel type's spread until then: only gross faults show (calibration.py),
                # which is no judgement of the wheel: say so, and count it in the FDI's health
                status.level = STALE
                status.message = f"cannot judge yet: learning its unit until {self.calibration_time:g} s"
                status.values.append(("judged", "false"))
            channel = self.channels[self.decision.lead]
            beyond = stamp_seconds(stamp) > channel.curves.horizon   # this stamp's, not the channel's latest
            if beyond and status.level == OK:   # never OK while it cannot judge
                status.level = STALE
                status.values.append(("judged", "false"))
                status.message = (f"cannot judge: the threshold curves end at {channel.curves.horizon:g} s "
                                  f"({self.fdi.threshold_path(self.decision.lead)})")
            statuses.append(status)
        self.pub_diag.publish(diagnostic_array_cdr(stamp, statuses))
        self.pub_ident.publish(diagnostic_array_cdr(stamp, ident))

    def _publish_observer(self, observer, stamp, rows, note=None, silent=False):
        """Thresholds, alarms and the per-wheel status of one observer's sample."""
        pubs = self.pubs[observer]
        pubs["threshold"].publish(joint_state_cdr(stamp, self.joints, effort=[rows[a][1] for a in self.names]))
        pubs["alarm"].publish(joint_state_cdr(stamp, self.joints, effort=[float(rows[a][2]) for a in self.names]))
        pubs["status"].publish(diagnostic_array_cdr(stamp, [
            _status(f"{observer} observer: wheel {a}", a, *rows[a], note=note,
                    unjudged=self._why_unjudged(observer, stamp, rows[a], silent)) for a in self.names]))

    def _why_unjudged(self, observer, stamp, row, silent=False):
        """Why an observer's sample of a wheel (its ``row`` of that stamp: the channel has moved on by the
        time a stamp is decided) was not judged (STALE), or None."""
        if silent:
            return (f"no {observer} residual for {stamp * 1e-9:g} s within "
                    f"{self.param('input_timeout'):g} s (observer silent)")
        if not (math.isfinite(row[0]) and math.isfinite(row[1])):
            return f"non-finite {observer} residual at {stamp * 1e-9:g} s"
        return None

    def _watch_inputs(self):
        """Samples an observer never completed are decided without it; silence of every input is said."""
        self.pairing.flush(waited=self.param("input_timeout"))   # a grid that never came
        if not self.live:   # a replay's player paces on /diagnostics and fails a stalled replay itself
            return
        now, timeout = time.monotonic(), self.param("input_timeout")
        # silent: having spoken, it sent no row for input_timeout (not one that lags, nor the graph starting)
        silent = {o for o in self.channels if now - self.last_row.get(o, now) > timeout}
        for stamp in sorted(self.done_samples):
            handled = self.done_samples[stamp]
            missing = [o for o in self.channels if o not in handled]
            if "telemetry" in handled and missing and set(missing) <= silent:
                self._decide(stamp, silent=missing)
        last = self.inputs["telemetry"].last_ns
        if last is not None and not self.silent_said and now - self.last_input > timeout and not self.run_ended():
            self.silent_said = True
            self.pub_diag.publish(diagnostic_array_cdr(last, [
                Status(STALE, f"{T.VERDICT_STATUS} {a} ({self.decision.phrase})",
                       f"cannot judge: no input for {timeout:g} s after {last * 1e-9:g} s", f"reaction_wheel_{a}")
                for a in self.names]))

    def poll(self):
        self._watch_inputs()
        flushed = all([g.flush() for g in self.gates])
        if flushed and self.run_ended():
            self.finish()

    def timing(self):
        """Figures for ``rw-fdi bench``: the node's wall time per callback, its CPU per FDI period (stamp)."""
        from ..graph.timing import summary
        out = summary(callback=self.compute, callback_cpu=list(self.period_cpu.values()))
        if self.period_cpu:   # where the worst period was: an alarm, a decision, a run's start
            out["callback_cpu_max_at_s"] = 1e-9 * max(self.period_cpu, key=self.period_cpu.get)
        return out


main = main_for(IsolationNode)

if __name__ == "__main__":
    main()
