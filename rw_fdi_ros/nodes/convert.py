"""Message <-> numpy conversions shared by the nodes (sim-time stamps as integer nanoseconds)."""
from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped


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


def vector_array(msg) -> np.ndarray:
    v = msg.vector
    return np.array([v.x, v.y, v.z])
