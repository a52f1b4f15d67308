"""docs/graph.md's node parameter table and the nodes' declarations cannot drift apart.

The declarations are read from the node modules' source (every `self.declare_parameter(...)` with a
literal name, in the node's own module and the base classes it uses); the two kinds declared in a
loop are named in the table by their pattern (`fault.<axis>.<kind>`) or one row each (isolation's
plant choices). Where a default is a literal, the table's type and default must be it.
"""
import ast
from pathlib import Path

import pytest

from rw_fdi_ros.core.mission.plant_choices import DEFAULT

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

ROOT = Path(__file__).resolve().parents[1]
NODES = {"plant": ["plant"], "pid_controller": ["pid_controller", "runtime", "wheel_type"],
         "elman_observer": ["elman_observer", "observer_node", "runtime", "wheel_type"],
         "linear_observer": ["linear_observer", "observer_node", "runtime", "wheel_type"],
         "model_observer": ["model_observer", "observer_node", "runtime", "wheel_type"],
         "isolation": ["isolation", "runtime", "wheel_type"],
         "recorder": ["recorder"], "player": ["player"],
         "wheel_allocation": ["wheel_allocation", "runtime", "wheel_type"],
         "momentum_dumping": ["momentum_dumping", "runtime"], "live_view": ["live_view", "runtime"],
         "plugin_observer": ["plugin_observer", "observer_node", "runtime", "wheel_type"],
         "wheel_telemetry": ["wheel_telemetry", "runtime", "wheel_type"]}
LOOPED = {"plant": {"fault.<wheel>.<kind>"}, "isolation": {*DEFAULT.as_dict(), "fdi.*"},
          # the FDI configuration (graph/fdi_parameters.declare_fdi): one row, its fields in their own table
          **{node: {"fdi.*"} for node in ("elman_observer", "linear_observer", "model_observer", "plugin_observer")}}
TYPES = {bool: "bool", int: "int", float: "double", str: "string"}
ARRAYS = {"DOUBLE_ARRAY": "double[]", "STRING_ARRAY": "string[]", "BOOL": "bool"}


def test_every_node_executable_is_in_the_table_and_installed_by_setup_py():
    import ast
    from rw_fdi_ros.graph.entry import NODES as EXECUTABLES
    assert set(NODES) == set(EXECUTABLES) - {"composed"}   # composed runs the others
    tree = ast.parse((ROOT / "setup.py").read_text())
    listed = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                  and getattr(n.targets[0], "id", "") == "NODES")
    assert sorted(listed) == sorted(EXECUTABLES)   # each an installed console script (ros2 run, ros2 launch)


def declared(modules) -> dict:
    """name -> (type, default text or None) of the literal-named declare_parameter calls."""
    out = {}
    for mod in modules:
        # the node programs, and their plumbing in graph/
        room = "graph" if mod in ("observer_node", "runtime", "wheel_type") else "nodes"
        for call in ast.walk(ast.parse((ROOT / "rw_fdi_ros" / room / f"{mod}.py").read_text())):
            if not (isinstance(call, ast.Call) and getattr(call.func, "attr", "") == "declare_parameter"
                    and isinstance(call.args[0], ast.Constant)):
                continue
            default = call.args[1]
            if isinstance(default, ast.Attribute) and default.attr in ARRAYS:   # Parameter.Type.X: no default
                out[call.args[0].value] = (ARRAYS[default.attr], "unset")
                continue
            try:
                value = ast.literal_eval(default)
            except ValueError:            # computed (a design, a constant of the code): the name alone
                out[call.args[0].value] = (None, None)
                continue
            out[call.args[0].value] = (TYPES[type(value)], f"`{value}`")
    return out


def documented_rows():
    """The cells (node, name, type, default, unit, description) of docs/graph.md's "Node parameters" table."""
    text = (ROOT / "docs" / "graph.md").read_text()
    section = text.split("## Node parameters", 1)[1].split("\n## ", 1)[0]
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[1].startswith("`"):
            yield cells


def documented_table() -> dict:
    """node -> parameter -> (type, default) of docs/graph.md's "Node parameters" table."""
    rows = {}
    for cells in documented_rows():
        rows.setdefault(cells[0], {})[cells[1].strip("`")] = (cells[2], cells[3])
    return rows


@pytest.mark.parametrize("node", sorted(NODES))
def test_readme_lists_every_parameter_the_node_declares(node):
    table = documented_table().get(node, {})
    code = declared(NODES[node])
    assert set(table) == set(code) | LOOPED.get(node, set())
    for name, (kind, default) in code.items():
        if kind is not None:
            assert table[name] == (kind, default), name


def test_the_table_check_would_see_a_missing_row():
    table = documented_table()
    assert "stall_timeout" in table["player"] and "stall_timeout" in declared(NODES["player"])
    assert set(table) == set(NODES)


def test_every_numeric_parameter_has_a_range_and_the_table_states_it():
    """Issue 26: `--persistence -2` made every wheel alarm with nothing said; every numeric node parameter
    is now range-checked at declaration (graph/parameters.py) and docs/graph.md says the range."""
    from rw_fdi_ros.graph.parameters import range_of, range_text
    numeric = 0
    for node, name, kind, _, _, description in documented_rows():
        name = name.strip("`")
        if kind in ("int", "double"):
            numeric += 1
            limits = range_of(node, "fault.x.bus_voltage" if name.startswith("fault.") else name)
            assert limits is not None, f"{node}.{name}: numeric without a range (graph/parameters.py)"
            assert name.startswith("fault.") or range_text(limits) in description, (node, name, description)
    assert numeric >= 40


@pytest.mark.parametrize("args, said", [
    (["isolation", "-p", "fdi.persistence:=-2"], "parameter fdi.persistence must be a whole number of FDI samples"),
    (["pid_controller", "-p", "initial_tcv:=9.0"], "initial_tcv out of range"),
    (["plant", "-p", "fault.y.current_limiter:=3.0"], "fault.y.current_limiter out of range"),
    (["recorder", "-p", "drain_timeout:=0.0"], "drain_timeout out of range"),
    (["plant", "-p", "fault.w.bus_voltage:=4.0"], "parameter fault.w.bus_voltage: no such fault; wheel set"),
    (["plant", "-p", "fault.x.voltage:=4.0"], "parameter fault.x.voltage: no such fault"),
    (["isolation", "-p", "fdi.decision:=4of3"], "fdi.decision must be one of elman, linear, model or a vote"),
    (["model_observer", "-p", "fdi.unit_calibration:=-1.0"], "parameter fdi.unit_calibration must be a finite number")])
def test_a_node_refuses_a_parameter_out_of_its_range_in_one_line(args, said, tmp_path):
    import os
    import subprocess
    import sys
    from rw_fdi_ros.runner.launcher import DomainLease
    with DomainLease() as lease:
        env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        run = subprocess.run([sys.executable, "-m", f"rw_fdi_ros.nodes.{args[0]}", "--ros-args", *args[1:]],
                             capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert run.returncode == 2, run.stderr[-1000:]
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and said in lines[0] and "Traceback" not in run.stderr, run.stderr[-1000:]
