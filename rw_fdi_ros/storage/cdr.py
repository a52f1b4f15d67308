"""The CDR byte layout of the messages the lockstep sends every step, in one place (no ROS imports).

Plain CDR after a 4-byte encapsulation header (byte 1: 1 little endian, 0 big
endian); offsets of aligned fields count from after that header. The nodes
pack and unpack their hot topics here with ``struct`` (building rclpy message
objects costs more than the rest of a node's step), the recorder stamps
messages by :func:`header_stamp_ns`, and the bag readers decode recorded
Vector3Stamped and JointState rows without a message object per row.
"""
from __future__ import annotations

import struct

import numpy as np

_CDR_LE = b"\x00\x01\x00\x00"   # encapsulation header: plain CDR, little endian
_VECTOR = struct.Struct("<3d")


def clock_cdr(stamp_ns_: int) -> bytes:
    """rosgraph_msgs/Clock serialised (plain CDR, little endian): the plant's clock every step.

    Parameters
    ----------
    stamp_ns_ : int
        Sim time [ns].

    Returns
    -------
    bytes
        The message's CDR bytes, encapsulation header included (12 bytes).
    """
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
    """geometry_msgs/Vector3Stamped serialised as rclpy would (decoded equal), without a message object.

    Parameters
    ----------
    stamp_ns_ : int
        Header stamp [ns].
    values : sequence of float, length 3
        The vector's x, y, z, in the unit of the topic.
    frame_id : str
        Header frame_id.

    Returns
    -------
    bytes
        The message's CDR bytes (plain CDR, little endian), encapsulation header included.
    """
    frame = _FRAMES.get(frame_id)
    if frame is None:
        frame = _FRAMES[frame_id] = _frame_field(frame_id)
    sec, nsec = divmod(int(stamp_ns_), 1_000_000_000)
    x, y, z = values
    return b"".join((_CDR_LE, struct.pack("<iI", sec, nsec), frame, _VECTOR.pack(x, y, z)))


def read_vector_cdr(raw: bytes):
    """(stamp_ns, np.ndarray(3)) of a serialised geometry_msgs/Vector3Stamped, either byte order.

    Parameters
    ----------
    raw : bytes
        The message's CDR bytes, encapsulation header included.

    Returns
    -------
    stamp_ns : int
        Header stamp [ns].
    values : ndarray of float64, shape (3,)
        The vector's x, y, z, in the unit of the topic.
    """
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
    lockstep's per-step messages; decoded equal to what rclpy would send.

    Parameters
    ----------
    stamp_ns_ : int
        Header stamp [ns].
    names : tuple of str
        Joint names (hashable: the constant part of the message is cached by ``(frame_id, names)``).
    position, velocity, effort : sequence of float, shape (k,) each
        The joint arrays, in the units of the topic; empty to leave one out.
    frame_id : str
        Header frame_id.

    Returns
    -------
    bytes
        The message's CDR bytes, encapsulation header included.
    """
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


class Status:
    """One diagnostic_msgs/DiagnosticStatus as plain data, for :func:`diagnostic_array_cdr`: what a node builds
    on every FDI period without a message object (rclpy's field checks and conversion cost more than the rest
    of the isolation node's period).

    Attributes
    ----------
    level : int
        OK 0, WARN 1, ERROR 2, STALE 3.
    name, message, hardware_id : str
        As in DiagnosticStatus.
    values : list of (str, str)
        The key-value pairs, in order.
    """

    __slots__ = ("level", "name", "message", "hardware_id", "values")

    def __init__(self, level: int = 0, name: str = "", message: str = "", hardware_id: str = "", values=None):
        self.level, self.name, self.message, self.hardware_id = int(level), name, message, hardware_id
        self.values = [] if values is None else list(values)


def diagnostic_array_cdr(stamp_ns_: int, statuses, frame_id: str = "") -> bytes:
    """diagnostic_msgs/DiagnosticArray serialised (plain CDR, little endian) without a message object; decoded
    equal to what rclpy would send (test_convert; the padding bytes are zero where rclpy leaves them unset).

    Parameters
    ----------
    stamp_ns_ : int
        Header stamp [ns].
    statuses : sequence of Status
        The array's statuses, in order.
    frame_id : str
        Header frame_id.

    Returns
    -------
    bytes
        The message's CDR bytes, encapsulation header included.
    """
    sec, nsec = divmod(int(stamp_ns_), 1_000_000_000)
    out = bytearray(_CDR_LE)
    out += struct.pack("<iI", sec, nsec)
    # offsets count from after the 4-byte encapsulation header, so len(out) % 4 is the offset's
    out += _named(frame_id)
    out += _PAD[-len(out) % 4]
    out += struct.pack("<I", len(statuses))
    for s in statuses:
        out.append(s.level)   # an octet: no alignment
        for text in (_named(s.name), _string(s.message), _named(s.hardware_id)):
            out += _PAD[-len(out) % 4]
            out += text
        out += _PAD[-len(out) % 4]
        out += struct.pack("<I", len(s.values))
        for key, value in s.values:
            out += _PAD[-len(out) % 4]
            out += _named(key)
            out += _PAD[-len(out) % 4]
            out += _string(value)
    return bytes(out)


_PAD = (b"", b"\x00", b"\x00\x00", b"\x00\x00\x00")
_NAMED = {}


def _string(text: str) -> bytes:
    """A CDR string without its alignment: uint32 length with the NUL, the bytes, the NUL."""
    data = text.encode()
    return struct.pack("<I", len(data) + 1) + data + b"\x00"


def _named(text: str) -> bytes:
    """:func:`_string` of a name that recurs (a status' name, a key), kept."""
    out = _NAMED.get(text)
    if out is None:
        out = _string(text)
        if len(_NAMED) < 10_000:   # names recur; a stream of new ones must not grow it without end
            _NAMED[text] = out
    return out


def read_joint_state_cdr(raw: bytes):
    """(stamp_ns, position, velocity, effort) of a serialised sensor_msgs/JointState, either byte
    order; the arrays are np.ndarray (empty where the message leaves them out).

    Parameters
    ----------
    raw : bytes
        The message's CDR bytes, encapsulation header included.

    Returns
    -------
    stamp_ns : int
        Header stamp [ns].
    position, velocity, effort : ndarray of float64, shape (k,) each
        The joint arrays, in the units of the topic; shape (0,) where left out.
    """
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


def header_stamp_ns(raw: bytes, default: int) -> int:
    """Sim-time stamp of a CDR message whose first field is a builtin_interfaces/Time.

    Header-stamped messages and rosgraph_msgs/Clock all start with it, right
    after the 4-byte encapsulation header (byte 1 = 1: little endian).

    Parameters
    ----------
    raw : bytes
        The message's CDR bytes, encapsulation header included.
    default : int
        What to return for a message too short to hold a stamp [ns].

    Returns
    -------
    int
        The stamp [ns], or ``default``.
    """
    if len(raw) < 12:
        return default
    fmt = "<iI" if raw[1] == 1 else ">iI"
    sec, nsec = struct.unpack_from(fmt, raw, 4)
    return sec * 1_000_000_000 + nsec
