"""The graph through real processes and DDS: bags, determinism, isolation, and failures.

Every process runs in a private ROS_DOMAIN_ID with loopback-only discovery
and is torn down (SIGKILL after a grace period) also when a test fails.
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.runner.graph import graph_nodes
from rw_fdi_ros.runner.launcher import DomainLease, GraphProcesses
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.storage.bag import read_bag
from rw_fdi_ros.runner.scenario_run import resolve_scenario, run_scenario

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

BIN = Path(sys.executable).parent
FAULT_RUN = """name: short_faults
duration: 40.0
seed: 5
faults:
  - {kind: bus_voltage, wheel: x, onset: 20.0, value: 4.0}
  - {kind: current_limiter, wheel: z, onset: 25.0, value: 0.6}
"""


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scn") / "short_faults.yaml"
    path.write_text(FAULT_RUN)
    return path


@pytest.fixture(scope="module")
def runs(scenario_file, tmp_path_factory):
    """seed 5 alone; then seeds 5 and 6 at the same time (two domains)."""
    out = tmp_path_factory.mktemp("bags")
    told = []
    alone = run_scenario(str(scenario_file), seed=5, out_dir=out, name="alone",
                         progress=lambda t, duration: told.append((t, duration)))
    alone.told = told
    results = {}
    threads = [threading.Thread(target=lambda s=s, n=n: results.__setitem__(n, run_scenario(
        str(scenario_file), seed=s, out_dir=out, name=n))) for s, n in ((5, "twin"), (6, "other"))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    return alone, results["twin"], results["other"]


def decoded(bag_path):
    data = read_bag(bag_path)
    out = {}
    for topic, rows in data.messages.items():
        if data.types[topic] == "geometry_msgs/msg/Vector3Stamped":
            out[topic] = data.vectors(topic)
        elif data.types[topic] == T.JOINT_STATE:
            out[topic] = data.joint_states(topic)
        else:
            out[topic] = [repr(m) for _, m in rows]
    return out


def test_a_run_tells_how_far_it_is_each_wall_second(runs):
    """The plant writes its simulated time about once a wall second and the launcher passes it on
    (`rw-fdi run` shows it as a bar): rising, within the run's 40 s."""
    alone, _, _ = runs
    assert alone.ok, alone.reason
    assert alone.told or alone.wall_time < 3.0, alone.wall_time
    times = [t for t, _ in alone.told]
    assert times == sorted(times) and all(0.0 <= t <= 40.0 and d == 40.0 for t, d in alone.told), alone.told


def test_fault_run_records_every_topic_readable_by_rosbags_and_mcap(runs):
    alone, _, _ = runs
    assert alone.ok, alone.reason
    bag = alone.bag
    assert (bag / "metadata.yaml").exists() and len(list(bag.glob("*.mcap"))) == 1

    from rosbags.highlevel import AnyReader
    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        for conn, _, raw in reader.messages(connections=[c for c in reader.connections if c.topic == T.ATTITUDE]):
            reader.deserialize(raw, conn.msgtype)
    for topic, _, _ in T.graph_topics():
        assert counts.get(topic, 0) > 0, topic
    assert counts[T.ATTITUDE] == 401 and counts[T.CLOCK] == 401 and counts[T.tcv_command("y")] == 401
    assert counts[T.WHEELS] == 401 and counts[T.FDI_TELEMETRY] == 40     # one report per FDI period, t = 1..40 s

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(next(bag.glob("*.mcap")), "rb") as fh:
        seen = {}
        for _, channel, _, msg in make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
    assert seen == counts

    data = read_bag(bag)
    for topic, rows in data.messages.items():
        log_times = [t for t, _ in rows]
        assert log_times == sorted(log_times)
        if hasattr(rows[0][1], "header"):
            stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in rows]
            assert stamps == log_times, topic            # log time is the sim-time stamp
            assert all(b > a for a, b in zip(stamps, stamps[1:])) or topic == T.PLANT_DONE, topic
    wheels = data.topic(T.WHEELS)[-1][1]
    assert list(wheels.name) == ["reaction_wheel_x", "reaction_wheel_y", "reaction_wheel_z", "reaction_wheel_s"]
    assert len(wheels.position) == len(wheels.velocity) == len(wheels.effort) == 4   # x, y, z and s
    truth = data.topic(T.FAULT_TRUTH)
    before = [m for t, m in truth if t < 20e9][-1]
    late = truth[-1][1]
    assert [s.level for s in before.status] == [0, 0, 0, 0]         # OK before the first onset
    assert [s.level for s in late.status] == [2, 0, 2, 0]           # ERROR on x and z
    assert [s.hardware_id for s in late.status] == ["reaction_wheel_x", "reaction_wheel_y", "reaction_wheel_z",
                                                    "reaction_wheel_s"]
    assert late.status[0].message.startswith("bus_voltage=4 since 20") and "current_limiter" in late.status[2].message
    # the plant's physics is the core's: X's pointing diverges after the bus drops to 4 V
    summary = alone.summary
    assert summary["final_error_deg"]["x"] > 1.0 and summary["final_error_deg"]["y"] < 0.5


def test_same_seed_gives_identical_messages_and_parallel_runs_do_not_meet(runs):
    alone, twin, other = runs
    assert twin.ok and other.ok, (twin.reason, other.reason)
    a, b, c = decoded(alone.bag), decoded(twin.bag), decoded(other.bag)
    assert a.keys() == b.keys()
    for topic in a:
        if isinstance(a[topic], tuple):
            for x, y in zip(a[topic], b[topic]):
                np.testing.assert_array_equal(x, y, err_msg=topic)
        else:
            assert a[topic] == b[topic], topic
    assert not np.array_equal(a[T.ATTITUDE][1], c[T.ATTITUDE][1])   # seed 6 is its own run
    assert len(c[T.ATTITUDE][0]) == 401


def cli(*args, timeout=60):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    return subprocess.run([str(BIN / "rw-fdi"), *args], capture_output=True, text=True, timeout=timeout, env=env)


def test_cli_malformed_scenario_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("faults:\n  - {kind: bus_voltage, wheel: q, onset: 1, value: 5}\n")
    t0 = time.monotonic()
    r = cli("run", "--scenario", str(bad), "--out", str(tmp_path))
    assert r.returncode == 2 and time.monotonic() - t0 < 20
    assert r.stderr.strip().count("\n") == 0 and "wheel must be one of x, y, z" in r.stderr
    assert "Traceback" not in r.stderr


def test_cli_unknown_scenario_name(tmp_path):
    r = cli("run", "--scenario", "no_such_thing", "--out", str(tmp_path))
    assert r.returncode == 2 and "unknown scenario 'no_such_thing'" in r.stderr


def graph(scenario_file, tmp_path, seed=5, tweak=None, flush=None):
    scenario, path = resolve_scenario(str(scenario_file), seed)
    scenario = scenario.__class__(**{**scenario.__dict__, "duration": 400.0})
    bag = tmp_path / "bag"
    nodes = graph_nodes(scenario, path, bag, command_timeout=3.0)
    nodes[0].parameters["duration"] = 400.0
    if flush:
        nodes[-1].parameters["flush_period"] = flush
    if tweak:
        tweak(nodes)
    lease = DomainLease()
    procs = GraphProcesses(nodes, lease.domain_id, Path(tempfile.mkdtemp(prefix="rw_fdi_test_"))).start()
    return procs, lease, bag


def run_and_kill(procs, victim, when):
    killer = threading.Thread(target=lambda: (when(), procs.procs[victim].send_signal(signal.SIGKILL)))
    killer.start()
    t0 = time.monotonic()
    result = procs.run(watchdog=60)
    killer.join()
    return result, time.monotonic() - t0


def test_nan_torque_command_stops_the_run_naming_the_axis(scenario_file, tmp_path):
    def nan_setpoint(nodes):   # a controller that computes NaN (its gains are range-checked at start)
        nodes[2].parameters["setpoints"] = [float("nan")] * len(nodes[2].parameters["setpoints"])   # _y
    procs, lease, bag = graph(scenario_file, tmp_path, tweak=nan_setpoint)
    try:
        t0 = time.monotonic()
        result = procs.run(watchdog=60)
        assert not result.ok and time.monotonic() - t0 < 30
        # the wheel allocation takes the controllers' commands: it stops the run naming the axis
        assert "wheel_allocation" in result.reason and "axis y" in result.reason and "nan" in result.reason
        assert read_bag(bag).topic(T.ATTITUDE)            # the bag was finalised and reads
    finally:
        procs.stop_all()
        lease.release()


def test_a_plant_held_on_the_telemetry_records_the_same_run(runs, scenario_file, tmp_path, monkeypatch):
    """telemetry_lead at its least, one FDI period: the step after each FDI stamp is held until
    wheel_telemetry has sent that stamp; the run ends and its bag is the free-running one's, message for message."""
    from rw_fdi_ros.storage.compare import bag_differences
    alone = runs[0]
    monkeypatch.setenv("RW_FDI_TIMING", "1")   # the plant's figures at exit: how often it held
    procs, lease, bag = graph(scenario_file, tmp_path, tweak=lambda nodes: nodes[0].parameters.update(
        telemetry_lead=1.0, duration=40.0))
    try:
        result = procs.run(watchdog=120)
        assert result.ok, result.reason
        assert bag_differences(alone.bag, bag) == []
        figures = [json.loads(line.split(" ", 1)[1]) for p in result.log_dir.glob("*.log")
                   for line in p.read_text().splitlines() if line.startswith("RW_FDI_TIMING ")]
        assert next(f for f in figures if f["node"] == "plant")["telemetry_holds"] > 0
    finally:
        procs.stop_all()
        lease.release()


def test_the_plant_starts_only_once_the_recorder_and_every_node_hear_their_writers(scenario_file, tmp_path):
    """DDS matches each direction on its own: a recorder counted by the plant's writers may not yet hear
    them (a CI run once recorded no /attitude at all), nor a controller (a CI run's pid_controller_z never heard
    step 0). The plant waits for /recorder/ready and for each node's name on /graph/ready."""
    def no_recorder_no_z(nodes):
        nodes.pop()   # the recorder; the plant still asks for its /recorder/ready, and for no reader count of it
        nodes[:] = [n for n in nodes if n.name != "pid_controller_z"]   # still in the plant's ready_nodes
        nodes[0].parameters.update(attitude_readers=3, wheels_readers=2, wait_for_subscribers=0,
                                   startup_timeout=3.0)
        assert "pid_controller_z" in nodes[0].parameters["ready_nodes"]
    procs, lease, _ = graph(scenario_file, tmp_path, tweak=no_recorder_no_z)
    try:
        result = procs.run(watchdog=60)
        assert not result.ok and "plant stopped (exit code 3)" in result.reason, result.reason
        assert "never ready on /recorder/ready, /graph/ready (" in result.reason, result.reason
        # the allocation does not hear z's axis either; every node that heard its writers said so
        assert "pid_controller_z, wheel_allocation not heard)" in result.reason, result.reason
    finally:
        procs.stop_all()
        lease.release()


def bag_has_data(bag, timeout: float = 30.0):
    """Wait until the bag holds several 1 s chunks (~10-20 kB each, the first with the schemas): the run is
    stepping. A fixed sleep instead killed a node before the first step on a loaded machine (an empty bag)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        files = list(bag.glob("*.mcap"))
        if files and files[0].stat().st_size > 60000:
            return
        time.sleep(0.05)


def test_controller_killed_mid_run(scenario_file, tmp_path):
    procs, lease, bag = graph(scenario_file, tmp_path, flush=1.0)
    try:
        result, took = run_and_kill(procs, "pid_controller_y", lambda: bag_has_data(bag))
        assert not result.ok and took < 30
        assert result.reason.startswith("pid_controller_y stopped (killed by signal 9)"), result.reason
        data = read_bag(bag)
        assert data.complete and len(data.topic(T.ATTITUDE)) > 0
    finally:
        procs.stop_all()
        lease.release()


def test_recorder_killed_mid_run_leaves_readable_bag(scenario_file, tmp_path):
    procs, lease, bag = graph(scenario_file, tmp_path, flush=1.0)
    try:
        # the kill lands after at least one complete chunk, whichever write it interrupts
        result, took = run_and_kill(procs, "recorder", lambda: bag_has_data(bag))
        assert not result.ok and took < 30
        assert result.reason.startswith("recorder stopped (killed by signal 9)")
        data = read_bag(bag)
        assert not data.complete
        t, attitude, body_rate, _ = data.joint_states(T.ATTITUDE)
        assert attitude.shape == body_rate.shape == (len(t), 3)
        assert len(t) > 5 and np.all(np.diff(t) > 0)
    finally:
        procs.stop_all()
        lease.release()


def node_alone(exe, *ros_args, timeout=60):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with DomainLease() as lease:
        env["ROS_DOMAIN_ID"] = str(lease.domain_id)
        return subprocess.run([str(BIN / exe), "--ros-args", *ros_args], capture_output=True, text=True,
                              timeout=timeout, env=env)


def test_plant_alone_from_its_console_script():
    r = node_alone("plant", "-p", "scenario:=no_such_thing")
    assert r.returncode == 2 and "unknown scenario" in r.stderr and "Traceback" not in r.stderr
    r = node_alone("plant", "-p", "startup_timeout:=1.0")
    assert r.returncode == 3 and "no wheel allocation on /wheels/command" in r.stderr


def test_nodes_alone_reject_a_joint_they_do_not_have():
    r = node_alone("pid_controller", "-p", "joint:=attitude_w")
    assert r.returncode == 2 and "joint must be one of attitude_x, attitude_y, attitude_z" in r.stderr
    # a bare axis letter is what YAML retypes (`y` is a boolean to rcl): named joints never are
    r = node_alone("elman_observer", "-p", "wheel:=y")
    assert r.returncode != 0 and "Traceback" not in r.stderr and "wheel" in r.stderr


def test_a_campaign_starts_a_hung_graph_over_once(monkeypatch, tmp_path):
    """A watchdog failure (every process alive, none finishing) gets one more graph; others do not."""
    from rw_fdi_ros.tools.campaigns import campaign
    from rw_fdi_ros.runner.scenario_run import RunOutcome
    calls = []

    def fake_run(ref, seed, out_dir, **kwargs):
        calls.append(seed)
        if seed == 1 and calls.count(1) == 1:
            return RunOutcome(False, "graph did not finish within 120 s (watchdog; still running: plant)", None, 120)
        if seed == 2:
            return RunOutcome(False, "plant stopped (exit code 3): no torque command from axis x", None, 5)
        return RunOutcome(True, "completed", tmp_path / f"bag{seed}", 5)
    monkeypatch.setattr(campaign, "run_scenario", fake_run)
    res = campaign.run_campaign("fault_free", 3, 0, tmp_path, executor=campaign.LocalExecutor(1))
    assert sorted(calls) == [0, 1, 1, 2]
    assert [s for s, _ in res.retried] == [1] and "watchdog" in res.retried[0][1]
    assert [s for s, _ in res.failed] == [2] and len(res.done) == 2


def test_sigterm_ends_a_run_like_ctrl_c_with_a_complete_bag(tmp_path):
    """`kill` (SIGTERM) on `rw-fdi run`: the nodes are stopped, the bag is closed complete and readable,
    the exit is non-zero with a one-line reason; no node is left running."""
    scenario = tmp_path / "long.yaml"
    scenario.write_text("name: long\nduration: 5000.0\nseed: 3\nfaults: []\n")
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen([str(BIN / "rw-fdi"), "run", "--scenario", str(scenario), "--no-fdi", "--out",
                             str(tmp_path / "bags")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:   # recording: some chunks written
            files = list((tmp_path / "bags").glob("*/*.mcap"))
            if files and files[0].stat().st_size > 60000:
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode not in (0, None), out
    assert "Traceback" not in err and "interrupted" in err and err.strip().count("\n") == 0, err
    bag, = (tmp_path / "bags").iterdir()
    data = read_bag(bag)
    assert data.complete, data.note
    t, attitude, _, _ = data.joint_states(T.ATTITUDE)
    assert len(t) > 5 and t[-1] < 5000.0   # stopped part way, every message up to there kept
    import re
    logs = re.search(r"node logs: (\S+)\)", err)
    assert logs, err   # the nodes read their parameters from that directory: none may still run
    leftover = subprocess.run(["pgrep", "-f", logs.group(1)], capture_output=True, text=True).stdout.split()
    assert not leftover, leftover
