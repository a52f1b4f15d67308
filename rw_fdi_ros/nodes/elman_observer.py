"""elman_observer: one wheel's Elman network in recall mode (thesis Fig. 4.8), started once per wheel
with the ``wheel`` parameter (its joint, ``reaction_wheel_x`` / ``_y`` / ``_z`` / ``_s``; the redundant
wheel, of the same type, runs the network of its type, core/fdi/elman.network_wheel).

Every FDI sample (1 s) it estimates the reaction torque from the command
voltage, its own previous estimate and (speed-aware method) the wheel speed,
and publishes the estimate, the residual and the ripple bound: the signed
40-sample mean of r - r^ with its bound (speed_aware) or the 40-sample mean of
|r - r^| with bound 0 (thesis). numpy only, no torch.
"""
from __future__ import annotations

from ..core.fdi.residuals import ResidualFilter
from ..core.fdi.elman import REGENERATE, ElmanWeights, ModelError, WheelRecall
from ..graph import topics as T
from ..graph.observer_node import ObserverNode
from ..graph.runtime import EXIT_BAD_INPUT, NodeError, main_for


class ElmanObserverNode(ObserverNode):
    node_name = "elman_observer"

    def __init__(self, name: str | None = None):
        super().__init__(name)
        self.declare_parameter("wheel", self.joints[0])   # the wheel joint this network watches
        try:
            axis = T.axis_of_joint(self.param("wheel"), self.joints)
        except ValueError as exc:
            raise NodeError(f"parameter wheel {exc}", EXIT_BAD_INPUT) from None
        try:
            path = self.fdi.model_path(axis)   # FdiConfig's rule: fdi.models, else the vehicle's shipped set
            weights = ElmanWeights.load(path)
            if weights.speed_aware != self.speed_aware:
                raise ModelError(f"{path}: a {weights.inputs}-input network cannot run fdi.method={self.method!r} "
                                 f"({'3 inputs with the wheel speed' if self.speed_aware else '2 inputs'} needed); "
                                 f"{REGENERATE}")
        except ModelError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None
        self.index = self.names.index(axis)
        self.out_joints = (self.param("wheel"),)
        self.weights = weights
        self.reset()
        self.start("elman", axis)

    def reset(self):
        # the measured torque while the wheel stands by, recall from its first running sample (elman.WheelRecall)
        self.recall = WheelRecall(self.weights)
        window = self.param("window")
        self.residual = (self.signed_residual(self.weights.uncertainty_gain) if self.speed_aware
                         else ResidualFilter(window))

    def observe(self, sample):
        """(estimate, residual, bound) of this node's wheel for one FdiSample: the network's recall and its residual.

        Parameters
        ----------
        sample : core.fdi.telemetry.FdiSample
            The FDI sample, fields (N,).

        Returns
        -------
        tuple of numpy.ndarray
            (estimate r^, residual, ripple bound) [N m], each (N,) (an Elman node: its wheel's).
        """
        i = self.index
        u, r = float(sample.tcv[i]), float(sample.reaction_torque[i])
        if self.speed_aware:
            network = self.recall.update(u, r, float(sample.wheel_speed[i]),   # recalls its own, uncorrected
                                         None if sample.model_torque is None else float(sample.model_torque[i]))
            residual, bound = self.residual.update(r, network, sample.ripple_phasor[i], self.regressors(sample, i))
            estimate = self.residual.estimate   # calibrated to the unit when the node calibrates
        else:
            estimate = self.recall.update(u, r)
            residual, bound = self.residual.update(r, estimate), 0.0
        return [estimate], [residual], [bound]


main = main_for(ElmanObserverNode)

if __name__ == "__main__":
    main()
