"""The range of every numeric node parameter, checked before a node starts (one table for all nodes).

GraphNode.declare_parameter gives each numeric parameter named here a ROS 2 ParameterDescriptor with
its range (IntegerRange / FloatingPointRange), so rcl refuses an out-of-range value at declaration
and `ros2 param describe` shows the range; a non-finite float is refused too (a range lets NaN
through). docs/graph.md's node parameter table states each range (test/test_node_parameters.py).
"""
from __future__ import annotations

import math

from ..core.fdi.detection import PERSISTENCE_MAX
from ..core.mission.scenario import FAULT_LIMITS

BIG = 1e9               # "no upper bound" for a float, kept finite for the descriptor
COUNT_MAX = 1_000       # readers, samples
TIMEOUT = (0.01, BIG)   # wall seconds: a timeout of 0 would fire at once

# name -> (low, high), inclusive
RANGES = {
    "persistence": (0, PERSISTENCE_MAX),              # 0: the threshold file's
    "unit_calibration_time": (0.0, BIG),
    "input_timeout": TIMEOUT,
    "min_subscribers": (0, COUNT_MAX),
    "diagnostics_readers": (0, COUNT_MAX),
    "estimate_readers": (0, COUNT_MAX),
    "attitude_readers": (0, COUNT_MAX),
    "bus_grid_readers": (0, COUNT_MAX),
    "wheels_readers": (0, COUNT_MAX),
    "fdir_readers": (0, COUNT_MAX),
    "magnetometer_readers": (0, COUNT_MAX),
    "dipole_limit": (0.0, 1000.0),                    # [A m^2] per rod
    "gain": (0.0, 1.0),                               # [1/s] the dumping law's
    "start_speed": (0.0, 1000.0),                     # [rad/s]
    "stop_speed": (0.0, 1000.0),
    "wheel_inertia": (1e-6, 100.0),                    # [kg m^2] the vehicle's wheel J
    "null_space_time_constant": (0.0, 1e6),            # [s] the allocation's null-space hold, 0: none
    "verdict_timeout": TIMEOUT,
    "wait_for_subscribers": (0, COUNT_MAX),
    "speed_up": (0.01, 1000.0),
    "fdi_period": (0.01, 100.0),
    "port": (0, 65_535),                              # the live view's WebSocket server (0: any free port)
    "window": (1, 100_000),
    "control_period": (0.001, 1.0),
    "max_gap": (0.001, BIG),                          # [s] wheel_telemetry: reports further apart: not judged
    "command_hold": (0.0, BIG),                       # [s] wheel_telemetry: 0 waits for every command
    "kp": (0.0, BIG),
    "ki": (0.0, BIG),
    "kd": (0.0, BIG),
    "setpoint_weight": (0.0, 10.0),
    "initial_tcv": (-5.0, 5.0),                        # the wheel drive's command range [V]
    "seed": (-1, 2**63 - 1),                           # -1: the scenario file's
    "duration": (0.0, 1e7),                            # 0: the scenario's
    "command_timeout": TIMEOUT,
    "startup_timeout": TIMEOUT,
    "truth_period": (0.01, BIG),
    "telemetry_lead": (0.0, BIG),                      # [s] of sim time; 0: not paced on the telemetry
    "rate": (0.0, BIG),                                # 0: paced by the consumers
    "pace_period": (0.01, 100.0),
    "pace_window": (1, 1_000_000),
    "stall_timeout": TIMEOUT,
    "flush_period": (0.01, BIG),
    "drain_timeout": TIMEOUT,
}
# where one executable's parameter means more than the shared one: 0 switches something off
BY_NODE = {
    "plant": {"control_period": (0.0, 1.0)},           # 0: the scenario's, else 0.1
    "recorder": {"fdi_period": (0.0, 100.0),           # 0: no FDI nodes to record
                 "telemetry_period": (0.0, 100.0)},    # 0: no FDI telemetry to wait for
}


def range_of(node: str, name: str):
    """(low, high) of parameter ``name`` of executable ``node``, or None when it has none (not numeric).

    Parameters
    ----------
    node : str
        The executable's name.
    name : str
        The parameter's name.

    Returns
    -------
    tuple or None
        (low, high).
    """
    if name.startswith("fault."):   # live fault injection fault.<axis>.<kind>: the scenario's limits
        return FAULT_LIMITS.get(name.rsplit(".", 1)[-1])
    return BY_NODE.get(node, {}).get(name, RANGES.get(name))


def descriptor(node: str, name: str, value):
    """The ParameterDescriptor with the range of ``name`` for a default ``value`` (int or float), or None.

    Parameters
    ----------
    node : str
        The executable's name.
    name : str
        The parameter's name.
    value : object
        Its default value.

    Returns
    -------
    rcl_interfaces.msg.ParameterDescriptor or None
        The descriptor with its range.
    """
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    limits = range_of(node, name)
    if limits is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    low, high = limits
    if isinstance(value, int):
        return ParameterDescriptor(integer_range=[IntegerRange(from_value=int(low), to_value=int(high), step=1)])
    return ParameterDescriptor(floating_point_range=[FloatingPointRange(from_value=float(low),
                                                                        to_value=float(high), step=0.0)])


def finite(value) -> bool:
    """Whether a parameter's value is finite (anything but a float is).

    Parameters
    ----------
    value : object
        The value.

    Returns
    -------
    bool
        False for a float inf or nan.
    """
    return not isinstance(value, float) or math.isfinite(value)


def range_text(limits) -> str:
    """How docs/graph.md's table states a range: 'range [0, 1000]'.

    Parameters
    ----------
    limits : tuple
        (low, high).

    Returns
    -------
    str
        The text.
    """
    def shown(x):
        return str(x) if isinstance(x, int) else f"{x:g}"
    return f"range [{shown(limits[0])}, {shown(limits[1])}]"
