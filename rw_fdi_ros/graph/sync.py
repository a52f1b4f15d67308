"""Pairing of messages that belong to the same sim-time stamp, across topics."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from ..storage.cdr import read_joint_state_cdr


class StampSync:
    """Collects one per-wheel JointState per named input for a stamp; calls ``on_complete(stamp_ns, values)``
    once all inputs of that stamp are in (values: name -> np.ndarray, the messages' efforts, one per
    joint). The callbacks take the serialised message: subscribe with ``raw=True``."""

    def __init__(self, names, on_complete, accept=None):
        self.names = tuple(names)
        self.on_complete = on_complete
        self.accept = accept or (lambda stamp: True)
        self.pending = {}

    def callback(self, name):
        def on_raw(raw):
            stamp, _, _, effort = read_joint_state_cdr(raw)
            self.add(name, stamp, effort)
        return on_raw

    def subscribe(self, node, name, topic: str, qos):
        """A raw subscription of ``node`` to ``topic`` feeding input ``name``."""
        return node.create_subscription(JointState, topic, self.callback(name), qos, raw=True)

    def add(self, name, stamp, values):
        if not self.accept(stamp):
            return
        entry = self.pending.setdefault(stamp, {})
        entry[name] = values
        if len(entry) == len(self.names):
            del self.pending[stamp]
            self.on_complete(stamp, entry)
