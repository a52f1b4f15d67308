"""The nodes that model the wheels (controllers, allocation, observers, isolation) take the vehicle's wheel type
as one parameter, ``wheel_type``: its datasheet as the vehicle file writes it (core/mission/vehicle.wheel_parameter, one
line of JSON, every value with its unit), '' for the thesis' ITHACO Type A. The launcher sets it from the
scenario's vehicle."""
from __future__ import annotations

from ..core.mission.vehicle import VehicleError, wheel_from_parameter
from ..core.physics.wheel import WheelParams
from .runtime import EXIT_BAD_INPUT, NodeError


def declare_wheel_type(node) -> WheelParams:
    """Declare ``wheel_type`` on ``node`` and return its WheelParams (NodeError, one line, for a bad one).

    Parameters
    ----------
    node : GraphNode
        The node.

    Returns
    -------
    core.physics.wheel.WheelParams
        The wheel type.
    """
    node.declare_parameter("wheel_type", "")
    try:
        return wheel_from_parameter(node.param("wheel_type"))
    except VehicleError as exc:
        raise NodeError(f"parameter {exc}", EXIT_BAD_INPUT) from None
