"""The lockstep's hand-packed CDR equals what rclpy serialises (decoded), both ways."""
import numpy as np
import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import deserialize_message, serialize_message

from rw_fdi_ros.nodes.convert import read_vector_cdr, vector_cdr, vector_msg
from rw_fdi_ros.storage.bag import header_stamp_ns


@pytest.mark.parametrize("frame_id", ["body", "", "a", "abc", "abcdefgh", "wheel_frame_x"])
@pytest.mark.parametrize("stamp", [0, 100_000_000, 399_900_000_000, 2**31 * 1_000_000_000 - 1])
def test_vector_cdr_decodes_like_rclpy(frame_id, stamp):
    values = (1.5, -2.25e-3, np.pi)
    msg = deserialize_message(vector_cdr(stamp, values, frame_id), Vector3Stamped)
    assert msg.header.frame_id == frame_id
    assert msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec == stamp
    assert (msg.vector.x, msg.vector.y, msg.vector.z) == values


@pytest.mark.parametrize("frame_id", ["body", "", "abcdefg"])
def test_read_vector_cdr_of_rclpy_bytes(frame_id):
    raw = serialize_message(vector_msg(1_234_567_891, [0.1, -7.0, 3e-9], frame_id))
    stamp, values = read_vector_cdr(raw)
    assert stamp == 1_234_567_891 == header_stamp_ns(raw, -1)
    assert values.tolist() == [0.1, -7.0, 3e-9]


def test_read_vector_cdr_big_endian():
    import struct
    raw = b"\x00\x00\x00\x00" + struct.pack(">iII", 3, 5, 1) + b"\x00" + b"\x00" * 3 + struct.pack(">3d", 1, 2, 3)
    stamp, values = read_vector_cdr(raw)
    assert stamp == 3_000_000_005 and values.tolist() == [1.0, 2.0, 3.0]
