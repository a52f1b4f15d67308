"""pid_controller: one axis' PID (eq. 2.36); started once per axis with the ``joint`` parameter
(its attitude joint, ``attitude_x`` / ``attitude_y`` / ``attitude_z``).

For each plant step it takes the attitude state stamped k (/attitude, a
JointState: its axis' angle and body rate) and answers with the torque command voltage stamped k on /<axis>/tcv_command.
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from ..core.control.pid import PidController, design_gains
from ..core.physics.spacecraft import BODY_AXES
from ..core.mission.scenario import setpoint_at
from ..core.physics.spacecraft import INERTIA
from ..graph import topics as T
from ..storage.cdr import read_joint_state_cdr, vector_cdr
from ..graph.gate import GatedPublisher
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for
from ..graph.wheel_type import declare_wheel_type


class PidControllerNode(GraphNode):
    node_name = "pid_controller"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("joint", T.ATTITUDE_JOINTS[0])   # the attitude joint this controller holds
        try:
            axis = T.axis_of_joint(self.param("joint"), T.ATTITUDE_JOINTS)
        except ValueError as exc:
            raise NodeError(f"parameter joint {exc}", EXIT_BAD_INPUT) from None
        i = BODY_AXES.index(axis)
        design = design_gains(INERTIA[i])
        self.declare_parameter("control_period", 0.1)
        self.declare_parameter("kp", float(design.kp))   # N m / rad   (body torque)
        self.declare_parameter("ki", float(design.ki))   # N m / (rad s)
        self.declare_parameter("kd", float(design.kd))   # N m / (rad/s)
        self.declare_parameter("setpoint_weight", design.setpoint_weight)
        self.declare_parameter("initial_tcv", 0.0)       # [V] command held before t = 0
        self.declare_parameter("setpoint_times", Parameter.Type.DOUBLE_ARRAY)  # [s]
        self.declare_parameter("setpoints", Parameter.Type.DOUBLE_ARRAY)       # [rad]; empty: hold the first attitude
        self.declare_parameter("min_subscribers", 1)     # plant (+ recorder) before the first command

        times, values = self.param("setpoint_times") or [], self.param("setpoints") or []
        if len(times) != len(values):
            raise NodeError("setpoint_times and setpoints must have the same length", EXIT_BAD_INPUT)
        self.schedule = (np.asarray(times, float), np.asarray(values, float)) if len(times) else None
        gains = type(design)(kp=self.param("kp"), ki=self.param("ki"), kd=self.param("kd"),
                             setpoint_weight=self.param("setpoint_weight"))
        self.pid = PidController(gains, self.param("control_period"), initial_tcv=self.param("initial_tcv"),
                                 wheel=declare_wheel_type(self))   # its volts per torque and command limit
        self.axis, self.index = axis, i
        self.pub = GatedPublisher(self.create_publisher(Vector3Stamped, T.tcv_command(axis), T.RELIABLE),
                                  self.param("min_subscribers"))
        self.say_ready_when_heard([self.create_subscription(JointState, T.ATTITUDE, self._on_state, T.RELIABLE,
                                                            raw=True)])
        # the run is over when the plant says so; the answer to its last sample goes out first
        self.follow_run_end()

    def _on_state(self, raw):
        stamp, attitude, rate, _ = read_joint_state_cdr(raw)
        attitude, rate = attitude[self.index], rate[self.index]
        t = stamp * 1e-9
        setpoint = setpoint_at(*self.schedule, t) if self.schedule else None
        if setpoint is None:
            setpoint = self.pid.origin if self.pid.origin is not None else attitude
        tcv = float(self.pid.update(setpoint, attitude, rate))
        command = [0.0, 0.0, 0.0]
        command[self.index] = tcv
        self.pub.publish(vector_cdr(stamp, command))
        self.last_handled = stamp

    def poll(self):
        if self.pub.flush() and self.run_ended():
            self.finish()


main = main_for(PidControllerNode)

if __name__ == "__main__":
    main()
