"""What both observer kinds share: the plant's tcv and reaction torque turned into FDI samples."""
from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped

from ..core.sampling import FdiSampler
from . import topics as T
from .sync import StampSync


def subscribe_fdi_samples(node, on_sample, period: float, sampling: str = "mean"):
    """Call ``on_sample(stamp_ns, tcv[3], reaction_torque[3])`` on every FDI stamp, with the samples
    made by :class:`FdiSampler` from every control-period message."""
    sampler = FdiSampler(period, sampling)

    def on_pair(stamp, values):
        sample = sampler.add(stamp, values["tcv"], values["torque"])
        if sample is not None:
            on_sample(*sample)
    sync = StampSync(("tcv", "torque"), on_pair)
    node.create_subscription(Vector3Stamped, T.TCV, sync.callback("tcv"), T.RELIABLE)
    node.create_subscription(Vector3Stamped, T.REACTION_TORQUE, sync.callback("torque"), T.RELIABLE)
    return sync
