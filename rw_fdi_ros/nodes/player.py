"""player: replays recorded bags' topics (rosbag replay for evaluation), one bag after another.

Raw CDR bytes go out as they were recorded, in log-time (= sim-time) order.
Two modes:
- ``rate`` > 0: paced by the wall clock, ``rate`` sim seconds per wall second;
- ``rate`` = 0: as fast as the consumers keep up without dropping a message:
  the player runs at most ``pace_window`` FDI samples ahead of what
  ``pace_topic`` (the isolation node's /diagnostics) reports done; well
  inside the 1000-deep reliable queues, so nothing is overwritten unread.

Many bags, one graph: with ``bags`` the player replays them in order through
the same FDI nodes, which start a new run when the stamps go back to the
start. A bag's /plant/done goes out once the consumers have finished its
last FDI sample; with ``await_recorder`` the first bag starts once the
recorder has matched the FDI nodes' writers (/recorder/ready), and the next
only once it has closed the bag of the one before (/recorder/closed), so no
message of one run can land in another's bag.
"""
from __future__ import annotations

import time

from rclpy.parameter import Parameter
from std_msgs.msg import String

from ..storage.bag import BagError, BagInfo, iter_messages, iter_time_order
from ..graph import topics as T
from ..graph.convert import stamp_ns
from ..graph.runtime import EXIT_BAD_INPUT, EXIT_TIMEOUT, GraphNode, NodeError, ReadySignal, main_for

PLANT_OUTPUTS = [T.CLOCK, T.ATTITUDE, T.WHEELS, T.FAULT_EFFECT, T.FDI_BUS_GRID, T.FDI_TELEMETRY, T.FAULT_TRUTH,
                 T.SCENARIO, T.PLANT_DONE]


class PlayerNode(GraphNode):
    node_name = "player"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("bag", "")
        self.declare_parameter("bags", Parameter.Type.STRING_ARRAY)  # several bags, in order (else ``bag``)
        self.declare_parameter("topics", Parameter.Type.STRING_ARRAY)  # default: the plant's outputs
        self.declare_parameter("rate", 0.0)               # 0: paced by the consumers; else sim s per wall s
        self.declare_parameter("pace_topic", T.DIAGNOSTICS)
        self.declare_parameter("pace_period", 1.0)        # FDI period [s]
        self.declare_parameter("pace_window", 20)         # FDI samples the player may run ahead
        self.declare_parameter("min_subscribers", 0)      # readers of the FDI telemetry before starting
        self.declare_parameter("bus_grid_readers", 0)     # readers of its bus-voltage grid before starting
        self.declare_parameter("await_recorder", False)   # /recorder/ready first; between bags /recorder/closed
        self.declare_parameter("startup_timeout", 60.0)
        self.declare_parameter("stall_timeout", 10.0)     # wall s without consumer progress -> error
        self.bags = list(self.param("bags") or []) or [self.param("bag")]
        self.topics = self.param("topics") or PLANT_OUTPUTS
        self.rate = self.param("rate")
        self.period_ns = int(round(self.param("pace_period") * 1e9))
        qos = {name: q for name, _, q in T.graph_topics() + T.fdi_topics()}
        self.runs = []   # per bag: (path, stamp of its last FDI sample)
        self.pubs = {}
        for path in self.bags:   # all scanned up front: a bad bag fails before anything is replayed
            info, last_fdi_ns = BagInfo(path=path), -1
            try:   # a stream: the rows themselves are read again, in time order, when the bag's turn comes
                for topic, log_time, _ in iter_messages(path, self.topics, info):
                    if self._is_fdi_sample(topic, log_time):
                        last_fdi_ns = max(last_fdi_ns, log_time)
            except (BagError, OSError) as exc:
                raise NodeError(str(exc), EXIT_BAD_INPUT) from None
            if not info.complete:
                self.get_logger().warn(f"{path}: {info.note}; replaying what is there")
            if info.types.get(T.FDI_TELEMETRY, T.JOINT_STATE) != T.JOINT_STATE:
                raise NodeError(f"{path}: recorded with the text FDI telemetry of an older rw_fdi_ros, which the "
                                "FDI nodes no longer read: evaluate it with --engine core", EXIT_BAD_INPUT)
            for t in info.counts:
                if t not in self.pubs:
                    self.pubs[t] = self.create_publisher(T.message_class(info.types[t]), t, qos.get(t, T.RELIABLE))
            self.runs.append((path, last_fdi_ns))
        self.window_ns = max(int(self.param("pace_window")) - 1, 0) * self.period_ns
        self.pace_sub = None
        if self.rate <= 0:
            from diagnostic_msgs.msg import DiagnosticArray
            self.pace_sub = self.create_subscription(DiagnosticArray, self.param("pace_topic"), self._on_pace,
                                                     T.RELIABLE)
        self.closed = set()
        # the recorder hears every FDI writer before the first bag goes out (nodes/recorder.py)
        self.recorder = ReadySignal(self, self.param("await_recorder"))
        if self.param("await_recorder"):
            self.create_subscription(String, T.RECORDER_CLOSED, lambda m: self.closed.add(m.data), T.LATCHED)
        self.started = None
        self.last_progress = time.monotonic()
        self.run_index = -1
        self._next_run()

    def _next_run(self):
        """Start the next bag: rows, pacing state, the stamp of its last FDI sample."""
        self.run_index += 1
        path, self.last_fdi_ns = self.runs[self.run_index] if self.run_index < len(self.runs) else ("", -1)
        order = {t: i for i, t in enumerate(PLANT_OUTPUTS)}
        self.rows = iter_time_order(path, self.topics, lambda t: order.get(t, 99)) if path else iter(())
        self.paced_until = -1          # consumers have finished every FDI sample up to this stamp
        self.waiting_for = None        # FDI stamp published, not yet reported done
        self.done_sent = False
        self._advance()                # the first row to publish

    def _advance(self):
        """The next row of the current bag (None at its end); a bag that breaks mid-replay fails naming it."""
        try:
            self.row = next(self.rows, None)
        except (BagError, OSError, ValueError) as exc:
            self.row = None
            self.fail(f"{self.bags[self.run_index]}: unreadable during the replay ({exc})", EXIT_BAD_INPUT)

    def _is_fdi_sample(self, topic, log_time) -> bool:
        return topic == T.FDI_TELEMETRY and log_time % self.period_ns == 0

    def _on_pace(self, msg):
        self.paced_until = max(self.paced_until, stamp_ns(msg.header.stamp))
        self.last_progress = time.monotonic()

    def _ready(self):
        if not self.recorder.seen:
            return False
        need = {T.FDI_TELEMETRY: self.param("min_subscribers"), T.FDI_BUS_GRID: self.param("bus_grid_readers")}
        inputs = all(self.pubs[t].get_subscription_count() >= k for t, k in need.items() if t in self.pubs)
        return inputs and (self.pace_sub is None or self.pace_sub.get_publisher_count() >= 1)

    def poll(self):
        now = time.monotonic()
        if self.started is None:
            if not self._ready():
                if now - self.last_progress > self.param("startup_timeout"):
                    self.fail("no consumers for the replayed topics" if self.recorder.seen else
                              f"the recorder never reported every FDI topic matched on {T.RECORDER_READY}",
                              EXIT_TIMEOUT)
                return
            self.started = now
            self.last_progress = now
        while self.run_index < len(self.runs):
            if not self._play(now):
                return
            if not self.done_sent:   # the recorder's wait is timed from the run's end, not its start
                self.done_sent = True
                self.last_progress = now
            if self.param("await_recorder") and str(self.run_index) not in self.closed:
                if now - self.last_progress > self.param("stall_timeout"):
                    self.fail(f"recorder did not close the replay of {self.bags[self.run_index]} within "
                              f"{self.param('stall_timeout'):g} s", EXIT_TIMEOUT)
                return
            self._next_run()
            self.started = now
            self.last_progress = now
        self.finish()

    def _play(self, now) -> bool:
        """Publish what is due of the current bag; True once all of it is out and consumed."""
        while self.row is not None:
            log_time, topic, raw = self.row
            if self.rate > 0:
                if now < self.started + log_time * 1e-9 / self.rate:
                    return False
            elif self.waiting_for is not None and log_time > self.waiting_for:
                if self.paced_until < self.waiting_for - self.window_ns:
                    return self._stalled(now, f"no {self.param('pace_topic')} for t={self.waiting_for * 1e-9:g} s")
                self.waiting_for = None
            if topic == T.PLANT_DONE and self.rate <= 0 and self.paced_until < self.last_fdi_ns:
                return self._stalled(now, "at the end of the bag")  # the end goes out once all is consumed
            self.pubs[topic].publish(raw)
            if self.rate <= 0 and self._is_fdi_sample(topic, log_time):
                self.waiting_for = log_time   # an FDI sample went out: let the consumers finish it
                self.last_progress = now
            self._advance()
        if self.rate <= 0 and self.paced_until < self.last_fdi_ns:
            return self._stalled(now, "at the end of the bag")
        return True

    def _stalled(self, now, what: str) -> bool:
        if now - self.last_progress > self.param("stall_timeout"):
            self.fail(f"consumers stalled {what} within {self.param('stall_timeout'):g} s "
                      f"({self.bags[self.run_index]})", EXIT_TIMEOUT)
        return False


main = main_for(PlayerNode)

if __name__ == "__main__":
    main()
