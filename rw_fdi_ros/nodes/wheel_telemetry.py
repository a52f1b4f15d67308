"""wheel_telemetry: the FDI telemetry from what any wheel and its driver report.

The FDI nodes read /wheels/fdi_telemetry (and its bus grid) once per FDI
period. This node makes them from two standard streams, at any rate at or
above the FDI's, with jitter and dropped messages:

* /wheels, sensor_msgs/JointState: velocity = wheel speed Omega [rad/s];
  effort, where it has a value per joint, = reaction torque r [N m] (else r
  from the speed, core/fdi/wheel_reports.py);
* /wheels/command, sensor_msgs/JointState: effort = torque command voltage u [V];
* optionally the driver's housekeeping, held until the next report: /wheels/bus_voltage,
  sensor_msgs/BatteryState (voltage [V]) and /wheels/temperature, sensor_msgs/Temperature (temperature [C]),
  each naming its joint in header.frame_id (empty: every wheel). The identification holds its bus and
  temperature families to them (core/fdi/identification: a report, not the samples, then tells a current
  loss from a bus drop).

The wheels are matched by joint name: the wheel set's reaction_wheel_<name>,
or ``joint_names`` (the streams' own names, in the wheel set's order). Both
topics remap as any ROS topic. The nominal model's torque, friction and ripple
phasor come from ``wheel_type`` (the vehicle's datasheet), never from a
simulator's internals: core/fdi/wheel_reports.ReportSampler puts the reports
on the control grid and averages them. Stamps are the messages' (sim time or
wall time alike). Our own graph goes this way too: the plant reports its
wheels as any wheel does, and this node makes what the FDI sees.
"""
from __future__ import annotations

import numpy as np
from rclpy.parameter import Parameter
from sensor_msgs.msg import BatteryState, JointState, PointCloud2, Temperature

from ..core.fdi.wheel_reports import ReportSampler
from ..core.physics.wheel_set import DEFAULT_WHEEL_SET, joint_name, wheel_set
from ..graph import topics as T
from ..graph.convert import fdi_messages, stamp_ns
from ..graph.gate import GatedPublisher
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for, relative
from ..graph.wheel_type import declare_wheel_type


# FdiSample channel -> (message type, topic, its field): the driver's housekeeping, optional
HOUSEKEEPING = {"bus_voltage": (BatteryState, T.WHEEL_BUS_VOLTAGE, "voltage"),
                "temperature": (Temperature, T.WHEEL_TEMPERATURE, "temperature")}
STALLED = 10   # messages in a row whose stamps do not advance: an unstamped stream, said in one line


class WheelTelemetryNode(GraphNode):
    node_name = "wheel_telemetry"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("wheel_set", DEFAULT_WHEEL_SET)   # core/physics/wheel_set.py
        self.declare_parameter("joint_names", Parameter.Type.STRING_ARRAY)   # the streams', in the set's order
        self.declare_parameter("fdi_period", 1.0)     # [s] T
        self.declare_parameter("control_period", 0.1)  # [s] dt, the grid the reports are put on
        self.declare_parameter("max_gap", 2.5)        # [s] speed reports further apart: the FDI cannot judge
        # [s] of newer speed reports a speed report waits for its command (a driver sending on change only);
        # 0: until it comes (a source in lockstep with its commands, as our plant is)
        self.declare_parameter("command_hold", 1.0)
        self.declare_parameter("min_subscribers", 0)   # readers of the telemetry before the first sample goes
        self.declare_parameter("bus_grid_readers", 0)  # readers of its bus grid (the isolation node) before it goes
        wheel = declare_wheel_type(self)
        try:
            names = wheel_set(self.param("wheel_set")).names
        except ValueError as exc:
            raise NodeError(f"parameter {exc}", EXIT_BAD_INPUT) from None
        joints = list(self.param("joint_names") or []) or [joint_name(n) for n in names]
        if len(joints) != len(names) or len(set(joints)) != len(joints):
            raise NodeError(f"parameter joint_names: {len(names)} distinct names for the wheel set's "
                            f"{', '.join(names)}, got {joints}", EXIT_BAD_INPUT)
        fdi_period, step = self.param("fdi_period"), self.param("control_period")
        # in whole nanoseconds, as the grid's points are: 1/3 s never lands on a 1-s FDI stamp
        if round(fdi_period * 1e9) % round(step * 1e9) or step > fdi_period:
            raise NodeError("parameter control_period must divide fdi_period in whole nanoseconds", EXIT_BAD_INPUT)
        self.names, self.joints = names, tuple(joints)
        self.stamps = {}   # topic -> (its newest stamp [ns], messages in a row that did not advance it)
        self.wheel = wheel
        self.reports = ReportSampler(wheel, fdi_period, step, self.param("max_gap"), identification=True,
                                     hold=self.param("command_hold"))
        self.pubs = {T.FDI_TELEMETRY: GatedPublisher(self.create_publisher(JointState, T.FDI_TELEMETRY, T.RELIABLE),
                                                     self.param("min_subscribers")),
                     T.FDI_BUS_GRID: GatedPublisher(self.create_publisher(PointCloud2, T.FDI_BUS_GRID, T.RELIABLE),
                                                    self.param("bus_grid_readers"))}
        # once it hears a writer on both: a plant that must not step before (our graph) waits for it
        self.say_ready_when_heard([self.create_subscription(JointState, T.WHEEL_COMMAND, self._on_command,
                                                            T.RELIABLE),
                                   self.create_subscription(JointState, T.WHEELS, self._on_wheels, T.RELIABLE)])
        self.housekeeping = [self.create_subscription(kind, topic, self._on_housekeeping(channel, topic, field),
                                                      T.RELIABLE)
                             for channel, (kind, topic, field) in HOUSEKEEPING.items()]
        self.follow_run_end(period=fdi_period)   # a run that says its end (/plant/done): ours, a replay

    def _ordered(self, msg, field: str, topic: str):
        """The message's ``field`` in the wheel set's order; a field without a value per joint, or a joint
        missing, is a bad stream: the node stops naming it (None)."""
        values = list(getattr(msg, field))
        if len(values) != len(msg.name):
            self.fail(f"{self.resolve_topic_name(relative(topic))}: {len(values)} {field} values for "
                      f"{len(msg.name)} joints", EXIT_BAD_INPUT)
            return None
        by_name = dict(zip(msg.name, values))
        missing = [j for j in self.joints if j not in by_name]
        if missing:
            self.fail(f"{self.resolve_topic_name(relative(topic))}: no joint(s) {', '.join(missing)} among "
                      f"{', '.join(msg.name)} (parameter joint_names maps the stream's names)", EXIT_BAD_INPUT)
            return None
        return np.array([by_name[j] for j in self.joints], float)

    def _stamped(self, msg, topic: str) -> bool:
        """Whether the message's stamp advances its stream: speed and command are paired by their stamps, so a
        stream whose stamps stand still (unstamped: all 0) stops the node after STALLED messages."""
        stamp = stamp_ns(msg.header.stamp)
        last, stalled = self.stamps.get(topic, (None, 0))
        stalled = stalled + 1 if last is not None and stamp <= last else 0
        self.stamps[topic] = (max(stamp, last if last is not None else stamp), stalled)
        if stalled >= STALLED:
            self.fail(f"{self.resolve_topic_name(relative(topic))}: {STALLED} messages whose header stamps do not "
                      f"advance (at {stamp * 1e-9:g} s; unstamped?): speed and command are paired by their stamps",
                      EXIT_BAD_INPUT)
        return stalled == 0

    def _on_command(self, msg):
        tcv = self._ordered(msg, "effort", T.WHEEL_COMMAND) if self._stamped(msg, T.WHEEL_COMMAND) else None
        if tcv is not None:
            self._send(self.reports.add_command(stamp_ns(msg.header.stamp), tcv))

    def _on_wheels(self, msg):
        speed = self._ordered(msg, "velocity", T.WHEELS) if self._stamped(msg, T.WHEELS) else None
        if speed is None:
            return
        torque = self._ordered(msg, "effort", T.WHEELS) if msg.effort else None   # optional: r from the speed
        self._send(self.reports.add_speed(stamp_ns(msg.header.stamp), speed, torque))

    def _on_housekeeping(self, channel: str, topic: str, field: str):
        """The callback of a bus voltage or temperature report: the wheel its frame_id names (empty: every wheel)
        holds the value until the next report."""
        def take(msg):
            joint = msg.header.frame_id
            if joint and joint not in self.joints:
                self.fail(f"{self.resolve_topic_name(relative(topic))}: frame_id {joint!r} is none of the joints "
                          f"{', '.join(self.joints)}", EXIT_BAD_INPUT)
                return
            values = np.full(len(self.joints), np.nan)
            values[[self.joints.index(joint)] if joint else slice(None)] = getattr(msg, field)
            self.reports.add_housekeeping(stamp_ns(msg.header.stamp), **{channel: values})
        return take

    def _commands_in(self) -> bool:
        """Whether the run's end may flush what waits: at once where commands are held (``command_hold`` > 0),
        else once the command stream has reached the last speed report, whose own command may come after
        /plant/done (the last sample's command mean then never depends on which came first)."""
        if self.param("command_hold") > 0:
            return True
        command, speed = self.stamps.get(T.WHEEL_COMMAND, (None, 0))[0], self.stamps.get(T.WHEELS, (None, 0))[0]
        return speed is None or (command is not None and command >= speed)

    def _send(self, samples):
        """The FDI telemetry (and its bus grid) of each FDI sample."""
        for sample in samples:
            for topic, message in fdi_messages(sample, self.names, self.wheel.bus_voltage):
                self.pubs[topic].publish(message)
            self.last_handled = sample.stamp_ns

    def poll(self):
        if (getattr(self, "_run_end", None) is not None and self._commands_in()) or self.run_ended():
            self._send(self.reports.flush())   # the source ended (or left)
        if all([p.flush() for p in self.pubs.values()]) and self.run_ended():
            self.finish()


main = main_for(WheelTelemetryNode)

if __name__ == "__main__":
    main()
