"""momentum_dumping: the magnetorquers' flight software, the cross-product law (core/physics/magnetorquers.py).

On each magnetometer reading stamped k (/magnetometer, sensor_msgs/MagneticField, body axes [T]) and
the wheel state stamped k (/wheels), it answers with the three rods' dipole stamped k
(/magnetorquers/command, geometry_msgs/Vector3Stamped, body axes [A m^2]); the plant holds it from
step k on, and waits for it like for the wheel command (the lockstep). It dumps the momentum of the
wheels in use only: what the wheel allocation said of its wheels on /fdir/wheels at a step before k (a
wheel given up or held is not the controller's to move).
"""
from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import JointState, MagneticField

from ..core.physics.environment import MAGNETOMETER_PERIOD
from ..core.physics.magnetorquers import Dumper, MomentumDumping
from ..core.physics.wheel import WheelParams
from ..core.physics.wheel_set import DEFAULT_WHEEL_SET, WHEEL_SETS, joint_name, wheel_set
from ..graph import topics as T
from ..storage.cdr import read_joint_state_cdr, vector_cdr
from ..graph.convert import stamp_ns
from ..graph.gate import GatedPublisher
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for

IN_USE_STATES = ("in_use", "kept_in_use")   # convert.wheel_states_msg's states the controller moves


class MomentumDumpingNode(GraphNode):
    node_name = "momentum_dumping"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        default = MomentumDumping()
        self.declare_parameter("wheel_set", DEFAULT_WHEEL_SET)          # core/physics/wheel_set.py
        self.declare_parameter("dipole_limit", default.dipole_limit)   # [A m^2] per rod
        self.declare_parameter("gain", default.gain)                   # k [1/s]
        self.declare_parameter("start_speed", default.start_speed)     # [rad/s] a wheel in use above: dump
        self.declare_parameter("stop_speed", default.stop_speed)       # [rad/s] net momentum below J x this: stop
        self.declare_parameter("enabled", True)                        # false: the rods stay off
        self.declare_parameter("fdir", True)                           # follow /fdir/wheels (the wheels in use)
        self.declare_parameter("min_subscribers", 1)                   # the plant (+ recorder) before the first
        self.declare_parameter("wheel_inertia", WheelParams().inertia)  # [kg m^2] the vehicle's datasheet J
        if self.param("wheel_set") not in WHEEL_SETS:
            raise NodeError(f"parameter wheel_set must be one of {', '.join(WHEEL_SETS)}, "
                            f"got {self.param('wheel_set')!r}", EXIT_BAD_INPUT)
        if not self.param("wheel_inertia") > 0.0:
            raise NodeError("parameter wheel_inertia must be > 0 [kg m^2]", EXIT_BAD_INPUT)
        if self.param("stop_speed") > self.param("start_speed"):
            raise NodeError("parameter stop_speed must not be above start_speed", EXIT_BAD_INPUT)
        self.wheels = wheel_set(self.param("wheel_set"))
        self.joints = tuple(joint_name(n) for n in self.wheels.names)
        self.in_use = ~self.wheels.mask(self.wheels.standby)[None, :]   # before the allocation says otherwise
        self.decided = []        # (stamp, in use (1, N)) of the allocation's /fdir/wheels
        settings = MomentumDumping(**{k: self.param(k) for k in ("dipole_limit", "gain", "start_speed",
                                                                  "stop_speed", "enabled")})
        self.dumper = Dumper([settings])
        self.wheel_inertia = self.param("wheel_inertia")   # the datasheet's J: what flight software knows
        self.field = None        # (stamp, reading) waiting for the wheel state of its stamp
        self.speeds = {}         # stamp -> wheel speeds (N,), the latest few
        self.pub = GatedPublisher(self.create_publisher(Vector3Stamped, T.DIPOLE_COMMAND, T.RELIABLE),
                                  self.param("min_subscribers"))
        inputs = [self.create_subscription(MagneticField, T.MAGNETOMETER, self._on_field, T.RELIABLE),
                  self.create_subscription(JointState, T.WHEELS, self._on_wheels, T.RELIABLE, raw=True)]
        if self.param("fdir"):
            inputs.append(self.create_subscription(DiagnosticArray, T.FDIR_WHEELS, self._on_wheel_states,
                                                   T.RELIABLE))
        self.say_ready_when_heard(inputs)
        self.follow_run_end(period=MAGNETOMETER_PERIOD)   # it answers the magnetometer's stamps only

    def _on_wheel_states(self, msg):
        states = {s.hardware_id: next((v.value for v in s.values if v.key == "state"), "") for s in msg.status}
        self.decided.append((stamp_ns(msg.header.stamp), np.array([[states.get(j, "") in IN_USE_STATES
                                                                     for j in self.joints]])))

    def _in_use_before(self, stamp: int):
        """The wheels in use as the allocation decided them at a step before ``stamp`` (the core loop's
        order: a decision of step k acts on the readings after it; a reading of step k may come before
        or after the decision of its own step). The allocation says a decision before it sends its
        command, and the plant steps on that command: a decision of an earlier step is here first."""
        earlier = [(t, use) for t, use in self.decided if t < stamp]
        self.decided = earlier[-1:] + [(t, use) for t, use in self.decided if t >= stamp]
        return earlier[-1][1] if earlier else self.in_use

    def _on_field(self, msg):
        f = msg.magnetic_field
        self.field = (stamp_ns(msg.header.stamp), [[f.x, f.y, f.z]])
        self._answer()

    def _on_wheels(self, raw):
        stamp, _, speed, _ = read_joint_state_cdr(raw)
        if len(speed) != len(self.joints):
            self.fail(f"{T.WHEELS} has {len(speed)} wheels, the wheel set {self.wheels.name} "
                      f"{len(self.joints)}", EXIT_BAD_INPUT)
            return
        self.speeds[stamp] = speed
        for old in [s for s in self.speeds if s < stamp - 10 ** 10]:   # 10 s back is plenty
            del self.speeds[old]
        self._answer()

    def _answer(self):
        if self.field is None or self.field[0] not in self.speeds:
            return
        stamp, reading = self.field
        self.field = None
        dipole = self.dumper.update(reading, self.speeds[stamp][None, :], self._in_use_before(stamp),
                                    self.wheel_inertia, self.wheels.matrix)[0]
        self.pub.publish(vector_cdr(stamp, dipole))
        self.last_handled = stamp

    def poll(self):
        if self.pub.flush() and self.run_ended():
            self.finish()


main = main_for(MomentumDumpingNode)

if __name__ == "__main__":
    main()
