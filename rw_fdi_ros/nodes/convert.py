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
