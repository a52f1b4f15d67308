"""Topic names, message types and QoS of the graph: one table every node and tool reads.

Per control step the plant sends three messages the graph acts on: the clock,
the attitude state (controllers) and the wheel state, both
sensor_msgs/JointState, the standard way ROS reports rotational degrees of
freedom (PlotJuggler and Foxglove plot them by joint name); the controllers
answer with body-axis commands (geometry_msgs/Vector3Stamped, x, y, z the
spacecraft axes) and the wheel allocation with one command per wheel. Once per
FDI period the wheel_telemetry node makes of the wheel state and the commands
the FDI telemetry every FDI node reads. Whatever is
per wheel is a JointState with the wheels' joint names (reaction_wheel_<name>,
the wheel set's names: x, y, z and the redundant s by default): N wheels, not
three axes. Every message that analysis depends on carries a header stamp in
sim time.

Who reads what is a table here too (READS), and how many readers each
publisher waits for before its first message is derived from it for a
given graph (WAITS, reader_counts; runner/graph.py sets the parameters).
rclpy is imported only for the QoS profiles, on first use.
"""
from __future__ import annotations

from ..core.fdi.detection import OBSERVERS, observers_of
from ..core.physics.spacecraft import BODY_AXES
from ..core.physics.wheel_set import DEFAULT_WHEEL_SET, joint_name, wheel_set as named_wheel_set


JOINT_STATE = "sensor_msgs/msg/JointState"

CLOCK = "/clock"
# JointState attitude_<axis>: position = small-angle attitude [rad], velocity = body rate [rad/s]. The
# thesis' per-axis angles, not a quaternion: a tumbling axis would wrap, and the controllers need them.
ATTITUDE = "/attitude"
ATTITUDE_JOINTS = tuple(f"attitude_{a}" for a in BODY_AXES)
# JointState reaction_wheel_<name>: position = rotor angle [rad], velocity = wheel speed Omega [rad/s]
# (relative to the body, what the tachometer reads), effort = reaction torque along its spin axis [N m]
WHEELS = "/wheels"
# JointState reaction_wheel_<name>, effort = torque command voltage [V] (what the wheel electronics take),
# from the wheel allocation to the plant every step; a wheel out of use gets 0
WHEEL_COMMAND = "/wheels/command"
# A wheel driver's housekeeping, optional (the wheel_telemetry node reads them; our plant sends none):
# sensor_msgs/BatteryState voltage = the bus voltage at the wheel's driver [V]; sensor_msgs/Temperature
# temperature = the wheel's [C]. header.frame_id names the joint; empty: every wheel (one bus, one sensor)
WHEEL_BUS_VOLTAGE = "/wheels/bus_voltage"
WHEEL_TEMPERATURE = "/wheels/temperature"
# DiagnosticArray, one status per wheel: in use (OK), standby (OK), given up (ERROR) and why; on every
# reconfiguration decision and at the start (nodes/wheel_allocation.py)
FDIR_WHEELS = "/fdir/wheels"
# in orbit (core/physics/environment.py): sensor_msgs/MagneticField, the field in body axes [T] with the noise's
# covariance, from the plant once per magnetometer period; and the magnetorquers' dipole in body axes
# [A m^2] (geometry_msgs/Vector3Stamped, frame body) from the momentum-dumping node for the same stamp
MAGNETOMETER = "/magnetometer"
DIPOLE_COMMAND = "/magnetorquers/command"


def wheel_joints(wheel_set: str = DEFAULT_WHEEL_SET) -> tuple:
    """The joint names of a wheel set's wheels, in its order.

    Parameters
    ----------
    wheel_set : str
        The wheel set's name.

    Returns
    -------
    tuple of str
        The joint names, e.g. 'reaction_wheel_x'.
    """
    return tuple(joint_name(n) for n in named_wheel_set(wheel_set).names)


def axis_of_joint(joint: str, joints: tuple) -> str:
    """The axis or wheel name of ``joint`` (one of ``joints``, e.g. 'reaction_wheel_y' -> 'y'). Nodes are
    told their joint by name, never by a bare letter: a YAML layer between a launch file and rcl reads
    a bare ``y`` or ``n`` as a boolean. ValueError naming the valid joints otherwise.

    Parameters
    ----------
    joint : str
        The joint's name.
    joints : tuple of str
        The valid joint names.

    Returns
    -------
    str
        The axis or wheel name.
    """
    if joint not in joints:
        raise ValueError(f"must be one of {', '.join(joints)}, got {joint!r}")
    return joint.rsplit("_", 1)[1]
# the wheel electronics' report once per FDI period: period means of tcv, reaction torque, speed and the
# nominal model's terms (core/fdi/telemetry.py), a JointState of named channels 'reaction_wheel_<name>/<quantity>',
# the value in position (graph/convert.py); beside it, for fault identification only, the motor torque on
# the bus-voltage grid (a PointCloud2 table: one point per bus voltage, one float64 field per wheel)
FDI_TELEMETRY = "/wheels/fdi_telemetry"
FDI_BUS_GRID = "/wheels/fdi_telemetry/bus_grid"
FAULT_EFFECT = "/fault/effect"        # JointState effort: reaction torque minus a healthy wheel's [N m], per wheel
FAULT_TRUTH = "/fault/ground_truth"   # what is injected where since when (DiagnosticArray)
SCENARIO = "/scenario"                # the scenario YAML (latched)
PLANT_DONE = "/plant/done"            # std_msgs/Header: stamp = last step, frame_id = why it ended
RECORDER_CLOSED = "/recorder/closed"  # std_msgs/String (latched): index of the bag the recorder closed
RECORDER_READY = "/recorder/ready"    # std_msgs/String (latched): the graph's writers of what it records are matched
# std_msgs/String (latched), one writer per node: the node's name, once it hears a writer of each input it steps on
NODE_READY = "/graph/ready"
# the nodes that say so (GraphNode.say_ready_when_heard); the plant waits for those of its graph (ready_nodes)
SAYS_READY = ("pid_controller", "wheel_allocation", "momentum_dumping", "wheel_telemetry", "elman_observer",
              "linear_observer", "model_observer", "plugin_observer", "isolation")


def tcv_command(axis: str) -> str:
    """Per-axis controller output: Vector3Stamped with only that axis' component set [V].

    Parameters
    ----------
    axis : str
        The axis or wheel name.

    Returns
    -------
    str
        The topic's name.
    """
    return f"/{axis}/tcv_command"


# one message each per control step: a whole recorded run has as many of each as it has steps
STEP_TOPICS = (CLOCK, ATTITUDE, WHEELS, *(tcv_command(a) for a in BODY_AXES), WHEEL_COMMAND)


# messages a reliable topic's writer and reader keep: a reader further behind loses the oldest for good
QUEUE_DEPTH = 1000


def _profiles() -> dict:
    """The graph's QoS profiles. Deep reliable queues: the recorder is not part of the lockstep and
    must not lose samples; latched: a late joiner still gets the scenario and the run's end."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    return {"RELIABLE": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=QUEUE_DEPTH,
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


VECTOR, DIAGNOSTICS_TYPE = "geometry_msgs/msg/Vector3Stamped", "diagnostic_msgs/msg/DiagnosticArray"
# (topic, ROS type name, QoS name) of everything the plant side of a run sends (resolved by graph_topics)
PLANT_ROWS = ((CLOCK, "rosgraph_msgs/msg/Clock", "RELIABLE"), (ATTITUDE, JOINT_STATE, "RELIABLE"),
              (WHEELS, JOINT_STATE, "RELIABLE"), (FAULT_EFFECT, JOINT_STATE, "RELIABLE"),
              (FDI_BUS_GRID, "sensor_msgs/msg/PointCloud2", "RELIABLE"), (FDI_TELEMETRY, JOINT_STATE, "RELIABLE"),
              (FAULT_TRUTH, DIAGNOSTICS_TYPE, "RELIABLE"),
              (SCENARIO, "std_msgs/msg/String", "LATCHED"), (PLANT_DONE, "std_msgs/msg/Header", "LATCHED"),
              *((tcv_command(a), VECTOR, "RELIABLE") for a in BODY_AXES), (WHEEL_COMMAND, JOINT_STATE, "RELIABLE"),
              (FDIR_WHEELS, DIAGNOSTICS_TYPE, "RELIABLE"))
ORBIT_ROWS = ((MAGNETOMETER, "sensor_msgs/msg/MagneticField", "RELIABLE"),)
MAGNETORQUER_ROWS = ((DIPOLE_COMMAND, VECTOR, "RELIABLE"),)


def _with_qos(rows):
    return [(topic, type_name, __getattr__(qos)) for topic, type_name, qos in rows]


def graph_topics():
    """(topic, ROS type name, qos) of everything a run records.

    Returns
    -------
    list of tuple
        (topic, type name, QoS profile).
    """
    return _with_qos(PLANT_ROWS)


DIAGNOSTICS = "/diagnostics"
# /diagnostics carries two kinds of status per wheel, told apart by name (what the shipped
# config/diagnostics/aggregator.yaml groups them by): the isolation node's FDI verdict, and FDIR's state of
# the wheel (in use, standby, kept in use, held, given up; the wheel allocation, once per FDI period)
VERDICT_STATUS = "rw_fdi: reaction wheel"
FDIR_STATUS = "fdir: reaction wheel"


def verdict_statuses(msg) -> list:
    """The FDI verdict statuses of a /diagnostics message (an rclpy or a rosbags one), in its order: those
    named VERDICT_STATUS, FDIR's state of the wheels, on the same topic, left out.

    Parameters
    ----------
    msg : diagnostic_msgs.msg.DiagnosticArray
        A /diagnostics message.

    Returns
    -------
    list
        Its verdict statuses.
    """
    return [s for s in msg.status if s.name.startswith(VERDICT_STATUS)]


def writer_counts(record_plant: bool) -> dict:
    """Topic -> its writers in a graph, where more than one: /diagnostics has the isolation node and, in a
    run (not a replay, ``record_plant`` False), the wheel allocation (FDIR's state), each once per FDI period.

    Parameters
    ----------
    record_plant : bool
        A run (True) or a replay of its bag (False).

    Returns
    -------
    dict
        Topic -> number of writers.
    """
    return {DIAGNOSTICS: 2 if record_plant else 1}

IDENTIFICATION = "/fdi/identification"   # fault kind and size per alarmed wheel (DiagnosticArray)


# The observers' and the isolation node's per-wheel outputs are JointStates: name = the wheels' joints,
# effort = the value ([N m]; an alarm 1 or 0). An Elman node watches one wheel: its messages hold that joint.
OBSERVER_OUTPUTS = ("estimate", "residual", "ripple_bound")


def observer_topic(observer: str, kind: str, axis: str | None = None) -> str:
    """One of an observer's per-wheel outputs; the Elman nodes publish one of each per wheel (its own joint).

    Parameters
    ----------
    observer : str
        The observer's name.
    kind : str
        One of OBSERVER_OUTPUTS: 'estimate', the estimated reaction torque [N m]; 'residual', the 40-sample
        mean of r - r^ (speed_aware, signed) or of |r - r^| (thesis) [N m]; 'ripple_bound', what aliased
        commutation ripple can add to the residual [N m] (speed_aware; 0 for thesis).
    axis : str or None
        The wheel of an Elman node; None: one topic for all the wheels.

    Returns
    -------
    str
        The topic's name.
    """
    if kind not in OBSERVER_OUTPUTS:
        raise ValueError(f"kind must be one of {', '.join(OBSERVER_OUTPUTS)}, got {kind!r}")
    return f"/fdi/{observer}/{axis}/{kind}" if axis else f"/fdi/{observer}/{kind}"


def fdi_output_topics(observer: str):
    """What the isolation node publishes per observer: threshold, alarm (1/0 per axis), status.

    Parameters
    ----------
    observer : str
        The observer's name.

    Returns
    -------
    dict
        'threshold', 'alarm', 'status' -> the topic's name.
    """
    return {"threshold": f"/fdi/{observer}/threshold", "alarm": f"/fdi/{observer}/alarm",
            "status": f"/fdi/{observer}/status"}


def plugin_slots(p) -> tuple:
    """The slots of a user's observers (core/fdi/observer_plugin.py) a node's parameters ``p`` name: its
    ``plugin_observers``, comma-separated (a string: rcl has no empty string array).

    Parameters
    ----------
    p : dict
        The node's parameters.

    Returns
    -------
    tuple of str
        The slots' names.
    """
    return tuple(x.strip() for x in str(p.get("plugin_observers", "") or "").split(",") if x.strip())


def _fdi_rows(method: str | None = None, wheel_set: str = DEFAULT_WHEEL_SET, plugins=()):
    """(topic, type, QoS name) of the FDI half of a graph of FDI ``method`` (None: every slot's) with the
    plug-in observers of slots ``plugins``."""
    rows, observers = [], (OBSERVERS if method is None else observers_of(method)) + tuple(plugins)
    for obs in observers:
        rows += [(observer_topic(obs, kind, axis), JOINT_STATE, "RELIABLE") for axis in observer_axes(obs, wheel_set)
                 for kind in OBSERVER_OUTPUTS]
    for obs in observers:
        out = fdi_output_topics(obs)
        rows += [(out["threshold"], JOINT_STATE, "RELIABLE"), (out["alarm"], JOINT_STATE, "RELIABLE"),
                 (out["status"], DIAGNOSTICS_TYPE, "RELIABLE")]
    return rows + [(DIAGNOSTICS, DIAGNOSTICS_TYPE, "RELIABLE"), (IDENTIFICATION, DIAGNOSTICS_TYPE, "RELIABLE")]


def fdi_topics(method: str | None = None, wheel_set: str = DEFAULT_WHEEL_SET, plugins=()):
    """(topic, type, qos) of the FDI half of a graph of FDI ``method`` (None: every slot's), plug-ins beside.

    Parameters
    ----------
    method : str or None
        The FDI method; None: every observer slot's topics.
    wheel_set : str
        The wheel set's name.
    plugins : sequence of str
        The plug-in observers' slots.

    Returns
    -------
    list of tuple
        (topic, type name, QoS profile).
    """
    return _with_qos(_fdi_rows(method, wheel_set, plugins))


# what bag replay plays: what the observer and isolation nodes (and the recorder of their outputs) read, one
# message per FDI period rather than a dozen per control step
FDI_INPUTS = [FDI_BUS_GRID, FDI_TELEMETRY, FAULT_TRUTH, SCENARIO, PLANT_DONE]
# what a recorder of a replay (record_plant false) keeps of the plant's topics besides the FDI's
REPLAY_RECORDED = (CLOCK, SCENARIO, PLANT_DONE, FAULT_TRUTH)


def recorded_rows(record_plant: bool = True, fdi: bool = False, extra=(), method: str = "speed_aware",
                  wheel_set: str = DEFAULT_WHEEL_SET, orbit: bool = False, magnetorquers: bool = False, plugins=()):
    """(topic, type, QoS name) the recorder subscribes to: the plant's topics (with ``record_plant``
    false only REPLAY_RECORDED; in ``orbit`` the magnetometer, with ``magnetorquers`` their command),
    with ``fdi`` those of the FDI of ``method`` on ``wheel_set`` (and of the plug-in slots ``plugins``), and
    ``extra`` 'name:pkg/msg/Type'.

    Parameters
    ----------
    record_plant : bool
        A run (True) or a replay (False: only REPLAY_RECORDED of the plant's).
    fdi : bool
        Whether the FDI's topics are recorded.
    extra : sequence of str
        More topics, 'name:pkg/msg/Type'.
    method : str
        The FDI method.
    wheel_set : str
        The wheel set's name.
    orbit : bool
        An orbit run: the magnetometer is recorded.
    magnetorquers : bool
        The magnetorquers' command is recorded (with ``orbit``).
    plugins : sequence of str
        The plug-in observers' slots.

    Returns
    -------
    list of tuple
        (topic, type name, QoS name).
    """
    rows = [r for r in PLANT_ROWS if record_plant or r[0] in REPLAY_RECORDED]
    if record_plant:
        rows += list(ORBIT_ROWS if orbit else ()) + list(MAGNETORQUER_ROWS if magnetorquers else ())
    rows += _fdi_rows(method, wheel_set, plugins) if fdi else []
    for spec in extra or ():
        name, _, type_name = spec.partition(":")
        rows.append((name, type_name, "RELIABLE"))
    return rows


def live_rows(p: dict) -> list:
    """(topic, type, QoS name) the live view (nodes/live_view.py) shows for its parameters ``p``: what the
    run's bag would hold.

    Parameters
    ----------
    p : dict
        The live view's parameters.

    Returns
    -------
    list of tuple
        (topic, type name, QoS name).
    """
    rows = recorded_rows(True, p.get("fdi", True), (), p.get("fdi_method", "speed_aware"), _wheel_set(p),
                         p.get("orbit", False), p.get("magnetorquers", False), plugin_slots(p))
    return [r for r in rows if r[0] != FDI_BUS_GRID]   # the identification's binary table: nothing to watch


# -- who reads what ----------------------------------------------------------------------------------
# A node holds its first messages until its topic's readers are matched (DDS drops what goes out before;
# graph/gate.py), so how many readers each topic has in a graph is derived here, from what each node
# subscribes to, and handed to the publishers as parameters (runner/graph.py): a node added to READS is
# waited for, and a node missing from it is an error, not a silent stall. Parameters (NodeSpec.parameters)
# are read with the nodes' own defaults.

def _run_end(p) -> list:
    """GraphNode.follow_run_end: /plant/done unless the node stays for the next run."""
    return [PLANT_DONE] if p.get("end_with_run", True) else []


def observer_axes(observer: str, wheel_set: str = DEFAULT_WHEEL_SET) -> tuple:
    """The wheels of an observer's own topics: one Elman node per wheel of the set, the others one for
    all the wheels (None).

    Parameters
    ----------
    observer : str
        The observer's name.
    wheel_set : str
        The wheel set's name.

    Returns
    -------
    tuple
        The wheel names (Elman), or (None,).
    """
    return named_wheel_set(wheel_set).names if observer == "elman" else (None,)


def residual_inputs(method: str = "speed_aware", wheel_set: str = DEFAULT_WHEEL_SET, plugins=()) -> list:
    """What the isolation node of FDI ``method`` reads of its observers (and of the plug-in slots ``plugins``):
    residual and ripple bound of each.

    Parameters
    ----------
    method : str
        The FDI method.
    wheel_set : str
        The wheel set's name.
    plugins : sequence of str
        The plug-in observers' slots.

    Returns
    -------
    list of str
        The topics' names.
    """
    return [observer_topic(obs, kind, a) for obs in (*observers_of(method), *plugins)
            for a in observer_axes(obs, wheel_set) for kind in ("residual", "ripple_bound")]


def _fdi_observers(p) -> tuple:
    """(method, plug-in slots) of an FDI node's ``fdi.*`` parameters (graph/fdi_parameters.py)."""
    from ..fdi_config import FdiConfig
    given = dict(p.get("fdi") or {})
    fdi = FdiConfig(method=given.get("method", "speed_aware"), plugins=tuple(given.get("plugins") or ()))
    return fdi.method, fdi.plugin_slots


def _fdi_slots(p) -> tuple:
    """Every observer slot of an FDI node's ``fdi.*`` parameters: the method's, then the plug-ins'."""
    method, plugins = _fdi_observers(p)
    return (*observers_of(method), *plugins)


def _wheel_set(p) -> str:
    return p.get("wheel_set") or DEFAULT_WHEEL_SET


# executable -> its parameters -> the topics it subscribes to
READS = {
    "plant": lambda p: [WHEEL_COMMAND] + ([DIPOLE_COMMAND] if p.get("magnetorquers") else [])
                       + ([FDI_TELEMETRY] if p.get("telemetry_lead", 0.0) > 0 else [])
                       + ([RECORDER_READY] if p.get("recorder_ready") else [])
                       + ([NODE_READY] if p.get("ready_nodes") else []),
    "pid_controller": lambda p: [ATTITUDE] + _run_end(p),
    "wheel_allocation": lambda p: [*(tcv_command(a) for a in BODY_AXES), ATTITUDE, WHEELS]
                                  + ([DIAGNOSTICS] if p.get("fdir", True) else []) + _run_end(p),
    **dict.fromkeys(("elman_observer", "linear_observer", "model_observer", "plugin_observer"),
                    lambda p: [FDI_TELEMETRY] + _run_end(p)),
    "momentum_dumping": lambda p: [MAGNETOMETER, WHEELS] + ([FDIR_WHEELS] if p.get("fdir", True) else [])
                                  + _run_end(p),
    "isolation": lambda p: [FDI_TELEMETRY, FDI_BUS_GRID, *residual_inputs(_fdi_observers(p)[0], _wheel_set(p),
                                                                          _fdi_observers(p)[1])] + _run_end(p),
    "recorder": lambda p: [r[0] for r in recorded_rows(p.get("record_plant", True), p.get("fdi_period", 0.0) > 0,
                                                       p.get("extra_topics"), p.get("fdi_method", "speed_aware"),
                                                       _wheel_set(p), p.get("orbit", False),
                                                       p.get("magnetorquers", False), plugin_slots(p))],
    "live_view": lambda p: [r[0] for r in live_rows(p)],   # /plant/done among them: its end
    "wheel_telemetry": lambda p: [WHEELS, WHEEL_COMMAND, WHEEL_BUS_VOLTAGE, WHEEL_TEMPERATURE] + _run_end(p),
    # paced by what the isolation node reports done (rate 0); between bags it waits for the recorder
    "player": lambda p: ([p.get("pace_topic", DIAGNOSTICS)] if p.get("rate", 0.0) <= 0 else [])
                        + ([RECORDER_CLOSED, RECORDER_READY] if p.get("await_recorder", False) else []),
}


def _observer_waits(observer: str, axis: str | None) -> dict:
    return {"estimate_readers": [observer_topic(observer, "estimate", axis)],
            "min_subscribers": [observer_topic(observer, kind, axis) for kind in ("residual", "ripple_bound")]}


# executable -> its parameters -> {parameter: the topics of its own whose readers that parameter counts}
WAITS = {
    "plant": lambda p: {"attitude_readers": [ATTITUDE], "wheels_readers": [WHEELS],
                        "wait_for_subscribers": [CLOCK, FAULT_EFFECT, FAULT_TRUTH, SCENARIO],
                        **({"magnetometer_readers": [MAGNETOMETER]} if p.get("magnetorquers") else {})},
    "pid_controller": lambda p: {"min_subscribers": [tcv_command(axis_of_joint(p["joint"], ATTITUDE_JOINTS))]},
    "wheel_allocation": lambda p: {"min_subscribers": [WHEEL_COMMAND], "fdir_readers": [FDIR_WHEELS],
                                   "diagnostics_readers": [DIAGNOSTICS]},
    "momentum_dumping": lambda p: {"min_subscribers": [DIPOLE_COMMAND]},
    "elman_observer": lambda p: _observer_waits("elman", axis_of_joint(p["wheel"], wheel_joints(_wheel_set(p)))),
    "linear_observer": lambda p: _observer_waits("linear", None),
    "model_observer": lambda p: _observer_waits("model", None),
    "plugin_observer": lambda p: _observer_waits(p["slot"], None),
    "isolation": lambda p: {"diagnostics_readers": [DIAGNOSTICS],
                            "min_subscribers": [IDENTIFICATION, *(t for obs in _fdi_slots(p)
                                                                  for t in fdi_output_topics(obs).values())]},
    "player": lambda p: {"min_subscribers": [FDI_TELEMETRY], "bus_grid_readers": [FDI_BUS_GRID]},
    "wheel_telemetry": lambda p: {"min_subscribers": [FDI_TELEMETRY], "bus_grid_readers": [FDI_BUS_GRID]},
    "recorder": lambda p: {},   # what it sends (/recorder/closed) is latched
}


def reads(node) -> list:
    """The topics ``node`` (anything with ``executable`` and ``parameters``: runner.graph.NodeSpec) reads.

    Parameters
    ----------
    node : runner.graph.NodeSpec
        The node.

    Returns
    -------
    list of str
        The topics' names.
    """
    if node.executable not in READS:
        raise ValueError(f"node {node.name}: what {node.executable} reads is not in graph/topics.py READS, "
                         "so nothing would wait for it")
    return READS[node.executable](node.parameters)


def readers(topic: str, nodes) -> int:
    """How many of ``nodes`` read ``topic``.

    Parameters
    ----------
    topic : str
        The topic's name.
    nodes : iterable of runner.graph.NodeSpec
        The graph's nodes.

    Returns
    -------
    int
        The number of readers.
    """
    return sum(topic in reads(n) for n in nodes)


def waits(node) -> dict:
    """{parameter: the topics whose readers it counts} of ``node`` (none: it waits for no reader).

    Parameters
    ----------
    node : runner.graph.NodeSpec
        The node.

    Returns
    -------
    dict
        Parameter name -> tuple of topics.
    """
    return WAITS[node.executable](node.parameters) if node.executable in WAITS else {}


def reader_counts(node, nodes) -> dict:
    """{parameter: readers} of ``node``'s wait parameters in the graph ``nodes``. One parameter counts
    for all its topics, so they must have the same readers (else the node needs a parameter more).

    Parameters
    ----------
    node : runner.graph.NodeSpec
        The node.
    nodes : iterable of runner.graph.NodeSpec
        The graph's nodes.

    Returns
    -------
    dict
        Parameter name -> readers.
    """
    counts = {}
    for param, topics in waits(node).items():
        found = {t: readers(t, nodes) for t in topics}
        if len(set(found.values())) > 1:
            raise ValueError(f"node {node.name}: parameter {param} counts the readers of {', '.join(topics)}, "
                             f"which differ in this graph ({found}): give {node.executable} one per topic")
        counts[param] = found[topics[0]]
    return counts


def message_class(type_name: str):
    """Import the rclpy message class for 'pkg/msg/Name'.

    Parameters
    ----------
    type_name : str
        'pkg/msg/Name'.

    Returns
    -------
    type
        The message class.
    """
    import importlib
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)
