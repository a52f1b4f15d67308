"""The run graph as data: which nodes, with which parameters, for one scenario and seed.

Both our launcher (here, CI, the CLI) and the ROS 2 launch file in
``launch/`` build the graph from :func:`graph_nodes`, so they cannot drift.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import yaml

from ..fdi_config import FdiConfig
from ..core.control.allocation import TorqueAllocator
from ..core.controller_design import design_controller
from ..core.fdi.detection import observers_of
from ..core.physics.plant import Plant
from ..core.mission.plant_choices import DEFAULT, PlantChoices
from ..core.physics.spacecraft import BODY_AXES
from ..core.mission.vehicle import wheel_parameter
from ..core.mission.scenario import Scenario
from ..core.physics.wheel_set import joint_name, wheel_set
from ..graph import topics as T
from ..graph.fdi_parameters import fdi_parameters

CONTROL_PERIOD = DEFAULT.control_period


@dataclass
class NodeSpec:
    name: str                 # ROS node name (unique in the graph)
    executable: str           # console script / module under rw_fdi_ros.nodes
    parameters: dict = field(default_factory=dict)
    essential: bool = True    # its death ends the run

    @property
    def module(self) -> str:
        return f"rw_fdi_ros.nodes.{self.executable}"


@dataclass
class ProcessSpec:
    """One process of the graph: a node's own (one node) or a composed one (nodes/composed.py)."""

    name: str
    nodes: list

    @property
    def essential(self) -> bool:
        return any(n.essential for n in self.nodes)


# which process each node executable goes to, per grouping (--compose / compose:=); "none": every node its
# own process, as `ros2 run` starts them. The default was chosen by measurement (docs/benchmarks.md).
_LOOP = {"plant": "loop", "player": "loop", "pid_controller": "loop", "wheel_allocation": "loop",
         "momentum_dumping": "loop"}
_FDI = {"elman_observer": "fdi", "linear_observer": "fdi", "model_observer": "fdi", "plugin_observer": "fdi",
        "isolation": "fdi"}   # wheel_telemetry: a process of its own, where a launch file remaps its streams
GROUPINGS = {
    "none": None,
    "all": dict.fromkeys([*_LOOP, *_FDI, "wheel_telemetry", "recorder"], "graph"),
    "loop_fdi": {**_LOOP, **_FDI, "recorder": "loop"},
    "loop_fdi_recorder": {**_LOOP, **_FDI, "recorder": "recorder"},
}
DEFAULT_GROUPING = "loop_fdi"


def processes(nodes, grouping: str = DEFAULT_GROUPING) -> list:
    """``nodes`` (NodeSpec) dealt into the processes of ``grouping`` (GROUPINGS), in the nodes' order; a
    group of one node is that node's own process. ValueError for an unknown grouping.

    Parameters
    ----------
    nodes : iterable of NodeSpec
        The graph's nodes.
    grouping : str
        A key of GROUPINGS.

    Returns
    -------
    list of ProcessSpec
        One per group, in the order of each group's first node.
    """
    if grouping not in GROUPINGS:
        raise ValueError(f"grouping must be one of {', '.join(GROUPINGS)}, got {grouping!r}")
    table = GROUPINGS[grouping]
    groups = {}
    for node in nodes:
        groups.setdefault(node.name if table is None else table.get(node.executable, node.name), []).append(node)
    return [ProcessSpec(members[0].name if len(members) == 1 else name, members) for name, members in groups.items()]


def graph_nodes(scenario: Scenario, scenario_ref: str, bag: Path | None, command_timeout: float = 5.0,
                emf_limit: str | None = None, fdi=None, live: int | None = None):
    """Plant, three PID controllers, the wheel allocation (with FDIR when ``fdi`` says so), (when ``fdi``) the
    observers and isolation, and (when ``bag``) the recorder for one run. ``fdi``: an FdiConfig or its mapping
    (an empty one: the shipped FDI); None: no FDI.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario, seed included.
    scenario_ref : str
        What the plant node loads the scenario from (a path, or a name in config/scenarios/).
    bag : Path or None
        The bag directory the recorder writes; None: no recorder.
    command_timeout : float
        Wall time [s] the plant waits for a command before it fails the run.
    emf_limit : str, optional
        The plant choice emf_limit (PlantChoices); None: the scenario's.
    fdi : FdiConfig or mapping or None
        The run's FDI; None: none.
    live : int, optional
        The port of a live view (nodes/live_view.py: the run in Foxglove as it happens; 0: any free port);
        None: none.

    Returns
    -------
    list of NodeSpec
        The nodes, told their reader counts, their string parameters checked (:func:`checked_strings`).
    """
    fdi = None if fdi is None else FdiConfig.of(fdi)
    choices = scenario.plant_choices(emf_limit=emf_limit)
    period = choices.control_period
    times, values = scenario.setpoint_schedule()
    start = Plant(scenario, wheels=choices.wheel_set)   # the plant's own units and wheels at t = 0
    feedforward = start.vehicle.controller.friction_feedforward
    # the body-axis command that holds them (closed_loop.simulate's, less the allocation's friction feed-forward)
    hold = TorqueAllocator(start.wheels, 1, start.datasheet.command_limit, start.datasheet,
                           feedforward).integrator_start(start.tcv, start.wheel_speed)[0]
    # a vehicle file's spacecraft: its controllers designed on its inertia, its FDIR's momentum checks on it
    # (the thesis' vehicle: the nodes' own defaults, the same numbers)
    vehicle = scenario.vehicle
    design = design_controller(vehicle).gains if vehicle is not None else None
    # the wheel type of every node that models the wheels ('' the thesis' Type A: the nodes' default)
    wheel_type = wheel_parameter(scenario.spacecraft.wheel, scenario.spacecraft.wheel_type)
    typed = {"wheel_type": wheel_type} if wheel_type else {}
    nodes = [NodeSpec("plant", "plant", {
        "scenario": scenario_ref, "seed": scenario.seed, "control_period": period,
        "emf_limit": choices.emf_limit, "wheel_momentum_coupling": choices.wheel_momentum_coupling,
        "wheel_set": choices.wheel_set, "magnetic_field": choices.magnetic_field, "command_timeout": command_timeout,
        "recorder_ready": bag is not None,
        "magnetorquers": scenario.magnetorquers is not None})]
    for i, axis in enumerate(BODY_AXES):
        nodes.append(NodeSpec(f"pid_controller_{axis}", "pid_controller", {
            "joint": T.ATTITUDE_JOINTS[i], "control_period": period, "initial_tcv": float(hold[i]),
            "setpoint_times": [float(t) for t in times], "setpoints": [float(v) for v in values[:, i]],
            **typed, **({} if design is None else {"kp": float(design.kp[i]), "ki": float(design.ki[i]),
                                                   "kd": float(design.kd[i])})}))
    nodes.append(NodeSpec("wheel_allocation", "wheel_allocation", {
        "wheel_set": choices.wheel_set, "control_period": period,
        "fdir": fdi is not None and fdi.fdir,
        "fdi_period": choices.fdi_period, **typed, **({"friction_feedforward": True} if feedforward else {}),
        "null_space_time_constant": start.vehicle.controller.null_space_time_constant,
        **({} if vehicle is None else {"body_inertia": [float(v) for v in vehicle.inertia_matrix.ravel()],
                                       "wheel_inertia": float(vehicle.wheel.inertia)})}))
    if scenario.magnetorquers is not None:
        rods = scenario.magnetorquers
        nodes.append(NodeSpec("momentum_dumping", "momentum_dumping", {
            "wheel_set": choices.wheel_set, "dipole_limit": rods.dipole_limit, "gain": rods.gain,
            "start_speed": rods.start_speed, "stop_speed": rods.stop_speed, "enabled": rods.enabled,
            **({} if vehicle is None else {"wheel_inertia": float(vehicle.wheel.inertia)})}))
    if fdi is not None or bag is not None:   # the FDI, and the bag, take the wheels' reports as it makes them
        telemetry = telemetry_node(choices, wheel_type)
        telemetry.parameters["command_hold"] = 0.0   # our plant steps on each command: every report has its own
        nodes.append(telemetry)
        # the plant keeps within a quarter of the telemetry's /wheels queue of it (a loaded CI lost 19 s of it),
        # at least the FDI period the telemetry needs (a tick of 4 ms or less: the queue is not a period long)
        nodes[0].parameters["telemetry_lead"] = max(T.QUEUE_DEPTH * period / 4, choices.fdi_period)
    if fdi is not None:
        nodes += fdi_nodes(fdi, choices, await_bus_grid=True, wheel_type=wheel_type)   # a grid with every report
    if live is not None:
        nodes.append(NodeSpec("live_view", "live_view", {
            "port": int(live), "wheel_set": choices.wheel_set, "fdi": fdi is not None,
            "fdi_method": fdi.method if fdi else "speed_aware", "orbit": scenario.environment is not None,
            "magnetorquers": scenario.magnetorquers is not None}))
    if bag is not None:
        # absolute: a bag named like a number or a YAML word ("1e3", "on") is a path, never retyped
        nodes.append(NodeSpec("recorder", "recorder", {"output": str(Path(bag).resolve()),
                                                       "fdi_period": choices.fdi_period if fdi is not None else 0.0,
                                                       "telemetry_period": choices.fdi_period,
                                                       "fdi_method": fdi.method if fdi else "speed_aware",
                                                       "wheel_set": choices.wheel_set,
                                                       "orbit": scenario.environment is not None,
                                                       "magnetorquers": scenario.magnetorquers is not None,
                                                       **plugin_parameters(fdi)}))
    return checked_strings(with_reader_counts(nodes))


def attach_nodes(vehicle: str | None = None, fdi=None, joint_names=(), max_gap: float | None = None):
    """The FDI graph on anyone's wheels: the wheel_telemetry node (their JointState streams) and the FDI nodes of
    ``vehicle``, without our plant and controllers.

    Parameters
    ----------
    vehicle : str or None
        A shipped vehicle's name, a vehicle file or a vehicle's FDI directory; None: the thesis' MakSat.
    fdi : FdiConfig or mapping or None
        The FDI (None or an empty one: the vehicle's shipped FDI).
    joint_names : sequence of str
        The streams' joint names in the vehicle's wheel set's order; empty: ours (reaction_wheel_<name>).
    max_gap : float, optional
        [s] speed reports further apart leave the FDI periods between them not judged; None: the node's.

    Returns
    -------
    list of NodeSpec
        wheel_telemetry, the observers and the isolation node, told their reader counts.
    """
    from ..core.mission.scenario import vehicle_scenario
    scenario = vehicle_scenario(vehicle, duration=1.0)
    choices = scenario.plant_choices()
    wheel_type = wheel_parameter(scenario.spacecraft.wheel, scenario.spacecraft.wheel_type)
    telemetry = telemetry_node(choices, wheel_type, joint_names, max_gap)
    fdi = FdiConfig.of(fdi or {}).with_vehicle_dir(vehicle)
    fdi_graph = fdi_nodes(fdi, choices, wheel_type=wheel_type)
    return checked_strings(with_reader_counts([telemetry, *fdi_graph]))


def telemetry_node(choices: PlantChoices, wheel_type: str = "", joint_names=(), max_gap: float | None = None):
    """The wheel_telemetry node: the FDI telemetry from the wheels' JointState streams (ours or anyone's).

    Parameters
    ----------
    choices : PlantChoices
        The wheel set, the FDI and control periods.
    wheel_type : str
        The vehicle's wheel type (core/mission/vehicle.wheel_parameter; '' the thesis' Type A).
    joint_names : sequence of str
        The streams' joint names in the wheel set's order; empty: ours.
    max_gap : float, optional
        [s] speed reports further apart leave the FDI periods between not judged; None: the node's.

    Returns
    -------
    NodeSpec
        The node.
    """
    return NodeSpec("wheel_telemetry", "wheel_telemetry", {
        "wheel_set": choices.wheel_set, "fdi_period": choices.fdi_period, "control_period": choices.control_period,
        **({"joint_names": list(joint_names)} if joint_names else {}),
        **({"max_gap": float(max_gap)} if max_gap is not None else {}),
        **({"wheel_type": wheel_type} if wheel_type else {})})


def plugin_parameters(fdi) -> dict:
    """The ``plugin_observers`` parameter (the slots of the FDI's plug-ins, comma-separated) of the nodes that
    read or record their topics; {} without plug-ins (the nodes' default)."""
    slots = () if fdi is None else fdi.plugin_slots
    return {"plugin_observers": ",".join(slots)} if slots else {}


# plain scalars rcl's parameter parser takes for booleans beyond PyYAML's (YAML 1.1) own: `y`, `n`
RCL_BOOLEAN_WORDS = {"y", "yes", "true", "on", "n", "no", "false", "off"}


def misread_by_yaml(value: str) -> bool:
    """Whether a string parameter could come out of a YAML layer as something else: launch_ros
    yaml-loads a plain string (PyYAML, YAML 1.1) and writes it back bare, and rcl parses its params
    file with its own rules (``y``/``n`` booleans, ``1e3`` a double).

    Parameters
    ----------
    value : str
        A string parameter's value.

    Returns
    -------
    bool
        True where it reads as a boolean, a number or another YAML value (or is no valid YAML).
    """
    if value.strip().lower() in RCL_BOOLEAN_WORDS:
        return True
    try:
        if yaml.safe_load(value) != value:
            return True
    except yaml.YAMLError:
        return True
    for number in (float, lambda v: int(v, 0)):
        try:
            number(value)
            return True
        except ValueError:
            pass
    return False


def flat_parameters(parameters: dict, prefix: str = "") -> dict:
    """``parameters`` with a nested set (``{"fdi": {"method": ...}}``) under the dotted names rcl gives them.

    Parameters
    ----------
    parameters : dict
        A node's parameters, as a params file holds them.
    prefix : str
        The enclosing set's dotted name ('' at the top).

    Returns
    -------
    dict
        dotted name -> value.
    """
    out = {}
    for name, value in parameters.items():
        if isinstance(value, dict):
            out.update(flat_parameters(value, f"{prefix}{name}."))
        else:
            out[f"{prefix}{name}"] = value
    return out


def checked_strings(nodes):
    """``nodes``, after checking that none of their string parameters is one a YAML layer between a
    launch file and rcl would retype (our names are joint names, method names and absolute paths):
    ValueError naming the node and parameter otherwise.

    Parameters
    ----------
    nodes : list of NodeSpec
        The graph's nodes.

    Returns
    -------
    list of NodeSpec
        ``nodes`` themselves.
    """
    for node in nodes:
        for name, value in flat_parameters(node.parameters).items():
            if isinstance(value, str) and misread_by_yaml(value):
                raise ValueError(f"{node.name}: parameter {name}={value!r} would be read as another type by "
                                 "YAML on its way to the node")
    return nodes


def with_reader_counts(nodes):
    """``nodes``, each told how many readers of its topics to wait for: what the others read
    (graph/topics.py READS), so a node added to the graph is waited for, and the plant the nodes to hear
    ready. Call it on the finished list.

    Parameters
    ----------
    nodes : list of NodeSpec
        The graph's nodes.

    Returns
    -------
    list of NodeSpec
        ``nodes`` themselves, their parameters updated in place.
    """
    for node in nodes:
        node.parameters.update(T.reader_counts(node, nodes))
        if node.executable == "plant":   # and it steps once every node that says so hears its inputs
            node.parameters["ready_nodes"] = [n.name for n in nodes if n.executable in T.SAYS_READY]
    return nodes


def fdi_nodes(fdi, choices: PlantChoices, await_bus_grid: bool = False, wheel_type: str = ""):
    """An Elman observer per wheel of the set, the linear observer, the model observer (speed_aware) and the
    isolation node (told the run's choices), as ``fdi`` (FdiConfig) says. Without models or
    thresholds given, the nodes take the shipped set of the method themselves (a real ROS 2 install's share/).

    Parameters
    ----------
    fdi : FdiConfig
        The run's FDI.
    choices : PlantChoices
        The run's plant choices (wheel set, FDI period [s] and sampling).
    await_bus_grid : bool
        Every report of the FDI telemetry comes with its bus-voltage grid: the isolation node waits for it
        from the first report (else only once it has seen the grid's publisher, which may come late).
    wheel_type : str
        The vehicle's wheel type (core/mission/vehicle.wheel_parameter; '' the thesis' Type A, the nodes' default).

    Returns
    -------
    list of NodeSpec
        The Elman observers, the other observers, then the isolation node.
    """
    fdi = fdi.for_vehicle(choices.vehicle)
    nodes = []
    common = {**fdi_parameters(fdi), "fdi_period": choices.fdi_period, "fdi_sampling": choices.fdi_sampling,
              "wheel_set": choices.wheel_set, **({"wheel_type": wheel_type} if wheel_type else {})}
    for axis in wheel_set(choices.wheel_set).names:
        nodes.append(NodeSpec(f"elman_observer_{axis}", "elman_observer", {"wheel": joint_name(axis), **common}))
    for obs in observers_of(fdi.method)[1:]:   # linear_observer, model_observer: every wheel each
        nodes.append(NodeSpec(f"{obs}_observer", f"{obs}_observer", dict(common)))
    from ..core.fdi.observer_plugin import find_state
    for spec, cls in zip(fdi.plugins, fdi.plugin_classes()):   # a user's observers: a plugin_observer node each
        state = find_state(fdi.plugin_dirs, cls.slot)
        nodes.append(NodeSpec(f"{cls.slot}_observer", "plugin_observer", {
            **common, "observer": spec, "slot": cls.slot,
            **({"observer_state": str(Path(state).resolve())} if state else {})}))
    iso = {**choices.as_dict(), **fdi_parameters(fdi), "await_bus_grid": bool(await_bus_grid),
           **({"wheel_type": wheel_type} if wheel_type else {})}
    nodes.append(NodeSpec("isolation", "isolation", iso))
    return nodes
