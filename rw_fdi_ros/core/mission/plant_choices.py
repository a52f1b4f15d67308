"""The choices a run is made under, as one object (physics.md [choice] items, sampling periods).

A run's choices are built once, from the scenario's ``plant:`` mapping with any
command-line overrides, and travel as this object: the plant node records them
in the bag's /scenario, model cards and threshold files record the ones they
were made under, and the FDI refuses files made under other choices.

Files and bags written before a choice existed were made under its legacy value
(``LEGACY``), not under today's default: a recorded mapping that lacks a key is
read with the legacy value, a scenario that lacks it gets the default.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

from ..physics.geomagnetic import FIELD_MODELS
from ..physics.wheel import EMF_LIMITS
from .vehicle import DEFAULT_VEHICLE
from ..physics.wheel_set import DEFAULT_WHEEL_SET, WHEEL_SETS

# how an FDI sample is made of the control-rate samples of its period (fdi/sampling.py): their mean, or the one at
# the FDI stamp (the thesis')
SAMPLINGS = ("mean", "instant")

# what a scenario file may set under `plant:` (the rest is fixed by the graph)
SCENARIO_KEYS = ("emf_limit", "wheel_momentum_coupling", "control_period", "wheel_set", "magnetic_field")
# what a bag's /scenario records under `plant:`: those and the vehicle's name (its `vehicle:` holds the rest)
RECORDED_KEYS = SCENARIO_KEYS + ("vehicle",)
# the value a recorded mapping without the key was made under
LEGACY = {"wheel_momentum_coupling": False, "wheel_set": "orthogonal"}
# (choice, made under, running) pairs that are no difference to what was fitted or trained: a three-wheel
# set's files hold for the same three wheels with a standby wheel, whose runs are bit for bit the same
# until a reconfiguration (test_fdir.py); the standby wheel is judged with its type's band. The field
# model moves the body, not the wheels the observers model.
EQUIVALENT = {("wheel_set", "orthogonal", "orthogonal_skew"), ("magnetic_field", "igrf", "tilted_dipole"),
              ("magnetic_field", "tilted_dipole", "igrf")}
# what the graph's FDI runs at, whatever the scenario: sample period [s] (the plant's telemetry report,
# core/fdi/telemetry.py) and how control-rate data becomes one FDI sample (core/fdi/sampling.py [choice])
FDI_PERIOD = 1.0
FDI_SAMPLING = "mean"


class PlantChoiceError(ValueError):
    """A choice with a value the package does not know; one line for the user."""


@dataclass(frozen=True)
class PlantChoices:
    """emf_limit: EMF torque limiting of the wheel drive (physics.md); wheel_momentum_coupling:
    the wheels' momentum h_w in the body's Euler equations (on: complete physics, off: eq. 2.27
    as the thesis writes it); control_period: lockstep tick [s]; wheel_set: the wheels and their
    spin axes (wheel_set.py); fdi_period / fdi_sampling: the observers' sample period [s] and how
    control-rate data becomes one FDI sample; magnetic_field: the geomagnetic model of a run in orbit
    (geomagnetic.py; no effect without an orbit); vehicle: the name of the spacecraft the run flies
    (vehicle.py): the FDI's networks and bands are fitted for one vehicle and refuse another.
"""

    emf_limit: str = "kf_scaled"
    wheel_momentum_coupling: bool = True
    control_period: float = 0.1
    wheel_set: str = DEFAULT_WHEEL_SET
    fdi_period: float = FDI_PERIOD
    fdi_sampling: str = FDI_SAMPLING
    magnetic_field: str = "igrf"
    vehicle: str = DEFAULT_VEHICLE

    def __post_init__(self):
        if not isinstance(self.vehicle, str) or not self.vehicle:
            raise PlantChoiceError(f"vehicle must be a vehicle's name, got {self.vehicle!r}")
        if self.magnetic_field not in FIELD_MODELS:
            raise PlantChoiceError(f"magnetic_field must be one of {', '.join(FIELD_MODELS)}, "
                                   f"got {self.magnetic_field!r}")
        if self.emf_limit not in EMF_LIMITS:
            raise PlantChoiceError(f"emf_limit must be one of {', '.join(EMF_LIMITS)}, got {self.emf_limit!r}")
        if not isinstance(self.wheel_momentum_coupling, bool):
            raise PlantChoiceError("wheel_momentum_coupling must be true or false, "
                                   f"got {self.wheel_momentum_coupling!r}")
        if self.wheel_set not in WHEEL_SETS:
            raise PlantChoiceError(f"wheel_set must be one of {', '.join(WHEEL_SETS)}, got {self.wheel_set!r}")
        if self.fdi_sampling not in SAMPLINGS:
            raise PlantChoiceError(f"fdi_sampling must be one of {', '.join(SAMPLINGS)}, got {self.fdi_sampling!r}")
        for key in ("control_period", "fdi_period"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 1e-3 <= value <= 10.0:
                raise PlantChoiceError(f"{key} must be a number of seconds in [0.001, 10], got {value!r}")

    @classmethod
    def for_scenario(cls, scenario_plant: dict | None = None, **overrides) -> "PlantChoices":
        """A new run's choices: the scenario's ``plant:`` mapping, then overrides that are not None.

        Parameters
        ----------
        scenario_plant : dict or None
            The scenario's ``plant:`` mapping.
        **overrides
            Choice -> value; None or '' leaves the scenario's.

        Returns
        -------
        PlantChoices
            The choices.
        """
        given = {k: v for k, v in (scenario_plant or {}).items() if k in RECORDED_KEYS}
        given.update({k: v for k, v in overrides.items() if v is not None and v != ""})
        return cls(**given)

    @classmethod
    def from_recorded(cls, recorded: dict | None) -> "PlantChoices":
        """What a bag, model card or threshold file was made under; missing keys take LEGACY values.

        Parameters
        ----------
        recorded : dict or None
            The recorded choices.

        Returns
        -------
        PlantChoices
            The choices.
        """
        known = {f.name for f in fields(cls)}
        values = {**LEGACY, **{k: v for k, v in (recorded or {}).items() if k in known}}
        return cls(**values)

    @classmethod
    def of_recording(cls, recorded: dict | None, fdi_sampling: str = FDI_SAMPLING) -> "PlantChoices":
        """What the FDI of a recorded run works under: the plant's choices as the bag's /scenario
        recorded them (from_recorded), the graph's FDI period and ``fdi_sampling``. A run simulated
        for the FDI without a bag gives its would-be record, ``scenario.plant_choices().scenario_dict()``.

        Parameters
        ----------
        recorded : dict or None
            The plant mapping of the bag's /scenario.
        fdi_sampling : str
            How the FDI samples the plant.

        Returns
        -------
        PlantChoices
            The choices.
        """
        return cls.from_recorded(recorded).with_(fdi_period=FDI_PERIOD, fdi_sampling=fdi_sampling)

    def as_dict(self) -> dict:
        """Every choice by name.

        Returns
        -------
        dict
            Field -> value.
        """
        return asdict(self)

    def scenario_dict(self) -> dict:
        """The part a bag's /scenario records (the graph fixes the FDI sampling).

        Returns
        -------
        dict
            Choice -> value.
        """
        return {k: getattr(self, k) for k in RECORDED_KEYS}

    def with_(self, **changes) -> "PlantChoices":
        """These choices with some changed.

        Parameters
        ----------
        **changes
            Field -> new value.

        Returns
        -------
        PlantChoices
            The new choices.
        """
        return replace(self, **changes)

    def differences(self, made_under: "PlantChoices", keys=None):
        """[(key, made_under value, our value)] where they differ (periods to 1e-12 s).

        Parameters
        ----------
        made_under : PlantChoices
            What a bag, model card or threshold file was made under.
        keys : sequence of str, optional
            The choices compared (default: every one).

        Returns
        -------
        list of tuple
            (key, made_under value, our value); pairs listed in EQUIVALENT do not count.
        """
        out = []
        for key in keys or [f.name for f in fields(self)]:
            ours, theirs = getattr(self, key), getattr(made_under, key)
            same = abs(ours - theirs) <= 1e-12 if isinstance(ours, float) else ours == theirs
            if not same and (key, theirs, ours) not in EQUIVALENT:
                out.append((key, theirs, ours))
        return out


DEFAULT = PlantChoices()
