"""launch/rw_fdi.launch.py under the real `launch` and `launch_ros` (test/launch_api.py).

- `ros2 launch` of the installed file (a colcon install of a clean copy), a faulty scenario with the FDI
  nodes: every node starts and ends by itself, so does the launch (exit 0), and the bag is a whole run
  with the right verdict.
- In orbit with magnetorquers: the momentum-dumping node starts, answers every magnetometer reading
  and ends by itself.
- A node killed mid-run: the launch ends promptly with a non-zero exit naming it, every other node is
  stopped, and the bag is readable up to the failure and says the run was interrupted.
- Without running: the parameter files launch_ros writes for each node, read back by rcl itself,
  hold exactly our launcher's parameters (three argument sets), strings as strings.
"""
import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from colcon_ws import colcon_env
from launch_api import launch_env, ros2_launch_command, use_launch
from rw_fdi_ros.runner.graph import DEFAULT_GROUPING, flat_parameters, graph_nodes, misread_by_yaml, processes
from rw_fdi_ros.storage.compare import bag_differences
from rw_fdi_ros.runner.launcher import DomainLease
from rw_fdi_ros.runner.scenario_run import resolve_scenario

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

ROOT = Path(__file__).resolve().parents[1]
SOURCE_LAUNCH_FILE = ROOT / "launch" / "rw_fdi.launch.py"
FAULT = """name: {name}
duration: {duration}
seed: 3
faults:
  - {{kind: current_limiter, wheel: x, onset: 40, value: 0.6}}
"""


BURNT = []   # domain leases held to the end of the session


class Launch:
    """`ros2 launch` of the installed launch file in its own session and private domain; torn down
    (SIGINT to the group, SIGKILL after a grace period) whatever happens to the test."""

    def __init__(self, ws: Path, work: Path, *arguments, launch_file: str = "rw_fdi.launch.py"):
        self.lease = DomainLease()
        env = launch_env(colcon_env())
        env.update(ROS_DOMAIN_ID=str(self.lease.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                   ROS_LOG_DIR=str(work / "ros_log"), PYTHONUNBUFFERED="1")
        launch_file = ws / "install" / "rw_fdi_ros" / "share" / "rw_fdi_ros" / "launch" / launch_file
        command = " ".join(f"'{a}'" for a in ros2_launch_command(sys.executable, launch_file, *arguments))
        self.log, self.env = work / "launch.log", env
        with open(self.log, "w") as out:
            self.proc = subprocess.Popen(["bash", "-c", f"source {ws / 'install' / 'setup.bash'} && exec {command}"],
                                         cwd=work, env=env, stdout=out, stderr=subprocess.STDOUT,
                                         stdin=subprocess.DEVNULL, start_new_session=True)

    def wait(self, timeout: float) -> int:
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            # where each node still running is: SIGUSR1 makes it write its stack (graph/runtime.spin_nodes)
            running = [label for label, pid in node_pids(self.output()).items() if Path(f"/proc/{pid}").exists()
                       and os.kill(pid, signal.SIGUSR1) is None]
            time.sleep(3.0)
            pytest.fail(f"ros2 launch did not end within {timeout:g} s; still running: {running}\n"
                        f"{self.output()[-12000:]}")

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def run(self, timeout: float = 240) -> tuple:
        """(exit code, output) once the launch has ended by itself; torn down whatever happens."""
        try:
            return self.wait(timeout=timeout), self.output()
        finally:
            self.close()

    def close(self, reuse_domain: bool = True):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)   # the launch's children too, whatever state they are in
        except ProcessLookupError:
            pass
        self.proc.wait(timeout=10)
        if reuse_domain:
            self.lease.release()
        else:   # a SIGKILLed participant's shared-memory ports linger: no later test of this session gets it
            BURNT.append(self.lease)


def node_pids(output: str) -> dict:
    """launch's `[<exe>-<k>]: process started with pid [N]` lines, keyed by the process label."""
    out = {}
    for line in output.splitlines():
        if "process started with pid [" in line:
            label = line.split("]: process started")[0].rsplit("[", 1)[1]
            out[label] = int(line.rsplit("[", 1)[1].rstrip("]"))
    return out


def expected_nodes(scenario_file: Path, bag: Path):
    scenario, path = resolve_scenario(str(scenario_file))
    return graph_nodes(scenario, path, bag, fdi={"method": "speed_aware"})


def launch_fault(ws: Path, work: Path, duration: float, *arguments, bag_name: str = "bag"):
    """(Launch, scenario file, bag) of `ros2 launch` recording a current loss on x at 40 s."""
    scenario = work / "loss.yaml"
    scenario.write_text(FAULT.format(name="loss", duration=duration))
    bag = work / bag_name
    return Launch(ws, work, f"scenario:={scenario}", f"bag:={bag}", *arguments), scenario, bag


def test_ros2_launch_runs_a_faulty_scenario_to_its_end_and_the_bag_holds_the_verdict(colcon_workspace, tmp_path):
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import bag_info, read_series
    from rw_fdi_ros.runner.verdict import fdi_verdict, verdict_topics
    launch, scenario, bag = launch_fault(colcon_workspace, tmp_path, 90)
    code, output = launch.run()
    assert code == 0, output[-3000:]
    started = node_pids(output)
    nodes = expected_nodes(scenario, bag)
    # plant, 3 controllers, the wheel allocation, wheel_telemetry, 4 Elman (x, y, z, s), linear, model, isolation,
    # recorder: composed by default into three processes (the loop and the recorder; wheel_telemetry, where a
    # launch file may remap its streams; the FDI nodes)
    assert len(nodes) == 14 and len(started) == len(processes(nodes, DEFAULT_GROUPING)) == 3, output[-3000:]
    for label in started:   # each ended by itself: exit 0, and launch never had to signal it
        assert f"[{label}]: process has finished cleanly" in output, label
    assert "sending signal" not in output and "Caught exception" not in output, output[-3000:]
    info = bag_info(bag)
    assert info.complete and T.PLANT_DONE in info.counts, info.note
    counts = {info.counts[t] for t in T.STEP_TOPICS}
    assert counts == {901}, counts   # 0..90 s at 0.1 s on every per-step topic
    data = read_series(bag, verdict_topics())
    verdict = fdi_verdict(data)
    said = verdict["verdict"]   # /diagnostics
    assert said["x"] and not said["y"] and not said["z"] and not said["s"], verdict
    assert said["x"][0][0] >= 40.0, verdict   # alarm intervals: none before the onset
    assert verdict["verdict"]["x"][0][1] is None   # confirmed, held to the end
    found = verdict["identification"]["x"]   # x kept in use beside s, driven: identified on all its samples
    assert found["fault_kind"] == "current_limiter" and "switched off" not in found["message"], found
    # FDIR acted on it: x kept in use beside the redundant s brought in, said on /fdir/wheels (recorded)
    states = {s.hardware_id: {kv.key: kv.value for kv in s.values}["state"] for s in data.last(T.FDIR_WHEELS).status}
    assert states["reaction_wheel_x"] == "kept_in_use" and states["reaction_wheel_s"] == "in_use", states
    # every node its own process (compose:=none): the same bag, message for message
    launch, _, alone = launch_fault(colcon_workspace, tmp_path, 90, "compose:=none", bag_name="bag_none")
    code, output = launch.run()
    assert code == 0 and len(node_pids(output)) == 14, output[-3000:]
    assert bag_differences(bag, alone) == []


ORBIT = """name: orbit
duration: 30.0
seed: 3
initial: {wheel_speed: [38.0, -36.0, 37.0]}
environment: {epoch: 2026-03-01T00:00:00}
magnetorquers: {}
"""


def test_ros2_launch_in_orbit_runs_the_momentum_dumping_node(colcon_workspace, tmp_path):
    """In orbit with magnetorquers the launch file starts the momentum-dumping node too (its own process
    with compose:=none, a params file from launch_ros): it answers every magnetometer reading, the rods
    dump (the wheels start above the dump start), and everything ends by itself."""
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import bag_info, read_bag
    scenario = tmp_path / "orbit.yaml"
    scenario.write_text(ORBIT)
    bag = tmp_path / "orbit_bag"
    launch = Launch(colcon_workspace, tmp_path, f"scenario:={scenario}", f"bag:={bag}", "compose:=none")
    code, output = launch.run()
    assert code == 0, output[-3000:]
    started = node_pids(output)
    assert any(label.startswith("momentum_dumping") for label in started), sorted(started)
    for label in started:
        assert f"[{label}]: process has finished cleanly" in output, label
    info = bag_info(bag)
    assert info.complete and info.counts[T.MAGNETOMETER] == info.counts[T.DIPOLE_COMMAND] == 31, info.counts
    dipoles = [m.vector for _, m in read_bag(bag, [T.DIPOLE_COMMAND]).topic(T.DIPOLE_COMMAND)]
    assert all(max(abs(v.x), abs(v.y), abs(v.z)) > 1.0 for v in dipoles)


def test_a_node_killed_mid_run_ends_the_launch_with_a_failure_and_a_readable_bag(colcon_workspace, tmp_path):
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import bag_info
    launch, _, bag = launch_fault(colcon_workspace, tmp_path, 2000, "compose:=none")
    try:
        deadline = time.monotonic() + 120
        mcap = bag / "bag.mcap"
        # mid-run: the recorder has flushed chunks of the run (one per 10 s of sim time)
        while not (mcap.is_file() and mcap.stat().st_size > 200_000):
            assert launch.proc.poll() is None and time.monotonic() < deadline, launch.output()[-3000:]
            time.sleep(0.2)
        victim = next(pid for label, pid in node_pids(launch.output()).items() if label.startswith("pid_controller"))
        command = Path(f"/proc/{victim}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        name = command.split("__node:=")[1].split()[0]
        os.kill(victim, signal.SIGKILL)
        killed = time.monotonic()
        code = launch.wait(timeout=60)
        ended = time.monotonic() - killed
        output = launch.output()
    finally:
        launch.close(reuse_domain=False)
    assert code != 0, output[-3000:]
    assert f"{name} exited with code -9" in output, output[-3000:]
    assert ended < 20, ended   # launch's own SIGINT -> SIGTERM -> SIGKILL ladder is 10 s at most
    assert "sending signal 'SIGINT'" in output   # launch stopped the others the ROS way
    for label in node_pids(output):   # and every one of them ended
        assert f"[{label}]: process has finished cleanly" in output or f"[{label}]: process has died" in output
    info = bag_info(bag)   # readable up to the failure, closed by the recorder on launch's SIGINT
    assert info.counts.get(T.ATTITUDE, 0) > 100 and T.PLANT_DONE not in info.counts, info.counts
    shown = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "bag", str(bag)], capture_output=True,
                           text=True, timeout=120, cwd=ROOT)
    assert shown.returncode == 0 and "run interrupted: no /plant/done" in shown.stdout, shown.stdout + shown.stderr


def _launch_file_module():
    use_launch()
    spec = importlib.util.spec_from_file_location("rw_fdi_launch", SOURCE_LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def parameter_files(overrides: dict, every: bool = False) -> list:
    """(node name, executable, params file launch_ros writes) of the launch file's nodes for ``overrides``:
    the real launch context, the file's OpaqueFunction, launch_ros' own substitution of parameters.
    ``every``: each node's whole list of parameter files (ours, then a user's params_file) instead."""
    # every node its own Node action, as `ros2 run` starts them: the parameter files launch_ros writes per
    # node (a composed process reads our launcher's file, test_strings_yaml_would_retype_reach_a_node_...)
    out = []
    for action in launch_nodes({"compose": "none", **overrides}):
        files = action._Node__expanded_parameter_arguments
        assert every or (len(files) == 1 and files[0][1]), files
        out.append((action.node_name.rsplit("/", 1)[-1], action.node_executable,
                    [f for f, _ in files] if every else files[0][0]))
    return out


def launch_nodes(overrides: dict) -> list:
    """The launch file's Node actions for the launch arguments ``overrides`` (the rest at their defaults),
    substituted in the real launch context as `ros2 launch` would."""
    use_launch()
    from launch import LaunchContext
    from launch.actions import DeclareLaunchArgument, OpaqueFunction
    from launch_ros.actions import Node
    description = _launch_file_module().generate_launch_description()
    context = LaunchContext()
    for entity in description.entities:
        if isinstance(entity, DeclareLaunchArgument):
            context.launch_configurations[entity.name] = "".join(s.perform(context) for s in entity.default_value)
    context.launch_configurations.update(overrides)
    opaque = next(e for e in description.entities if isinstance(e, OpaqueFunction))
    nodes = [a for a in opaque.execute(context) if isinstance(a, Node)]
    for action in nodes:
        action._perform_substitutions(context)
    return nodes


KALMAN = f"{ROOT}/examples/kalman_observer/kalman_observer.py:KalmanObserver"   # docs/observers.md's example
READ_BACK = """
import json, sys, rclpy
from rclpy.node import Node
out = {}
for name, path in json.loads(sys.argv[1]):
    rclpy.init(args=["--ros-args", "--params-file", path])
    node = Node(name, automatically_declare_parameters_from_overrides=True)
    out[name] = {p.name: [p.type_.name, p.value if not isinstance(p.value, (list, tuple)) else list(p.value)]
                 for p in node._parameters.values() if p.name not in ("use_sim_time", "start_type_description_service")}
    node.destroy_node()
    rclpy.shutdown()
print(json.dumps(out))
"""


def rcl_reads(files: list) -> dict:
    """name -> parameter -> [type, value] as rcl parses each params file for a node of that name."""
    got = subprocess.run([sys.executable, "-c", READ_BACK, json.dumps(files)], capture_output=True, text=True,
                         timeout=120, env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"))
    assert got.returncode == 0, got.stderr[-2000:]
    return json.loads(got.stdout.strip().splitlines()[-1])


def _rcl_type(value) -> str:
    if isinstance(value, (list, tuple)):
        return {float: "DOUBLE_ARRAY", str: "STRING_ARRAY", int: "INTEGER_ARRAY"}[type(value[0])]
    return {bool: "BOOL", int: "INTEGER", float: "DOUBLE", str: "STRING"}[type(value)]


@pytest.mark.parametrize("overrides, fdi, bag", [
    ({"scenario": "bus_5v5_x", "seed": "3", "bag": "bags/demo"}, {"method": "speed_aware"}, "bags/demo"),
    ({"scenario": "fault_free", "fdi": "false"}, None, None),
    ({"scenario": "current_0p6_x", "fdi_method": "thesis"}, {"method": "thesis"}, None),
    ({"scenario": "current_0p6_x", "models": str(ROOT / "config" / "fdi"), "persistence": "4"},
     {"models": str(ROOT / "config" / "fdi"), "persistence": 4}, None),
    ({"scenario": "current_0p6_x", "decision": "2of3"}, {"decision": "2of3"}, None),
    ({"scenario": "current_0p6_x", "observers": KALMAN, "bag": "bags/k"}, {"plugins": (KALMAN,)}, "bags/k")])
def test_rcl_reads_our_launchers_parameters_from_the_files_launch_ros_writes(overrides, fdi, bag):
    files = parameter_files(overrides)
    seed = int(overrides.get("seed", "-1"))
    scenario, path = resolve_scenario(overrides["scenario"], seed if seed >= 0 else None)
    ours = graph_nodes(scenario, path, Path(bag) if bag else None, fdi=fdi)
    assert [(name, exe) for name, exe, _ in files] == [(n.name, n.executable) for n in ours]
    got = rcl_reads([(name, path) for name, _, path in files])
    for spec in ours:
        typed = {k: [_rcl_type(v), list(v) if isinstance(v, (list, tuple)) else v]
                 for k, v in flat_parameters(spec.parameters).items() if not (isinstance(v, (list, tuple)) and not v)}
        assert got[spec.name] == typed, spec.name
    if fdi is not None:
        assert {"elman_observer_x", "elman_observer_y", "elman_observer_z", "linear_observer",
                "isolation"} <= {n.name for n in ours}
    assert "recorder" in got if bag else "recorder" not in got
    if fdi and fdi.get("plugins"):   # a user's observer: its node, judged and recorded
        assert got["kalman_observer"]["observer"] == ["STRING", KALMAN]
        assert got["isolation"]["fdi.plugins"] == got["kalman_observer"]["fdi.plugins"] == ["STRING_ARRAY", [KALMAN]]
        assert got["recorder"]["plugin_observers"] == ["STRING", "kalman"]


RETYPED = ["y", "n", "Y", "yes", "no", "on", "off", "true", "False", "1.5", "7", "0x10", "1e3", "~", "null", "",
           "x: 1"]


def test_a_string_a_yaml_layer_would_retype_is_refused_before_any_node_starts():
    """graph_nodes names things so that no YAML layer can misread them; the guard behind that."""
    assert all(misread_by_yaml(v) for v in RETYPED)
    assert not any(misread_by_yaml(v) for v in ["attitude_y", "reaction_wheel_n", "speed_aware", "/tmp/1e3",
                                                "kf_scaled", "mean"])
    scenario, path = resolve_scenario("fault_free")
    assert all(p["output"].startswith("/") for p in [n.parameters for n in graph_nodes(scenario, path, Path("1e3"))
                                                     if n.name == "recorder"])
    from rw_fdi_ros.runner.graph import NodeSpec, checked_strings
    with pytest.raises(ValueError, match="probe: parameter axis='y'"):
        checked_strings([NodeSpec("probe", "plant", {"axis": "y"})])


def test_strings_yaml_would_retype_reach_a_node_intact_through_our_params_file(tmp_path):
    """Our own launcher hands parameters over as a --params-file too: every string quoted, so a node
    started with it gets back every string as a string (and numbers as numbers)."""
    from rw_fdi_ros.runner.graph import NodeSpec
    from rw_fdi_ros.runner.launcher import write_params_file
    values = {f"p{i}": v for i, v in enumerate(RETYPED)} | {"number": 2.5, "count": 3, "flag": True}
    path = write_params_file([NodeSpec("probe", "plant", values)], tmp_path / "params.yaml")
    got = rcl_reads([("probe", str(path))])["probe"]
    for name, value in values.items():
        assert got[name] == [_rcl_type(value), value], (name, value, got.get(name))


def test_use_sim_time_and_a_users_parameters_file_reach_every_node(tmp_path):
    """use_sim_time:=true sets every node's use_sim_time (rcl reads it back from launch_ros' file), and
    params_file:=FILE comes after ours for every node, so a user's value wins (issue 38: ROS 2 habits)."""
    mine = tmp_path / "mine.yaml"
    mine.write_text("/**:\n  ros__parameters:\n    command_timeout: 9.0\n")
    files = parameter_files({"scenario": "fault_free", "use_sim_time": "true", "params_file": str(mine)}, every=True)
    assert len(files) >= 10 and all(paths[-1] == str(mine) for _, _, paths in files), files
    for name, _, paths in files:   # launch_ros' own file (PyYAML with python tags: read as text)
        assert "use_sim_time: true" in Path(paths[0]).read_text(), name
    plain = parameter_files({"scenario": "fault_free"})
    assert all("use_sim_time" not in Path(path).read_text() for _, _, path in plain)



def test_a_namespace_puts_every_node_under_it_and_our_params_file_reaches_them_there(tmp_path):
    """namespace:=sc1 (or an including file's PushRosNamespace): every node of the launch file is /sc1/<name>,
    and our params file keys each node by /**/<name>, which rcl matches in any namespace (read back by rcl)."""
    from rw_fdi_ros.runner.graph import NodeSpec
    from rw_fdi_ros.runner.launcher import write_params_file
    nodes = launch_nodes({"scenario": "fault_free", "namespace": "sc1", "use_sim_time": "true"})
    assert nodes and all(a.expanded_node_namespace == "/sc1" for a in nodes), [a.expanded_node_namespace
                                                                             for a in nodes]
    assert all(("/clock", "/sc1/clock") in [tuple(r) for r in a.expanded_remapping_rules] for a in nodes)
    path = write_params_file([NodeSpec("probe", "plant", {"count": 3, "flag": True})], tmp_path / "params.yaml",
                             namespace="any")
    assert path.read_text().startswith("'/**/probe':")   # quoted, as every string of the file
    assert rcl_reads([("probe", str(path))])["probe"]["count"] == [_rcl_type(3), 3]
