"""The lockstep's hand-packed CDR equals what rclpy serialises (decoded), both ways."""
import numpy as np
import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import deserialize_message, serialize_message

from rw_fdi_ros.graph.convert import vector_msg
from rw_fdi_ros.storage.cdr import header_stamp_ns, read_vector_cdr, vector_cdr


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


@pytest.mark.parametrize("position, velocity, effort", [((), (1.5, -2.0, 3e-3), (4.0, 5.0, -6e-4)),
                                                        ((0.1, 0.2, 0.3), (1.0, 2.0, 3.0), ())])
def test_joint_state_cdr_decodes_as_rclpy_would_and_reads_back(position, velocity, effort):
    from sensor_msgs.msg import JointState
    from rw_fdi_ros.storage.cdr import joint_state_cdr, read_joint_state_cdr
    names = ("reaction_wheel_x", "reaction_wheel_y", "reaction_wheel_z")
    raw = joint_state_cdr(12_300_000_001, names, position, velocity, effort, frame_id="body")
    msg = deserialize_message(raw, JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (12, 300_000_001, "body")
    assert list(msg.name) == list(names)
    assert (list(msg.position), list(msg.velocity), list(msg.effort)) == (list(position), list(velocity), list(effort))
    stamp, p, v, e = read_joint_state_cdr(serialize_message(msg))   # and rclpy's own bytes read back
    assert stamp == 12_300_000_001 and (p.tolist(), v.tolist(), e.tolist()) == (list(position), list(velocity),
                                                                                  list(effort))


def test_fdi_telemetry_report_gives_back_the_very_sample():
    """The report carries the numbers as repr text: the observers see the plant's doubles, not a rounding."""
    import numpy as np
    from rclpy.serialization import deserialize_message as des, serialize_message as ser
    from diagnostic_msgs.msg import DiagnosticArray
    from rw_fdi_ros.core.telemetry import TelemetrySampler
    from rw_fdi_ros.graph.convert import fdi_sample_of, fdi_telemetry_msg
    rng = np.random.default_rng(1)
    sampler = TelemetrySampler(1.0, identification=True)
    rows = [sampler.add(k * 100_000_000, rng.uniform(-5, 5, 3), rng.normal(0, 1e-2, 3), rng.uniform(20, 30, 3))
            for k in range(11)]
    sample = rows[-1]
    back = fdi_sample_of(des(ser(fdi_telemetry_msg(sample, ("x", "y", "z"))), DiagnosticArray), ("x", "y", "z"))
    assert back.stamp_ns == sample.stamp_ns == 1_000_000_000
    for name in ("tcv", "reaction_torque", "wheel_speed", "model_torque", "ripple_phasor", "motor_torque",
                 "friction_torque", "bus_motor_torque", "tcv_instant", "reaction_torque_instant"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sample, name), err_msg=name)
    assert not np.array_equal(back.tcv, back.tcv_instant)       # a mean is not the last value
    instant = back.sampled("instant")
    np.testing.assert_array_equal(instant.tcv, sample.tcv_instant)
    light = fdi_sample_of(des(ser(fdi_telemetry_msg(sample, ("x", "y", "z"))), DiagnosticArray), ("x", "y", "z"),
                          identification=False)
    # the observers read all but the identification's bus grid (the unit calibration needs the model terms)
    assert light.bus_motor_torque is None
    np.testing.assert_array_equal(light.motor_torque, sample.motor_torque)
    np.testing.assert_array_equal(light.friction_torque, sample.friction_torque)


def test_clock_cdr_decodes_as_rclpy_would():
    from rosgraph_msgs.msg import Clock
    from rw_fdi_ros.storage.cdr import clock_cdr
    msg = deserialize_message(clock_cdr(399_900_000_001), Clock)
    assert (msg.clock.sec, msg.clock.nanosec) == (399, 900_000_001)
