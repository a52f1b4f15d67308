"""model_observer: the nominal wheel model of each wheel of the set, driven by what the wheel reports.

With the tachometer measuring the wheel's state the observer needs no state
estimate: r^ is the nominal Bialke model's reaction torque at the measured
command voltage and wheel speed (core/fdi/telemetry.model_reaction_torque; the
wheel electronics report it as model_reaction_torque), the residual the
signed 40-sample mean of r - r^ with its ripple bound; with
unit_calibration_time the model learns the wheel's own unit first
(core/fdi/calibration.py). Speed-aware method only: the thesis' observers see no
wheel speed.
"""
from __future__ import annotations

from ..graph.observer_node import WheelsObserverNode
from ..graph.runtime import main_for


class ModelObserverNode(WheelsObserverNode):
    node_name = "model_observer"
    slot = "model"
    needs_speed = True

    def estimate(self, sample):
        """r^ of every wheel: the plant model's, as the telemetry report carries it.

        Parameters
        ----------
        sample : core.fdi.telemetry.FdiSample
            The FDI sample, fields (N,).

        Returns
        -------
        numpy.ndarray
            (N,) r^ [N m].
        """
        return sample.model_torque


main = main_for(ModelObserverNode)

if __name__ == "__main__":
    main()
