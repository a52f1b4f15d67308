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
        """The raw-message callback feeding input ``name``.

        Parameters
        ----------
        name : str
            The input's name.

        Returns
        -------
        callable
            Takes the serialised JointState.
        """
        def on_raw(raw):
            stamp, _, _, effort = read_joint_state_cdr(raw)
            self.add(name, stamp, effort)
        return on_raw

    def subscribe(self, node, name, topic: str, qos):
        """A raw subscription of ``node`` to ``topic`` feeding input ``name``.

        Parameters
        ----------
        node : rclpy.node.Node
            The node.
        name : str
            The input's name.
        topic : str
            The topic's name.
        qos : rclpy.qos.QoSProfile
            The subscription's QoS.

        Returns
        -------
        rclpy.subscription.Subscription
            The subscription.
        """
        return node.create_subscription(JointState, topic, self.callback(name), qos, raw=True)

    def add(self, name, stamp, values):
        """Add input ``name``'s values at ``stamp``; calls ``on_complete`` once all inputs of the stamp are in.

        Parameters
        ----------
        name : str
            The input's name.
        stamp : int
            The stamp [ns].
        values : numpy.ndarray
            The message's efforts, one per joint.
        """
        if not self.accept(stamp):
            return
        entry = self.pending.setdefault(stamp, {})
        entry[name] = values
        if len(entry) == len(self.names):
            del self.pending[stamp]
            self.on_complete(stamp, entry)
