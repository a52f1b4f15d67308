"""Message <-> numpy conversions shared by the nodes (sim-time stamps as integer nanoseconds).

The lockstep's hot topics (Vector3Stamped at the control rate) go out and
come in as CDR bytes, packed and unpacked here with ``struct``: building and
converting rclpy message objects costs more than the rest of a node's step.
"""
from __future__ import annotations

import struct

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped

_CDR_LE = b"\x00\x01\x00\x00"   # encapsulation header: plain CDR, little endian
_VECTOR = struct.Struct("<3d")


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


def clock_cdr(stamp_ns_: int) -> bytes:
    """rosgraph_msgs/Clock serialised (plain CDR, little endian): the plant's clock every step."""
    sec, nsec = divmod(int(stamp_ns_), 1_000_000_000)
    return _CDR_LE + struct.pack("<iI", sec, nsec)


def _frame_field(frame_id: str) -> bytes:
    """CDR string (uint32 length with the NUL, bytes, NUL) padded so the float64s that follow sit on
    an 8-byte boundary (offsets count from after the encapsulation header; the stamp takes 8 bytes)."""
    text = frame_id.encode() + b"\x00"
    field = struct.pack("<I", len(text)) + text
    return field + b"\x00" * (-(8 + len(field)) % 8)


_FRAMES = {}


def vector_cdr(stamp_ns_: int, values, frame_id: str = "body") -> bytes:
    """geometry_msgs/Vector3Stamped serialised as rclpy would (decoded equal), without a message object."""
    frame = _FRAMES.get(frame_id)
    if frame is None:
        frame = _FRAMES[frame_id] = _frame_field(frame_id)
    sec, nsec = divmod(int(stamp_ns_), 1_000_000_000)
    x, y, z = values
    return b"".join((_CDR_LE, struct.pack("<iI", sec, nsec), frame, _VECTOR.pack(x, y, z)))


def read_vector_cdr(raw: bytes):
    """(stamp_ns, np.ndarray(3)) of a serialised geometry_msgs/Vector3Stamped, either byte order."""
    end = "<" if raw[1] == 1 else ">"
    sec, nsec, length = struct.unpack_from(end + "iII", raw, 4)
    offset = 4 + 12 + length
    offset += -(offset - 4) % 8
    return sec * 1_000_000_000 + nsec, np.array(struct.unpack_from(end + "3d", raw, offset))


def _cdr_string(text: str, offset: int) -> tuple:
    """(bytes, new offset) of a CDR string at ``offset`` (4-aligned uint32 length with the NUL)."""
    data = text.encode() + b"\x00"
    pad = -offset % 4
    out = b"\x00" * pad + struct.pack("<I", len(data)) + data
    return out, offset + len(out)


def _joint_state_prefix(frame_id: str, names: tuple) -> bytes:
    """The constant part of a JointState after the stamp: frame_id and the joint names."""
    out, offset = _cdr_string(frame_id, 8)
    parts = [out]
    pad = -offset % 4
    parts.append(b"\x00" * pad + struct.pack("<I", len(names)))
    offset += pad + 4
    for name in names:
        out, offset = _cdr_string(name, offset)
        parts.append(out)
    return b"".join(parts)


_JOINT_PREFIXES = {}


def joint_state_cdr(stamp_ns_: int, names: tuple, position=(), velocity=(), effort=(), frame_id: str = "") -> bytes:
    """sensor_msgs/JointState serialised (plain CDR, little endian) without a message object: the
    lockstep's per-step messages; decoded equal to what rclpy would send."""
    key = (frame_id, names)
    prefix = _JOINT_PREFIXES.get(key)
    if prefix is None:
        prefix = _JOINT_PREFIXES[key] = _joint_state_prefix(frame_id, names)
    sec, nsec = divmod(int(stamp_ns_), 1_000_000_000)
    parts = [_CDR_LE, struct.pack("<iI", sec, nsec), prefix]
    offset = 8 + len(prefix)
    for values in (position, velocity, effort):
        n = len(values)
        pad = -offset % 4
        parts.append(b"\x00" * pad + struct.pack("<I", n))
        offset += pad + 4
        if n:
            pad = -offset % 8
            parts.append(b"\x00" * pad + struct.pack(f"<{n}d", *values))
            offset += pad + 8 * n
    return b"".join(parts)


def read_joint_state_cdr(raw: bytes):
    """(stamp_ns, position, velocity, effort) of a serialised sensor_msgs/JointState, either byte
    order; the arrays are np.ndarray (empty where the message leaves them out)."""
    end = "<" if raw[1] == 1 else ">"
    body = memoryview(raw)[4:]
    sec, nsec, length = struct.unpack_from(end + "iII", body, 0)
    offset = 12 + length
    offset += -offset % 4
    (count,) = struct.unpack_from(end + "I", body, offset)
    offset += 4
    for _ in range(count):
        offset += -offset % 4
        (length,) = struct.unpack_from(end + "I", body, offset)
        offset += 4 + length
    arrays = []
    for _ in range(3):
        offset += -offset % 4
        (n,) = struct.unpack_from(end + "I", body, offset)
        offset += 4
        if n:
            offset += -offset % 8
        arrays.append(np.array(struct.unpack_from(f"{end}{n}d", body, offset)))
        offset += 8 * n
    return sec * 1_000_000_000 + nsec, arrays[0], arrays[1], arrays[2]


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
