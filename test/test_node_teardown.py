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

from rw_fdi_ros.launch.launcher import TEARDOWN_HUNG

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
