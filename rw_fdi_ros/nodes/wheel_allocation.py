"""wheel_allocation: the controllers' body-axis commands over the wheels in use, and FDIR's reconfiguration.

For each plant step k it takes the three controllers' commands stamped k
(/<axis>/tcv_command) and answers with one torque command voltage per wheel
of the set on /wheels/command, stamped k: the minimum-norm allocation over
the wheels in use within the +-5 V limit (core/control/allocation.py); a wheel out
of use gets 0 V.

FDIR (core/fdir.py): for a wheel /diagnostics reports ERROR (the FDI's latched,
confirmed verdict) the standby wheel is brought in and the wheel given up, kept
in use beside it, or held, by its momentum and by the share of its torque it
gave over the last second (fdir.DeliveryLog, kept from /wheels and the commands
sent, as the core loop keeps it); the decision
made on the FDI sample stamped t shapes the commands from t + 1 s on
(fdir.DECISION_DELAY), so before the command of step k the node waits for
/diagnostics of that sample: the run is the same run whatever the processes'
timing, the one the core loop computes (test_fdir_graph.py). An operator
takes a wheel out of use by the parameter ``out_of_use`` (joint names;
``ros2 param set /wheel_allocation out_of_use "['reaction_wheel_x']"``),
from the next step on. Every decision goes out on /fdir/wheels (one status
per wheel: in use, standby, kept in use, held, given up and why), which the recorder
keeps; the same statuses go out on /diagnostics once per FDI period (stamped with
that period's step, as the wheels stand after its decisions), where an operator's
diagnostic_aggregator finds them beside the FDI's verdict (config/diagnostics/).
A wheel given up is never commanded again; a held one (its momentum
more than the wheels in use could take) gets only the speed-hold command,
from its speed of the same step (allocation.hold_command). With
``friction_feedforward`` (a vehicle's choice) every command adds the wheels'
modelled friction at that step's speeds (allocation.friction_feedforward). A set
with more wheels in use than axes holds its null-space speeds
(``null_space_time_constant``, allocation.null_projector).
"""
from __future__ import annotations

import math
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Vector3Stamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from ..core.control.allocation import NULL_SPACE_TIME_CONSTANT, TorqueAllocator
from ..core.fdir import DecisionDelay, DeliveryLog, Reconfiguration
from ..core.fdi.verdict import speed_envelope, stamp_seconds
from ..core.physics.spacecraft import BODY_AXES, INERTIA, inertia_times
from ..core.physics.wheel_set import DEFAULT_WHEEL_SET, joint_name, wheel_set
from ..storage.cdr import joint_state_cdr, read_joint_state_cdr, read_vector_cdr
from ..graph import topics as T
from ..graph.convert import stamp_ns, wheel_states_msg
from ..graph.gate import GatedPublisher
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for
from ..graph.wheel_type import declare_wheel_type

OPERATOR = "operator command"
class WheelAllocationNode(GraphNode):
    node_name = "wheel_allocation"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("wheel_set", DEFAULT_WHEEL_SET)   # core/physics/wheel_set.py
        self.declare_parameter("control_period", 0.1)            # the lockstep tick [s]
        self.declare_parameter("fdir", True)                     # act on /diagnostics (false: no FDI in the graph)
        self.declare_parameter("fdi_period", 1.0)                # [s] the stamps /diagnostics comes at
        # wall s to wait for a verdict before going on: under the plant's command_timeout (5 s), or the plant
        # would end the run first
        self.declare_parameter("verdict_timeout", 3.0)
        self.declare_parameter("out_of_use", Parameter.Type.STRING_ARRAY)   # joints the operator took out
        self.declare_parameter("min_subscribers", 1)             # plant (+ recorder) before the first command
        # the vehicle (core/mission/vehicle.py): its inertia I [kg m^2], the diagonal (3) or the matrix row by row (9),
        # and the wheels' J [kg m^2]: what the momentum checks of a reconfiguration read
        self.declare_parameter("body_inertia", [float(v) for v in INERTIA])
        self.wheel = declare_wheel_type(self)   # its command limit, hold feed-forward, nominal model and envelope
        self.declare_parameter("wheel_inertia", self.wheel.inertia)
        # the wheels' modelled friction cancelled from their speeds (the vehicle's controller.friction_feedforward;
        # core/control/allocation.friction_feedforward): every command then waits for its step's wheel speeds
        self.declare_parameter("friction_feedforward", False)
        # [s] the null-space speed hold of a set with more wheels in use than axes (the vehicle's
        # controller.null_space_time_constant; core/control/allocation.null_projector), 0 for none
        self.declare_parameter("null_space_time_constant", NULL_SPACE_TIME_CONSTANT)
        self.declare_parameter("fdir_readers", 0)                # of /fdir/wheels (the recorder) before it goes
        self.declare_parameter("diagnostics_readers", 0)         # of /diagnostics before FDIR's state goes there
        try:
            self.wheels = wheel_set(self.param("wheel_set"))
        except ValueError as exc:
            raise NodeError(f"parameter {exc}", EXIT_BAD_INPUT) from None
        self.joints = tuple(joint_name(n) for n in self.wheels.names)
        self.period = self.param("control_period")
        self.fdi_period_ns = int(round(self.param("fdi_period") * 1e9))
        self.allocator = TorqueAllocator(self.wheels, limit=self.wheel.command_limit, params=self.wheel,
                                         feedforward=self.param("friction_feedforward"),
                                         null_time_constant=self.param("null_space_time_constant"))
        inertia = np.asarray(self.param("body_inertia"), float)
        if inertia.size not in (3, 9) or not np.all(np.isfinite(inertia)) or self.param("wheel_inertia") <= 0:
            raise NodeError("parameter body_inertia: 3 numbers (the diagonal) or 9 (the matrix, row by row) "
                            "[kg m^2], and wheel_inertia > 0", EXIT_BAD_INPUT)
        self.body_inertia = inertia if inertia.size == 3 else inertia.reshape(3, 3)
        self.reconfiguration = Reconfiguration(self.wheels, speed_envelope(self.wheel), body_inertia=self.body_inertia,
                                               wheel_inertia=self.param("wheel_inertia"))
        self.delay = DecisionDelay()
        self.operator = list(self.param("out_of_use") or [])   # joints the operator took out, not yet applied
        unknown = [j for j in self.operator if j not in self.joints]
        if unknown:
            raise NodeError(f"parameter out_of_use: unknown wheel joint(s) {unknown}; the set's: "
                            f"{', '.join(self.joints)}", EXIT_BAD_INPUT)
        self.axis_commands = {}     # stamp -> {axis index: value}
        self.state = {}             # stamp -> (wheel speeds, body rate): what a decision's momentum check reads
        self.commands_sent = {}     # stamp -> the wheel commands sent for it (in force over the next step)
        self.delivery = DeliveryLog(params=self.wheel)   # what the wheels gave for their commands (as the core loop)
        self.verdict_ns = -1        # the latest /diagnostics stamp in
        self.decision_cpu = []      # [s] CPU of each /diagnostics callback that carried a verdict (timing)
        self.waiting_since = None   # wall time a complete command started waiting for a verdict
        self.blind_said = False
        self.blind_at = None        # the verdict stamp FDIR went blind at: blind until a newer one comes
        self.add_on_set_parameters_callback(self._on_parameters)
        self._wire()
        self.said_start = False
        self.follow_run_end()

    def _wire(self):
        """The publishers (each gated on its readers) and the subscriptions."""
        self.pub = GatedPublisher(self.create_publisher(JointState, T.WHEEL_COMMAND, T.RELIABLE),
                                  self.param("min_subscribers"))
        self.pub_fdir = GatedPublisher(self.create_publisher(DiagnosticArray, T.FDIR_WHEELS, T.RELIABLE),
                                       self.param("fdir_readers"))
        self.pub_diag = GatedPublisher(self.create_publisher(DiagnosticArray, T.DIAGNOSTICS, T.RELIABLE),
                                       self.param("diagnostics_readers"))
        inputs = [self.create_subscription(Vector3Stamped, T.tcv_command(axis),
                                           lambda raw, i=i: self._on_axis(i, raw), T.RELIABLE, raw=True)
                  for i, axis in enumerate(BODY_AXES)]
        inputs.append(self.create_subscription(JointState, T.WHEELS, self._on_wheels, T.RELIABLE, raw=True))
        inputs.append(self.create_subscription(JointState, T.ATTITUDE, self._on_attitude, T.RELIABLE, raw=True))
        if self.param("fdir"):   # the isolation node's verdicts; it writes FDIR's state there too
            inputs.append((self.create_subscription(DiagnosticArray, T.DIAGNOSTICS, self._on_diagnostics,
                                                    T.RELIABLE), 2))
        self.say_ready_when_heard(inputs)

    # -- inputs ----------------------------------------------------------------------
    def _on_axis(self, i, raw):
        if self.exit_code is not None:
            return
        stamp, values = read_vector_cdr(raw)
        value = float(values[i])
        if not math.isfinite(value):
            self.fail(f"torque command from axis {BODY_AXES[i]} at t={stamp * 1e-9:.1f} s is {value}", EXIT_BAD_INPUT)
            return
        self.axis_commands.setdefault(stamp, {})[i] = value
        self._try_command()

    def _on_wheels(self, raw):
        stamp, _, speed, torque = read_joint_state_cdr(raw)
        command = self.commands_sent.pop(stamp - int(round(self.period * 1e9)), None)
        for old in [s for s in self.commands_sent if s < stamp]:
            del self.commands_sent[old]
        if command is not None:   # the command in force over the step that led to this state
            self.delivery.add(command, speed, torque)
        self.state.setdefault(stamp, [None, None])[0] = speed
        self._state_in()

    def _on_attitude(self, raw):
        stamp, _, rate, _ = read_joint_state_cdr(raw)
        self.state.setdefault(stamp, [None, None])[1] = rate
        self._state_in()

    def _state_in(self):
        if self.axis_commands:   # a command may be waiting for this step's state (a decision, a held wheel)
            self._try_command()

    def _on_diagnostics(self, msg):
        """A wheel /diagnostics says ERROR is confirmed faulty: decided now, applied DECISION_DELAY later."""
        stamp = stamp_ns(msg.header.stamp)
        confirmed = {}   # in the statuses' order: the set's
        verdicts = T.verdict_statuses(msg)   # not FDIR's own state, which comes here too
        if not verdicts:
            return
        c0 = time.thread_time()   # the FDIR decision of one FDI period, and the command it releases (bench fdi)
        for status in verdicts:
            name = status.hardware_id.removeprefix("reaction_wheel_")
            if status.level == DiagnosticStatus.ERROR and name in self.wheels.names:
                first = next((kv.value for kv in status.values if kv.key == "first_alarm"), "none")
                confirmed[name] = float(first) if first != "none" else stamp_seconds(stamp)
        self.delay.confirm(confirmed, stamp_seconds(stamp), self.reconfiguration.settled)
        self.verdict_ns = max(self.verdict_ns, stamp)
        self._try_command()
        self.decision_cpu.append(time.thread_time() - c0)

    def timing(self):
        """Figures for ``rw-fdi bench``: the CPU time of each FDI period's FDIR decision.

        Returns
        -------
        dict
            graph.timing.summary's figures of 'callback_cpu'.
        """
        from ..graph.timing import summary
        return summary(callback_cpu=self.decision_cpu)

    def _on_parameters(self, params):
        for p in params:
            if p.name != "out_of_use":
                continue
            wanted = list(p.value or [])
            unknown = [j for j in wanted if j not in self.joints]
            if unknown:
                return SetParametersResult(successful=False, reason=f"unknown wheel joint(s) {unknown}; the set's: "
                                                                    f"{', '.join(self.joints)}")
            given = [joint_name(w) for w in self.reconfiguration.given_up]
            back = [j for j in self.param("out_of_use") or [] if j not in wanted and j in given]
            if back:
                return SetParametersResult(successful=False, reason=f"{', '.join(back)} given up: a wheel given up "
                                                                    "stays out of use")
            self.operator += [j for j in wanted if j not in given and j not in self.operator]
        return SetParametersResult(successful=True)

    # -- the command of one step ---------------------------------------------------------
    def _verdict_needed(self, stamp) -> int:
        """The /diagnostics stamp the command of ``stamp`` waits for (-1: none)."""
        if not self.param("fdir"):
            return -1
        made = stamp - int(round(self.delay.delay * 1e9))
        # the first FDI sample is at one period: at 0 no command is in force yet (core/fdi/wheel_reports.py)
        return -1 if made < self.fdi_period_ns else made - made % self.fdi_period_ns

    def _try_command(self):
        for stamp in sorted(self.axis_commands):
            if len(self.axis_commands[stamp]) < 3:
                return
            if self.verdict_ns < self._verdict_needed(stamp) and not self._blind(stamp):
                return
            t = stamp_seconds(stamp)
            due = self.delay.due(t) + [(j.removeprefix("reaction_wheel_"), OPERATOR) for j in self.operator]
            # after a reconfiguration: review on this step's state; the feed-forward reads its speeds
            watched = bool(self.reconfiguration.decisions) or self.allocator.needs_speeds
            if (due or watched) and any(x is None for x in self.state.get(stamp, (None,))):
                self.delay.pending[:0] = [(t, w) for w in due if w[1] != OPERATOR]
                return   # the momentum check and a held wheel read this step's state: it comes with the attitude
            self.operator = []
            self.waiting_since = None
            commands = self.axis_commands.pop(stamp)
            speeds, rate = self.state.pop(stamp, (None, None))
            for old in [s for s in self.state if s < stamp]:
                del self.state[old]
            decisions = []
            for wheel, reason in due:   # an operator's command is obeyed even where it costs the pointing
                decisions += self.reconfiguration.give_up(
                    wheel, t, reason, speeds, inertia_times(self.body_inertia, rate), force=reason == OPERATOR,
                    delivered=self.delivery.share(self.wheels.index(wheel)))
            if self.reconfiguration.decisions and speeds is not None:
                on_fdi = stamp % self.fdi_period_ns == 0   # a kept wheel's share is judged once an FDI period
                decisions += self.reconfiguration.review(t, speeds, self.delivery.of(self.wheels.names) if on_fdi
                                                         else None)
            if any(d.action != "at_limit" for d in decisions):
                self.allocator.use(self.reconfiguration.ordered_in_use(), held=self.reconfiguration.held)
            for d in decisions:
                self.get_logger().warning(d.message())
            if decisions or not self.said_start:
                self.said_start = True
                self._publish_wheels(stamp)
            if self.fdi_period_ns and stamp % self.fdi_period_ns == 0:   # fresh each FDI period (aggregators)
                self.pub_diag.publish(wheel_states_msg(stamp, self.reconfiguration, self.wheels.names))
            u = self.allocator.wheel_commands([[commands[0], commands[1], commands[2]]],
                                              None if speeds is None else [speeds])[0]
            self.commands_sent[stamp] = u
            self.pub.publish(joint_state_cdr(stamp, self.joints, effort=u))
            self.last_handled = stamp

    def _blind(self, stamp) -> bool:
        """Whether to command without the verdict: none came for ``verdict_timeout`` wall seconds (said)."""
        if self.blind_at is not None and self.blind_at == self.verdict_ns:
            return True   # still no new verdict: do not stall every step again
        now = time.monotonic()
        if self.waiting_since is None:
            self.waiting_since = now
        if now - self.waiting_since < self.param("verdict_timeout"):
            return False
        self.blind_at = self.verdict_ns
        if not self.blind_said:
            self.blind_said = True
            self.get_logger().error(f"no /diagnostics for {self._verdict_needed(stamp) * 1e-9:g} s within "
                                    f"{self.param('verdict_timeout'):g} s: FDIR blind, commanding without it")
        return True

    def _publish_wheels(self, stamp):
        self.pub_fdir.publish(wheel_states_msg(stamp, self.reconfiguration, self.wheels.names))

    def poll(self):
        if self.axis_commands:
            self._try_command()
        if self.pub.flush() & self.pub_fdir.flush() & self.pub_diag.flush() and self.run_ended():
            self.finish()


main = main_for(WheelAllocationNode)

if __name__ == "__main__":
    main()
