"""The spacecraft without ROS: plain numpy over the thesis' equations, used by the nodes and the offline tools.

Layered bottom up, each package with a public face: physics (wheel, body, plant, orbit, faults); mission (the
vehicle and the scenario as data); control (PID, allocation); fdi (observers, residuals, bands, the FDI
pipeline, identification); fdir (what the spacecraft does with a wheel the FDI confirms); flight (a batch flown
through all of them, given the gains); controller_design (the vehicle's gains, designed on its own step
responses, which it flies); closed_loop (a flight under that design).
"""

__all__ = ["closed_loop", "control", "controller_design", "fdi", "fdir", "flight", "mission", "physics"]

# The flat core/ of before the packages: a user's script importing rw_fdi_ros.core.scenario still runs. Each old
# name is the new module itself (one object, not a copy), registered under the old name on first import.
MOVED = {
    "allocation": "control.allocation", "pid": "control.pid",
    "calibration": "fdi.calibration", "detection": "fdi.detection", "elman": "fdi.elman",
    "identification": "fdi.identification", "identifiability": "fdi.identification.identifiability",
    "input_health": "fdi.input_health", "isolation": "fdi.verdict", "linear_observer": "fdi.linear_observer",
    "observer_plugin": "fdi.observer_plugin", "onboard": "fdi.pipeline", "residuals": "fdi.residuals",
    "telemetry": "fdi.telemetry", "threshold_file": "fdi.threshold_file", "threshold_fit": "fdi.threshold_fit",
    "plant_choices": "mission.plant_choices", "sampling": "mission.plant_choices", "scenario": "mission.scenario",
    "vehicle": "mission.vehicle", "yaml_text": "mission.yaml_text",
    "environment": "physics.environment", "geomagnetic": "physics.geomagnetic",
    "magnetorquers": "physics.magnetorquers",
    "orbit": "physics.orbit", "plant": "physics.plant", "spacecraft": "physics.spacecraft", "wheel": "physics.wheel",
    "wheel_set": "physics.wheel_set",
}


class _MovedFinder:
    """Finds ``rw_fdi_ros.core.<old>`` (MOVED) as the module it became."""

    def find_spec(self, fullname, path=None, target=None):
        import importlib.util
        old = fullname.removeprefix(__name__ + ".")
        if old == fullname or old not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        import importlib
        module = importlib.import_module(f"{__name__}.{MOVED[spec.name.rsplit('.', 1)[1]]}")
        self.own_spec = module.__spec__   # the import machinery writes the old name's spec over it
        return module

    def exec_module(self, module):
        """The new module ran already: its own spec given back."""
        module.__spec__ = self.own_spec


def _install():
    import sys
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.append(_MovedFinder())


_install()
