"""Message <-> numpy conversions shared by the nodes (sim-time stamps as integer nanoseconds).

The lockstep's hot topics go out and come in as CDR bytes (``storage.cdr``);
what is built here are the message objects of the slower topics.
"""
from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped

from ..core.fdir import Reconfiguration
from ..core.wheel_set import joint_name
from .topics import FDIR_STATUS


def time_msg(stamp_ns: int) -> Time:
    return Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))


def stamp_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def step_stamp_ns(step: int, period: float) -> int:
    """Stamp of lockstep step k: k * period, exact in integer nanoseconds."""
    return int(step) * int(round(period * 1e9))


def vector_msg(stamp_ns_: int, values, frame_id: str = "body") -> Vector3Stamped:
    msg = Vector3Stamped()
    msg.header.stamp = time_msg(stamp_ns_)
    msg.header.frame_id = frame_id
    msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in values)
    return msg


def fdi_telemetry_msg(sample, axes):
    """diagnostic_msgs/DiagnosticArray of one FDI telemetry report: one status per wheel
    (hardware_id reaction_wheel_<axis>) whose values are core.telemetry.report_values."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from ..core.telemetry import report_values
    msg = DiagnosticArray()
    msg.header.stamp = time_msg(sample.stamp_ns)
    for i, axis in enumerate(axes):
        status = DiagnosticStatus(level=DiagnosticStatus.OK, name=f"wheel electronics: reaction wheel {axis} "
                                  "FDI telemetry", hardware_id=f"reaction_wheel_{axis}", message="period means")
        status.values = [KeyValue(key=k, value=v) for k, v in report_values(sample, i).items()]
        msg.status.append(status)
    return msg


def fdi_sample_of(msg, axes, identification: bool = True):
    """The core.telemetry.FdiSample of an FDI telemetry report (an rclpy or a rosbags message);
    ``identification=False`` skips the terms only fault identification needs."""
    from ..core.telemetry import sample_from_report
    by_wheel = {s.hardware_id: {kv.key: kv.value for kv in s.values} for s in msg.status}
    try:
        wheels = [by_wheel[f"reaction_wheel_{a}"] for a in axes]
    except KeyError as exc:
        raise ValueError(f"FDI telemetry without wheel {exc}") from None
    return sample_from_report(stamp_ns(msg.header.stamp), wheels, identification)


STATES = {"in_use": DiagnosticStatus.OK, "standby": DiagnosticStatus.OK, "kept_in_use": DiagnosticStatus.WARN,
          "held": DiagnosticStatus.WARN, "given_up": DiagnosticStatus.ERROR}


def wheel_states_msg(stamp: int, reconfiguration: Reconfiguration, names) -> DiagnosticArray:
    """/fdir/wheels (and /diagnostics, once per FDI period): one status per wheel of the set (in use, standby,
    kept in use, held, given up and why) as ``reconfiguration`` (core/fdir.py) stands at ``stamp``; the
    core-loop engine writes the same."""
    r = reconfiguration
    msg = DiagnosticArray()
    msg.header.stamp = time_msg(stamp)
    last = {d.wheel: d for d in r.decisions}
    for name in names:
        state = ("given_up" if name in r.given_up else "kept_in_use" if name in r.kept else
                 "held" if name in r.held else "in_use" if name in r.in_use else "standby")
        d = last.get(name)
        status = DiagnosticStatus(level=STATES[state], name=f"{FDIR_STATUS} {name}",
                                  hardware_id=joint_name(name), message=state.replace("_", " ") + (
                                      f" since {d.time:g} s: {d.reason}" if d else ""))
        status.values = [KeyValue(key="state", value=state)] + (
            [KeyValue(key="since", value=f"{d.time:g}"), KeyValue(key="reason", value=d.reason)] if d else [])
        msg.status.append(status)
    return msg


def offered_qos(profile) -> dict:
    """An rclpy QoSProfile in rosbag2's metadata form (version 9: policies by name, durations as sec/nsec),
    what a recorded topic was offered with: a player offers the same (a latched topic latched again)."""
    def duration(d):
        sec, nsec = divmod(int(d.nanoseconds), 1_000_000_000)
        return {"sec": sec, "nsec": nsec}
    return {"history": profile.history.name.lower(), "depth": int(profile.depth),
            "reliability": profile.reliability.name.lower(), "durability": profile.durability.name.lower(),
            "deadline": duration(profile.deadline), "lifespan": duration(profile.lifespan),
            "liveliness": profile.liveliness.name.lower(),
            "liveliness_lease_duration": duration(profile.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": bool(profile.avoid_ros_namespace_conventions)}

