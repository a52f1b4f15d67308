"""live_view: the run as it happens, in Foxglove (opt-in: ``rw-fdi run --live``, ``ros2 launch ... live:=8765``).

It subscribes to what the bag of the run would hold (graph/topics.py ``live_rows``) and
logs each message to a Foxglove WebSocket server (foxglove-sdk) on ``ws://host:port`` (subprotocol
``foxglove.sdk.v1`` or its older name ``foxglove.websocket.v1``, graph/ws_relay.py), one channel per
topic, same name, the message's fields as JSON with its schema (graph/live.py), at the message's sim-time
stamp (/scenario at 0, as the bag has it). In Foxglove, "Open connection" to that address, and the shipped
layout (config/foxglove/rw_fdi.json) plots the residuals against their thresholds, the alarms and the
verdict as they come, as it does for a recorded bag. It is a reader like the recorder (the publishers wait
for its subscriptions at the start) but answers nothing, so the lockstep never waits on it; it converts a
message only while a client is subscribed to its channel, and a message it cannot convert is said once and
skipped, never the run's end. It stays 2 s after the run's end, so a client gets the last FDI period.
"""
from __future__ import annotations

from ..core.physics.wheel_set import DEFAULT_WHEEL_SET, WHEEL_SETS
from ..extras import require
from ..graph import topics as T
from ..graph.convert import stamp_ns
from ..graph.live import json_schema, to_json
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for, wall_time
from ..graph.ws_relay import SUBPROTOCOLS, SubprotocolRelay

END_GRACE = 2.0   # [wall s] it serves after /plant/done: a client gets the run's last FDI period


class LiveViewNode(GraphNode):
    node_name = "live_view"

    def __init__(self, name: str | None = None, **kwargs):
        super().__init__(name, **kwargs)
        self.declare_parameter("host", "127.0.0.1")       # the WebSocket server's address (0.0.0.0: any)
        self.declare_parameter("port", 8765)              # its port (0: any free one, logged)
        self.declare_parameter("wheel_set", DEFAULT_WHEEL_SET)
        self.declare_parameter("fdi", True)               # the FDI's topics too
        self.declare_parameter("fdi_method", "speed_aware")
        self.declare_parameter("orbit", False)            # the magnetometer
        self.declare_parameter("magnetorquers", False)    # the rods' command
        if self.param("wheel_set") not in WHEEL_SETS:
            raise NodeError(f"parameter wheel_set must be one of {', '.join(WHEEL_SETS)}, "
                            f"got {self.param('wheel_set')!r}", EXIT_BAD_INPUT)
        try:
            foxglove = require("foxglove", "live")
            require("websockets", "live")   # graph/ws_relay.py
        except RuntimeError as exc:
            raise NodeError(f"the live view: {exc}", EXIT_BAD_INPUT) from None
        self.foxglove = foxglove.Context()   # its own: composed live views do not share channels
        # the SDK's server on a private port behind a relay that also speaks the protocol's older name
        self.server = foxglove.start_server(name="rw_fdi_ros", host="127.0.0.1", port=0, context=self.foxglove)
        try:
            self.relay = SubprotocolRelay(self.param("host"), self.param("port"), self.server.port)
        except Exception as exc:   # the port taken, an address not ours: one line, not a traceback
            self.server.stop()
            raise NodeError(f"live view: no WebSocket server on {self.param('host')}:{self.param('port')}: {exc}",
                            EXIT_BAD_INPUT) from None
        self.port = self.relay.port
        self.channels = {}
        params = {k: self.param(k) for k in ("wheel_set", "fdi", "fdi_method", "orbit", "magnetorquers")}
        for topic, type_name, qos in T.live_rows(params):
            cls = T.message_class(type_name)
            self.channels[topic] = foxglove.Channel(topic, schema=json_schema(cls, type_name), message_encoding="json",
                                                    context=self.foxglove)
            self.create_subscription(cls, topic, lambda msg, topic=topic: self._on_message(topic, msg),
                                     getattr(T, qos))
        self.get_logger().info(f"live view: ws://{self.param('host')}:{self.port} ({len(self.channels)} channels, "
                               f"subprotocol {' or '.join(SUBPROTOCOLS)}; Foxglove: Open connection)")
        self.sim_time = 0
        self.done_wall = None   # wall time /plant/done came (the live view's own end: END_GRACE later)
        self.said = set()       # topics whose messages it could not show (said once)
        self.declare_parameter("end_with_run", True)   # false: keep serving after the run (a replay of many)

    def _on_message(self, topic: str, msg):
        # a header's stamp; /plant/done is a Header, /clock a Clock; /scenario (a String) describes the run from
        # its start, as in the bag; any other message without one: the latest sim time seen
        stamped = msg.header if hasattr(msg, "header") else msg
        time = getattr(stamped, "stamp", getattr(stamped, "clock", None))
        stamp = stamp_ns(time) if time is not None else (0 if topic == T.SCENARIO else self.sim_time)
        self.sim_time = max(self.sim_time, stamp)
        if topic == T.PLANT_DONE and self.param("end_with_run"):
            self.done_wall = wall_time()
        channel = self.channels[topic]
        if not channel.has_sinks():   # no client on it: nothing to convert
            return
        try:
            channel.log(to_json(msg), log_time=stamp)
        except Exception as exc:  # noqa: BLE001 -- a view's trouble is said, never the run's end
            if topic not in self.said:
                self.said.add(topic)
                self.get_logger().warning(f"live view: {topic} not shown ({type(exc).__name__}: {exc})")

    def poll(self):
        if self.done_wall is not None and wall_time() - self.done_wall > END_GRACE:
            self.finish()

    def close(self):
        try:
            self.relay.stop()
        finally:
            self.server.stop()
        super().close()


main = main_for(LiveViewNode)

if __name__ == "__main__":
    main()
