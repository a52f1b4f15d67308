"""The FDI of a run as one typed value, the way rosbag2_py's StorageOptions carries a bag's storage: every
command, the launch file and the graph take it, and it resolves, loads and checks its files by one rule.

Paths: ``models`` (Elman networks) default to the method's shipped set; ``thresholds`` default to
``models`` when models are given (a directory ``rw-fdi defaults`` or ``train`` + ``fit-thresholds``
wrote; its ``unit_calibrated/`` with a unit calibration, where it has one, as config/fdi), else to the
shipped thresholds of the method and the unit calibration (paths.thresholds_dir).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

from .core.fdi.detection import METHODS, PERSISTENCE_MAX, observers_of
from .core.fdi.threshold_file import ThresholdError


@dataclass(frozen=True)
class FdiConfig:
    """What the FDI of a run is made of.

    Attributes
    ----------
    method : str
        'speed_aware' (ours) or 'thesis' (core/fdi/detection.METHODS).
    models, thresholds : str or None
        Directories of ``elman_<wheel>.npz`` and ``thresholds_<observer>.json``; None: the rule above.
    persistence : int or None
        P, samples above the threshold before an alarm, 1..PERSISTENCE_MAX; None: the threshold file's.
    unit_calibration : float
        [s] of each run the observers learn their wheel's unit from (speed_aware only); 0: the datasheet wheel.
    fdir : bool
        Whether the wheel allocation acts on the verdict (reconfiguration); False: detection alone.
    decision : str or None
        What makes /diagnostics: an observer of the method, or a vote 'KofN' of its N observers
        (core/fdi/verdict.decision_of); None: the method's decision observer.
    vehicle : str or None
        Whose shipped FDI the defaults are (paths.fdi_dir): the run's vehicle (:meth:`for_vehicle`); None: the
        thesis' MakSat (config/fdi).
    plugins : tuple of str
        Observers of the user's beside ours (core/fdi/observer_plugin.py: entry point names, ``module:Class`` or
        ``file.py:Class``), speed_aware only; their state and bands in the thresholds directory
        (``observer_<slot>.json``, ``thresholds_<slot>.json``).
    """

    method: str = "speed_aware"
    models: str | None = None
    thresholds: str | None = None
    persistence: int | None = None
    unit_calibration: float = 0.0
    fdir: bool = True
    vehicle: str | None = None
    decision: str | None = None
    plugins: tuple = ()

    def __post_init__(self):
        from .core.fdi.observer_plugin import absolute_spec   # a worker elsewhere finds a file.py:Class spec too
        object.__setattr__(self, "plugins", tuple(absolute_spec(p) for p in self.plugins or ()))
        if self.plugins and self.method != "speed_aware":
            raise ValueError("--observer needs --fdi-method speed_aware (a plug-in's residual is signed, with the "
                             "ripple bound)")
        if self.method not in METHODS:
            raise ValueError(f"fdi_method must be one of {', '.join(METHODS)}, got {self.method!r}")
        p = self.persistence
        if p is not None and (isinstance(p, bool) or int(p) != p or not 1 <= p <= PERSISTENCE_MAX):
            raise ValueError(f"persistence must be a whole number of FDI samples in [1, {PERSISTENCE_MAX}], got {p}")
        c = self.unit_calibration
        if not (isinstance(c, (int, float)) and math.isfinite(c) and c >= 0):
            raise ThresholdError(f"--unit-calibration must be a finite number of seconds >= 0, got {c}")
        if c and self.method != "speed_aware":
            raise ThresholdError("--unit-calibration needs --fdi-method speed_aware (the thesis' residual is unsigned)")
        self.decision_rule   # one line naming what it accepts

    @classmethod
    def of(cls, value) -> "FdiConfig":
        """An FdiConfig from itself or a mapping of its fields (None values: the defaults)."""
        if isinstance(value, cls):
            return value
        given = {k: v for k, v in dict(value or {}).items() if v is not None}
        return cls(**{**given, "unit_calibration": float(given.get("unit_calibration", 0.0))})

    def as_dict(self) -> dict:
        return asdict(self)

    @property
    def decision_rule(self):
        """The core/fdi/verdict.DecisionRule of this configuration (ValueError for one the method has not)."""
        from .core.fdi.verdict import decision_of
        try:
            return decision_of(self.decision or "", self.method, self.observers if self.plugins else None)
        except ValueError as exc:
            raise ValueError(f"--{exc}") from None

    def for_vehicle(self, vehicle: str) -> "FdiConfig":
        """This configuration for a run of ``vehicle`` (its name): the shipped FDI of that vehicle for what no
        file is given (the given files as they are: their bands refuse another vehicle, checked_curves)."""
        from dataclasses import replace
        from .core.mission.vehicle import DEFAULT_VEHICLE
        return replace(self, vehicle=None if vehicle == DEFAULT_VEHICLE else vehicle)

    def with_vehicle_dir(self, vehicle) -> "FdiConfig":
        """This configuration judging with ``vehicle``'s networks where ``vehicle`` is its FDI directory (`rw-fdi
        defaults --vehicle`, `rw-fdi telemetry --fit`) and no --models is given (its bands too, without
        --thresholds); else as it is."""
        from dataclasses import replace
        if vehicle and Path(vehicle).is_dir() and not self.models:
            return replace(self, models=str(Path(vehicle).resolve()))
        return self

    @property
    def observers(self) -> tuple:
        """The slots of the FDI's observers: the method's, then the plug-ins'."""
        return observers_of(self.method) + self.plugin_slots

    @property
    def plugin_slots(self) -> tuple:
        return tuple(cls.slot for cls in self.plugin_classes())

    def plugin_classes(self) -> tuple:
        """The plug-ins' WheelObserver classes (ObserverError, one line, for one not found or twice); found
        once per configuration (finding an entry point reads every installed package's metadata)."""
        if "_plugin_classes" in self.__dict__:
            return self.__dict__["_plugin_classes"]
        from .core.fdi.observer_plugin import ObserverError, load_observer
        classes = tuple(load_observer(spec) for spec in self.plugins)
        slots = [c.slot for c in classes]
        if len(set(slots)) != len(slots):
            raise ObserverError(f"--observer: a slot given twice ({', '.join(slots)})")
        object.__setattr__(self, "_plugin_classes", classes)   # not a field: not compared, copied or replaced
        return classes

    def __getstate__(self):   # to a worker: the specs, not the classes (one from a file.py is not importable there)
        return {k: v for k, v in self.__dict__.items() if k != "_plugin_classes"}

    @property
    def plugin_dirs(self) -> tuple:
        """Where a plug-in's trained state is looked for: the thresholds directory (and the one it is the
        ``unit_calibrated/`` of), then the models directory."""
        t = self.thresholds_dir
        return (t, *((t.parent,) if t.name == "unit_calibrated" else ()), self.models_dir)

    def load_plugins(self) -> tuple:
        """((class, state), ...) of the plug-ins: each with its trained state (ObserverError for one that
        trains and has none)."""
        from .core.fdi.observer_plugin import ObserverError, load_state, state_path, trains
        out = []
        for spec, cls in zip(self.plugins, self.plugin_classes()):
            state = load_state(self.plugin_dirs, cls.slot)
            if not state and trains(cls):
                raise ObserverError(f"observer {spec} is not trained: no {state_path(self.thresholds_dir, cls.slot)}"
                                    f" (`rw-fdi train --observer {spec} --simulate fault_free --out DIR`, then "
                                    "`rw-fdi fit-thresholds --observer ... --out DIR`)")
            out.append((cls, state))
        return tuple(out)

    @property
    def models_dir(self) -> Path:
        """``models``; else the networks the given bands were fitted with where they lie beside them (a
        directory `rw-fdi defaults` wrote); else the vehicle's shipped set; bands of your own given alone for a
        vehicle without one: the method's (what `fit-thresholds` fits with by default)."""
        from .core.fdi.elman import MODEL_SET
        from .paths import fdi_dir
        if self.models:
            return Path(self.models)
        if self.thresholds and (Path(self.thresholds) / MODEL_SET).is_file():
            return Path(self.thresholds)
        own = fdi_dir(self.method, self.vehicle)
        return fdi_dir(self.method) if self.thresholds and not own.is_dir() else own

    @property
    def thresholds_dir(self) -> Path:
        from .paths import thresholds_dir
        if not (self.thresholds or self.models):
            return thresholds_dir(self.method, self.unit_calibration, self.vehicle)
        # a directory laid out as config/fdi (rw-fdi defaults --vehicle): its calibrated bands beside
        base = Path(self.thresholds or self.models)
        own = base / "unit_calibrated"
        return own if self.unit_calibration > 0 and own.is_dir() else base

    def model_path(self, wheel: str) -> Path:
        """The network ``wheel`` runs (its own, or its type's: core/fdi/elman.network_path)."""
        from .core.fdi.elman import network_path
        return network_path(self.models_dir, wheel)

    def threshold_path(self, observer: str) -> Path:
        return self.thresholds_dir / f"thresholds_{observer}.json"

    def load_models(self) -> dict:
        """wheel -> ElmanWeights of the wheels the set was trained for, each a network of this method (ModelError
        names the file)."""
        from .core.fdi.elman import REGENERATE, ElmanWeights, ModelError, network_wheels
        if not self.models_dir.is_dir() and self.vehicle is not None:
            raise ModelError(f"no shipped {self.method} FDI for vehicle {self.vehicle} ({self.models_dir}): make it "
                             "with `rw-fdi defaults --vehicle FILE --out DIR` (speed_aware) and give --models DIR")
        weights = {}
        for a in network_wheels(self.models_dir):
            weights[a] = ElmanWeights.load(self.model_path(a))
            if weights[a].speed_aware != (self.method == "speed_aware"):
                raise ModelError(f"{self.model_path(a)}: not a network for fdi_method={self.method!r}; {REGENERATE}")
        return weights

    def load_thresholds(self, plant=None, duration: float | None = None) -> dict:
        """observer -> ThresholdCurves of this configuration, each through :func:`checked_curves`."""
        for slot, spec in zip(self.plugin_slots, self.plugins):
            if not self.threshold_path(slot).is_file():
                raise ThresholdError(f"no bands for observer {spec} in {self.thresholds_dir}: fit them with "
                                     f"`rw-fdi fit-thresholds --observer {spec} --simulate fault_free --out DIR` and "
                                     "give --thresholds DIR")
        return {obs: checked_curves(self.threshold_path(obs), obs, self.method, self.unit_calibration, plant, duration)
                for obs in self.observers}

    def check(self, plant=None, duration: float | None = None):
        """Load what the FDI nodes will load, before any process starts: one-line ModelError/ThresholdError.
        ``plant``: the run's PlantChoices (default: the defaults); ``duration`` [s]: the run's length."""
        from .core.mission.plant_choices import DEFAULT
        if self.unit_calibration and duration is not None and self.unit_calibration >= duration:
            raise ThresholdError(f"--unit-calibration {self.unit_calibration:g} s is not shorter than the "
                                 f"{duration:g} s run: the observers would spend all of it learning their wheels "
                                 "and judge none of it")
        self.load_models()
        self.load_plugins()
        self.load_thresholds(plant or DEFAULT, duration)

    def following_models(self) -> "FdiConfig":
        """This configuration with the method its models are made for (thesis: two-input networks): what
        replays and evaluations of given models take. ModelError for a missing or broken model."""
        from dataclasses import replace
        from .core.fdi.elman import ElmanWeights, network_wheels
        speed_aware = all(ElmanWeights.load(self.model_path(a)).speed_aware for a in network_wheels(self.models_dir))
        return replace(self, method="speed_aware" if speed_aware else "thesis",
                       unit_calibration=self.unit_calibration if speed_aware else 0.0)

    def load(self) -> tuple:
        """(ObserverModels: the Elman weights by wheel and the plug-ins, {observer: ThresholdCurves}) for the
        core loop (screen, evaluate, benches)."""
        from .core.fdi.observer_plugin import ObserverModels
        return ObserverModels(self.load_models(), self.load_plugins()), self.load_thresholds()

    def loaded(self, fdi_period: float = 1.0):
        """The core/fdi/pipeline.LoadedFdi of this configuration: what the core loop's FDI pipeline runs, as the
        isolation node runs it (its bands, models, decision, persistence and unit calibration)."""
        from .core.fdi.calibration import calibration_samples
        from .core.fdi.pipeline import LoadedFdi
        models, curves = self.load()
        return LoadedFdi(curves, models, self.decision_rule, self.persistence,
                         calibration_samples(self.unit_calibration, fdi_period))


def checked_curves(path, observer: str, method: str, unit_calibration: float = 0.0, plant=None,
                   duration: float | None = None):
    """The ThresholdCurves of ``observer`` at ``path``, checked against the method, the unit calibration and,
    where given, the run's PlantChoices (and FDI period) and length: one-line ThresholdError naming the file.
    What every command and the isolation node load thresholds through.

    Parameters
    ----------
    path : str or Path
        The threshold file (``thresholds_<observer>.json``).
    observer : str
        The observer slot the curves must be fitted for.
    method : str
        The FDI method, 'speed_aware' or 'thesis'.
    unit_calibration : float
        Time [s] of the run the observers learn their wheel's unit from; 0: the datasheet wheel.
    plant : PlantChoices, optional
        The run's plant choices, checked with its FDI period [s]; None: not checked.
    duration : float, optional
        The run's length [s], which the curves must cover; None: not checked.

    Returns
    -------
    ThresholdCurves
        The loaded curves (ThresholdError, naming the file, where a check fails).
    """
    from .core.fdi.threshold_file import ThresholdCurves
    path = str(path)
    curves = ThresholdCurves.load(path, observer)
    curves.check_method(method, origin=path)
    curves.check_unit_calibration(unit_calibration, origin=path)
    if plant is not None:
        curves.check_compatible(plant, origin=path)
        if abs(curves.sample_period - plant.fdi_period) > 1e-12:
            raise ThresholdError(f"{path}: sample period {curves.sample_period} s differs from the FDI period "
                                 f"{plant.fdi_period} s")
    if duration is not None:
        curves.check_horizon(duration, origin=path)
    return curves
