"""What both observer kinds share: take the plant's tcv and reaction torque at the FDI period."""
from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped

from . import topics as T
from .sync import StampSync


def subscribe_fdi_samples(node, on_sample, period: float):
    """Call ``on_sample(stamp_ns, tcv[3], reaction_torque[3])`` for every stamp on the FDI period."""
    period_ns = int(round(period * 1e9))
    sync = StampSync(("tcv", "torque"), lambda stamp, v: on_sample(stamp, v["tcv"], v["torque"]),
                     accept=lambda stamp: stamp % period_ns == 0)
    node.create_subscription(Vector3Stamped, T.TCV, sync.callback("tcv"), T.RELIABLE)
    node.create_subscription(Vector3Stamped, T.REACTION_TORQUE, sync.callback("torque"), T.RELIABLE)
    return sync
