"""The wheel allocation node's own logic, in process: the operator's parameter, the wait for the verdict,
never a command to a wheel given up. (The live graph: test_fdir_graph.py.)"""
import os

import numpy as np
import pytest

from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.storage.cdr import joint_state_cdr, vector_cdr

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


@pytest.fixture()
def node(monkeypatch):
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
    import rclpy
    from rw_fdi_ros.nodes.wheel_allocation import WheelAllocationNode
    rclpy.init()
    n = WheelAllocationNode()
    sent = []
    n.pub.publish = sent.append        # what would go to the plant, as CDR bytes
    n.pub_fdir.publish = lambda msg: sent.append(msg)
    n.diagnostics = []
    n.pub_diag.publish = n.diagnostics.append   # FDIR's state on /diagnostics
    n.sent = sent
    yield n
    n.destroy_node()
    rclpy.try_shutdown()


def _step(node, k, axis=(1.0, -2.0, 0.5)):
    stamp = k * 100_000_000
    node._on_wheels(joint_state_cdr(stamp, node.joints, [0.0] * 4, [20.0, 19.0, 17.0, 0.0], [0.0] * 4))
    node._on_attitude(joint_state_cdr(stamp, ("attitude_x", "attitude_y", "attitude_z"), [0.0] * 3, [0.0] * 3))
    for i in range(3):
        node._on_axis(i, vector_cdr(stamp, [axis[i] if j == i else 0.0 for j in range(3)]))


def _commands(node):
    from rw_fdi_ros.storage.cdr import read_joint_state_cdr
    return [read_joint_state_cdr(m)[3] for m in node.sent if isinstance(m, bytes)]


def test_the_operator_takes_a_wheel_out_and_it_is_never_commanded_again(node):
    from rclpy.parameter import Parameter
    node.set_parameters([Parameter("fdir", value=False)])   # no FDI here: no verdict to wait for
    node._verdict_needed = lambda stamp: -1
    _step(node, 0)
    assert np.array_equal(_commands(node)[-1], [1.0, -2.0, 0.5, 0.0])   # three axis wheels: the identity
    result = node.set_parameters([Parameter("out_of_use", value=["reaction_wheel_x"])])[0]
    assert result.successful
    _step(node, 1)
    u = _commands(node)[-1]
    assert u[0] == 0.0 and u[3] != 0.0
    np.testing.assert_allclose(node.wheels.matrix @ u, [1.0, -2.0, 0.5], atol=1e-12)   # the same body torque
    refused = node.set_parameters([Parameter("out_of_use", Parameter.Type.STRING_ARRAY, [])])[0]
    assert not refused.successful and "stays out of use" in refused.reason
    bad = node.set_parameters([Parameter("out_of_use", value=["reaction_wheel_q"])])[0]
    assert not bad.successful and "reaction_wheel_s" in bad.reason
    for k in range(2, 6):
        _step(node, k)
    assert all(u[0] == 0.0 for u in _commands(node)[1:])
    fdir = [m for m in node.sent if not isinstance(m, bytes)][-1]
    states = {s.hardware_id: {kv.key: kv.value for kv in s.values}["state"] for s in fdir.status}
    assert states == {"reaction_wheel_x": "given_up", "reaction_wheel_y": "in_use", "reaction_wheel_z": "in_use",
                      "reaction_wheel_s": "in_use"}


def test_a_command_waits_for_the_verdict_it_depends_on(node):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    # the first FDI sample is at 1 s (at 0 no command is in force yet): before 2 s no verdict is due
    for k in range(20):
        _step(node, k)
    assert len(_commands(node)) == 20
    _step(node, 20)       # t = 2 s depends on the verdict of t = 1 s
    assert len(_commands(node)) == 20
    msg = DiagnosticArray()
    msg.header.stamp.sec = 1
    msg.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR if j == "reaction_wheel_y" else DiagnosticStatus.OK,
                                   name=f"{T.VERDICT_STATUS} {j[-1]}", hardware_id=j,
                                   values=[KeyValue(key="first_alarm", value="1")])
                  for j in node.joints]
    node._on_diagnostics(msg)   # stamped 1 s: y confirmed faulty, applied from t = 2 s
    u = _commands(node)[-1]
    # s could not take y's momentum and slew from these speeds; y, reported giving no torque, is held
    assert len(_commands(node)) == 21 and u[3] != 0.0 and node.reconfiguration.held == {"y": 19.0}


def test_fdirs_state_goes_to_diagnostics_each_fdi_period_and_is_not_read_back_as_a_verdict(node):
    """/diagnostics carries FDIR's state once per FDI period; the node reads that topic for the verdict, so
    its own statuses come back to it: a wheel it holds or gives up (ERROR there) is no confirmed fault."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    for k in range(10):
        _step(node, k)
    assert len(node.diagnostics) == 1 and node.diagnostics[0].header.stamp.sec == 0   # t = 0 s only
    assert [s.name for s in node.diagnostics[0].status] == [f"{T.FDIR_STATUS} {w}" for w in ("x", "y", "z", "s")]
    echo = DiagnosticArray()
    echo.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR, name=f"{T.FDIR_STATUS} y",
                                    hardware_id="reaction_wheel_y")]
    node._on_diagnostics(echo)
    assert node.verdict_ns == -1 and not node.delay.pending   # not a verdict: nothing decided, nothing waited on
    for k in range(10, 21):
        _step(node, k)
    assert len(_commands(node)) == 20   # t = 2 s still waits for the verdict of t = 1 s


def test_without_verdicts_it_goes_blind_once_and_stays_blind_until_one_comes(node):
    import time
    from rclpy.parameter import Parameter
    node.set_parameters([Parameter("verdict_timeout", value=0.01)])
    for k in range(21):
        _step(node, k)
    assert len(_commands(node)) == 20        # t = 2 s waits for the verdict of t = 1 s (the first FDI sample)
    time.sleep(0.05)
    node._try_command()                       # the timeout passed: said, and commanded without it
    assert len(_commands(node)) == 21 and node.blind_said
    for k in range(21, 41):                   # no new verdict: every later step goes out at once
        _step(node, k)
    assert len(_commands(node)) == 41


def test_an_operator_overrules_a_wheel_fdir_held():
    from rw_fdi_ros.core.fdir import Reconfiguration
    from rw_fdi_ros.core.physics.wheel_set import WHEEL_SETS
    r = Reconfiguration(WHEEL_SETS["orthogonal_skew"])
    speeds = [27.5, 25.0, 24.0, 0.0]
    assert [d.action for d in r.give_up("z", 4.0, "confirmed", speeds)] == ["kept_in_use", "in_use"]
    assert [d.action for d in r.give_up("x", 5.0, "confirmed", speeds)] == ["held"]   # no spare left
    assert r.give_up("x", 6.0, "confirmed", speeds) == []                 # FDIR does not ask again
    forced = r.give_up("x", 7.0, "operator command", speeds, force=True)
    assert [d.action for d in forced] == ["out_of_use"] and r.ordered_in_use() == ("y", "z", "s")
    assert not r.held and r.given_up == ["x"]


def test_a_held_wheel_gets_the_speed_hold_command_from_its_own_speed(node):
    """z confirmed first (kept beside s: no spare left), then x at 20 rad/s, more than y, z and s could take:
    held at 20 rad/s, out of control; its command each step is the hold law on that step's speed, the
    others the allocation's."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rw_fdi_ros.core.control.allocation import hold_command

    def verdict(faulty, stamp_s):
        msg = DiagnosticArray()
        msg.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR if j in faulty else DiagnosticStatus.OK,
                                       name=f"{T.VERDICT_STATUS} {j[-1]}", hardware_id=j,
                                       values=[KeyValue(key="first_alarm", value=str(stamp_s))])
                      for j in node.joints]
        msg.header.stamp.sec = stamp_s
        return msg
    for k in range(10):
        _step(node, k)
    node._on_diagnostics(verdict({"reaction_wheel_z"}, 0))
    for k in range(10, 20):
        _step(node, k)
    assert node.reconfiguration.kept == {"z"} and not node.reconfiguration.spares
    node._on_diagnostics(verdict({"reaction_wheel_z", "reaction_wheel_x"}, 1))
    _step(node, 20)
    assert node.reconfiguration.held == {"x": 20.0}
    u = _commands(node)[-1]
    assert u[0] == pytest.approx(float(hold_command(20.0, 20.0)))
    np.testing.assert_allclose(node.wheels.matrix[:, 1:] @ u[1:], [1.0, -2.0, 0.5], atol=1e-12)
    fdir_msg = [m for m in node.sent if not isinstance(m, bytes)][-1]
    states = {s.hardware_id: {kv.key: kv.value for kv in s.values}["state"] for s in fdir_msg.status}
    assert states["reaction_wheel_x"] == "held" and states["reaction_wheel_s"] == "in_use"
