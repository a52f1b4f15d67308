"""plugin_observer: a user's observer (core/observer_plugin.WheelObserver) as a node of the graph.

    ros2 run rw_fdi_ros plugin_observer --ros-args -p observer:=my_pkg.kalman:KalmanObserver \
        -p observer_state:=my_fdi/observer_kalman.json

It reads the FDI telemetry as our observer nodes do and publishes the plug-in's
estimate, the speed-aware residual and its ripple bound on /fdi/<slot>/...
(the residual learns each wheel's unit with unit_calibration_time, and the
plug-in's calibrate hook sees those samples too). The isolation node judges it
when told its slot (plugin_observers) and bands (thresholds_<slot>).
"""
from __future__ import annotations

import json

from ..core.observer_plugin import ObserverError, load_observer, step
from ..graph.observer_node import WheelsObserverNode
from ..graph.runtime import EXIT_BAD_INPUT, NodeError, main_for


class PluginObserverNode(WheelsObserverNode):
    node_name = "plugin_observer"
    needs_speed = True   # its residual is the speed-aware one, with the ripple bound

    def __init__(self, name: str | None = None):   # name: another than node_name (composition)
        super().__init__(name or self.node_name)

    def declare_own_parameters(self):
        self.declare_parameter("observer", "")         # entry point name, module:Class or file.py:Class
        self.declare_parameter("observer_state", "")   # its observer_<slot>.json (empty: untrained)
        self.declare_parameter("slot", "")             # what the launcher expects its slot to be (empty: any)
        try:
            if not self.param("observer"):
                raise ObserverError("parameter observer must name a WheelObserver (module:Class, file.py:Class or "
                                    "an entry point of rw_fdi_ros.observers)")
            cls = load_observer(self.param("observer"))
            if self.param("slot") and self.param("slot") != cls.slot:
                raise ObserverError(f"parameter slot {self.param('slot')!r}: {self.param('observer')} has slot "
                                    f"{cls.slot!r}")
            state = {}
            if self.param("observer_state"):
                with open(self.param("observer_state")) as f:
                    state = json.load(f)["state"]
        except (ObserverError, OSError, ValueError, KeyError) as exc:
            raise NodeError(str(exc) if isinstance(exc, ObserverError) else
                            f"parameter observer_state {self.param('observer_state')}: unreadable ({exc})",
                            EXIT_BAD_INPUT) from None
        self.slot = cls.slot
        self.plugin = cls(self.names, self.param("fdi_period"), state)
        self.samples_seen = 0

    def uncertainty_gain(self, wheel: str) -> float:
        return self.plugin.uncertainty_gain(wheel)

    def reset(self):
        self.plugin.reset()
        self.samples_seen = 0
        super().reset()

    def estimate(self, sample):
        calibrating = self.samples_seen < self.calibration_samples
        self.samples_seen += 1
        return step(self.plugin, sample, calibrating)


main = main_for(PluginObserverNode)

if __name__ == "__main__":
    main()
