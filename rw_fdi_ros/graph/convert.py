"""Message <-> numpy conversions shared by the nodes (sim-time stamps as integer nanoseconds).

The lockstep's hot topics go out and come in as CDR bytes (``storage.cdr``);
what is built here are the message objects of the slower topics.
"""
from __future__ import annotations

import array

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped

from ..core.fdir import Reconfiguration
from ..core.physics.wheel_set import joint_name
from . import topics as T
from ..storage.cdr import joint_state_cdr
from .topics import FDIR_STATUS


def time_msg(stamp_ns: int) -> Time:
    """A builtin_interfaces/Time of a stamp in integer nanoseconds.

    Parameters
    ----------
    stamp_ns : int
        The stamp [ns].

    Returns
    -------
    builtin_interfaces.msg.Time
        The same stamp, seconds and nanoseconds.
    """
    return Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))


def stamp_ns(stamp: Time) -> int:
    """A builtin_interfaces/Time's stamp in integer nanoseconds.

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
        The stamp.

    Returns
    -------
    int
        The stamp [ns].
    """
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def step_stamp_ns(step: int, period: float) -> int:
    """Stamp of lockstep step k: k * period, exact in integer nanoseconds.

    Parameters
    ----------
    step : int
        The step k.
    period : float
        The lockstep period [s].

    Returns
    -------
    int
        The stamp [ns].
    """
    return int(step) * int(round(period * 1e9))


def vector_msg(stamp_ns_: int, values, frame_id: str = "body") -> Vector3Stamped:
    """A geometry_msgs/Vector3Stamped of three values at a stamp.

    Parameters
    ----------
    stamp_ns_ : int
        The stamp [ns].
    values : array_like
        (3,) x, y, z.
    frame_id : str
        The frame of the header.

    Returns
    -------
    geometry_msgs.msg.Vector3Stamped
        The message.
    """
    msg = Vector3Stamped()
    msg.header.stamp = time_msg(stamp_ns_)
    msg.header.frame_id = frame_id
    msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in values)
    return msg


def telemetry_channel(name: str, key: str) -> str:
    """The FDI telemetry report's channel of wheel ``name``'s quantity ``key`` ('reaction_wheel_x/tcv').

    Parameters
    ----------
    name : str
        The wheel's name.
    key : str
        The quantity's key (core.fdi.telemetry.report_columns).

    Returns
    -------
    str
        The channel's name.
    """
    return f"{joint_name(name)}/{key}"


def fdi_messages(sample, names, bus_voltage: float) -> list:
    """(topic, message) of one FDI sample, in the order they go out: its bus-voltage grid (when it has one; the
    isolation node decides on the telemetry once the grid is in), then the telemetry (CDR).

    Parameters
    ----------
    sample : core.fdi.telemetry.FdiSample
        The sample.
    names : sequence of str
        The wheels.
    bus_voltage : float
        The wheel type's nominal bus voltage [V].

    Returns
    -------
    list of tuple
        (topic, message).
    """
    grid = bus_grid_msg(sample, names, bus_voltage)
    telemetry = (T.FDI_TELEMETRY, fdi_telemetry_cdr(sample, names))
    return ([(T.FDI_BUS_GRID, grid)] if grid is not None else []) + [telemetry]


def fdi_telemetry_cdr(sample, names) -> bytes:
    """The FDI telemetry report of one sample (sensor_msgs/JointState, CDR): one named channel per wheel and
    quantity (:func:`telemetry_channel`, core.telemetry.report_columns), its value in ``position``; the
    exact doubles, plottable by name (PlotJuggler) or index (Foxglove, the shipped layout).

    Parameters
    ----------
    sample : core.fdi.telemetry.FdiSample
        The FDI sample.
    names : sequence of str
        The wheels, in the sample's order.

    Returns
    -------
    bytes
        The serialised sensor_msgs/JointState.
    """
    from ..core.fdi.telemetry import report_columns
    from ..core.fdi.telemetry import HOUSEKEEPING_FIELDS
    columns = report_columns(sample)
    # a wheel's quantities in a block each, then the housekeeping a driver may start reporting mid-run: a layout
    # that reads the blocks by index (config/foxglove) keeps its places
    order = [[k for k in columns if k not in HOUSEKEEPING_FIELDS], [k for k in columns if k in HOUSEKEEPING_FIELDS]]
    pairs = [(i, n, key) for keys in order for i, n in enumerate(names) for key in keys]
    return joint_state_cdr(sample.stamp_ns, tuple(telemetry_channel(n, key) for _, n, key in pairs),
                           position=[columns[key][i] for i, _, key in pairs])


def bus_grid_msg(sample, names, bus_voltage: float = 8.0):
    """The identification's bus-voltage grid of one sample (sensor_msgs/PointCloud2, or None without it): one
    point per bus voltage V, fields ``bus_voltage`` [V] and each wheel's joint name (k_t I_m(u, Omega; V),
    period means [N m]), float64: a self-describing binary table beside the report, 26 kB a second.

    Parameters
    ----------
    sample : core.fdi.telemetry.FdiSample
        The FDI sample.
    names : sequence of str
        The wheels, in the sample's order.
    bus_voltage : float, optional
        The wheel type's nominal bus V_nom [V]: the grid is identification.bus_voltage_grid(V_nom).

    Returns
    -------
    sensor_msgs.msg.PointCloud2 or None
        The grid; None when the sample has no bus-voltage grid.
    """
    if sample.bus_motor_torque is None:
        return None
    from sensor_msgs.msg import PointCloud2, PointField
    from ..core.fdi.identification import bus_voltage_grid
    table = np.column_stack([bus_voltage_grid(bus_voltage), np.asarray(sample.bus_motor_torque, float).T])
    msg = PointCloud2(height=1, width=table.shape[0], is_bigendian=False, point_step=8 * table.shape[1],
                      row_step=8 * table.size, is_dense=True)
    msg.header.stamp = time_msg(sample.stamp_ns)
    msg.fields = [PointField(name=field, offset=8 * k, datatype=PointField.FLOAT64, count=1)
                  for k, field in enumerate(("bus_voltage", *(joint_name(n) for n in names)))]
    msg.data = array.array("B", table.astype("<f8").tobytes())
    return msg


def bus_grid_of(msg, names) -> np.ndarray:
    """(N, grid) motor torques [N m] of a :func:`bus_grid_msg` (an rclpy or a rosbags message), wheels in
    ``names`` order; ValueError if it is not that table or not on the identification's grid.

    Parameters
    ----------
    msg : sensor_msgs.msg.PointCloud2
        A :func:`bus_grid_msg` (rclpy or rosbags).
    names : sequence of str
        The wheels, in the order wanted.

    Returns
    -------
    numpy.ndarray
        (N, grid) motor torques [N m].
    """
    from ..core.fdi.identification import bus_voltage_grid
    offsets = {f.name: f.offset for f in msg.fields if f.datatype == 8 and f.count == 1}   # FLOAT64
    step = msg.point_step
    try:
        columns = [offsets["bus_voltage"]] + [offsets[joint_name(n)] for n in names]
    except KeyError as exc:
        raise ValueError(f"bus grid without float64 field {exc}") from None
    rows = msg.width * msg.height
    if step % 8 or any(c % 8 for c in columns) or len(msg.data) < rows * step:
        raise ValueError("bus grid: fields not on 8-byte columns, or data shorter than its points")
    table = np.frombuffer(bytes(msg.data[:rows * step]), ">f8" if msg.is_bigendian else "<f8").reshape(rows, -1)
    table = table[:, [c // 8 for c in columns]]
    if not rows or not np.array_equal(table[:, 0], bus_voltage_grid(table[0, 0])):
        raise ValueError("bus grid on other bus voltages than the identification's (recorded by another version)")
    return table[:, 1:].T


def fdi_sample_of(msg, names, identification: bool = True, bus_grid=None):
    """The core.telemetry.FdiSample of an FDI telemetry report (an rclpy or a rosbags message), wheels in
    ``names`` order; ``bus_grid`` its :func:`bus_grid_msg`, if identification reads it
    (``identification=False`` skips the terms only fault identification needs). Reads the text report
    (DiagnosticArray) of bags recorded before the report was numeric, too. ValueError if malformed.

    Parameters
    ----------
    msg : sensor_msgs.msg.JointState or diagnostic_msgs.msg.DiagnosticArray
        The FDI telemetry report (numeric, or the legacy text form).
    names : sequence of str
        The wheels, in the order wanted.
    identification : bool
        Whether the terms only fault identification needs are read.
    bus_grid : sensor_msgs.msg.PointCloud2 or None
        The report's bus-voltage grid.

    Returns
    -------
    core.fdi.telemetry.FdiSample
        The sample.
    """
    from ..core.fdi.telemetry import sample_from_report
    if hasattr(msg, "status"):   # legacy: one status per wheel, key -> repr text
        by_wheel = {s.hardware_id: {kv.key: kv.value for kv in s.values} for s in msg.status}
    else:
        by_wheel = {}
        for channel, value in zip(msg.name, msg.position):
            joint, _, key = channel.rpartition("/")
            by_wheel.setdefault(joint, {})[key] = value
    try:
        wheels = [by_wheel[joint_name(n)] for n in names]
    except KeyError as exc:
        raise ValueError(f"FDI telemetry without wheel {exc}") from None
    grid = bus_grid_of(bus_grid, names) if identification and bus_grid is not None else None
    return sample_from_report(stamp_ns(msg.header.stamp), wheels, identification, grid)


def telemetry_wheels(msg) -> tuple:
    """The wheel names an FDI telemetry report (either form) holds, in its order.

    Parameters
    ----------
    msg : sensor_msgs.msg.JointState or diagnostic_msgs.msg.DiagnosticArray
        The FDI telemetry report.

    Returns
    -------
    tuple of str
        The wheel names.
    """
    joints = ([s.hardware_id for s in msg.status] if hasattr(msg, "status")
              else list(dict.fromkeys(c.rpartition("/")[0] for c in msg.name)))
    return tuple(j.removeprefix("reaction_wheel_") for j in joints)


STATES = {"in_use": DiagnosticStatus.OK, "standby": DiagnosticStatus.OK, "kept_in_use": DiagnosticStatus.WARN,
          "held": DiagnosticStatus.WARN, "given_up": DiagnosticStatus.ERROR}


def wheel_states_msg(stamp: int, reconfiguration: Reconfiguration, names) -> DiagnosticArray:
    """/fdir/wheels (and /diagnostics, once per FDI period): one status per wheel of the set (in use, standby,
    kept in use, held, given up and why) as ``reconfiguration`` (core/fdir.py) stands at ``stamp``; the
    core-loop engine writes the same.

    Parameters
    ----------
    stamp : int
        The stamp [ns].
    reconfiguration : core.fdir.Reconfiguration
        FDIR's state of the wheels.
    names : sequence of str
        The wheels of the set.

    Returns
    -------
    diagnostic_msgs.msg.DiagnosticArray
        One status per wheel.
    """
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
    what a recorded topic was offered with: a player offers the same (a latched topic latched again).

    Parameters
    ----------
    profile : rclpy.qos.QoSProfile
        The profile.

    Returns
    -------
    dict
        rosbag2's offered_qos_profiles entry.
    """
    def duration(d):
        sec, nsec = divmod(int(d.nanoseconds), 1_000_000_000)
        return {"sec": sec, "nsec": nsec}
    return {"history": profile.history.name.lower(), "depth": int(profile.depth),
            "reliability": profile.reliability.name.lower(), "durability": profile.durability.name.lower(),
            "deadline": duration(profile.deadline), "lifespan": duration(profile.lifespan),
            "liveliness": profile.liveliness.name.lower(),
            "liveliness_lease_duration": duration(profile.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": bool(profile.avoid_ros_namespace_conventions)}

