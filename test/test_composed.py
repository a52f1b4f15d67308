"""The composed graph: several nodes per process (ROS 2 composition as rclpy has it), one bag.

The same seeds through every grouping of runner/graph.GROUPINGS, with the FDI nodes and FDIR acting:
the bags are the one-node-per-process graph's, message for message (so every topic of the full graph, FDI
nodes included, is a function of the seed: compared decoded, as rclpy leaves the CDR padding after strings
uninitialised). A node that fails in a composed
process ends the run naming the node; the composed executable answers bad input in one line.
"""
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

from rw_fdi_ros.runner.graph import DEFAULT_GROUPING, GROUPINGS, graph_nodes, processes
from rw_fdi_ros.runner.launcher import DomainLease, GraphProcesses
from rw_fdi_ros.storage.bag import read_bag
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.storage.compare import bag_differences
from rw_fdi_ros.scoring.bag_series import verdict_messages
from rw_fdi_ros.runner.fdi_run import run_with_fdi
from rw_fdi_ros.runner.scenario_run import resolve_scenario

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

SCENARIO = """name: composed
duration: 80.0
seed: {seed}
manoeuvres: {{interval_s: [20.0, 40.0], size_deg: [-5.0, 5.0]}}
faults:
  - {{kind: current_limiter, wheel: y, onset: 30.0, value: 0.6}}
"""


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("composed")
    path = root / "composed.yaml"
    path.write_text(SCENARIO.format(seed=22_000_000))   # disjoint from every other seed range
    out = {}
    for grouping in GROUPINGS:
        run = run_with_fdi(str(path), out_dir=root / grouping, grouping=grouping)
        assert run.ok, (grouping, run.reason)
        out[grouping] = run.bag
    return out


def test_the_groupings_deal_every_node_once():
    scenario, path = resolve_scenario("fault_free")
    nodes = graph_nodes(scenario, path, Path("/tmp/bag"), fdi={})
    for grouping in GROUPINGS:
        procs = processes(nodes, grouping)
        assert sorted(n.name for p in procs for n in p.nodes) == sorted(n.name for n in nodes)
    assert len(processes(nodes, "none")) == len(nodes) and len(processes(nodes, "all")) == 1
    assert [p.name for p in processes(nodes, DEFAULT_GROUPING)] == ["loop", "wheel_telemetry", "fdi"]
    with pytest.raises(ValueError, match="grouping must be one of"):
        processes(nodes, "some")


@pytest.mark.parametrize("grouping", [g for g in GROUPINGS if g != "none"])
def test_a_composed_graph_records_the_one_process_per_node_bag(bags, grouping):
    assert bag_differences(bags["none"], bags[grouping]) == []


def test_the_run_is_not_trivial(bags):
    """What the bags agree on includes a detected fault and FDIR's decision."""
    data = read_bag(bags[DEFAULT_GROUPING], topics=["/diagnostics", "/fdir/wheels"])
    assert any(s.level == 2 for _, m in verdict_messages(data) for s in m.status)
    assert len(data.topic("/fdir/wheels")) >= 2   # the start, and the decision on y


def test_diagnostics_carry_the_verdict_and_fdirs_state_each_fdi_period(bags):
    """/diagnostics: the FDI's verdict and FDIR's state of every wheel once per FDI period (FDIR's as
    /fdir/wheels last said it), and every status grouped by exactly one analyzer of the shipped aggregator
    configuration (GenericAnalyzer's startswith)."""
    data = read_bag(bags[DEFAULT_GROUPING], topics=["/diagnostics", "/fdir/wheels"])
    rows = [(t, m) for t, m in data.topic("/diagnostics")]
    fdir = {}
    for _, m in rows:
        states = [s for s in m.status if s.name.startswith(T.FDIR_STATUS)]
        if states:
            fdir[m.header.stamp.sec] = {s.hardware_id: s for s in states}
    verdicts = verdict_messages(data)
    # FDIR's state from 0 s, the FDI's verdict from its first sample at 1 s (no command in force at 0), to 80 s
    assert len(fdir) == 81 and len(verdicts) == 80
    changes = sorted((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                      {s.hardware_id: (s.level, s.message) for s in m.status}) for _, m in data.topic("/fdir/wheels"))
    for t, states in fdir.items():   # as /fdir/wheels last said, at or before that FDI period's step
        said = [c for c in changes if c[0] <= t][-1][1]
        assert {h: (s.level, s.message) for h, s in states.items()} == said, t
    assert fdir[80]["reaction_wheel_y"].level != 0 and fdir[0]["reaction_wheel_y"].level == 0   # y acted on
    analyzers = yaml.safe_load(Path("config/diagnostics/aggregator.yaml").read_text())["analyzers"]["ros__parameters"]
    prefixes = {name: a["startswith"] for name, a in analyzers.items() if isinstance(a, dict)}
    names = {s.name for _, m in rows for s in m.status}
    for name in names:
        matched = [a for a, starts in prefixes.items() if any(name.startswith(p) for p in starts)]
        assert len(matched) == 1, (name, matched)
    assert {a for name in names for a, starts in prefixes.items() if any(name.startswith(p) for p in starts)} == \
        set(prefixes)   # no analyzer left idle


def test_a_failing_node_ends_a_composed_run_naming_itself(tmp_path):
    scenario, path = resolve_scenario("fault_free", 3)
    nodes = graph_nodes(scenario, path, tmp_path / "bag", command_timeout=3.0)
    nodes[2].parameters["setpoints"] = [float("nan")] * len(nodes[2].parameters["setpoints"])   # pid_controller_y
    with DomainLease() as lease:
        procs = GraphProcesses(nodes, lease.domain_id, Path(tempfile.mkdtemp(prefix="rw_fdi_test_")),
                               grouping="all").start()
        try:
            t0 = time.monotonic()
            result = procs.run(watchdog=60)
        finally:
            procs.stop_all()
    assert not result.ok and time.monotonic() - t0 < 30
    assert result.reason.startswith("graph stopped (exit code 2)"), result.reason
    assert "wheel_allocation: error:" in result.reason and "axis y" in result.reason, result.reason
    assert read_bag(tmp_path / "bag").topic("/attitude")   # the recorder, in the same process, closed its bag


@pytest.mark.parametrize("args, says", [([], "no node given"), (["plant"], "is not NAME=EXECUTABLE"),
                                        (["a=nothing"], "'nothing' is not a node executable"),
                                        (["a=plant", "a=recorder"], "a node name given twice")])
def test_the_composed_executable_refuses_bad_input_in_one_line(args, says):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with DomainLease() as lease:
        env["ROS_DOMAIN_ID"] = str(lease.domain_id)
        r = subprocess.run([sys.executable, "-m", "rw_fdi_ros.nodes.composed", *args], capture_output=True,
                           text=True, timeout=60, env=env)
    assert r.returncode == 2 and says in r.stderr and "Traceback" not in r.stderr, r.stderr
