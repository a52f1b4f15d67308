"""ROS 2 messages as Foxglove's JSON: the live view's conversion (nodes/live_view.py).

A message becomes the JSON object of its fields, named and nested as in the ROS message, so the message
paths of a Foxglove layout read a live channel as they read a recorded bag (``/wheels.velocity[1]``,
``/fault/ground_truth.status[:]{hardware_id=="reaction_wheel_x"}.level``): arrays become lists, a byte (a
status' level) a number, and a non-finite float ``null`` (JSON has no NaN). Each channel carries the JSON
schema of its type, made from the message's own field table (rosidl's ``get_fields_and_field_types``).
"""
from __future__ import annotations

import importlib
import math

NUMBER_TYPES = ("float", "double", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
                "octet", "byte", "char")


def _message_class(kind: str):
    """The class of a nested field type, 'pkg/Name' or 'pkg/msg/Name'."""
    parts = kind.split("/")
    return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[-1])


def _element(kind: str) -> str | None:
    """The element type of a sequence or array field type ('sequence<double>', 'double[3]'), else None."""
    if kind.startswith("sequence<"):
        return kind[len("sequence<"):].split(",")[0].rstrip(">")
    if kind.endswith("]"):
        return kind[:kind.index("[")]
    return None


def _field_schema(kind: str) -> dict:
    element = _element(kind)
    if element is not None:
        return {"type": "array", "items": _field_schema(element)}
    if "/" in kind:
        return json_schema(_message_class(kind))
    if kind == "boolean":
        return {"type": "boolean"}
    if kind.split("<")[0] in ("string", "wstring"):
        return {"type": "string"}
    return {"type": ["number", "null"] if kind in ("float", "double") else "number"}


def json_schema(message_class, title: str | None = None) -> dict:
    """The JSON schema of a ROS message class's JSON form (:func:`to_json`).

    Parameters
    ----------
    message_class : type
        An rclpy message class (e.g. sensor_msgs.msg.JointState).
    title : str, optional
        The schema's title: the ROS type name ('sensor_msgs/msg/JointState'), by which Foxglove's panels know
        a channel; None: the class name.

    Returns
    -------
    dict
        A JSON schema: an object with one property per field, nested messages as objects.
    """
    fields = message_class.get_fields_and_field_types()
    return {"type": "object", "title": title or message_class.__name__,
            "properties": {name: _field_schema(kind) for name, kind in fields.items()}}


def _value(value):
    if hasattr(value, "get_fields_and_field_types"):
        return to_json(value)
    if isinstance(value, (bytes, bytearray)):   # a byte field (a status' level) is one byte
        return value[0] if len(value) == 1 else list(value)
    if isinstance(value, str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "__len__"):   # list, array.array, numpy array
        return [_value(v) for v in value]
    if hasattr(value, "item"):      # a numpy scalar
        return _value(value.item())
    return value


def to_json(message) -> dict:
    """A ROS message as the JSON object Foxglove plots (module docstring).

    Parameters
    ----------
    message : rclpy message
        Any ROS 2 message.

    Returns
    -------
    dict
        Field name -> value: numbers, strings, lists and nested objects, JSON-serialisable.
    """
    return {name: _value(getattr(message, name)) for name in message.get_fields_and_field_types()}
