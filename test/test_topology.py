"""Who reads what is one table (graph/topics.py), and every node's reader counts come from it.

A publisher holds its first messages until its topic's readers are matched (DDS drops what goes out
before), so a count too high stalls a run and one too low loses its start. No ROS graph runs here:
test_graph.py and test_fdi_graph.py run them.
"""
import subprocess
import sys

import pytest

from rw_fdi_ros.core.mission.plant_choices import DEFAULT
from rw_fdi_ros.runner.graph import NodeSpec, graph_nodes, with_reader_counts
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.tools.campaigns.replay import replay_nodes
from rw_fdi_ros.runner.scenario_run import resolve_scenario


def run_graph(fdi: bool, recording: bool):
    scenario, path = resolve_scenario("bus_5v5_x", 3)
    return graph_nodes(scenario, path, "bags/demo" if recording else None, fdi={} if fdi else None)


def replay_graph(rate: float = 0.0):
    return replay_nodes(["a", "b"], ["a_out", "b_out"], {}, DEFAULT.as_dict(), rate)


GRAPHS = {"fdi, recorded": lambda: run_graph(True, True), "fdi": lambda: run_graph(True, False),
          "no fdi, recorded": lambda: run_graph(False, True), "no fdi": lambda: run_graph(False, False),
          "replay": replay_graph, "replay at a rate": lambda: replay_graph(2.0)}


def counts(nodes) -> dict:
    """node name -> {parameter: value} of its reader-count parameters."""
    return {n.name: {k: n.parameters[k] for k in T.waits(n)} for n in nodes}


@pytest.mark.parametrize("graph", sorted(GRAPHS))
def test_every_count_is_the_readers_the_table_gives_the_graph(graph):
    nodes = GRAPHS[graph]()
    for node in nodes:
        for param, topics in T.waits(node).items():
            for topic in topics:
                assert node.parameters[param] == T.readers(topic, nodes), (node.name, param, topic)


def test_the_counts_are_the_graph_we_know():
    """The derivation spelt out for the graphs we ship: controllers, FDI nodes, recorder, player."""
    full = counts(run_graph(True, True))
    # the attitude: 3 controllers, the wheel allocation (its momentum check), the recorder; the wheels: the
    # allocation, the wheel_telemetry node, the recorder; the FDI telemetry that node makes from them and the
    # allocation's command: 4 Elman (one per wheel, the redundant s included), the linear and model observers,
    # isolation, recorder and the plant (it keeps within telemetry_lead of it); its bus-voltage grid: the
    # isolation node (fault identification) and the recorder
    assert full["plant"] == {"attitude_readers": 5, "wheels_readers": 3, "wait_for_subscribers": 1}
    assert full["wheel_telemetry"] == {"min_subscribers": 9, "bus_grid_readers": 2}
    assert full["pid_controller_y"] == {"min_subscribers": 2}   # the wheel allocation and the recorder
    assert full["wheel_allocation"] == {"min_subscribers": 3, "fdir_readers": 1, "diagnostics_readers": 2}
    assert full["elman_observer_z"] == full["linear_observer"] == full["model_observer"] == {
        "estimate_readers": 1, "min_subscribers": 2}
    assert full["isolation"] == {"diagnostics_readers": 2, "min_subscribers": 1}   # the recorder, the wheel allocation
    # the plant steps once every node it steps with hears its inputs (/graph/ready), the recorder its own way
    plant = run_graph(True, True)[0]
    assert plant.parameters["ready_nodes"] == [
        "pid_controller_x", "pid_controller_y", "pid_controller_z", "wheel_allocation", "wheel_telemetry",
        *(f"elman_observer_{a}" for a in "xyzs"), "linear_observer", "model_observer", "isolation"]
    assert plant.parameters["recorder_ready"] and plant.parameters["telemetry_lead"] == pytest.approx(25.0)
    bare = counts(run_graph(False, False))
    assert bare["plant"] == {"attitude_readers": 4, "wheels_readers": 1, "wait_for_subscribers": 0}
    assert bare["pid_controller_x"] == {"min_subscribers": 1}
    assert "wheel_telemetry" not in bare   # no FDI and no bag: nobody reads the telemetry
    # the recorder records the telemetry, and the plant keeps within telemetry_lead of it
    assert counts(run_graph(False, True))["wheel_telemetry"] == {"min_subscribers": 2, "bus_grid_readers": 1}
    replay = counts(replay_graph())
    # the FDI nodes; the isolation node its grid; the replay's recorder reads neither
    assert replay["player"] == {"min_subscribers": 7, "bus_grid_readers": 1}
    assert replay["isolation"] == {"diagnostics_readers": 2, "min_subscribers": 1}   # + the pacing player
    assert counts(replay_graph(2.0))["isolation"]["diagnostics_readers"] == 1   # paced by the clock


def test_a_node_added_to_the_table_is_waited_for(monkeypatch):
    before = counts(run_graph(True, True))
    monitor = [T.ATTITUDE, T.observer_topic("linear", "residual"), T.observer_topic("linear", "ripple_bound")]
    monkeypatch.setitem(T.READS, "monitor", lambda p: monitor)
    after = counts(with_reader_counts(run_graph(True, True) + [NodeSpec("monitor", "monitor")]))
    assert after["plant"]["attitude_readers"] == before["plant"]["attitude_readers"] + 1
    assert after["linear_observer"]["min_subscribers"] == before["linear_observer"]["min_subscribers"] + 1
    assert after["elman_observer_x"] == before["elman_observer_x"] and after["isolation"] == before["isolation"]


def test_the_thesis_method_runs_its_two_observers():
    """The thesis' FDI has no model observer (it sees no wheel speed): no node, and nothing waits for one."""
    scenario, path = resolve_scenario("bus_5v5_x", 3)
    nodes = graph_nodes(scenario, path, "bags/demo", fdi={"method": "thesis"})
    assert "model_observer" not in {n.name for n in nodes}
    assert counts(nodes)["wheel_telemetry"]["min_subscribers"] == 8   # 6 FDI nodes, the recorder, the plant
    iso = next(n for n in nodes if n.name == "isolation")
    assert T.observer_topic("model", "residual") not in T.reads(iso)
    assert T.observer_topic("linear", "residual") in T.reads(iso)
    # the recorders record (and wait at the run's end for) the observers that run, live and in replay
    replay = replay_nodes(["a"], ["a_out"], {"method": "thesis"}, DEFAULT.as_dict())
    for graph in (nodes, replay):
        recorded = T.reads(next(n for n in graph if n.name == "recorder"))
        assert not any(t.startswith("/fdi/model/") for t in recorded), recorded
        assert T.fdi_output_topics("linear")["alarm"] in recorded
    live = T.reads(next(n for n in run_graph(True, True) if n.name == "recorder"))
    assert T.fdi_output_topics("model")["alarm"] in live and T.observer_topic("model", "residual") in live


def test_a_node_the_table_does_not_know_is_an_error_not_a_stall():
    with pytest.raises(ValueError, match="monitor reads is not in graph/topics.py READS"):
        with_reader_counts(run_graph(True, False) + [NodeSpec("monitor", "monitor")])


def test_one_count_for_topics_with_different_readers_is_refused(monkeypatch):
    """The linear observer's min_subscribers counts residual and bound: a reader of one alone needs a
    parameter of its own, not a silently wrong wait on the other."""
    monkeypatch.setitem(T.READS, "monitor", lambda p: [T.observer_topic("linear", "residual")])
    with pytest.raises(ValueError, match="linear_observer: parameter min_subscribers counts"):
        with_reader_counts(run_graph(True, False) + [NodeSpec("monitor", "monitor")])


def test_graph_building_tools_import_no_rclpy():
    code = ("import sys, rw_fdi_ros.graph.topics, rw_fdi_ros.runner.graph, rw_fdi_ros.tools.campaigns.replay\n"
            "assert 'rclpy' not in sys.modules, 'rclpy imported'")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr


def test_a_live_view_is_one_more_reader_of_what_the_bag_records_and_its_own_process():
    """The live view (rw-fdi run --live) reads every recorded topic: each publisher waits for it too,
    and it runs in a process of its own in every grouping but "all" (never inside the lockstep's)."""
    from rw_fdi_ros.runner.graph import GROUPINGS, processes
    scenario, path = resolve_scenario("bus_5v5_x", 3)
    plain = counts(graph_nodes(scenario, path, "bags/demo", fdi={}))
    nodes = graph_nodes(scenario, path, "bags/demo", fdi={}, live=0)
    live = counts(nodes)
    view = next(n for n in nodes if n.executable == "live_view")
    assert view.parameters["port"] == 0 and view.parameters["fdi"] and T.DIAGNOSTICS in T.reads(view)
    assert live["plant"]["attitude_readers"] == plain["plant"]["attitude_readers"] + 1
    assert live["isolation"]["diagnostics_readers"] == plain["isolation"]["diagnostics_readers"] + 1
    assert live["plant"]["wait_for_subscribers"] == plain["plant"]["wait_for_subscribers"] + 1
    for grouping in GROUPINGS:
        if grouping != "all":
            assert any(p.nodes == [view] for p in processes(nodes, grouping)), grouping
