"""Pairing of messages that belong to the same sim-time stamp, across topics."""
from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped

from ..storage.cdr import read_vector_cdr


class StampSync:
    """Collects one Vector3Stamped per named input for a stamp; calls ``on_complete(stamp_ns, values)``
    once all inputs of that stamp are in (values: name -> np.ndarray(3)). The callbacks take the
    serialised message: subscribe with ``raw=True``."""

    def __init__(self, names, on_complete, accept=None):
        self.names = tuple(names)
        self.on_complete = on_complete
        self.accept = accept or (lambda stamp: True)
        self.pending = {}

    def callback(self, name):
        return lambda raw: self.add(name, *read_vector_cdr(raw))

    def subscribe(self, node, name: str, topic: str, qos):
        """A raw subscription of ``node`` to ``topic`` feeding input ``name``."""
        return node.create_subscription(Vector3Stamped, topic, self.callback(name), qos, raw=True)

    def add(self, name, stamp, values):
        if not self.accept(stamp):
            return
        entry = self.pending.setdefault(stamp, {})
        entry[name] = values
        if len(entry) == len(self.names):
            del self.pending[stamp]
            self.on_complete(stamp, entry)
