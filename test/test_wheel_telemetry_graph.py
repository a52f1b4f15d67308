"""The FDI graph on wheels that are not our plant (issue 57): the wheel_telemetry node makes the FDI telemetry from
a driver's JointState streams (its own joint names, 25 Hz with jitter and lost messages, no torque reported), the
shipped FDI judges it, and /diagnostics says which wheel failed, as with our plant."""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.tools.evaluation.telemetry_file import judge
from rw_fdi_ros.runner.graph import attach_nodes
from rw_fdi_ros.runner.launcher import DomainLease, GraphProcesses, stop_processes

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

DRIVER = Path(__file__).with_name("foreign_wheels.py")
ONSET = 150.0


def test_the_fdi_names_the_failed_wheel_of_a_stream_that_is_not_our_plants(tmp_path):
    from foreign_wheels import drive_graph
    nodes = attach_nodes(joint_names=("rw1", "rw2", "rw3", "rw4"))   # the thesis' vehicle, its shipped FDI
    alarmed = check_verdicts(drive_graph(nodes, tmp_path, "--duration", 300, "--onset", ONSET, "--housekeeping"))
    # the driver's housekeeping reached the FDI samples: each wheel's bus voltage and the set's temperature
    carried = json.loads((tmp_path / "heard.json").read_text())["housekeeping"]
    assert {k: v for k, v in carried.items() if k.endswith("/bus_voltage")} == {
        f"reaction_wheel_{a}/bus_voltage": 8.0 for a in "xyzs"}, carried
    assert [v for k, v in carried.items() if k.endswith("/temperature")] == [23.0] * 4, carried
    # the same stream as a table, judged offline by `rw-fdi telemetry`'s code: the graph's verdict, to the second
    offline = judge(stream_table())["wheels"]
    assert {f"reaction_wheel_{a}": w["first_alarm_s"] for a, w in offline.items()
            if w["first_alarm_s"] is not None} == alarmed


def stream_table():
    """The driver's run (foreign_wheels.stream) as the telemetry tool's table, the stamps the driver sends."""
    from foreign_wheels import JOINTS, stream
    from rw_fdi_ros.tools.evaluation.telemetry_file import Telemetry
    speeds, commands = stream(300.0, ONSET, 0.5)
    stamps = sorted({int(round(t * 1e9)) for t, _ in speeds + commands})
    row = {s: i for i, s in enumerate(stamps)}
    speed, command = (np.full((len(stamps), len(JOINTS)), np.nan) for _ in range(2))
    for t, w in speeds:
        speed[row[int(round(t * 1e9))]] = w
    for t, u in commands:
        command[row[int(round(t * 1e9))]] = u
    return Telemetry("driver", tuple(JOINTS), np.array(stamps, np.int64), speed, command)


def check_verdicts(heard: list) -> dict:
    """The statuses the driver heard: judged to the end, the half-current wheel y alone named, within a minute of
    its onset and never before, and identified a current loss; wheel -> first alarm [s]."""
    verdicts = [h for h in heard if h[1].startswith(T.VERDICT_STATUS)]
    assert verdicts and max(h[0] for h in verdicts) >= 299.0
    alarmed = {}
    for t, _, wheel, level, _, _ in verdicts:
        if level == 2:   # ERROR: faulty
            alarmed.setdefault(wheel, t)
    assert set(alarmed) == {"reaction_wheel_y"}, alarmed
    assert ONSET < alarmed["reaction_wheel_y"] <= ONSET + 60.0, alarmed
    kinds = {h[5].get("fault_kind") for h in heard if h[1] == "rw_fdi: identification wheel y"}
    assert kinds & {"current_limiter", "current_loss"}, kinds   # what it is, from the speed alone
    return alarmed


def test_the_fdi_launch_file_attaches_to_remapped_streams_in_a_namespace(colcon_workspace, tmp_path):
    """`ros2 launch rw_fdi_ros fdi.launch.py` of the installed file (the real launch and launch_ros): no plant, the
    driver's streams on topics of its own, the FDI under namespace sc1; the launch ends by itself (exit 0) with the
    run the driver says done."""
    from test_launch_file import Launch
    launch = Launch(colcon_workspace, tmp_path, "joint_names:=rw1,rw2,rw3,rw4", "wheels_topic:=/acs/rw/state",
                    "command_topic:=/acs/rw/cmd", "namespace:=sc1", launch_file="fdi.launch.py")
    out = tmp_path / "heard.json"
    driver = subprocess.Popen([sys.executable, str(DRIVER), str(out), "--duration", "300", "--onset", str(ONSET),
                               "--namespace", "sc1", "--speed-topic", "/acs/rw/state", "--command-topic",
                               "/acs/rw/cmd"], env=launch.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              start_new_session=True)
    try:
        log = driver.communicate(timeout=600)[0].decode()
        assert driver.returncode == 0, log[-2000:] + launch.output()[-3000:]
        code, output = launch.run(timeout=120)
        assert code == 0, output[-3000:]
    finally:
        stop_processes([driver])
        launch.close()
    check_verdicts(json.loads(out.read_text())["heard"])


BAD_STREAM = """
import sys, time, rclpy
from sensor_msgs.msg import JointState
from rw_fdi_ros.graph import topics as T
rclpy.init()
node = rclpy.create_node("bad_wheels")
pub = node.create_publisher(JointState, "/wheels", T.RELIABLE)
deadline = time.monotonic() + 60
while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
    rclpy.spin_once(node, timeout_sec=0.1)
stamped = int(sys.argv[2])
for k in range(1, 51):   # stamped: positions only; unstamped: speeds, every stamp 0
    msg = JointState(name=sys.argv[1].split(","), position=[0.0] * 4, velocity=[] if stamped else [1.0] * 4)
    msg.header.stamp.sec = k * stamped
    pub.publish(msg)
    time.sleep(0.1)
"""


@pytest.mark.parametrize("stamped, message", [
    (1, "/wheels: 0 velocity values for 4 joints"),
    (0, "/wheels: 10 messages whose header stamps do not advance (at 0 s; unstamped?)"),
])
def test_a_stream_without_wheel_speeds_or_stamps_stops_the_node_with_one_line(stamped, message):
    """A JointState on /wheels with positions only, or without a stamp: the node says so in one line, exit 2."""
    joints = "rw1,rw2,rw3,rw4"
    with DomainLease() as lease:
        procs = GraphProcesses(attach_nodes(joint_names=tuple(joints.split(",")))[:1], lease.domain_id,
                               Path(tempfile.mkdtemp(prefix="rw_fdi_test_")))
        procs.start()
        source = subprocess.Popen([sys.executable, "-c", BAD_STREAM, joints, str(stamped)], env=procs.env,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            code = procs.procs["wheel_telemetry"].wait(timeout=90)
            assert code == 2, procs.reason_of("wheel_telemetry")
            assert message in procs.reason_of("wheel_telemetry")
        finally:
            stop_processes([source])
            procs.stop_all()
