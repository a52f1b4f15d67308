"""A publisher that holds messages until its subscribers are matched.

DDS drops what is published before discovery has matched a reader, so a
node whose first outputs matter (a lockstep command, an FDI sample) queues
them until ``min_subscribers`` readers are there, then sends them in order.
"""
from __future__ import annotations


class GatedPublisher:
    def __init__(self, publisher, min_subscribers: int = 0):
        self.publisher = publisher
        self.min_subscribers = int(min_subscribers)
        self.open = self.min_subscribers <= 0
        self.queue = []

    def publish(self, msg):
        """Publish ``msg`` now if the gate is open, else queue it (and try to open the gate).

        Parameters
        ----------
        msg : object
            The message.
        """
        if self.open:
            self.publisher.publish(msg)
        else:
            self.queue.append(msg)
            self.flush()

    def flush(self):
        """Send what waits once enough readers are matched (call it from the node's poll).

        Returns
        -------
        bool
            Whether nothing waits any more.
        """
        if not self.open and self.publisher.get_subscription_count() >= self.min_subscribers:
            self.open = True
            for msg in self.queue:
                self.publisher.publish(msg)
            self.queue.clear()
        return not self.queue

    def wait_for_all_acked(self, timeout):
        """rclpy's: wait until every reader acknowledged what was published.

        Parameters
        ----------
        timeout : rclpy.duration.Duration
            How long to wait at most.

        Returns
        -------
        bool
            Whether all were acknowledged in time.
        """
        return self.publisher.wait_for_all_acked(timeout)
