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


def test_diagnostic_array_cdr_decodes_as_rclpy_would():
    """The isolation node's statuses, serialised without message objects, decode to the message rclpy would
    build: odd string lengths (alignment after the one-byte level), empty fields, no values, non-ASCII text."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rw_fdi_ros.storage.cdr import Status, diagnostic_array_cdr
    statuses = [Status(2, "rw_fdi: wheel x (model)", "faulty since 3 s: 0.7 \u00b1 0.1", "reaction_wheel_x",
                       [("residual", "1.2e-04"), ("first_alarm", "3"), ("k", "")]),
                Status(0), Status(3, "ab", "c", "d", [("e", "fg")])]
    msg = deserialize_message(diagnostic_array_cdr(12_300_000_001, statuses, "body"), DiagnosticArray)
    want = DiagnosticArray(status=[DiagnosticStatus(level=bytes([s.level]), name=s.name, message=s.message,
                                                    hardware_id=s.hardware_id,
                                                    values=[KeyValue(key=k, value=v) for k, v in s.values])
                                   for s in statuses])
    want.header.stamp.sec, want.header.stamp.nanosec, want.header.frame_id = 12, 300_000_001, "body"
    assert msg == want
    assert deserialize_message(diagnostic_array_cdr(5, []), DiagnosticArray).status == []


def _telemetry_sample(wheels: int = 3):
    import numpy as np
    from rw_fdi_ros.core.fdi.telemetry import TelemetrySampler
    rng = np.random.default_rng(1)
    sampler = TelemetrySampler(1.0, identification=True)
    rows = [sampler.add(k * 100_000_000, rng.uniform(-5, 5, wheels), rng.normal(0, 1e-2, wheels),
                        rng.uniform(20, 30, wheels)) for k in range(11)]
    return rows[-1]


FIELDS = ("tcv", "reaction_torque", "wheel_speed", "model_torque", "ripple_phasor", "motor_torque", "friction_torque",
          "free_motor_torque", "bus_motor_torque", "tcv_instant", "reaction_torque_instant")


def test_fdi_telemetry_report_gives_back_the_very_sample():
    """The report is numeric: named channels of the plant's doubles, and the bus grid beside it, exact."""
    import numpy as np
    from rclpy.serialization import deserialize_message as des, serialize_message as ser
    from sensor_msgs.msg import JointState, PointCloud2
    from rw_fdi_ros.graph.convert import bus_grid_msg, fdi_sample_of, fdi_telemetry_cdr, telemetry_wheels
    sample, names = _telemetry_sample(4), ("x", "y", "z", "s")
    report, grid = des(fdi_telemetry_cdr(sample, names), JointState), des(ser(bus_grid_msg(sample, names)), PointCloud2)
    assert report.name[:3] == ["reaction_wheel_x/tcv", "reaction_wheel_x/reaction_torque",
                               "reaction_wheel_x/wheel_speed"]
    assert report.position[report.name.index("reaction_wheel_s/wheel_speed")] == sample.wheel_speed[3]
    assert telemetry_wheels(report) == names
    assert [f.name for f in grid.fields] == ["bus_voltage", *(f"reaction_wheel_{n}" for n in names)]
    back = fdi_sample_of(report, names, bus_grid=grid)
    assert back.stamp_ns == sample.stamp_ns == 1_000_000_000
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(sample, name), err_msg=name)
    assert not np.array_equal(back.tcv, back.tcv_instant)       # a mean is not the last value
    np.testing.assert_array_equal(back.sampled("instant").tcv, sample.tcv_instant)
    # another order of the set's wheels reads each wheel's own numbers
    swapped = fdi_sample_of(report, ("s", "x", "y", "z"), bus_grid=grid)
    np.testing.assert_array_equal(swapped.bus_motor_torque[0], sample.bus_motor_torque[3])
    np.testing.assert_array_equal(swapped.tcv[1:], sample.tcv[:3])
    # the observers read all but the identification's bus grid (the unit calibration needs the model terms)
    light = fdi_sample_of(report, names, identification=False, bus_grid=grid)
    assert light.bus_motor_torque is None
    np.testing.assert_array_equal(light.free_motor_torque, sample.free_motor_torque)


def test_fdi_telemetry_refuses_a_malformed_report_or_grid():
    import numpy as np
    import pytest
    from rclpy.serialization import deserialize_message as des
    from sensor_msgs.msg import JointState
    from rw_fdi_ros.graph.convert import bus_grid_msg, fdi_sample_of, fdi_telemetry_cdr
    sample = _telemetry_sample()
    report = des(fdi_telemetry_cdr(sample, ("x", "y", "z")), JointState)
    with pytest.raises(ValueError, match="without wheel 'reaction_wheel_s'"):
        fdi_sample_of(report, ("x", "y", "z", "s"))
    with pytest.raises(ValueError, match="without float64 field 'reaction_wheel_y'"):
        fdi_sample_of(report, ("x", "y", "z"), bus_grid=bus_grid_msg(sample, ("x", "q", "z")))
    grid = bus_grid_msg(sample, ("x", "y", "z"))
    grid.data = grid.data[:-8]
    with pytest.raises(ValueError, match="shorter"):
        fdi_sample_of(report, ("x", "y", "z"), bus_grid=grid)
    other = bus_grid_msg(sample, ("x", "y", "z"))
    table = np.frombuffer(bytes(other.data), "<f8").reshape(other.width, -1).copy()
    table[:, 0] += 0.005   # another identification grid
    other.data = table.tobytes()
    with pytest.raises(ValueError, match="other bus voltages"):
        fdi_sample_of(report, ("x", "y", "z"), bus_grid=other)
    half = des(fdi_telemetry_cdr(sample, ("x", "y", "z")), JointState)
    half.name = [n for n in half.name if not n.endswith("/reaction_torque")]
    half.position = [p for n, p in zip(report.name, report.position) if not n.endswith("/reaction_torque")]
    with pytest.raises(ValueError, match="without tcv or reaction_torque"):
        fdi_sample_of(half, ("x", "y", "z"))


def test_a_legacy_text_report_still_reads():
    """Bags recorded before the report was numeric (one DiagnosticArray status per wheel, repr text, the grid
    as base64) read to the same sample: their evaluation on the core engine goes on working."""
    import base64
    import numpy as np
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rw_fdi_ros.core.fdi.telemetry import BUS_GRID_KEY, report_columns
    from rw_fdi_ros.graph.convert import fdi_sample_of, telemetry_wheels, time_msg
    sample, names = _telemetry_sample(), ("x", "y", "z")
    msg = DiagnosticArray()
    msg.header.stamp = time_msg(sample.stamp_ns)
    columns = report_columns(sample)
    for i, n in enumerate(names):
        values = [KeyValue(key=k, value=repr(float(v[i]))) for k, v in columns.items()]
        values.append(KeyValue(key=BUS_GRID_KEY, value=base64.b64encode(
            np.asarray(sample.bus_motor_torque[i], "<f8").tobytes()).decode()))
        msg.status.append(DiagnosticStatus(name=f"wheel electronics: reaction wheel {n} FDI telemetry",
                                           hardware_id=f"reaction_wheel_{n}", values=values))
    assert telemetry_wheels(msg) == names
    back = fdi_sample_of(msg, names)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(sample, name), err_msg=name)


def test_clock_cdr_decodes_as_rclpy_would():
    from rosgraph_msgs.msg import Clock
    from rw_fdi_ros.storage.cdr import clock_cdr
    msg = deserialize_message(clock_cdr(399_900_000_001), Clock)
    assert (msg.clock.sec, msg.clock.nanosec) == (399, 900_000_001)


def test_housekeeping_rides_after_every_wheels_block_and_reads_back():
    """A driver's bus voltage and temperature, from their first report on, go after all wheels' quantities: a layout
    that reads a wheel's block by index keeps its places; the values read back by name (NaN where not reported)."""
    import dataclasses
    import numpy as np
    from rclpy.serialization import deserialize_message as des
    from sensor_msgs.msg import JointState
    from rw_fdi_ros.graph.convert import fdi_sample_of, fdi_telemetry_cdr
    sample, names = _telemetry_sample(4), ("x", "y", "z", "s")
    plain = des(fdi_telemetry_cdr(sample, names), JointState)
    kept = dataclasses.replace(sample, bus_voltage=np.array([8.0, 7.5, np.nan, 8.0]), temperature=np.full(4, 31.0))
    report = des(fdi_telemetry_cdr(kept, names), JointState)
    assert report.name[:len(plain.name)] == plain.name and report.position[:len(plain.name)] == plain.position
    assert report.name[len(plain.name):len(plain.name) + 2] == ["reaction_wheel_x/bus_voltage",
                                                                 "reaction_wheel_x/temperature"]
    back = fdi_sample_of(report, names, identification=False)
    np.testing.assert_array_equal(back.bus_voltage, kept.bus_voltage)
    np.testing.assert_array_equal(back.temperature, kept.temperature)
