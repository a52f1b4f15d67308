"""Topic names, message types and QoS of the graph: one table every node and tool reads.

Per control step the plant sends three messages the graph acts on: the clock,
the attitude state (controllers) and the wheel state, both
sensor_msgs/JointState, the standard way ROS reports rotational degrees of
freedom (PlotJuggler and Foxglove plot them by joint name). Once per FDI
period it sends the FDI telemetry every FDI node reads. Vectors are
geometry_msgs/Vector3Stamped with x, y, z the spacecraft axes (one wheel per
axis). Every message that analysis depends on carries a header stamp in sim
time.
"""
from __future__ import annotations


AXES = ("x", "y", "z")
JOINT_STATE = "sensor_msgs/msg/JointState"

CLOCK = "/clock"
# JointState attitude_<axis>: position = small-angle attitude [rad], velocity = body rate [rad/s]. The
# thesis' per-axis angles, not a quaternion: a tumbling axis would wrap, and the controllers need them.
ATTITUDE = "/attitude"
ATTITUDE_JOINTS = tuple(f"attitude_{a}" for a in AXES)
# JointState reaction_wheel_<axis>: position = rotor angle [rad], velocity = wheel speed Omega [rad/s]
# (relative to the body, what the tachometer reads), effort = reaction torque on the body [N m]
WHEELS = "/wheels"
WHEEL_JOINTS = tuple(f"reaction_wheel_{a}" for a in AXES)
# the wheel electronics' report once per FDI period (DiagnosticArray, one status per wheel): period
# means of tcv, reaction torque, speed and the nominal model's terms (core/telemetry.py)
FDI_TELEMETRY = "/wheels/fdi_telemetry"
FAULT_EFFECT = "/fault/effect"        # reaction torque minus a healthy wheel's [N m], while a fault is injected
FAULT_TRUTH = "/fault/ground_truth"   # what is injected where since when (DiagnosticArray)
SCENARIO = "/scenario"                # the scenario YAML (latched)
PLANT_DONE = "/plant/done"            # std_msgs/Header: stamp = last step, frame_id = why it ended
RECORDER_CLOSED = "/recorder/closed"  # std_msgs/String (latched): index of the bag the recorder closed


def tcv_command(axis: str) -> str:
    """Per-axis controller output: Vector3Stamped with only that axis' component set [V]."""
    return f"/{axis}/tcv_command"


def _profiles() -> dict:
    """The graph's QoS profiles. Deep reliable queues: the recorder is not part of the lockstep and
    must not lose samples; latched: a late joiner still gets the scenario and the run's end."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    return {"RELIABLE": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                   reliability=ReliabilityPolicy.RELIABLE),
            "LATCHED": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                  durability=DurabilityPolicy.TRANSIENT_LOCAL)}


def __getattr__(name):
    """``topics.RELIABLE`` and ``topics.LATCHED``, made on first use (PEP 562): tools that only need
    topic names import this module without rclpy."""
    if name in ("RELIABLE", "LATCHED"):
        globals().update(_profiles())
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def graph_topics():
    """(topic, ROS type name, qos) of everything a run records."""
    RELIABLE, LATCHED = __getattr__("RELIABLE"), __getattr__("LATCHED")
    vec, joints, diag = "geometry_msgs/msg/Vector3Stamped", JOINT_STATE, "diagnostic_msgs/msg/DiagnosticArray"
    rows = [(CLOCK, "rosgraph_msgs/msg/Clock", RELIABLE),
            (ATTITUDE, joints, RELIABLE), (WHEELS, joints, RELIABLE),
            (FAULT_EFFECT, vec, RELIABLE), (FDI_TELEMETRY, diag, RELIABLE), (FAULT_TRUTH, diag, RELIABLE),
            (SCENARIO, "std_msgs/msg/String", LATCHED), (PLANT_DONE, "std_msgs/msg/Header", LATCHED)]
    rows += [(tcv_command(a), vec, RELIABLE) for a in AXES]
    return rows


OBSERVERS = ("elman", "linear")
DIAGNOSTICS = "/diagnostics"
IDENTIFICATION = "/fdi/identification"   # fault kind and size per alarmed wheel (DiagnosticArray)


def telemetry_readers(fdi: bool) -> int:
    """How many FDI nodes read the FDI telemetry (what the plant or player waits for): Elman x, y, z,
    the linear observer and the isolation node (fault identification); none without FDI."""
    return len(AXES) + 2 if fdi else 0


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
    RELIABLE = __getattr__("RELIABLE")
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
