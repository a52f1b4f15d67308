"""recorder: writes every topic of a run to a rosbag2 bag in MCAP storage.

Raw CDR bytes go to the bag untouched (no deserialisation), with the
message's own sim-time header stamp as log time, so a bag does not depend
on machine load. It finalises the bag when the plant reports the run done
(and every topic has caught up) or on SIGINT/SIGTERM; see storage/bag.py for
what a SIGKILL leaves behind. A topic that never catches up still gets the
bag closed, and the node exits non-zero naming it.

DDS matches a writer to this reader and this reader to the writer
separately: before the plant (in bag replay, the player) starts, the
recorder says on /recorder/ready that it has matched the writers the graph
has from its start (the plant's and the FDI nodes').

Bag replay of many runs through one graph gives it ``outputs``: one bag per
run, in order. When a run is done it closes that bag, says so on
/recorder/closed (the player waits for it before the next run) and opens the
next.
"""
from __future__ import annotations

from rclpy.parameter import Parameter
from std_msgs.msg import String

from ..storage.bag import BagError
from ..storage.writer import BagWriter
from ..storage.cdr import header_stamp_ns
from ..graph.convert import offered_qos
from ..graph import topics as T
from ..core.physics.wheel_set import DEFAULT_WHEEL_SET
from ..core.physics.environment import MAGNETOMETER_PERIOD
from ..graph.runtime import EXIT_BAD_INPUT, GraphNode, NodeError, main_for, relative, wall_time


class RecorderNode(GraphNode):
    node_name = "recorder"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("output", "bags/run")          # bag directory to create
        self.declare_parameter("outputs", Parameter.Type.STRING_ARRAY)  # one bag per run, in order (bag replay)
        self.declare_parameter("flush_period", 10.0)          # sim seconds between chunk flushes
        self.declare_parameter("extra_topics", Parameter.Type.STRING_ARRAY)   # 'name:pkg/msg/Type' beyond the graph's
        self.declare_parameter("drain_timeout", 5.0)          # after done: wall s without any message -> close
        self.declare_parameter("fdi_period", 0.0)             # > 0: the FDI nodes run; record their topics
        self.declare_parameter("telemetry_period", 0.0)       # > 0: the FDI telemetry's, whose last sample ends a run
        self.declare_parameter("fdi_method", "speed_aware")   # whose observers' topics (with fdi_period > 0)
        self.declare_parameter("record_plant", True)          # False: FDI outputs only (bag replay)
        self.declare_parameter("wheel_set", DEFAULT_WHEEL_SET)  # whose wheels' FDI topics (one Elman node per wheel)
        self.declare_parameter("orbit", False)                 # in orbit: record the magnetometer
        self.declare_parameter("magnetorquers", False)         # record the magnetorquers' command
        self.declare_parameter("plugin_observers", "")         # slots of a user's observers, comma-separated
        self.outputs = list(self.param("outputs") or []) or [self.param("output")]
        self.record_plant = self.param("record_plant")
        self.next_look = 0.0   # wall time of the next look for another graph
        self.output_index = 0
        self.fdi_period_ns = int(round(self.param("fdi_period") * 1e9))
        self.telemetry_period_ns = int(round(self.param("telemetry_period") * 1e9)) if self.record_plant else 0
        # what it subscribes to is the graph's table (topics.READS counts the recorder's reads from it)
        method = self.param("fdi_method")
        plugins = T.plugin_slots({"plugin_observers": self.param("plugin_observers")})
        try:
            rows = T.recorded_rows(self.param("record_plant"), self.fdi_period_ns > 0, self.param("extra_topics"),
                                   method, self.param("wheel_set"), self.param("orbit"), self.param("magnetorquers"),
                                   plugins)
            self.fdi_names = [t for t, _, _ in T.fdi_topics(method, self.param("wheel_set"), plugins)]
        except ValueError as exc:   # an unknown fdi_method or wheel set
            raise NodeError(f"parameter {exc}", EXIT_BAD_INPUT) from None
        self.rows = rows = [(name, type_name, getattr(T, qos)) for name, type_name, qos in rows]
        self.writers = T.writer_counts(self.param("record_plant"))
        self._open()
        try:
            self._subscribe(rows)
        except BaseException:   # a launch shutting down while we start (SIGINT): still a readable, closed bag
            self._close_bag()
            raise

    def _subscribe(self, rows):
        # the plant's per-step topics that must have reached the done stamp (none when replaying)
        self.final = list(T.STEP_TOPICS) if self.param("record_plant") else []
        # in orbit, once a magnetometer period: the last reading and the rods' answer to it
        self.final_orbit = [t for t, _, _ in rows if t in (T.MAGNETOMETER, T.DIPOLE_COMMAND)]
        self.pub_closed = self.create_publisher(String, T.RECORDER_CLOSED, T.LATCHED)
        self.pub_ready = self.create_publisher(String, T.RECORDER_READY, T.LATCHED)
        # what /recorder/ready waits for: the topics whose writers exist from the graph's start (the plant's
        # and the FDI nodes'); a replay's player writes only what its bag holds, extra topics may have none
        plant_rows = [*T.PLANT_ROWS, *(T.ORBIT_ROWS if self.param("orbit") else ()),
                      *(T.MAGNETORQUER_ROWS if self.param("magnetorquers") else ())]
        awaited = set(self.fdi_names) | ({n for n, _, _ in plant_rows} if self.param("record_plant") else set())
        self.subs, self.unmatched, self.ready, self.done_sub, self.sub_of = [], [], False, None, {}
        self.started, self.said_unmatched = wall_time(), False
        for name, type_name, qos in rows:
            cls = T.message_class(type_name)
            sub = self.create_subscription(cls, name, lambda raw, n=name: self._on_message(n, raw), qos, raw=True)
            self.subs.append(sub)
            self.sub_of[name] = sub
            if name in awaited:
                self.unmatched.append((name, sub))
            if name == T.PLANT_DONE and self.param("record_plant"):
                self.done_sub = sub
        self.stamped = {name for name, type_name, _ in rows if type_name != "std_msgs/msg/String"}

    def _open(self):
        try:
            self.bag = BagWriter(self.outputs[self.output_index], int(self.param("flush_period") * 1e9))
        except BagError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        for name, type_name, qos in self.rows:
            self.bag.add_topic(name, type_name, offered_qos(qos))
        self.bag.set_custom_data("engine", "graph")   # which engine recorded the run (the core loop can too)
        if self.get_namespace() != "/":   # the topics are recorded by the graph table's names, under this namespace
            self.bag.set_custom_data("namespace", self.get_namespace())
        self.last_stamp = {}   # topic -> its last stamp
        self.at_last = {}   # topic of several writers -> messages at its last stamp
        self.done_stamp = None
        self.done_wall = 0.0
        self.last_clock = 0
        self.last_message_wall = wall_time()

    def _on_message(self, topic, raw):
        if self.bag is None:
            return   # every bag is closed
        if topic in self.stamped:
            stamp = header_stamp_ns(raw, self.last_clock)
        else:   # the scenario (latched) describes the run from its start; other header-less data: the clock
            stamp = 0 if topic == T.SCENARIO else self.last_clock
        if topic == T.CLOCK:
            self.last_clock = stamp
        last = self.last_stamp.get(topic, -1)
        if topic in self.writers and stamp >= last:   # how many of its writers reached its last stamp
            self.at_last[topic] = self.at_last.get(topic, 0) + 1 if stamp == last else 1
        self.last_stamp[topic] = max(stamp, last)
        self.bag.write(topic, stamp, bytes(raw))
        self.last_message_wall = wall_time()
        if topic == T.PLANT_DONE:
            self.done_stamp, self.done_wall = stamp, wall_time()

    def poll(self):
        if self._another_graph():
            return
        if not self.ready:
            # a writer counting this reader does not mean this reader has matched the writer: the plant
            # (the player) starts on /recorder/ready, so no run goes out to a reader that drops it all
            self.unmatched = [(name, s) for name, s in self.unmatched
                              if s.get_publisher_count() < self.writers.get(name, 1)]
            if not self.unmatched:
                self.ready = True
                self.pub_ready.publish(String(data="ready"))
            elif not self.said_unmatched and wall_time() - self.started > 20.0:
                # the plant gives up after its startup_timeout: say which writers this reader never matched
                self.said_unmatched = True
                self.get_logger().warn(f"no writer matched yet on {', '.join(s.topic_name for _, s in self.unmatched)}")
        if self.done_stamp is None:
            self._check_plant_left()
            return
        final = self.final
        if self.fdi_period_ns > 0:   # the FDI outputs of the last FDI sample
            last_fdi = self.done_stamp - self.done_stamp % self.fdi_period_ns
            # every FDI topic: they come from several writers, and a bag closed on the first of them
            # would lose the others' last sample, or give it to the next run's bag (bag replay)
            lagging_fdi = [t for t in self.fdi_names if self.last_stamp.get(t, -1) < last_fdi or (
                t in self.writers and self.last_stamp[t] == last_fdi and self.at_last[t] < self.writers[t])]
        else:
            lagging_fdi = []
        if self.telemetry_period_ns > 0:   # the wheel_telemetry node's last sample comes after the last command
            last_sample = self.done_stamp - self.done_stamp % self.telemetry_period_ns
            lagging_fdi += [t for t in (T.FDI_BUS_GRID, T.FDI_TELEMETRY) if self.last_stamp.get(t, -1) < last_sample]
        last_reading = self.done_stamp - self.done_stamp % int(round(MAGNETOMETER_PERIOD * 1e9))
        lagging = ([t for t in final if self.last_stamp.get(t, -1) < self.done_stamp] + lagging_fdi
                   + [t for t in self.final_orbit if self.last_stamp.get(t, -1) < last_reading])
        # a loaded recorder may still be working through its queue: only silence ends the wait
        if not lagging or self._drained(lagging):
            if lagging and not self.param("record_plant"):
                # a replayed run whose outputs stopped short must not pass for a finished one, nor may
                # its late messages land in the next run's bag: drop it and stop (the tool says which)
                import shutil
                self._close_bag()
                shutil.rmtree(self.outputs[self.output_index], ignore_errors=True)
                self.fail(f"run {self.output_index}: {len(lagging)} topics did not reach the run's end within "
                          f"{self.param('drain_timeout'):g} s ({', '.join(lagging[:3])}, ...)")
                return
            self._close_bag()
            self.pub_closed.publish(String(data=str(self.output_index)))
            if lagging:   # kept (it is what the run sent), but the run is not a whole one: say so, exit non-zero
                self.fail(f"bag {self.outputs[self.output_index]} closed without the run's end on "
                          f"{', '.join(lagging[:3])}{', ...' if len(lagging) > 3 else ''} (no message for "
                          f"{self.param('drain_timeout'):g} s after /plant/done)")
                return
            self.output_index += 1
            if self.output_index < len(self.outputs):
                self._open()
            else:
                self.finish()

    def _drained(self, lagging) -> bool:
        """Silence for ``drain_timeout`` ends the wait. In a live run, a lagging topic's writer still in the graph
        may be a starved process working through its backlog (an FDI node ends on its own once it stops making
        progress): while one is, the wait is ten times as long. A replay's nodes serve every run: no such grace."""
        silent = wall_time() - max(self.done_wall, self.last_message_wall)
        timeout = self.param("drain_timeout")
        if silent <= timeout:
            return False
        return (silent > 10 * timeout or not self.record_plant
                or not any(self.sub_of[t].get_publisher_count() for t in lagging))

    def _another_graph(self) -> bool:
        """Two runs in one domain and namespace write into each other's bags: a second writer of the run's
        /scenario (one per run) is said, naming the cure, and this bag closed; looked at ten times a second. DDS
        discovery is not symmetric in time: the run that joins a domain another run occupies sees it first,
        and the other, seeing nothing of it, keeps a bag of its own messages alone."""
        now = wall_time()
        if not self.record_plant or self.bag is None or now < self.next_look:
            return False
        self.next_look = now + 0.1   # a graph query ten times a second, not every poll
        writers = self.count_publishers(relative(T.SCENARIO))
        if writers <= 1:
            return False
        import os
        self._close_bag()
        self.fail(f"another graph runs in this ROS domain (ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}) "
                  f"and namespace {self.get_namespace()!r}: {writers} writers of {T.SCENARIO}; give each run its "
                  "own domain or namespace (its bag would hold the other's messages)")
        return True

    def _check_plant_left(self):
        """The plant gone without /plant/done (killed, or its last message lost): nothing will end the
        wait, so after ``drain_timeout`` of silence the bag is closed with what came and the node fails."""
        if self.done_sub is None or not self.ready or self.done_sub.get_publisher_count() > 0:
            return
        silent = wall_time() - self.last_message_wall
        if silent > self.param("drain_timeout"):
            self._close_bag()
            self.fail(f"the plant left without {T.PLANT_DONE}: bag {self.outputs[self.output_index]} closed "
                      f"after {silent:.0f} s without a message (the run's end is not in it)")

    def _close_bag(self):
        if self.bag is not None:
            self.bag.close()
            self.get_logger().info(f"bag {self.outputs[self.output_index]}: {self.bag.count} messages")
            self.bag = None

    def close(self):
        self._close_bag()   # the bag first: nothing else this node does matters as much
        super().close()


main = main_for(RecorderNode)

if __name__ == "__main__":
    main()
