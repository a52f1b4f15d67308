"""linear_observer: the Luenberger observer of the N wheels of the set at once (thesis 3.3).

The full-order observer of the linearised wheel, poles 4x the wheel pole,
discretised (ZOH) at the node's FDI period (core/fdi/linear_observer.py), estimates
the reaction torque r^ from the command voltage and the measured torque. The
residual is the 40-sample mean of |r - r^| (thesis method) or the signed
40-sample mean of r - r^ with its ripple bound and a model-error term that grows
with the torque demand, as the Elman network's (speed_aware method; with
unit_calibration_time the estimate learns the wheel's own unit first,
core/fdi/calibration.py). The linearised model knows neither the wheel speed nor
the back-EMF: it is the thesis' baseline beside the Elman and model observers.
"""
from __future__ import annotations

from ..core.fdi.linear_observer import LinearObserver, uncertainty_gain
from ..core.physics.wheel import linearised_wheel
from ..graph.observer_node import WheelsObserverNode
from ..graph.runtime import main_for


class LinearObserverNode(WheelsObserverNode):
    node_name = "linear_observer"
    slot = "linear"

    def uncertainty_gain(self, wheel: str) -> float:
        """kappa of a wheel: the linear observer's model error term (core.fdi.linear_observer.uncertainty_gain).

        Parameters
        ----------
        wheel : str
            The wheel's name.

        Returns
        -------
        float
            kappa.
        """
        return uncertainty_gain(wheel)

    def declare_own_parameters(self):
        self.declare_parameter("speed_up", 4.0)      # observer pole / wheel pole (thesis 3.3)

    def reset(self):
        self.observer = LinearObserver(self.param("fdi_period"), linearised_wheel(params=self.wheel),
                                       speed_up=self.param("speed_up"))
        super().reset()

    def estimate(self, sample):
        """r^ of every wheel: the linear observer's update on the command and the measured reaction torque.

        Parameters
        ----------
        sample : core.fdi.telemetry.FdiSample
            The FDI sample, fields (N,).

        Returns
        -------
        numpy.ndarray
            (N,) r^ [N m].
        """
        return self.observer.update(sample.tcv, sample.reaction_torque)


main = main_for(LinearObserverNode)

if __name__ == "__main__":
    main()
