"""The live view: the graph's messages reach a Foxglove client over the WebSocket, as JSON with their schema.

In process: the live view node and a publisher in one private domain, and a client speaking Foxglove's
WebSocket protocol (foxglove.sdk.v1 or foxglove.websocket.v1: advertise, subscribe, binary message data)
that must receive what was published, stamp and values."""
import json
import os
import struct
import time

import pytest

from rw_fdi_ros.graph import topics as T

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


@pytest.fixture()
def live(monkeypatch):
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(100 + (os.getpid() + 37) % 100))
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rw_fdi_ros.nodes.live_view import LiveViewNode
    rclpy.init(args=["--ros-args", "-p", "port:=0", "-p", "fdi:=false"])
    node, source = LiveViewNode(), rclpy.create_node("live_view_test_source")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(source)
    yield node, source, executor
    node.close()
    executor.shutdown()
    node.destroy_node()
    source.destroy_node()
    rclpy.try_shutdown()


def _receive(ws, until, timeout=10.0):
    """Messages from the server until ``until(message)`` says done (text as JSON, binary as bytes)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        raw = ws.recv(timeout=max(end - time.monotonic(), 0.01))
        msg = json.loads(raw) if isinstance(raw, str) else raw
        if until(msg):
            return msg
    raise AssertionError("the live view sent nothing of the kind in time")


@pytest.mark.parametrize("subprotocol", ["foxglove.sdk.v1", "foxglove.websocket.v1"])
def test_a_client_receives_the_attitude_and_fdirs_state_as_they_are_published(live, subprotocol):
    """Under either name of the protocol: foxglove.websocket.v1 is what older Foxglove and Lichtblick offer."""
    from websockets.sync.client import connect
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from sensor_msgs.msg import JointState
    node, source, executor = live
    assert node.port > 0
    with connect(f"ws://127.0.0.1:{node.port}", subprotocols=[subprotocol]) as ws:
        assert ws.subprotocol == subprotocol
        advertised = {}

        def advertise(msg):
            if isinstance(msg, dict) and msg.get("op") == "advertise":
                advertised.update({c["topic"]: c for c in msg["channels"]})
            return {T.ATTITUDE, T.FDIR_WHEELS} <= set(advertised)
        _receive(ws, advertise)
        assert T.CLOCK in advertised and T.DIAGNOSTICS not in advertised   # no FDI in this graph
        schema = json.loads(advertised[T.ATTITUDE]["schema"])
        assert advertised[T.ATTITUDE]["encoding"] == "json"
        assert {"header", "name", "position", "velocity", "effort"} <= set(schema["properties"])
        ids = {1: T.ATTITUDE, 2: T.FDIR_WHEELS}
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": advertised[topic]["id"]} for i, topic in ids.items()]}))
        time.sleep(0.3)   # the subscription reaches the server before the messages

        attitude = JointState(name=list(T.ATTITUDE_JOINTS), position=[1e-3, -2e-3, float("nan")],
                              velocity=[0.0, 0.5, 0.25])
        attitude.header.stamp.sec, attitude.header.stamp.nanosec = 12, 300_000_000
        states = DiagnosticArray()
        states.header.stamp.sec = 13
        states.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR, name=f"{T.FDIR_STATUS} y",
                                          hardware_id="reaction_wheel_y", message="given up")]
        pubs = [source.create_publisher(JointState, T.ATTITUDE, T.RELIABLE),
                source.create_publisher(DiagnosticArray, T.FDIR_WHEELS, T.RELIABLE)]
        end = time.monotonic() + 10.0
        while min(p.get_subscription_count() for p in pubs) < 1 and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        pubs[0].publish(attitude)
        pubs[1].publish(states)
        got = {}
        end = time.monotonic() + 10.0
        while len(got) < 2 and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
            try:
                raw = ws.recv(timeout=0.05)
            except TimeoutError:
                continue
            if isinstance(raw, bytes) and raw[0] == 1:   # message data: op, subscription id, log time, payload
                sub, log_time = struct.unpack_from("<IQ", raw, 1)
                got[ids[sub]] = (log_time, json.loads(raw[13:]))
    assert set(got) == {T.ATTITUDE, T.FDIR_WHEELS}, got
    log_time, msg = got[T.ATTITUDE]
    assert log_time == 12_300_000_000 and msg["header"]["stamp"] == {"sec": 12, "nanosec": 300_000_000}
    assert msg["name"] == list(T.ATTITUDE_JOINTS) and msg["position"] == [1e-3, -2e-3, None]   # NaN: null
    assert msg["velocity"] == [0.0, 0.5, 0.25]
    log_time, msg = got[T.FDIR_WHEELS]
    assert log_time == 13_000_000_000
    assert msg["status"] == [{"level": 2, "name": f"{T.FDIR_STATUS} y", "message": "given up",
                              "hardware_id": "reaction_wheel_y", "values": []}]


def test_a_taken_port_is_one_line_not_a_traceback(live):
    from rclpy.parameter import Parameter
    from rw_fdi_ros.graph.runtime import NodeError
    from rw_fdi_ros.nodes.live_view import LiveViewNode
    node, _, _ = live
    with pytest.raises(NodeError, match=f"no WebSocket server on 127.0.0.1:{node.port}: "):
        LiveViewNode("live_view_again", parameter_overrides=[Parameter("port", value=node.port)])


def test_a_whole_run_with_a_live_view_reaches_a_client_and_records_its_bag(tmp_path):
    """`rw-fdi run --live`'s graph: the live view in a process of its own; a client connected while the run
    goes receives the attitude as the plant steps it, and the run and its bag are as without the view."""
    import socket
    import threading
    from websockets.sync.client import connect
    from rw_fdi_ros.runner.scenario_run import run_scenario
    with socket.socket() as s:   # a free port now (the server binds it a moment later)
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    outcome = {}
    runner = threading.Thread(target=lambda: outcome.update(run=run_scenario(
        "fault_free", seed=5, out_dir=tmp_path, live=port)))
    runner.start()
    stamps = []
    try:
        end = time.monotonic() + 60.0
        while time.monotonic() < end and not stamps:
            try:
                ws = connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], open_timeout=1.0)
            except OSError:
                time.sleep(0.1)
                continue
            with ws:
                channel = _receive(ws, lambda m: isinstance(m, dict) and m.get("op") == "advertise" and any(
                    c["topic"] == T.ATTITUDE for c in m["channels"]))
                attitude = next(c["id"] for c in channel["channels"] if c["topic"] == T.ATTITUDE)
                ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": attitude}]}))
                try:
                    while len(stamps) < 20:
                        raw = ws.recv(timeout=10.0)
                        if isinstance(raw, bytes) and raw[0] == 1 and struct.unpack_from("<I", raw, 1)[0] == 7:
                            msg = json.loads(raw[13:])
                            stamps.append(struct.unpack_from("<Q", raw, 5)[0])
                            assert msg["name"] == list(T.ATTITUDE_JOINTS) and len(msg["position"]) == 3
                except TimeoutError:
                    pass
    finally:
        runner.join(timeout=180)
    run = outcome["run"]
    assert run.ok, run.reason
    assert len(stamps) >= 5 and stamps == sorted(stamps) and stamps[-1] > stamps[0], stamps[:5]
    assert run.bag.exists() and run.summary["end_time"] > 0
