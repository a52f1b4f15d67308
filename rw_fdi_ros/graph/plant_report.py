"""What the plant node sends for one run, step by step: one implementation for the node and the core loop.

The plant node publishes what :class:`PlantReport` makes of each step; the
core-loop engine (tools/campaigns/engine.py) writes the same messages, with
the same stamps, straight into a bag. Hot topics come as CDR bytes
(storage/cdr.py), the slower ones as rclpy message objects.
"""
from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import MagneticField
from std_msgs.msg import Header, String

from ..core.physics.environment import MAGNETOMETER_NOISE
from ..core.physics.faults import FAULT_KINDS
from ..core.physics.wheel_set import joint_name
from ..storage.cdr import clock_cdr, joint_state_cdr
from . import topics as T
from .convert import time_msg

UNIT_FIELDS = (("torque_constant", "torque_constant"), ("driver_gain", "driver_gain"),
               ("viscous_friction_scale", "viscous_scale"), ("coulomb_friction", "coulomb_friction"))


def run_units(wheel, run: int, count: int) -> dict:
    """Ground-truth unit parameters of run ``run``'s ``count`` wheels (core.physics.wheel.WheelParams, scalar or
    (B, N) per parameter): what the truth message says of each wheel.

    Parameters
    ----------
    wheel : core.physics.wheel.WheelParams
        The batch's wheels.
    run : int
        The run's index b.
    count : int
        The number of wheels N.

    Returns
    -------
    dict
        Truth key -> (N,) values.
    """
    out = {}
    for key, attr in UNIT_FIELDS:
        value = np.asarray(getattr(wheel, attr), float)
        out[key] = np.broadcast_to(value if value.ndim < 2 else value[run], (count,))
    return out


def magnetometer_msg(stamp: int, field) -> MagneticField:
    """sensor_msgs/MagneticField in body axes [T], its covariance the noise's (environment.MAGNETOMETER_NOISE).

    Parameters
    ----------
    stamp : int
        The stamp [ns].
    field : array_like
        (3,) the reading [T].

    Returns
    -------
    sensor_msgs.msg.MagneticField
        The message.
    """
    msg = MagneticField()
    msg.header.stamp = time_msg(stamp)
    msg.header.frame_id = "body"
    msg.magnetic_field.x, msg.magnetic_field.y, msg.magnetic_field.z = (float(v) for v in field)
    variance = MAGNETOMETER_NOISE ** 2
    msg.magnetic_field_covariance = [variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0, 0.0, variance]
    return msg


class PlantReport:
    """The plant's messages of one run: the scenario at the start, per step (stamp k * period) the
    attitude, clock, wheel state (what any wheel reports: the FDI telemetry is the wheel_telemetry node's),
    fault effect (from the first onset) and ground truth (on change and every ``truth_period``), and
    /plant/done at the end."""

    def __init__(self, scenario_text: str, names, units: dict, truth_period: float = 1.0):
        self.scenario_text = scenario_text
        self.names = tuple(names)
        self.joints = tuple(joint_name(n) for n in self.names)
        self.units = units
        self.truth_period = truth_period
        self.truth_key = None
        self.truth_due = 0.0

    def start(self) -> list:
        """(topic, message) before the first step: the scenario as run (latched).

        Returns
        -------
        list of tuple
            (topic, message).
        """
        return [(T.SCENARIO, String(data=self.scenario_text))]

    def step(self, stamp: int, time: float, attitude, body_rate, wheel_angle, wheel_speed, reaction_torque,
             fault_effect, operating_point: dict, faults, magnetic_field=None) -> list:
        """(topic, CDR bytes or message) of one step, in the order they go out (the controllers' input
        first: they compute while the rest goes out). Wheel arrays (N,), body arrays (3,);
        ``operating_point`` kind -> (N,); ``faults`` the run's core.faults.Fault list; in orbit the
        magnetometer's reading (3,) [T] on its steps.

        Parameters
        ----------
        stamp : int
            The step's stamp [ns].
        time : float
            The step's time t [s].
        attitude : array_like
            (3,) attitude angles [rad].
        body_rate : array_like
            (3,) body rates [rad/s].
        wheel_angle : array_like
            (N,) wheel angles [rad].
        wheel_speed : array_like
            (N,) wheel speeds Omega [rad/s].
        reaction_torque : array_like
            (N,) reaction torques r [N m].
        fault_effect : array_like
            (N,) the faults' effect on the reaction torque [N m].
        operating_point : dict
            kind -> (N,) values.
        faults : list of core.physics.faults.Fault
            The run's faults.
        magnetic_field : array_like or None
            (3,) magnetometer reading [T], in orbit on its steps.

        Returns
        -------
        list of tuple
            (topic, CDR bytes or message).
        """
        out = [(T.ATTITUDE, joint_state_cdr(stamp, T.ATTITUDE_JOINTS, attitude, body_rate)),
               (T.CLOCK, clock_cdr(stamp)),
               (T.WHEELS, joint_state_cdr(stamp, self.joints, wheel_angle, wheel_speed, reaction_torque))]
        if magnetic_field is not None:
            out.append((T.MAGNETOMETER, magnetometer_msg(stamp, magnetic_field)))
        if any(f.onset <= time for f in faults):   # zero by definition before
            out.append((T.FAULT_EFFECT, joint_state_cdr(stamp, self.joints, effort=fault_effect)))
        truth = self._truth(stamp, time, fault_effect, operating_point, faults)
        return out + ([(T.FAULT_TRUTH, truth)] if truth is not None else [])

    def done(self, stamp: int, why: str = "completed") -> list:
        """(topic, message) after the last step: /plant/done at ``stamp``, saying why.

        Parameters
        ----------
        stamp : int
            The last stamp [ns].
        why : str
            Why the run ended.

        Returns
        -------
        list of tuple
            (topic, message).
        """
        return [(T.PLANT_DONE, Header(stamp=time_msg(stamp), frame_id=why))]

    def _truth(self, stamp, time, fault_effect, op, faults):
        """Ground truth on change and every truth_period: a DiagnosticArray, one status per wheel."""
        key = np.round([op[k] for k in FAULT_KINDS], 9)
        if self.truth_key is not None and np.array_equal(key, self.truth_key) and time + 1e-9 < self.truth_due:
            return None
        self.truth_key = key
        self.truth_due = time + self.truth_period
        msg = DiagnosticArray()
        msg.header.stamp = time_msg(stamp)
        for i, name in enumerate(self.names):
            active = [f for f in faults if f.wheel == i and f.onset <= time]
            status = DiagnosticStatus(name=f"plant: wheel {name} injected fault", hardware_id=self.joints[i])
            status.level = DiagnosticStatus.ERROR if active else DiagnosticStatus.OK
            status.message = "; ".join(f"{f.kind}={f.value:g} since {f.onset:g} s" for f in active) or "nominal"
            status.values = [KeyValue(key=k, value=f"{op[k][i]:.9g}") for k in FAULT_KINDS]
            status.values.append(KeyValue(key="onset", value=f"{min((f.onset for f in active), default=-1.0):g}"))
            status.values.append(KeyValue(key="fault_effect", value=f"{fault_effect[i]:.9g}"))
            status.values += [KeyValue(key=k, value=repr(float(v[i]))) for k, v in self.units.items()]
            msg.status.append(status)
        return msg
