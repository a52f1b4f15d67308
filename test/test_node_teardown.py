"""A node's end: the work first, then a watched teardown (graph/runtime.py).

A DDS teardown that never returns (the one-in-twelve "recorder did not finish" of issue 25 left a
complete bag and empty logs) ends the process by SIGALRM after TEARDOWN_TIMEOUT, with every thread's
stack in its log; the launcher reads that exit as done, with a note. A node interrupted while it is
still importing ends quietly (graph/entry.py), as `ros2 launch` shutting down makes them.
"""
import os
import signal
import subprocess
import sys
import time

import pytest

from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.runner.launcher import TEARDOWN_HUNG

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


TEARDOWN_TIMEOUT = 3   # the test's own (RW_FDI_TEARDOWN_TIMEOUT), not the nodes' 10 s

HANGING_TEARDOWN = """
import sys, time, rclpy
from rw_fdi_ros.graph import runtime
class Node:
    def destroy_node(self):
        print("destroying", flush=True)
        time.sleep(3600)
rclpy.init(args=[])
runtime._tear_down([Node()], {"recorder": (0, "")})
print("never here", flush=True)
"""


def test_a_teardown_that_never_returns_ends_by_its_watchdog_with_the_stack_in_the_log():
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-c", HANGING_TEARDOWN], capture_output=True, text=True,
                          timeout=TEARDOWN_TIMEOUT + 60,
                          env=dict(os.environ, RW_FDI_TEARDOWN_TIMEOUT=str(TEARDOWN_TIMEOUT)))
    took = time.monotonic() - t0
    assert done.returncode == TEARDOWN_HUNG == -signal.SIGALRM, (done.returncode, done.stderr[-2000:])
    assert "destroying" in done.stdout and "never here" not in done.stdout
    assert "destroy_node" in done.stderr and "Timeout" in done.stderr, done.stderr[-2000:]   # faulthandler's dump
    assert TEARDOWN_TIMEOUT - 1 <= took < TEARDOWN_TIMEOUT + 30, took


SLOW_IMPORT = """
import time
from rw_fdi_ros.graph import entry

def slow_import(name):   # a node module still importing its numerics
    print("importing", name, flush=True)
    time.sleep(60)
entry.importlib.import_module = slow_import
entry.linear_observer()
"""


def test_a_node_interrupted_while_importing_ends_quietly():
    proc = subprocess.Popen([sys.executable, "-c", SLOW_IMPORT], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline().strip() == "importing rw_fdi_ros.nodes.linear_observer"
        proc.send_signal(signal.SIGINT)   # a launch shutting down while the node starts
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 128 + signal.SIGINT, (proc.returncode, err[-2000:])
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-2000:]


DONE_WRITER_LEAVES = """
import time, rclpy
from std_msgs.msg import Header
from rw_fdi_ros.graph import runtime, topics as T
rclpy.init(args=[])
follower = runtime.GraphNode("follower")
follower.follow_run_end(grace=1.0)
plant = rclpy.create_node("plant")
done = plant.create_publisher(Header, T.PLANT_DONE, T.LATCHED)
executor = rclpy.executors.SingleThreadedExecutor()
executor.add_node(follower)
executor.add_node(plant)
t0 = time.monotonic()
while time.monotonic() - t0 < 4.0:   # the plant is there, and says nothing: the run goes on
    executor.spin_once(timeout_sec=0.05)
    assert not follower.run_ended(), "ended while the plant was there"
plant.destroy_publisher(done)        # it leaves, its done lost
t1 = time.monotonic()
while not follower.run_ended() and time.monotonic() - t1 < 30.0:
    executor.spin_once(timeout_sec=0.05)
print("ended after", round(time.monotonic() - t1, 2) if follower.run_ended() else None, flush=True)
"""


def test_a_node_whose_done_never_comes_ends_once_the_plant_has_left():
    """The launch test's pid_controller that never exited: the plant's /plant/done lost on a loaded machine
    (its writer gone before this reader acknowledged it) must not keep a node, and `ros2 launch`, waiting."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(150 + os.getpid() % 60))
    done = subprocess.run([sys.executable, "-c", DONE_WRITER_LEAVES], capture_output=True, text=True, timeout=90,
                          env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    ended = done.stdout.split("ended after", 1)[1].strip()
    assert ended != "None", done.stderr[-2000:]
    assert 1.0 <= float(ended) < 5.0, ended   # its grace after the writer left, looked at once a second
    assert f"the writers of {T.PLANT_DONE[1:]} left without this node hearing {T.PLANT_DONE}" in done.stderr


INPUT_WRITER_LEAVES = DONE_WRITER_LEAVES.replace(
    "follower.follow_run_end(grace=1.0)", "follower.follow_run_end(grace=1.0, inputs=(T.FDI_TELEMETRY,))").replace(
    "done = plant.create_publisher(Header, T.PLANT_DONE, T.LATCHED)",
    "from sensor_msgs.msg import JointState\ndone = plant.create_publisher(JointState, T.FDI_TELEMETRY, T.RELIABLE)")


def test_an_fdi_node_that_never_discovered_the_plant_ends_once_its_input_has_left():
    """The launch test whose linear, model and isolation nodes never exited with a complete bag and silent
    logs: they heard the run from wheel_telemetry but never discovered the plant, so neither its done nor
    its leaving reached them. The writer of their input leaving ends the run for them too."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(150 + os.getpid() % 60))
    done = subprocess.run([sys.executable, "-c", INPUT_WRITER_LEAVES], capture_output=True, text=True, timeout=90,
                          env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    ended = done.stdout.split("ended after", 1)[1].strip()
    assert ended != "None", done.stderr[-2000:]
    assert 1.0 <= float(ended) < 5.0, ended
    assert f"the writers of {T.PLANT_DONE[1:]}, {T.FDI_TELEMETRY[1:]} left without" in done.stderr


LAGGING_FOLLOWER = """
import time, rclpy
from std_msgs.msg import Header
from rw_fdi_ros.graph import runtime, topics as T
from rw_fdi_ros.graph.convert import time_msg
rclpy.init(args=[])
follower = runtime.GraphNode("follower")
follower.follow_run_end(grace=1.0, period=1.0)
plant = rclpy.create_node("plant")
done = plant.create_publisher(Header, T.PLANT_DONE, T.LATCHED)
done.publish(Header(stamp=time_msg(10_000_000_000)))   # the run ends at 10 s; the follower is at 0 s
executor = rclpy.executors.SingleThreadedExecutor()
executor.add_node(follower)
executor.add_node(plant)
t0 = time.monotonic()
while follower._run_end is None and time.monotonic() - t0 < 20.0:
    executor.spin_once(timeout_sec=0.05)
ended_at = None
for k in range(8):   # a loaded follower: a stamp every 0.6 s, 4.8 s in all, past its 1 s of grace
    t1 = time.monotonic()
    while time.monotonic() - t1 < 0.6:
        executor.spin_once(timeout_sec=0.05)
        if ended_at is None and follower.run_ended():
            ended_at = follower.last_handled
    follower.last_handled = k * 1_000_000_000
print("cut off at", ended_at, flush=True)
t2 = time.monotonic()   # stuck at 7 s: nothing more comes, the grace ends it
while not follower.run_ended() and time.monotonic() - t2 < 30.0:
    executor.spin_once(timeout_sec=0.05)
print("ended after", round(time.monotonic() - t2, 2) if follower.run_ended() else None, flush=True)
"""


def test_a_node_working_through_its_queue_is_not_cut_off_at_the_run_end():
    """An FDI process behind the plant on a loaded machine (the identification's samples queued) ends once its
    last stamp is handled, not a fixed grace after /plant/done; a node making no progress still ends."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(150 + (os.getpid() + 7) % 60))
    done = subprocess.run([sys.executable, "-c", LAGGING_FOLLOWER], capture_output=True, text=True, timeout=90,
                          env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "cut off at None" in done.stdout, done.stdout
    ended = done.stdout.split("ended after", 1)[1].strip()
    assert ended != "None", done.stderr[-2000:]
    assert 0.9 <= float(ended) < 3.0, ended
