"""The verdict users read (/diagnostics): the decision observer's alarm, latched (core/fdi/verdict.py)."""
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from rw_fdi_ros.core.fdi.verdict import LatchedVerdict, decision_observer
from rw_fdi_ros.runner.launcher import DomainLease
from rw_fdi_ros.core.fdi.verdict import decision_of

from conftest import verdict_of_flags


pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


def rows(alarms, first):
    return {a: (0.1, 1.0, alarm, t) for a, alarm, t in zip("xyz", alarms, first)}


def test_a_confirmed_failure_stays_until_reset_and_the_thesis_behaviour_does_not_latch():
    v = LatchedVerdict()
    assert v.update(rows([False, False, False], [None] * 3))["x"][2:] == (False, None)
    assert v.update(rows([True, False, False], [12.0, None, None]))["x"][2:] == (True, 12.0)
    after = v.update(rows([False, False, False], [12.0, None, None]))   # residual back under: still faulty
    assert after["x"][2:] == (True, 12.0) and v.latched["x"] and not v.latched["y"]
    assert after["y"][2:] == (False, None)
    v.reset()
    assert v.update(rows([False, False, False], [None] * 3))["x"][2:] == (False, None)
    plain = LatchedVerdict(latch=False)
    plain.update(rows([True, False, False], [12.0, None, None]))
    assert plain.update(rows([False, False, False], [12.0, None, None]))["x"][2] is False


def test_the_offline_verdict_is_the_decision_observers_alarm_latched():
    alarm = np.zeros((6, 3), bool)
    alarm[2:4, 1] = True          # y alarms at 2 s, drops at 4 s
    flags = {"model": alarm, "elman": np.ones((6, 3), bool)}
    v = verdict_of_flags(flags, decision_of("", "speed_aware"))
    assert v[:, 1].tolist() == [False, False, True, True, True, True]
    assert not v[:, 0].any() and not v[:, 2].any()   # the Elman network does not decide
    assert verdict_of_flags(flags, decision_of("", "thesis")).all()
    assert decision_observer("speed_aware") == "model" and decision_observer("thesis") == "elman"
    with pytest.raises(ValueError, match="fdi_method must be one of"):
        decision_observer("vote")


CALL_RESET = """
import sys, rclpy
from rclpy.node import Node
from std_srvs.srv import Trigger

rclpy.init()
node = Node("operator")
client = node.create_client(Trigger, "/isolation/reset")
assert client.wait_for_service(timeout_sec=30), "no /isolation/reset service"
future = client.call_async(Trigger.Request())
rclpy.spin_until_future_complete(node, future, timeout_sec=30)
print(future.result().success, future.result().message)
"""


def test_an_operator_resets_the_verdict_through_a_ros_2_service():
    """The isolation node offers ~/reset (std_srvs/Trigger), the conventional FDIR reset command."""
    with DomainLease() as lease:
        env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        node = subprocess.Popen([sys.executable, "-m", "rw_fdi_ros.nodes.isolation", "--ros-args", "-p",
                                 "input_timeout:=1000.0"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        try:
            time.sleep(1.0)
            call = subprocess.run([sys.executable, "-c", CALL_RESET], env=env, capture_output=True, text=True,
                                  timeout=90)
        finally:
            node.terminate()
            try:
                node.wait(timeout=10)
            except subprocess.TimeoutExpired:
                node.kill()
                node.wait()
    assert call.returncode == 0, call.stderr[-2000:]
    assert call.stdout.strip().splitlines()[-1] == "True no confirmed failure to clear"


def test_a_wheel_outside_the_operating_envelope_is_not_judged_but_a_confirmed_failure_stays():
    from rw_fdi_ros.core.fdi.verdict import WHEEL_SPEED_ENVELOPE, in_envelope
    assert in_envelope([0.0, -WHEEL_SPEED_ENVELOPE, 30.0]).all() and not in_envelope([60.0, 0, 0])[0]
    alarm = np.zeros((6, 3), bool)
    alarm[1:, 0] = True           # x alarms from 1 s: outside the envelope until 3 s, so confirmed at 3 s
    alarm[4:, 1] = True           # y alarms at 4 s while outside the envelope: never confirmed
    speed = np.full((6, 3), 25.0)
    speed[:3, 0] = 60.0
    speed[3:, 1] = 60.0
    v = verdict_of_flags({"model": alarm}, decision_of("", "speed_aware"), speed)
    assert v[:, 0].tolist() == [False, False, False, True, True, True]
    assert not v[:, 1].any()
    held = LatchedVerdict()
    held.update(rows([True, False, False], [1.0, None, None]))
    out = held.update(rows([False, False, False], [1.0, None, None]), {"x": False, "y": True, "z": True})
    assert out["x"][2:] == (True, 1.0)   # confirmed before it left the envelope: still faulty
