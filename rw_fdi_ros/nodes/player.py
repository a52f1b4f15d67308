"""player: replays a bag's recorded topics with its /clock (rosbag replay for evaluation).

Raw CDR bytes go out as they were recorded, in log-time (= sim-time) order.
Two modes:
- ``rate`` > 0: paced by the wall clock, ``rate`` sim seconds per wall second;
- ``rate`` = 0: as fast as the consumers keep up without dropping a message:
  the player runs at most ``pace_window`` FDI samples ahead of what
  ``pace_topic`` (the isolation node's /diagnostics) reports done; 20
  samples are 200 messages per topic, well inside the 1000-deep reliable
  queues, so nothing can be overwritten before it is read.
"""
from __future__ import annotations

import time

from rclpy.parameter import Parameter

from ..storage.bag import BagError, read_bag
from . import topics as T
from .convert import stamp_ns
from .runtime import EXIT_BAD_INPUT, EXIT_TIMEOUT, GraphNode, NodeError, main_for

PLANT_OUTPUTS = [T.CLOCK, T.ATTITUDE, T.BODY_RATE, T.WHEEL_SPEED, T.TCV, T.REACTION_TORQUE, T.FAULT_EFFECT,
                 T.FAULT_TRUTH, T.SCENARIO, T.PLANT_DONE]
# what the observer and isolation nodes (and the recorder of their outputs) read: bag replay for
# evaluation plays only these, which halves the player's work
FDI_INPUTS = [T.CLOCK, T.TCV, T.REACTION_TORQUE, T.WHEEL_SPEED, T.FAULT_TRUTH, T.SCENARIO, T.PLANT_DONE]


class PlayerNode(GraphNode):
    node_name = "player"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("bag", "")
        self.declare_parameter("topics", Parameter.Type.STRING_ARRAY)  # default: the plant's outputs
        self.declare_parameter("rate", 0.0)               # 0: paced by the consumers; else sim s per wall s
        self.declare_parameter("pace_topic", T.DIAGNOSTICS)
        self.declare_parameter("pace_period", 1.0)        # FDI period [s]
        self.declare_parameter("pace_window", 20)         # FDI samples the player may run ahead
        self.declare_parameter("min_subscribers", 0)      # readers of /wheel/tcv and reaction torque before starting
        self.declare_parameter("speed_subscribers", 0)    # readers of /wheel_speed before starting (speed_aware)
        self.declare_parameter("startup_timeout", 60.0)
        self.declare_parameter("stall_timeout", 10.0)     # wall s without consumer progress -> error
        topics = self.param("topics") or PLANT_OUTPUTS
        try:
            data = read_bag(self.param("bag"), topics=topics, raw=True)
        except (BagError, OSError) as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        if not data.complete:
            self.get_logger().warn(f"{data.path}: {data.note}; replaying what is there")
        qos = {name: q for name, _, q in T.graph_topics() + T.fdi_topics()}
        self.pubs = {t: self.create_publisher(T.message_class(data.types[t]), t, qos.get(t, T.RELIABLE))
                     for t in data.messages}
        rows = [(log_time, topic, raw) for topic, msgs in data.messages.items() for log_time, raw in msgs]
        order = {t: i for i, t in enumerate(PLANT_OUTPUTS)}
        self.rows = sorted(rows, key=lambda r: (r[0], order.get(r[1], 99)))
        self.next = 0
        self.rate = self.param("rate")
        self.period_ns = int(round(self.param("pace_period") * 1e9))
        self.window_ns = max(int(self.param("pace_window")) - 1, 0) * self.period_ns
        fdi_rows = [t for t, topic, _ in self.rows if topic == T.REACTION_TORQUE and t % self.period_ns == 0]
        self.last_fdi_ns = max(fdi_rows, default=-1)
        self.paced_until = -1          # consumers have finished every FDI sample up to this stamp
        self.waiting_for = None        # FDI stamp published, not yet reported done
        self.started = None
        self.last_progress = time.monotonic()
        self.pace_sub = None
        if self.rate <= 0:
            from diagnostic_msgs.msg import DiagnosticArray
            self.pace_sub = self.create_subscription(DiagnosticArray, self.param("pace_topic"), self._on_pace,
                                                     T.RELIABLE)

    def _on_pace(self, msg):
        self.paced_until = max(self.paced_until, stamp_ns(msg.header.stamp))
        self.last_progress = time.monotonic()

    def _ready(self):
        need = self.param("min_subscribers")
        need = {T.TCV: need, T.REACTION_TORQUE: need, T.WHEEL_SPEED: self.param("speed_subscribers")}
        inputs = all(self.pubs[t].get_subscription_count() >= k for t, k in need.items() if t in self.pubs)
        return inputs and (self.pace_sub is None or self.pace_sub.get_publisher_count() >= 1)

    def poll(self):
        now = time.monotonic()
        if self.started is None:
            if not self._ready():
                if now - self.last_progress > self.param("startup_timeout"):
                    self.fail("no consumers for the replayed topics", EXIT_TIMEOUT)
                return
            self.started = now
            self.last_progress = now
        while self.next < len(self.rows):
            log_time, topic, raw = self.rows[self.next]
            if self.rate > 0:
                if now < self.started + log_time * 1e-9 / self.rate:
                    return
            elif self.waiting_for is not None and log_time > self.waiting_for:
                if self.paced_until < self.waiting_for - self.window_ns:
                    if now - self.last_progress > self.param("stall_timeout"):
                        self.fail(f"consumers stalled: no {self.param('pace_topic')} for t="
                                  f"{self.waiting_for * 1e-9:g} s within {self.param('stall_timeout'):g} s",
                                  EXIT_TIMEOUT)
                    return
                self.waiting_for = None
            if topic == T.PLANT_DONE and self.rate <= 0 and self.paced_until < self.last_fdi_ns:
                break   # the run's end goes out only once the consumers have finished every FDI sample
            self.pubs[topic].publish(raw)
            if topic == T.REACTION_TORQUE and log_time % self.period_ns == 0 and self.rate <= 0:
                self.waiting_for = log_time   # an FDI sample went out: let the consumers finish it
                self.last_progress = now
            self.next += 1
        if self.next == len(self.rows) and (self.rate > 0 or self.paced_until >= self.last_fdi_ns):
            self.finish()
        elif now - self.last_progress > self.param("stall_timeout"):
            self.fail("consumers stalled at the end of the bag", EXIT_TIMEOUT)


main = main_for(PlayerNode)

if __name__ == "__main__":
    main()
