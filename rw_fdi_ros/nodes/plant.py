"""plant: spacecraft + its set of reaction wheels, owner of /clock, stepped in lockstep.

It publishes the sample of step k (stamped k * control_period), waits until
the wheel allocation's command stamped k has arrived (one voltage per wheel
of the set, core/physics/wheel_set.py), advances one control period and publishes
step k+1. A command missing for ``command_timeout`` wall seconds stops the
run with an error.

Its wheels report what any wheel reports, speed and reaction torque on
/wheels: the FDI telemetry is made from that and the allocation's command by
the wheel_telemetry node, the way the FDI attaches to anyone's wheels.
"""
from __future__ import annotations

import math
import os

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import JointState, MagneticField
from std_msgs.msg import Header, String

from ..core.physics.plant import Plant
from ..core.physics.faults import FAULT_KINDS, Fault, nominal_values
from ..core.mission.scenario import ScenarioError, load_scenario
from ..core.physics.wheel_set import joint_name
from ..graph import topics as T
from ..storage.cdr import read_joint_state_cdr, read_vector_cdr
from ..graph.convert import step_stamp_ns
from ..graph.plant_report import PlantReport, run_units
from ..graph.runtime import EXIT_BAD_INPUT, EXIT_TIMEOUT, GraphNode, NodeError, ReadySignal, main_for, wall_time


class PlantNode(GraphNode):
    node_name = "plant"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.t_created = wall_time()
        self.t_first = self.t_last = None   # wall time of the first and the last step published
        self.declare_parameter("scenario", "fault_free")
        self.declare_parameter("seed", -1)               # -1: the scenario file's seed
        self.declare_parameter("duration", 0.0)          # 0: the scenario's duration [s]
        self.declare_parameter("control_period", 0.0)    # lockstep tick [s]; 0: the scenario's, else 0.1
        self.declare_parameter("emf_limit", "")          # physics.md [choice]; empty: the scenario's, else kf_scaled
        self.declare_parameter("wheel_momentum_coupling", Parameter.Type.BOOL)  # unset: the scenario's, else true
        self.declare_parameter("wheel_set", "")          # core/physics/wheel_set.py; empty: the scenario's
        self.declare_parameter("magnetic_field", "")     # core/physics/geomagnetic.py, in orbit; empty: the scenario's
        self.declare_parameter("command_timeout", 5.0)   # wall seconds without a command -> error
        self.declare_parameter("startup_timeout", 60.0)  # wall seconds to discover the graph
        # readers to wait for before the first step, per topic (runner/graph.py derives them from topics.READS)
        self.declare_parameter("attitude_readers", 3)    # the controllers (+ wheel allocation, recorder)
        self.declare_parameter("wheels_readers", 0)      # of /wheels: the wheel allocation (+ recorder)
        self.declare_parameter("wait_for_subscribers", 0)  # of each other topic it sends per step (the recorder)
        self.declare_parameter("magnetometer_readers", 0)  # of /magnetometer: the momentum dumping (+ recorder)
        # in orbit with magnetorquers: wait for the momentum-dumping node's dipole on each magnetometer step
        # (false: the rods stay off)
        self.declare_parameter("magnetorquers", False)
        # a recorder's reader may match the plant's writer later than the writer matches it (DDS discovery
        # is per direction): until /recorder/ready it could miss a whole run while the counts above look done
        self.declare_parameter("recorder_ready", False)  # wait for /recorder/ready (a recorder records the run)
        # the nodes to hear on /graph/ready before the first step (runner/graph.py: every one that says it)
        self.declare_parameter("ready_nodes", Parameter.Type.STRING_ARRAY)
        self.declare_parameter("truth_period", 1.0)      # ground truth republished every [s]
        # [s] of its own time the plant may run ahead of the newest /wheels/fdi_telemetry: wheel_telemetry is
        # not in the lockstep, and a reader further behind than its queue loses /wheels for good; 0: not paced
        self.declare_parameter("telemetry_lead", 0.0)
        try:
            scenario = load_scenario(self.param("scenario"))
            self.choices = scenario.plant_choices(emf_limit=self.param("emf_limit"),
                                                  wheel_momentum_coupling=self.param("wheel_momentum_coupling"),
                                                  control_period=self.param("control_period") or None,
                                                  wheel_set=self.param("wheel_set"),
                                                  magnetic_field=self.param("magnetic_field"))
            wheel = scenario.datasheet(self.choices)
        except (ScenarioError, ValueError) as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        from ..core.physics.wheel_set import wheel_set
        self.wheels = wheel_set(self.choices.wheel_set)
        self.names = self.wheels.names
        self.joints = tuple(joint_name(n) for n in self.names)
        nominal = nominal_values(wheel)   # the wheel type's healthy values (its own bus voltage)
        for name in self.names:  # live fault injection: setting one injects from the current sim time
            for kind in FAULT_KINDS:
                self.declare_parameter(f"fault.{name}.{kind}", nominal[kind])
        stray = sorted(n for n in self._parameter_overrides if n.startswith("fault.") and not self.has_parameter(n))
        if stray:   # a wheel the set does not have, or a kind there is not: never silently ignored
            raise NodeError(f"parameter {stray[0]}: no such fault; wheel set {self.wheels.name} has wheels "
                            f"{', '.join(self.names)} and the kinds {', '.join(FAULT_KINDS)}", EXIT_BAD_INPUT)
        self.add_on_set_parameters_callback(self._on_parameters)
        if self.param("seed") >= 0:
            scenario = scenario.with_seed(self.param("seed"))
        self.duration = self.param("duration") or scenario.duration
        self.progress_file, self.progress_at = os.environ.get("RW_FDI_PROGRESS"), 0.0
        self.period = self.choices.control_period
        self.last_step = int(round(self.duration / self.period))
        self.scenario = scenario
        self.plant = Plant(scenario, wheel=wheel, control_period=self.period,
                           wheel_momentum_coupling=self.choices.wheel_momentum_coupling, wheels=self.wheels,
                           duration=self.duration, magnetic_field=self.choices.magnetic_field)
        self.rods = self.param("magnetorquers") and scenario.magnetorquers is not None
        if self.param("magnetorquers") and not self.rods:
            raise NodeError(f"parameter magnetorquers: scenario {scenario.name} has none (give it an environment "
                            "and magnetorquers)", EXIT_BAD_INPUT)
        if scenario.magnetorquers is not None and not self.rods:
            self.get_logger().warn("the scenario has magnetorquers but parameter magnetorquers is false: "
                                   "the rods stay off (no momentum_dumping node is waited for)")
        # this run's units (ground truth): datasheet values unless the scenario draws them
        self.report = PlantReport(scenario.effective_text(self.choices.scenario_dict()), self.names,
                                  run_units(self.plant.wheel, 0, len(self.names)), self.param("truth_period"))

        self.publishers_by_topic = {}   # the table's topic name -> its publisher (resolved in our namespace)

        def pub(msg_type, topic, qos=T.RELIABLE):
            self.publishers_by_topic[topic] = self.create_publisher(msg_type, topic, qos)
            return self.publishers_by_topic[topic]
        self.pub_clock = pub(Clock, T.CLOCK)
        self.pub_attitude = pub(JointState, T.ATTITUDE)
        self.pub_wheels = pub(JointState, T.WHEELS)
        self.pub_effect = pub(JointState, T.FAULT_EFFECT)
        self.pub_truth = pub(DiagnosticArray, T.FAULT_TRUTH)
        self.pub_scenario = pub(String, T.SCENARIO, T.LATCHED)
        self.pub_done = pub(Header, T.PLANT_DONE, T.LATCHED)
        self.pub_magnetometer = pub(MagneticField, T.MAGNETOMETER) if self.plant.in_orbit else None
        # what the plant steps on, by the node that writes it
        self.subs = {"wheel allocation": self.create_subscription(JointState, T.WHEEL_COMMAND, self._on_command,
                                                                  T.RELIABLE, raw=True)}
        if self.rods:
            self.subs["momentum dumping"] = self.create_subscription(Vector3Stamped, T.DIPOLE_COMMAND,
                                                                     self._on_dipole, T.RELIABLE, raw=True)
        self.tcv = self.dipole = None   # this step's answers, stepped on once both are in (dipole: when due)
        self.lead_ns = round(self.param("telemetry_lead") * 1e9)
        # a step held at s waits for the FDI sample at or before s - lead; the newest one whose command is in
        # is at least s - fdi_period: a lead under the period could wait for what comes after the held step
        if 0 < self.param("telemetry_lead") < self.choices.fdi_period:
            raise NodeError(f"parameter telemetry_lead: 0 or at least the FDI period ({self.choices.fdi_period:g} "
                            f"s), got {self.param('telemetry_lead'):g}", EXIT_BAD_INPUT)
        self.telemetry_ns, self.held = 0, None   # the newest telemetry's stamp; a step waiting for it to catch up
        self.holds = 0
        if self.lead_ns > 0:
            self.subs["wheel telemetry"] = self.create_subscription(JointState, T.FDI_TELEMETRY, self._on_telemetry,
                                                                    T.RELIABLE, raw=True)
        self.dipole_due = False
        ready_nodes = list(self.param("ready_nodes") or [])
        self.ready = [ReadySignal(self, self.param("recorder_ready")),
                      ReadySignal(self, bool(ready_nodes), T.NODE_READY, ready_nodes)]
        self.started = False
        self.t_wait = wall_time()
        self.step_wall = []   # wall seconds from publishing step k to publishing step k+1
        self.compute_wall = []  # of which the plant's own step computation
        self.get_logger().info(f"scenario {scenario.name} seed {scenario.seed}, {self.duration:g} s, wheels "
                               f"{', '.join(self.names)} ({self.wheels.name}); waiting for the graph")

    # -- parameters: live fault injection ----------------------------------------
    def _on_parameters(self, params):
        for p in params:
            parts = p.name.split(".")
            if len(parts) == 3 and parts[0] == "fault" and hasattr(self, "plant"):
                value = float(p.value)
                if not math.isfinite(value):
                    return SetParametersResult(successful=False, reason="fault value must be finite")
                fault = Fault(kind=parts[2], wheel=self.names.index(parts[1]), onset=self.plant.time, value=value)
                self.plant.inject(fault)
                self.get_logger().warn(f"injected {parts[2]}={value:g} on wheel {parts[1]} at {self.plant.time:.1f} s")
        return SetParametersResult(successful=True)

    # -- lockstep ------------------------------------------------------------------
    def _graph_ready(self) -> bool:
        if any(s.get_publisher_count() < 1 for s in self.subs.values()) or not all(r.seen for r in self.ready):
            return False
        need = [(self.pub_attitude, self.param("attitude_readers")), (self.pub_wheels, self.param("wheels_readers"))]
        need += [(p, self.param("wait_for_subscribers")) for p in (self.pub_effect, self.pub_clock,
                                                                   self.pub_truth, self.pub_scenario)]
        if self.pub_magnetometer is not None:
            need.append((self.pub_magnetometer, self.param("magnetometer_readers")))
        return all(p.get_subscription_count() >= k for p, k in need)

    def poll(self):
        now = wall_time()
        if not self.started:
            if self._graph_ready():
                self.started = True
                self.t_first = wall_time()
                self._send(self.report.start())
                self._publish(self.plant.sample())
            elif now - self.t_wait > self.param("startup_timeout"):
                missing = [f"no {writer} on {s.topic_name}" for writer, s in self.subs.items()
                           if s.get_publisher_count() < 1]
                silent = [r.missing() for r in self.ready if not r.seen]
                what = (", ".join(missing) if missing else
                        f"never ready on {', '.join(silent)}: a reader not matched to its writers" if silent else
                        "subscribers missing")
                self.fail(f"graph not ready after {self.param('startup_timeout'):g} s ({what})", EXIT_TIMEOUT)
            return
        if self.exit_code is None and now - self.t_wait > self.param("command_timeout"):
            what = (f"FDI telemetry on {T.FDI_TELEMETRY}" if self.held is not None else
                    f"wheel command on {T.WHEEL_COMMAND}" if self.tcv is None else
                    f"magnetorquer dipole on {T.DIPOLE_COMMAND}")
            self.fail(f"no {what} for step t={self.plant.time:.1f} s within {self.param('command_timeout'):g} s",
                      EXIT_TIMEOUT)

    def _this_step(self, stamp) -> bool:
        """Whether an answer stamped ``stamp`` is for the step waiting (the lockstep only takes this step's)."""
        return self.started and self.exit_code is None and stamp == step_stamp_ns(self.plant.step_index, self.period)

    def _on_command(self, raw):
        stamp, _, _, tcv = read_joint_state_cdr(raw)
        if not self._this_step(stamp):
            return
        if len(tcv) != len(self.names) or not np.all(np.isfinite(tcv)):
            self.fail(f"wheel command at t={self.plant.time:.1f} s is {tcv.tolist()}: one finite voltage per "
                      f"wheel ({', '.join(self.joints)}) expected", EXIT_BAD_INPUT)
            return
        self.tcv = tcv
        self._advance()

    def _on_dipole(self, raw):
        stamp, dipole = read_vector_cdr(raw)
        if not self._this_step(stamp):
            return
        if not np.all(np.isfinite(dipole)):
            self.fail(f"magnetorquer dipole at t={self.plant.time:.1f} s is not finite", EXIT_BAD_INPUT)
            return
        self.dipole = dipole
        self._advance()

    def _advance(self):
        if self.tcv is None or (self.dipole_due and self.dipole is None):
            return
        if self.dipole_due:
            self.plant.command_dipole(self.dipole)
        tcv, self.tcv, self.dipole = self.tcv, None, None
        t0 = wall_time()
        sample = self.plant.step(tcv)
        if self.progress_file and t0 - self.progress_at >= 1.0:   # our launcher shows it (launcher.run)
            self.progress_at = t0
            tmp = f"{self.progress_file}.tmp"
            with open(tmp, "w") as fh:
                fh.write(f"{self.plant.time:.3f} {self.duration:.3f}\n")
            os.replace(tmp, self.progress_file)
        self.compute_wall.append(wall_time() - t0)
        self.step_wall.append(t0 - self.t_wait)
        if step_stamp_ns(self.plant.step_index, self.period) - self.telemetry_ns > self.lead_ns > 0:
            self.held, self.t_wait = sample, wall_time()   # published once the telemetry catches up
            self.holds += 1
            return
        self._publish(sample)

    def _on_telemetry(self, raw):
        self.telemetry_ns = max(self.telemetry_ns, read_joint_state_cdr(raw)[0])
        if self.held is not None and self.exit_code is None and (
                step_stamp_ns(self.plant.step_index, self.period) - self.telemetry_ns <= self.lead_ns):
            sample, self.held = self.held, None
            self._publish(sample)

    def _send(self, messages):
        for topic, message in messages:
            self.publishers_by_topic[topic].publish(message)

    def _publish(self, sample):
        self.t_wait = wall_time()
        k = self.plant.step_index
        stamp = step_stamp_ns(k, self.period)
        field = None if sample.magnetic_field is None else sample.magnetic_field[0]
        self.dipole_due = self.rods and field is not None
        self._send(self.report.step(stamp, sample.time, sample.attitude[0], sample.body_rate[0],
                                    self.plant.wheel_angle[0], sample.wheel_speed[0], sample.reaction_torque[0],
                                    sample.fault_effect[0],
                                    {kind: v[0] for kind, v in sample.operating_point.items()}, self.plant.faults(),
                                    field))
        if k >= self.last_step:
            # done only once every reader has the last sample: a recorder that sees done has it all
            for pub in (self.pub_clock, self.pub_truth, self.pub_attitude, self.pub_wheels, self.pub_effect,
                        *([self.pub_magnetometer] if self.pub_magnetometer else [])):
                if not pub.wait_for_all_acked(Duration(seconds=5.0)):
                    self.get_logger().warn(f"{pub.topic_name}: not every reader acknowledged the last step "
                                           "within 5 s; done anyway (the recorder says what it lacks)")
            self.t_last = wall_time()
            self._send(self.report.done(stamp))
            # every node ends on it, the recorder included: it must reach them before this writer goes
            if not self.pub_done.wait_for_all_acked(Duration(seconds=5.0)):
                self.get_logger().warn(f"{T.PLANT_DONE}: not every reader acknowledged it within 5 s")
            self.finish()

    def timing(self):
        """Figures for ``rw-fdi bench``: the node's phases and step times."""
        from ..graph.timing import summary
        phases = {}
        if self.t_first is not None:
            phases["discovery_s"] = self.t_first - self.t_created   # node up -> every reader matched
            if self.t_last is not None:
                phases["stepping_s"] = self.t_last - self.t_first
        return {"steps": len(self.step_wall), "telemetry_holds": self.holds, **phases,
                **summary(step=self.step_wall, compute=self.compute_wall)}

main = main_for(PlantNode)

if __name__ == "__main__":
    main()
