"""Topic names, message types and QoS of the graph: one table every node and tool reads.

Vectors are geometry_msgs/Vector3Stamped with x, y, z the spacecraft axes
(one wheel per axis). Every message that analysis depends on carries a
header stamp in sim time.
"""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

AXES = ("x", "y", "z")

CLOCK = "/clock"
ATTITUDE = "/attitude"                # [rad], small-angle per-axis attitude
BODY_RATE = "/body_rate"              # [rad/s]
WHEEL_SPEED = "/wheel_speed"          # [rad/s]
TCV = "/wheel/tcv"                    # applied torque command voltage per wheel [V]
REACTION_TORQUE = "/wheel/reaction_torque"  # reaction torque per wheel on the body [N m]
FAULT_EFFECT = "/fault/effect"        # reaction torque minus a healthy wheel's in the same state [N m]
FAULT_TRUTH = "/fault/ground_truth"   # what is injected where since when (DiagnosticArray)
SCENARIO = "/scenario"                # the scenario YAML (latched)
PLANT_DONE = "/plant/done"            # std_msgs/Header: stamp = last step, frame_id = why it ended


def tcv_command(axis: str) -> str:
    """Per-axis controller output: Vector3Stamped with only that axis' component set [V]."""
    return f"/{axis}/tcv_command"


# Deep reliable queues: the recorder is not part of the lockstep and must not lose samples.
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def graph_topics():
    """(topic, ROS type name, qos) of everything a run records."""
    vec = "geometry_msgs/msg/Vector3Stamped"
    rows = [(CLOCK, "rosgraph_msgs/msg/Clock", RELIABLE),
            (ATTITUDE, vec, RELIABLE), (BODY_RATE, vec, RELIABLE), (WHEEL_SPEED, vec, RELIABLE),
            (TCV, vec, RELIABLE), (REACTION_TORQUE, vec, RELIABLE), (FAULT_EFFECT, vec, RELIABLE),
            (FAULT_TRUTH, "diagnostic_msgs/msg/DiagnosticArray", RELIABLE),
            (SCENARIO, "std_msgs/msg/String", LATCHED), (PLANT_DONE, "std_msgs/msg/Header", LATCHED)]
    rows += [(tcv_command(a), vec, RELIABLE) for a in AXES]
    return rows


OBSERVERS = ("elman", "linear")
DIAGNOSTICS = "/diagnostics"
IDENTIFICATION = "/fdi/identification"   # fault kind and size per alarmed wheel (DiagnosticArray)


def telemetry_readers(fdi_method: str | None) -> dict:
    """How many FDI nodes read each wheel-telemetry topic (what the plant or player waits for).

    Elman x, y, z and the linear observer read tcv and reaction torque, and the wheel speed
    when speed-aware; the isolation node reads all three (fault identification). No FDI: 0.
    """
    if fdi_method is None:
        return {TCV: 0, REACTION_TORQUE: 0, WHEEL_SPEED: 0}
    observers = len(AXES) + 1
    return {TCV: observers + 1, REACTION_TORQUE: observers + 1,
            WHEEL_SPEED: (observers if fdi_method == "speed_aware" else 0) + 1}


def estimate_topic(observer: str, axis: str | None = None) -> str:
    """Estimated reaction torque [N m]; the Elman nodes publish one per axis (own component set)."""
    return f"/fdi/{observer}/{axis}/estimate" if axis else f"/fdi/{observer}/estimate"


def residual_topic(observer: str, axis: str | None = None) -> str:
    """Residual [N m]: 40-sample mean of r - r^ (speed_aware, signed) or of |r - r^| (thesis)."""
    return f"/fdi/{observer}/{axis}/residual" if axis else f"/fdi/{observer}/residual"


def bound_topic(observer: str, axis: str | None = None) -> str:
    """What aliased commutation ripple can add to the residual [N m] (speed_aware; 0 for thesis)."""
    return f"/fdi/{observer}/{axis}/ripple_bound" if axis else f"/fdi/{observer}/ripple_bound"


def fdi_output_topics(observer: str):
    """What the isolation node publishes per observer: threshold, alarm (1/0 per axis), status."""
    return {"threshold": f"/fdi/{observer}/threshold", "alarm": f"/fdi/{observer}/alarm",
            "status": f"/fdi/{observer}/status"}


def fdi_topics():
    """(topic, type, qos) of the FDI half of the graph."""
    vec, diag = "geometry_msgs/msg/Vector3Stamped", "diagnostic_msgs/msg/DiagnosticArray"
    rows = []
    for a in AXES:
        rows += [(estimate_topic("elman", a), vec, RELIABLE), (residual_topic("elman", a), vec, RELIABLE),
                 (bound_topic("elman", a), vec, RELIABLE)]
    rows += [(estimate_topic("linear"), vec, RELIABLE), (residual_topic("linear"), vec, RELIABLE),
             (bound_topic("linear"), vec, RELIABLE)]
    for obs in OBSERVERS:
        out = fdi_output_topics(obs)
        rows += [(out["threshold"], vec, RELIABLE), (out["alarm"], vec, RELIABLE), (out["status"], diag, RELIABLE)]
    rows.append((DIAGNOSTICS, diag, RELIABLE))
    rows.append((IDENTIFICATION, diag, RELIABLE))
    return rows


def message_class(type_name: str):
    """Import the rclpy message class for 'pkg/msg/Name'."""
    import importlib
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)
