"""elman_observer: one wheel's Elman network in recall mode (thesis Fig. 4.8), started once per axis.

Every FDI sample (1 s) it estimates the reaction torque from the command
voltage and its own previous estimate, and publishes the estimate and the
residual (40-sample moving average of |r - r^|). numpy only, no torch.
"""
from __future__ import annotations

from ..core.detection import ResidualFilter
from ..core.elman import ElmanObserver, ElmanWeights, ModelError
from ..core.scenario import AXES
from ..paths import config_dir
from . import topics as T
from .observer_node import ObserverNode
from .runtime import EXIT_BAD_INPUT, NodeError, main_for


def default_model(axis: str) -> str:
    return str(config_dir() / "fdi" / f"elman_{axis}.npz")


class ElmanObserverNode(ObserverNode):
    node_name = "elman_observer"

    def __init__(self):
        super().__init__(self.node_name)
        self.declare_parameter("axis", "x")
        self.declare_parameter("model", "")            # npz; empty: config/fdi/elman_<axis>.npz
        axis = self.param("axis")
        if axis not in AXES:
            raise NodeError(f"parameter axis must be one of x, y, z, got {axis!r}", EXIT_BAD_INPUT)
        try:
            weights = ElmanWeights.load(self.param("model") or default_model(axis))
        except ModelError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        self.index = AXES.index(axis)
        self.observer = ElmanObserver(weights)
        self.residual = ResidualFilter(self.param("window"))
        self.started = False
        self.start(T.estimate_topic("elman", axis), T.residual_topic("elman", axis))

    def observe(self, tcv, torque):
        u, r = float(tcv[self.index]), float(torque[self.index])
        if not self.started:  # recall mode starts from the first measured torque
            self.observer.reset(r)
            self.started = True
        estimate = self.observer.update(u)
        own_estimate, own_residual = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        own_estimate[self.index] = estimate
        own_residual[self.index] = self.residual.update(r, estimate)
        return own_estimate, own_residual


main = main_for(ElmanObserverNode)

if __name__ == "__main__":
    main()
