"""plugin_observer: a user's observer (core/fdi/observer_plugin.WheelObserver) as a node of the graph.

    ros2 run rw_fdi_ros plugin_observer --ros-args -p observer:=my_pkg.kalman:KalmanObserver \
        -p observer_state:=my_fdi/observer_kalman.json

It reads the FDI telemetry as our observer nodes do and publishes the plug-in's
estimate, the speed-aware residual and its ripple bound on /fdi/<slot>/...
(the residual learns each wheel's unit with unit_calibration_time, and the
plug-in's calibrate hook sees those samples too). The isolation node judges it
when told its slot (plugin_observers) and bands (thresholds_<slot>).
"""
from __future__ import annotations

from ..core.fdi.observer_plugin import ObserverError, PluginRun, load_observer, read_state
from ..graph.observer_node import WheelsObserverNode
from ..graph.runtime import EXIT_BAD_INPUT, EXIT_ERROR, NodeError, main_for


class PluginObserverNode(WheelsObserverNode):
    node_name = "plugin_observer"
    needs_speed = True   # its residual is the speed-aware one, with the ripple bound

    def declare_own_parameters(self):
        self.declare_parameter("observer", "")         # entry point name, module:Class or file.py:Class
        self.declare_parameter("observer_state", "")   # its observer_<slot>.json (empty: untrained)
        self.declare_parameter("slot", "")             # what the launcher expects its slot to be (empty: any)
        try:
            if not self.param("observer"):
                raise ObserverError("parameter observer must name a WheelObserver (module:Class, file.py:Class or "
                                    "an entry point of rw_fdi_ros.observers)")
            self.observer_class = load_observer(self.param("observer"))
            self.slot = self.observer_class.slot
            if self.param("slot") and self.param("slot") != self.slot:
                raise ObserverError(f"parameter slot {self.param('slot')!r}: {self.param('observer')} has slot "
                                    f"{self.slot!r}")
            self.state = read_state(self.param("observer_state"), self.slot) if self.param("observer_state") else {}
            self.gains = dict(zip(self.names, self._new_run().uncertainty_gains()))
        except ObserverError as exc:
            raise NodeError(str(exc), EXIT_BAD_INPUT) from None

    def _new_run(self) -> PluginRun:
        return PluginRun(self.observer_class, self.names, self.param("fdi_period"), self.state,
                         self.calibration_samples)

    def uncertainty_gain(self, wheel: str) -> float:
        """kappa of a wheel, as the user's observer declares it.

        Parameters
        ----------
        wheel : str
            The wheel's name.

        Returns
        -------
        float
            kappa.
        """
        return self.gains[wheel]

    def reset(self):
        self.run = self._new_run()   # each run a new instance, as offline (a plug-in may change its state)
        super().reset()

    def estimate(self, sample):
        """r^ of every wheel: the user's observer's step (NodeError, one line, when its code fails).

        Parameters
        ----------
        sample : core.fdi.telemetry.FdiSample
            The FDI sample, fields (N,).

        Returns
        -------
        numpy.ndarray
            (N,) r^ [N m].
        """
        try:
            return self.run.step(sample)
        except ObserverError as exc:   # the user's code failed: one line naming it, not a traceback
            raise NodeError(str(exc), EXIT_ERROR) from None


main = main_for(PluginObserverNode)

if __name__ == "__main__":
    main()
