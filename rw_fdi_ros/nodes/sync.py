"""Pairing of messages that belong to the same sim-time stamp, across topics."""
from __future__ import annotations

from .convert import stamp_ns, vector_array


class StampSync:
    """Collects one Vector3Stamped per named input for a stamp; calls ``on_complete(stamp_ns, values)``
    once all inputs of that stamp are in (values: name -> np.ndarray(3))."""

    def __init__(self, names, on_complete, accept=None):
        self.names = tuple(names)
        self.on_complete = on_complete
        self.accept = accept or (lambda stamp: True)
        self.pending = {}

    def callback(self, name):
        return lambda msg: self.add(name, msg)

    def add(self, name, msg):
        stamp = stamp_ns(msg.header.stamp)
        if not self.accept(stamp):
            return
        entry = self.pending.setdefault(stamp, {})
        entry[name] = vector_array(msg)
        if len(entry) == len(self.names):
            del self.pending[stamp]
            self.on_complete(stamp, entry)
