"""launch/rw_fdi.launch.py builds the graph our launcher builds.

`launch` and `launch_ros` are not installable here, so the file is loaded with a stub of the few
names it uses; the stub records what the file asks for. What launch_ros would do with it (a YAML
parameter file per node) is then checked by reading the parameters back as rcl does: YAML.
"""
import importlib.util
import sys
import types
from pathlib import Path

import pytest
import yaml

from rw_fdi_ros.launch.graph import graph_nodes
from rw_fdi_ros.launch.launcher import node_command
from rw_fdi_ros.tools.run import resolve_scenario

LAUNCH_FILE = Path(__file__).resolve().parents[1] / "launch" / "rw_fdi.launch.py"


class _Recorded:
    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class ParameterValue(_Recorded):
    def __init__(self, value, value_type=None):
        super().__init__(value, value_type=value_type)
        self.value, self.value_type = value, value_type


class LaunchConfiguration:
    def __init__(self, name):
        self.name = name

    def perform(self, context):
        return context[self.name]


@pytest.fixture
def launch_module(monkeypatch):
    """The launch file imported against the stub API."""
    stubs = {
        "launch": {"LaunchDescription": lambda actions: list(actions)},
        "launch.actions": {"OpaqueFunction": _Recorded, "SetEnvironmentVariable": _Recorded,
                           "DeclareLaunchArgument": _Recorded, "RegisterEventHandler": _Recorded,
                           "LogInfo": _Recorded, "Shutdown": _Recorded},
        "launch.event_handlers": {"OnProcessExit": _Recorded},
        "launch.substitutions": {"LaunchConfiguration": LaunchConfiguration},
        "launch_ros": {}, "launch_ros.actions": {"Node": _Recorded},
        "launch_ros.parameter_descriptions": {"ParameterValue": ParameterValue},
    }
    for name, attrs in stubs.items():
        module = types.ModuleType(name)
        module.__dict__.update(attrs)
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("rw_fdi_launch", LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def launched(module, **overrides):
    """The Node actions the launch file makes for its arguments (defaults, then ``overrides``)."""
    actions = module.generate_launch_description()
    args = {a.args[0]: a.kwargs.get("default_value", "") for a in actions if "description" in a.kwargs}
    opaque = next(a for a in actions if "function" in a.kwargs)
    made = opaque.kwargs["function"]({**args, **overrides})
    return [a for a in made if "executable" in a.kwargs]


def exit_handlers(module, **overrides):
    actions = module.generate_launch_description()
    args = {a.args[0]: a.kwargs.get("default_value", "") for a in actions if "description" in a.kwargs}
    made = next(a for a in actions if "function" in a.kwargs).kwargs["function"]({**args, **overrides})
    nodes = [a for a in made if "executable" in a.kwargs]
    return nodes, [a.args[0] for a in made if a.args and "target_action" in getattr(a.args[0], "kwargs", {})]


# unquoted scalars rcl's parameter parser takes for booleans (the issue that found this: `axis: y`
# reached pid_controller_y as BOOL True)
RCL_BOOLEANS = {"y": True, "yes": True, "true": True, "on": True, "n": False, "no": False, "false": False,
                "off": False}


def as_rcl_reads_it(value):
    """What rcl makes of a parameter that launch_ros writes to its YAML parameter file: a typed
    string is written quoted and stays a string; a plain string goes unquoted and rcl guesses its
    type; anything else round-trips."""
    if isinstance(value, ParameterValue):
        assert value.value_type is str
        return value.value
    if isinstance(value, str):
        if value.lower() in RCL_BOOLEANS:
            return RCL_BOOLEANS[value.lower()]
        return yaml.safe_load(value)
    return yaml.safe_load(yaml.safe_dump(value))


@pytest.mark.parametrize("overrides, fdi, bag", [
    ({"scenario": "bus_5v5_x", "seed": "3", "bag": "bags/demo"}, {"method": "speed_aware"}, "bags/demo"),
    ({"scenario": "fault_free", "fdi": "false"}, None, None),
    ({"scenario": "current_0p6_x", "fdi_method": "thesis"}, {"method": "thesis"}, None)])
def test_launch_file_starts_the_graph_of_our_launcher(launch_module, overrides, fdi, bag):
    nodes = launched(launch_module, **overrides)
    seed = int(overrides.get("seed", "-1"))
    scenario, path = resolve_scenario(overrides["scenario"], seed if seed >= 0 else None)
    ours = graph_nodes(scenario, path, Path(bag) if bag else None, fdi=fdi)
    assert [(n.kwargs["executable"], n.kwargs["name"]) for n in nodes] == [(n.executable, n.name) for n in ours]
    assert all(n.kwargs["package"] == "rw_fdi_ros" for n in nodes)
    for node, spec in zip(nodes, ours):
        # no remapping on either side: the topics are the nodes' own names (nodes/topics.py)
        assert not node.kwargs.get("remappings") and not node.kwargs.get("ros_arguments"), spec.name
        cmd = node_command(spec, "params.yaml")
        remaps = [cmd[i + 1] for i, a in enumerate(cmd) if a in ("-r", "--remap")]
        assert remaps == [f"__node:={spec.name}"], cmd
        (params,) = node.kwargs["parameters"]
        assert {k: as_rcl_reads_it(v) for k, v in params.items()} == spec.parameters, spec.name
    if fdi is not None:
        names = {n.kwargs["name"] for n in nodes}
        assert {"elman_observer_x", "elman_observer_y", "elman_observer_z", "linear_observer", "isolation"} <= names


def test_a_bare_axis_letter_would_reach_the_node_as_a_boolean():
    """Why the launch file types its strings, and that this test's model of rcl would see it."""
    assert as_rcl_reads_it("y") is True and as_rcl_reads_it("x") == "x"
    assert as_rcl_reads_it(ParameterValue("y", value_type=str)) == "y"


RETYPED = ["y", "n", "Y", "yes", "no", "on", "off", "true", "False", "1.5", "7", "0x10", "~", "null", "", "x: 1"]


def test_strings_yaml_would_retype_reach_a_node_intact_through_our_params_file(tmp_path):
    """Our launcher hands parameters over as launch_ros does, a --params-file that rcl parses; a
    node started with it gets back every string, typed as a string (and numbers as numbers)."""
    import json
    import subprocess
    import sys
    from rw_fdi_ros.launch.graph import NodeSpec
    from rw_fdi_ros.launch.launcher import write_params_file
    values = {f"p{i}": v for i, v in enumerate(RETYPED)} | {"number": 2.5, "count": 3, "flag": True}
    path = write_params_file([NodeSpec("probe", "plant", values)], tmp_path / "params.yaml")
    script = ("import json, rclpy\nfrom rclpy.node import Node\nrclpy.init(args=['--ros-args', '--params-file', "
              f"{str(path)!r}])\nn = Node('probe', automatically_declare_parameters_from_overrides=True)\n"
              "print(json.dumps({p.name: [p.type_.name, p.value] for p in n._parameters.values()}))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.strip().splitlines()[-1])
    for name, value in values.items():
        kind = {str: "STRING", float: "DOUBLE", int: "INTEGER", bool: "BOOL"}[type(value)]
        assert got[name] == [kind, value], (name, value, got.get(name))


def test_a_failing_node_ends_the_launch_and_a_clean_exit_does_not(launch_module):
    """Every node has an exit handler; a non-zero exit shuts the launch down naming the node."""
    nodes, handlers = exit_handlers(launch_module, scenario="bus_5v5_x", bag="bags/demo")
    assert [h.kwargs["target_action"] for h in handlers] == nodes
    by_name = {h.kwargs["target_action"].kwargs["name"]: h.kwargs["on_exit"] for h in handlers}
    failed = by_name["pid_controller_y"](types.SimpleNamespace(returncode=3), None)
    shutdown = [a for a in failed if "reason" in a.kwargs]
    assert len(shutdown) == 1 and "pid_controller_y exited with code 3" in shutdown[0].kwargs["reason"]
    assert by_name["plant"](types.SimpleNamespace(returncode=0), None) is None
