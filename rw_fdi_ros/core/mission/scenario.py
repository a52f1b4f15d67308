"""Scenarios: a seed, a duration, initial conditions, set-point changes and a fault schedule.

A scenario file (YAML, see docs/scenarios.md) fixes what is fixed;
everything it leaves open is drawn from the thesis Table 2.3 envelope with
the run's seed, so the same seed always gives the same run.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from datetime import date, datetime, timezone
from pathlib import Path

import numpy as np
import yaml

from ...paths import file_name
from ..physics.environment import MAGNETOMETER_PERIOD, OrbitEnvironment, magnetometer_steps
from ..physics.faults import FAULT_KINDS, Fault
from ..physics.geomagnetic import IGRF_YEARS
from ..physics.magnetorquers import MomentumDumping
from ..physics.orbit import CircularOrbit, OrbitError, TleOrbit
from .plant_choices import SCENARIO_KEYS, PlantChoiceError, PlantChoices
from ..physics.wheel_set import AXIS_WHEELS, WHEEL_SETS
from .vehicle import (DEFAULT_VEHICLE, DISPERSION_LIMITS, THESIS, UNIT_SPREAD_MAX, Dispersions, Vehicle,
                      VehicleError, load_vehicle, shipped_set_name)
from ..physics.wheel import UNIT_PARAMETERS, WheelParams, unit_wheel
from .yaml_text import MAX_CHARACTERS, YamlError, read_yaml

SEED_MAX = 2**63 - 1   # numpy's seeds are non-negative; the bags record them as int64
# [s] after a set-point change (or a fault's onset) the pointing error is the slew's: twice the thesis' 30 s
# settling target; the service bench judges the pointing outside it and the run summary counts a fault's error so
SETTLE_S = 60.0

# Thesis Table 2.3 ranges drawn per axis (the default vehicle's dispersions, vehicle.py).
ATTITUDE_RANGE_DEG = Dispersions().attitude_deg
BODY_RATE_RANGE = Dispersions().body_rate
WHEEL_SPEED_RANGE = Dispersions().wheel_speed
SETPOINT_CHANGE_RANGE_DEG = Dispersions().setpoint_change_deg


# `plant.vehicle` is a record (a bag's /scenario): it must name the scenario's own vehicle
PLANT_KEYS = set(SCENARIO_KEYS) | {"vehicle"}


class ScenarioError(ValueError):
    """A scenario that cannot be run; the message is one line, fit for a user."""


@dataclass(frozen=True)
class SetpointChange:
    time: float
    change_deg: tuple | None  # None: drawn from Table 2.3 (-5..5 deg per axis)


@dataclass(frozen=True)
class Manoeuvres:
    """A spacecraft in service: set-point changes at random times, each ``interval_s`` (uniform in the
    range) after the one before, from ``start_s`` on, every axis moved by a size uniform in ``size_deg``
    (Table 2.3's -5..5 deg by default). Drawn from a stream of their own: the initial conditions and the
    disturbance of a seed do not move when manoeuvres are added."""

    interval_s: tuple = (60.0, 300.0)
    size_deg: tuple = SETPOINT_CHANGE_RANGE_DEG
    start_s: float = 0.0

    def draw(self, seed: int, duration: float) -> list:
        """[(time, change [deg] per axis)] of the changes inside (start_s, duration).

        Parameters
        ----------
        seed : int
            The scenario's seed.
        duration : float
            The run's duration [s].

        Returns
        -------
        list of tuple
            (time [s], (3,) change [deg]).
        """
        rng = np.random.default_rng([int(seed), 3])
        out, t = [], self.start_s
        while True:
            t += rng.uniform(*self.interval_s)
            if t >= duration:
                return out
            out.append((t, rng.uniform(*self.size_deg, 3)))


@dataclass(frozen=True)
class InitialConditions:
    attitude: np.ndarray      # [rad], per axis
    body_rate: np.ndarray     # [rad/s]
    wheel_speed: np.ndarray   # [rad/s]


@dataclass(frozen=True)
class Scenario:
    name: str
    duration: float = 400.0
    seed: int = 0
    faults: tuple = ()
    setpoints: tuple = (SetpointChange(0.0, None),)
    initial: dict = field(default_factory=dict)  # fixed initial conditions (deg / rad/s)
    description: str = ""
    plant: dict = field(default_factory=dict)   # plant choices the run was made under (emf_limit, ...)
    wheels: dict = field(default_factory=dict)  # unit-to-unit variation (variation, spread, scale); {}: datasheet
    manoeuvres: Manoeuvres | None = None        # set-point changes at random times beside ``setpoints``
    environment: OrbitEnvironment | None = None  # in orbit (environment.py); None: no orbit, no field
    magnetorquers: MomentumDumping | None = None  # rods and their dumping law (magnetorquers.py)
    source_text: str = ""     # the YAML it came from, recorded in every bag
    vehicle: Vehicle | None = None   # the spacecraft (vehicle.py); None: the thesis' (config/vehicles/maksat.yaml)

    @property
    def spacecraft(self) -> Vehicle:
        """The vehicle the run flies: its own, else the default (the thesis' MakSat)."""
        return self.vehicle if self.vehicle is not None else THESIS

    def with_seed(self, seed: int) -> "Scenario":
        """This scenario with another seed.

        Parameters
        ----------
        seed : int
            The seed.

        Returns
        -------
        Scenario
            The new scenario.
        """
        if not 0 <= int(seed) <= SEED_MAX:
            raise ScenarioError(f"scenario {self.name}: seed {seed} is not a whole number in [0, {SEED_MAX}]")
        return replace(self, seed=int(seed))

    def with_faults(self, faults) -> "Scenario":
        """This scenario with other faults.

        Parameters
        ----------
        faults : iterable of core.physics.faults.Fault
            The faults.

        Returns
        -------
        Scenario
            The new scenario.
        """
        return replace(self, faults=tuple(faults))

    # -- draws ---------------------------------------------------------------
    def _rng(self):
        return np.random.default_rng([int(self.seed), 0])

    def disturbance_rng(self):
        """Independent stream for the external disturbance (eq. 2.34).

        Returns
        -------
        numpy.random.Generator
            The stream, keyed by the seed.
        """
        return np.random.default_rng([int(self.seed), 1])

    def draws(self):
        """Initial conditions and set-point changes, Table 2.3 uniform draws unless fixed.

        Returns
        -------
        tuple
            (InitialConditions, [(time [s], (3,) set-point change [rad])]).
        """
        rng = self._rng()
        d = self.spacecraft.dispersions
        att = rng.uniform(*d.attitude_deg, 3)
        rate = rng.uniform(*d.body_rate, 3)
        speed = rng.uniform(*d.wheel_speed, len(self.wheel_set().active))   # each active wheel's
        changes = [rng.uniform(*d.setpoint_change_deg, 3) for _ in self.setpoints]
        fixed = self.initial
        att = np.asarray(fixed.get("attitude_deg", att), float)
        rate = np.asarray(fixed.get("body_rate", rate), float)
        speed = np.asarray(fixed.get("wheel_speed", speed), float)
        ic = InitialConditions(np.deg2rad(att), rate, speed)
        steps = []
        for sp, drawn in zip(self.setpoints, changes):
            steps.append((sp.time, np.deg2rad(drawn if sp.change_deg is None else np.asarray(sp.change_deg, float))))
        if self.manoeuvres is not None:
            steps += [(t, np.deg2rad(change)) for t, change in self.manoeuvres.draw(self.seed, self.duration)]
        return ic, steps

    def unit_scales(self, count: int = 3) -> dict | None:
        """Each of ``count`` wheels' parameters over the datasheet's (UNIT_PARAMETERS -> (count,) shares),
        or None for datasheet wheels. Drawn N(1, spread) cut at 3 sigma from a stream of their own (the
        initial conditions and the disturbance do not move); the first three wheels' from the stream they
        always came from, any further wheel's (the redundant one) from another, so adding a wheel moves
        none of the three. ``scale`` entries are taken as given (3 values: the first three wheels).

        Parameters
        ----------
        count : int
            The number of wheels N.

        Returns
        -------
        dict or None
            Parameter name -> (N,) shares of the datasheet's value.
        """
        if not self.wheels:
            return None
        spread = self.spacecraft.dispersions.unit_spreads if self.wheels.get("variation") else {}
        spread.update(self.wheels.get("spread", {}))
        rngs = [np.random.default_rng([int(self.seed), 2]), np.random.default_rng([int(self.seed), 4])]
        out = {}
        for name in UNIT_PARAMETERS:   # every draw made, used or not: one parameter's spread moves no other
            z = np.concatenate([np.clip(rng.standard_normal(n), -3.0, 3.0)
                                for rng, n in zip(rngs, (3, max(count - 3, 0)))])[:count]
            out[name] = 1.0 + spread.get(name, 0.0) * z
        for name, values in self.wheels.get("scale", {}).items():
            given = np.asarray(values, float)
            out[name] = np.concatenate([given, out[name][len(given):]])[:count]
        return out

    def datasheet(self, choices: PlantChoices | None = None) -> WheelParams:
        """The wheel type the run flies: its vehicle's datasheet under the run's plant choice emf_limit
        (``choices``, default this scenario's).

        Parameters
        ----------
        choices : PlantChoices or None
            The run's plant choices (default: this scenario's).

        Returns
        -------
        core.physics.wheel.WheelParams
            The datasheet wheel.
        """
        return replace(self.spacecraft.wheel, emf_limit=(choices or self.plant_choices()).emf_limit)

    def wheel_params(self, base: WheelParams | None = None) -> WheelParams:
        """The plant's wheels for this scenario: ``base`` (default: its vehicle's datasheet) or its units
        (unit_scales).

        Parameters
        ----------
        base : core.physics.wheel.WheelParams or None
            The datasheet (default: its vehicle's).

        Returns
        -------
        core.physics.wheel.WheelParams
            ``base``, or its units ((N,) per parameter) when the scenario varies them.
        """
        base = self.spacecraft.wheel if base is None else base
        scales = self.unit_scales(self.wheel_set().count)
        return base if scales is None else unit_wheel(base, scales)

    def wheel_set(self, recorded: bool = False):
        """The run's wheels (plant choice ``wheel_set``, wheel_set.py). ``recorded``: this is a bag's
        /scenario, whose plant mapping lacks the choice if it predates it (the three-wheel set then).

        Parameters
        ----------
        recorded : bool
            Whether this is a bag's /scenario.

        Returns
        -------
        core.physics.wheel_set.WheelSet
            The wheel set.
        """
        from ..physics.wheel_set import wheel_set
        return wheel_set(PlantChoices.from_recorded(self.plant).wheel_set if recorded
                         else self.plant_choices().wheel_set)

    def setpoint_schedule(self):
        """(times, attitude set-points [rad] of shape (n, 3)): piecewise constant from each time on.

        Returns
        -------
        tuple of numpy.ndarray
            (n,) times [s] and (n, 3) attitude set-points [rad].
        """
        ic, steps = self.draws()
        times, values, current = [], [], ic.attitude.copy()
        for t, change in sorted(steps, key=lambda s: s[0]):
            current = current + change
            times.append(t)
            values.append(current.copy())
        if not times or times[0] > 0.0:
            times.insert(0, 0.0)
            values.insert(0, ic.attitude.copy())
        return np.asarray(times, float), np.asarray(values, float)

    def effective_text(self, plant: dict | None = None) -> str:
        """The scenario YAML with the seed and plant choices actually used: what a bag records,
        enough to redo the run.

        Parameters
        ----------
        plant : dict or None
            Plant choices to record beside the scenario's own.

        Returns
        -------
        str
            The YAML text.
        """
        raw = read_yaml(self.source_text, self.name) if self.source_text else {"name": self.name}
        raw = dict(raw or {})
        raw["seed"] = int(self.seed)
        scales = self.unit_scales(self.wheel_set().count)
        if scales is not None:   # the units' values, so the bag alone redoes the run
            raw["wheels"] = {**raw.get("wheels", {}),
                             "scale": {k: [float(x) for x in v] for k, v in scales.items()}}
        if plant:
            raw["plant"] = {**raw.get("plant", {}), **plant}
        if self.vehicle is not None:   # the whole vehicle, not its file's name: the bag alone redoes the run
            raw["vehicle"] = self.vehicle.as_dict()
        raw.setdefault("name", self.name)
        return yaml.safe_dump(raw, sort_keys=False)

    def plant_choices(self, **overrides) -> PlantChoices:
        """The choices this scenario runs under (its ``plant:`` mapping, then overrides not None). A scenario
        that names a vehicle flies its wheel set: another one asked for is refused (its bag would not parse).

        Parameters
        ----------
        **overrides
            Choice -> value; None leaves the scenario's.

        Returns
        -------
        PlantChoices
            The choices.
        """
        choices = PlantChoices.for_scenario(self.plant, **overrides)
        if self.vehicle is not None and choices.wheel_set != self.plant.get("wheel_set", choices.wheel_set):
            raise PlantChoiceError(f"wheel_set {choices.wheel_set!r}: scenario {self.name} flies vehicle "
                                   f"{self.vehicle.name}, whose wheel set is {self.plant['wheel_set']}")
        return choices

    def fault_free(self) -> "Scenario":
        """This scenario without its faults.

        Returns
        -------
        Scenario
            The new scenario.
        """
        return replace(self, faults=())


def setpoint_at(times, values, t):
    """Set-point in force at time t from a schedule of :meth:`Scenario.setpoint_schedule`.

    Parameters
    ----------
    times : array_like, shape (n,)
        Times the set-points take effect [s], ascending.
    values : array_like, shape (n, 3)
        Attitude set-points [rad].
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (3,)
        The set-point [rad] (the first before ``times[0]``).
    """
    i = int(np.searchsorted(times, t + 1e-9, side="right")) - 1
    return values[max(i, 0)]


def in_transient(time, starts, settle: float = SETTLE_S):
    """Whether ``time`` lies within ``settle`` seconds after one of ``starts`` (set-point changes, onsets):
    where the pointing is a slew's (or a fault's first) error, not a steady one.

    Parameters
    ----------
    time : float or array_like
        Time(s) [s].
    starts : iterable of float
        When each transient begins [s]; those at or before 0 are the run's start, not a change.
    settle : float
        How long each lasts [s].

    Returns
    -------
    bool or ndarray of bool
        Per time.
    """
    t = np.asarray(time, float)
    out = np.zeros(t.shape, bool)
    for start in starts:
        if start > 0.0:
            out |= (t >= start) & (t < start + settle)
    return out if out.ndim else bool(out)


# -- parsing -----------------------------------------------------------------
def _num(where, value, lo=None, hi=None):
    if isinstance(value, str):   # YAML 1.1 reads 1e12 (no dot) as text: take what the user meant
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: expected a finite number, got {value!r}"[:300])
    try:
        number = float(value)   # an int beyond a double's range overflows here
    except OverflowError:
        number = float("inf")
    if not np.isfinite(number):
        raise ScenarioError(f"{where}: expected a finite number, got {value!r}"[:300])
    if (lo is not None and number < lo) or (hi is not None and number > hi):
        raise ScenarioError(f"{where}: {value} is outside [{lo}, {hi}]"[:300])
    return number


def _wheel(where, value, names=AXIS_WHEELS):
    """The index of a wheel named in a scenario (one of ``names``, its wheel set's; or its index)."""
    if isinstance(value, str) and value.lower() in names:
        return names.index(value.lower())
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < len(names):
        return value
    raise ScenarioError(f"{where}: wheel must be one of {', '.join(names)}, got {value!r}")


FAULT_LIMITS = {"bus_voltage": (0.0, 40.0), "current_limiter": (0.0, 1.0),
                 "temperature": (-100.0, 400.0), "ripple_gain": (0.0, 10.0)}


def _fault(where, raw, duration, names=AXIS_WHEELS):
    if not isinstance(raw, dict):
        raise ScenarioError(f"{where}: expected a mapping with kind, wheel, onset, value")
    unknown = set(raw) - {"kind", "wheel", "onset", "value", "ramp"}
    if unknown:
        raise ScenarioError(f"{where}: unknown field(s) {sorted(unknown)}")
    kind = raw.get("kind")
    if kind not in FAULT_KINDS:
        raise ScenarioError(f"{where}.kind: must be one of {', '.join(FAULT_KINDS)}, got {kind!r}")
    for key in ("wheel", "onset", "value"):
        if key not in raw:
            raise ScenarioError(f"{where}: missing '{key}'")
    return Fault(kind=kind, wheel=_wheel(f"{where}.wheel", raw["wheel"], names),
                 onset=_num(f"{where}.onset", raw["onset"], 0.0, duration),
                 value=_num(f"{where}.value", raw["value"], *FAULT_LIMITS[kind]),
                 ramp=_num(f"{where}.ramp", raw.get("ramp", 0.0), 0.0, None))


def _vector(where, raw, lengths=(3,), lo=None, hi=None, longer: str = "every wheel"):
    if not isinstance(raw, (list, tuple)) or len(raw) not in lengths:
        what = "3 numbers (x, y, z)" if set(lengths) == {3} else f"3 numbers (x, y, z) or {max(lengths)} ({longer})"
        raise ScenarioError(f"{where}: expected a list of {what}")
    return tuple(_num(f"{where}[{i}]", v, lo, hi) for i, v in enumerate(raw))


# What a scenario may ask of the spacecraft, checked before anything runs (every command parses scenarios here):
# a set-point change or an initial attitude of at most half a turn per axis (the manoeuvres' size_deg alike), a
# body rate the controllers are meant for, and no wheel beyond its speed limiter's threshold (Table 2.2's w_s),
# where the wheel model ends.
ANGLE_LIMIT_DEG = DISPERSION_LIMITS["attitude_deg"]
BODY_RATE_LIMIT = DISPERSION_LIMITS["body_rate"]            # [rad/s]
WHEEL_SPEED_LIMIT = WheelParams().overspeed_threshold      # [rad/s]
INITIAL_LIMITS = {"attitude_deg": ANGLE_LIMIT_DEG, "body_rate": BODY_RATE_LIMIT, "wheel_speed": WHEEL_SPEED_LIMIT}


# A scenario is a few KB written by hand (the largest recorded one, with every unit's scale, under 2 KB);
# 100 KB is not one, and YAML would take seconds to say so of a megabyte.
MAX_SCENARIO_CHARS = 100_000


def parse_scenario(text: str, origin: str = "<scenario>") -> Scenario:
    """Parse and validate scenario YAML; every problem is a one-line ScenarioError.

    Parameters
    ----------
    text : str
        The YAML (docs/scenarios.md).
    origin : str, optional
        Where it came from (a path), for the messages and the default name.

    Returns
    -------
    Scenario
        The scenario, ``source_text`` = ``text``.
    """
    if len(text) > MAX_SCENARIO_CHARS:
        raise ScenarioError(f"{origin}: {len(text):,} characters is not a scenario (at most "
                            f"{MAX_SCENARIO_CHARS:,}; a scenario is a few KB of YAML)")
    try:
        raw = read_yaml(text, origin)
    except YamlError as exc:
        raise ScenarioError(str(exc)) from None
    if not isinstance(raw, dict):
        raise ScenarioError(f"{origin}: a scenario is a YAML mapping (name, duration, faults, ...)")
    unknown = set(raw) - {"name", "description", "duration", "seed", "faults", "setpoints", "initial", "plant",
                          "wheels", "manoeuvres", "environment", "magnetorquers", "vehicle"}
    if unknown:
        raise ScenarioError(f"{origin}: unknown field(s) {sorted(unknown)}")
    duration = _num(f"{origin}: duration", raw.get("duration", 400.0), 1.0, 1e6)
    seed = raw.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed <= SEED_MAX:
        raise ScenarioError(f"{origin}: seed must be a whole number in [0, {SEED_MAX}], got {seed!r}"[:300])
    sps_raw = raw.get("setpoints", [{"time": 0.0, "change_deg": "random"}])
    if not isinstance(sps_raw, list):
        raise ScenarioError(f"{origin}: setpoints must be a list")
    setpoints = []
    for i, sp in enumerate(sps_raw):
        where = f"{origin}: setpoints[{i}]"
        if not isinstance(sp, dict) or "time" not in sp:
            raise ScenarioError(f"{where}: expected a mapping with time and change_deg")
        change = sp.get("change_deg", "random")
        setpoints.append(SetpointChange(_num(f"{where}.time", sp["time"], 0.0, duration),
                                        None if change == "random" else _vector(f"{where}.change_deg", change,
                                                                                  lo=-ANGLE_LIMIT_DEG,
                                                                                  hi=ANGLE_LIMIT_DEG)))
    initial_raw = raw.get("initial") or {}
    if not isinstance(initial_raw, dict):
        raise ScenarioError(f"{origin}: initial must be a mapping")
    bad = set(initial_raw) - {"attitude_deg", "body_rate", "wheel_speed"}
    if bad:
        raise ScenarioError(f"{origin}: initial: unknown field(s) {sorted(bad)}")
    plant = raw.get("plant") or {}
    if not isinstance(plant, dict) or set(plant) - PLANT_KEYS:
        raise ScenarioError(f"{origin}: plant may set only {sorted(PLANT_KEYS)}")
    if "control_period" in plant:
        _num(f"{origin}: plant.control_period", plant["control_period"], 1e-3, 1.0)
    vehicle = _vehicle(origin, raw.get("vehicle"))
    if vehicle is not None:
        plant = {**plant, "wheel_set": _vehicle_wheel_set(origin, vehicle, plant)}
        # its wheel's EMF limiting is the plant choice (one source: the graph and the bag read the choice)
        plant.setdefault("emf_limit", vehicle.wheel.emf_limit)
    named = DEFAULT_VEHICLE if vehicle is None else vehicle.name
    if plant.get("vehicle", named) != named:
        raise ScenarioError(f"{origin}: plant.vehicle {plant['vehicle']!r} records another vehicle than the "
                            f"scenario's ({named}); name the vehicle under `vehicle:`")
    if vehicle is not None:
        plant["vehicle"] = vehicle.name
    try:
        wheels = WHEEL_SETS[PlantChoices.for_scenario(plant).wheel_set]
    except PlantChoiceError as exc:
        raise ScenarioError(f"{origin}: plant.{exc}") from None
    names = wheels.names
    initial = {k: _vector(f"{origin}: initial.{k}", v, (3, len(wheels.active)) if k == "wheel_speed" else (3,),
                          lo=-INITIAL_LIMITS[k], hi=INITIAL_LIMITS[k], longer="every wheel in use")
               for k, v in initial_raw.items()}
    faults_raw = raw.get("faults") or []
    if not isinstance(faults_raw, list):
        raise ScenarioError(f"{origin}: faults must be a list")
    faults = tuple(_fault(f"{origin}: faults[{i}]", f, duration, names) for i, f in enumerate(faults_raw))
    name = str(raw.get("name") or Path(origin).stem)
    try:   # it names the run's bag and figure: a path here would write outside --out
        file_name(name)
    except ValueError as exc:
        raise ScenarioError(f"{origin}: name: {exc}") from None
    environment = _environment(f"{origin}: environment", raw.get("environment"), duration)
    period = float(plant.get("control_period", PlantChoices().control_period))
    try:
        if environment is not None:
            magnetometer_steps(period)
    except ValueError:
        raise ScenarioError(f"{origin}: plant.control_period {period:g} s does not divide the magnetometer's "
                            f"{MAGNETOMETER_PERIOD:g} s (in orbit)") from None
    magnetorquers = _magnetorquers(f"{origin}: magnetorquers", raw.get("magnetorquers"),
                                   None if vehicle is None else vehicle.magnetorquers)
    if magnetorquers is not None and environment is None:
        raise ScenarioError(f"{origin}: magnetorquers need a field: give the scenario an environment (an orbit)")
    return Scenario(name=name, duration=duration, seed=seed, faults=faults, setpoints=tuple(setpoints),
                    initial=initial, description=str(raw.get("description", "")), plant=dict(plant),
                    wheels=_wheels(f"{origin}: wheels", raw.get("wheels"), len(names)),
                    manoeuvres=_manoeuvres(f"{origin}: manoeuvres", raw.get("manoeuvres"), duration, vehicle),
                    source_text=text,
                    environment=environment, magnetorquers=magnetorquers, vehicle=vehicle)


def _vehicle(origin: str, raw) -> Vehicle | None:
    """A scenario's ``vehicle:``: a shipped vehicle's name, a vehicle file's path (relative to the scenario's
    folder when the scenario is a file) or the vehicle's mapping itself (what a bag records)."""
    if raw is None:
        return None
    if isinstance(raw, str) and not raw.endswith((".yaml", ".yml")) or isinstance(raw, dict):
        source = raw
    elif isinstance(raw, str):
        path = Path(raw).expanduser()
        source = path if path.is_absolute() else Path(origin).parent / path   # "<scenario>": the working folder
    else:
        raise ScenarioError(f"{origin}: vehicle: a shipped vehicle's name, a vehicle file or its mapping, got {raw!r}")
    try:
        vehicle = load_vehicle(source)
    except VehicleError as exc:
        raise ScenarioError(f"{origin}: vehicle: {exc}") from None
    return vehicle


def _vehicle_wheel_set(origin: str, vehicle: Vehicle, plant: dict) -> str:
    """The plant choice ``wheel_set`` of a scenario that names a vehicle: its vehicle's set, which must be one
    the graph knows by name (a shipped set; a set of the vehicle's own is for a later step), and not another
    one under ``plant:``."""
    known = shipped_set_name(vehicle.wheel_set)   # a Vehicle built in code may hold another (a file's may not)
    if known is None:
        raise ScenarioError(f"{origin}: vehicle: its wheel set {vehicle.wheel_set.name!r} is not one of the shipped "
                            f"sets ({', '.join(WHEEL_SETS)}); wheel sets of a vehicle's own are not flown yet")
    if plant.get("wheel_set", known) != known:
        raise ScenarioError(f"{origin}: plant.wheel_set {plant['wheel_set']!r}: the vehicle holds its wheel set "
                            f"({known})")
    return known


def _range(where, raw, lo, hi) -> tuple:
    if not isinstance(raw, (list, tuple)) or len(raw) != 2:
        raise ScenarioError(f"{where}: expected [low, high]")
    low, high = (_num(f"{where}[{i}]", v, lo, hi) for i, v in enumerate(raw))
    if low > high:
        raise ScenarioError(f"{where}: low {low:g} above high {high:g}")
    return low, high


def _manoeuvres(where, raw, duration, vehicle: Vehicle | None = None) -> Manoeuvres | None:
    """The ``manoeuvres:`` mapping: interval_s [low, high] (>= 1 s), size_deg [low, high] per axis (default:
    the vehicle's set-point changes), start_s."""
    if raw is None:
        return None
    if not isinstance(raw, dict) or set(raw) - {"interval_s", "size_deg", "start_s"}:
        raise ScenarioError(f"{where}: a mapping of interval_s, size_deg and start_s")
    default = Manoeuvres(size_deg=(vehicle or THESIS).dispersions.setpoint_change_deg)
    return Manoeuvres(interval_s=_range(f"{where}.interval_s", raw.get("interval_s", default.interval_s), 1.0, 1e6),
                      size_deg=_range(f"{where}.size_deg", raw.get("size_deg", default.size_deg), -ANGLE_LIMIT_DEG,
                                      ANGLE_LIMIT_DEG),
                      start_s=_num(f"{where}.start_s", raw.get("start_s", 0.0), 0.0, duration))


def _environment(where, raw, duration: float) -> OrbitEnvironment | None:
    """The ``environment:`` mapping: orbit (altitude_km, inclination_deg, raan_deg, argument_of_latitude_deg)
    or tle (its two lines), epoch (UTC date-time, IGRF's years), residual_dipole [A m^2] (x, y, z)."""
    if raw is None:
        return None
    if raw is True:
        raw = {}
    if not isinstance(raw, dict) or set(raw) - {"orbit", "tle", "epoch", "residual_dipole"}:
        raise ScenarioError(f"{where}: a mapping of orbit (or tle), epoch and residual_dipole")
    if "orbit" in raw and "tle" in raw:
        raise ScenarioError(f"{where}: give an orbit or a tle, not both")
    if "tle" in raw:
        lines = raw["tle"]
        if not isinstance(lines, list) or len(lines) != 2 or not all(isinstance(x, str) for x in lines):
            raise ScenarioError(f"{where}.tle: expected the element set's two lines as two strings")
        orbit = TleOrbit(*(x.strip() for x in lines))
        try:
            orbit.satellite()
        except OrbitError as exc:
            raise ScenarioError(f"{where}.tle: {exc}") from None
    else:
        elements = {} if raw.get("orbit") is None else raw["orbit"]
        limits = {"altitude_km": (150.0, 40000.0), "inclination_deg": (0.0, 180.0),
                  "raan_deg": (-360.0, 360.0), "argument_of_latitude_deg": (-360.0, 360.0)}
        if not isinstance(elements, dict) or set(elements) - set(limits):
            raise ScenarioError(f"{where}.orbit: may set only {', '.join(limits)}")
        orbit = CircularOrbit(**{k: _num(f"{where}.orbit.{k}", v, *limits[k]) for k, v in elements.items()})
    epoch = None
    if "epoch" in raw:
        value = raw["epoch"]
        try:
            epoch = value if isinstance(value, datetime) else (
                datetime(value.year, value.month, value.day) if isinstance(value, date)
                else datetime.fromisoformat(str(value)))
        except ValueError:
            raise ScenarioError(f"{where}.epoch: expected a UTC date-time like 2026-01-01T00:00:00, "
                                f"got {value!r}") from None
        epoch = epoch.replace(tzinfo=timezone.utc) if epoch.tzinfo is None else epoch.astimezone(timezone.utc)
    start = epoch or OrbitEnvironment(orbit=orbit).start()
    if not IGRF_YEARS[0] <= start.year < IGRF_YEARS[1]:
        what = "epoch" if epoch is not None else "tle (its epoch)"
        raise ScenarioError(f"{where}.{what}: {start.date()} is outside the field model's years "
                            f"{IGRF_YEARS[0]}-{IGRF_YEARS[1] - 1}")
    if isinstance(orbit, TleOrbit):
        try:   # SGP4 must carry the element set through the whole run
            orbit.position([0.0, duration], start)
        except OrbitError as exc:
            raise ScenarioError(f"{where}.tle: {exc}") from None
    given = {} if "residual_dipole" not in raw else {
        "residual_dipole": tuple(_num(f"{where}.residual_dipole[{i}]", v, -100.0, 100.0)
                                 for i, v in enumerate(_vector(f"{where}.residual_dipole", raw["residual_dipole"])))}
    return OrbitEnvironment(orbit=orbit, epoch=epoch, **given)


def _magnetorquers(where, raw, base: MomentumDumping | None = None) -> MomentumDumping | None:
    """The ``magnetorquers:`` mapping: dipole_limit [A m^2], and dumping: true, false (rods idle) or a
    mapping of gain [1/s], start_speed and stop_speed [rad/s]; what it leaves out is ``base``'s (the
    vehicle's rods and law, default the thesis vehicle's)."""
    if raw is None:
        return None
    if raw is True:
        raw = {}
    if not isinstance(raw, dict) or set(raw) - {"dipole_limit", "dumping"}:
        raise ScenarioError(f"{where}: a mapping of dipole_limit and dumping")
    values = {}
    if "dipole_limit" in raw:
        values["dipole_limit"] = _num(f"{where}.dipole_limit", raw["dipole_limit"], 0.0, 1000.0)
    dumping = raw.get("dumping", True)
    if isinstance(dumping, bool):
        values["enabled"] = dumping
    elif isinstance(dumping, dict) and not set(dumping) - {"gain", "start_speed", "stop_speed"}:
        limits = {"gain": (0.0, 1.0), "start_speed": (0.0, 1000.0), "stop_speed": (0.0, 1000.0)}
        values.update({k: _num(f"{where}.dumping.{k}", v, *limits[k]) for k, v in dumping.items()})
    else:
        raise ScenarioError(f"{where}.dumping: true, false or a mapping of gain, start_speed and stop_speed")
    settings = replace(base or MomentumDumping(), **values)
    if settings.stop_speed > settings.start_speed:
        raise ScenarioError(f"{where}.dumping: stop_speed {settings.stop_speed:g} above start_speed "
                            f"{settings.start_speed:g}")
    return settings


# a spread's draws are cut at 3 sigma, so every drawn scale lies inside the range a `scale` may give:
# the bag's recorded scenario always parses again
UNIT_SCALE_RANGE = (0.05, 5.0)


def _wheels(where, raw, count: int = 3) -> dict:
    """The ``wheels:`` mapping: variation (true: every unit parameter drawn with its default spread),
    spread (name -> 1-sigma share), scale (name -> shares of the datasheet: x y z, or one per wheel of
    the set's ``count``; a run's bag records all of them)."""
    if not raw:
        return {}
    if not isinstance(raw, dict) or set(raw) - {"variation", "spread", "scale"}:
        raise ScenarioError(f"{where}: a mapping of variation, spread and scale")
    out = {}
    if "variation" in raw:
        if not isinstance(raw["variation"], bool):
            raise ScenarioError(f"{where}.variation: true or false, got {raw['variation']!r}")
        out["variation"] = raw["variation"]
    for key, check in (("spread", lambda w, v: _num(w, v, 0.0, UNIT_SPREAD_MAX)),
                       ("scale", lambda w, v: tuple(_num(f"{w}[{i}]", x, *UNIT_SCALE_RANGE) for i, x in enumerate(
                           _vector(w, v, (3, count)))))):
        table = raw.get(key) or {}
        if not isinstance(table, dict) or set(table) - set(UNIT_PARAMETERS):
            raise ScenarioError(f"{where}.{key}: may set only {', '.join(UNIT_PARAMETERS)}")
        if table:
            out[key] = {name: check(f"{where}.{key}.{name}", v) for name, v in table.items()}
    return out


def scenario_dir() -> Path:
    """The directory of the scenarios known by name: config/scenarios/.

    Returns
    -------
    pathlib.Path
        The directory.
    """
    from ...paths import config_dir
    return config_dir() / "scenarios"


def available_scenarios():
    """The names of the scenarios in :func:`scenario_dir` (the stems of its .yaml files).

    Returns
    -------
    list of str
        The names, sorted.
    """
    return sorted(p.stem for p in scenario_dir().glob("*.yaml"))


def vehicle_scenario(vehicle=None, duration: float = 400.0) -> Scenario:
    """A fault-free run of ``vehicle`` through the scenario file's own checks (its wheel set, plant choices and
    dispersions): what a bench flies, and what the FDI of a vehicle's own wheels runs under.

    Parameters
    ----------
    vehicle : str or None
        A shipped vehicle's name, a vehicle file or a vehicle's FDI directory; None: the thesis' MakSat.
    duration : float
        [s] the run's length.

    Returns
    -------
    Scenario
        The run, named after the vehicle.
    """
    import json
    from .vehicle import load_vehicle
    name = load_vehicle(vehicle).name
    line = f"vehicle: {json.dumps(str(vehicle))}\n" if vehicle else ""
    return parse_scenario(f"name: {name}\n{line}duration: {duration!r}\n", origin=f"vehicle {name}")


def load_scenario(name_or_path: str) -> Scenario:
    """A scenario by file path or by name in config/scenarios/.

    Parameters
    ----------
    name_or_path : str
        A path to a YAML file, or a name in :func:`scenario_dir` (without .yaml).

    Returns
    -------
    Scenario
        The parsed scenario; ScenarioError when it is unknown, unreadable or invalid.
    """
    path = Path(name_or_path)
    if not path.suffix and not path.exists():
        path = scenario_dir() / f"{name_or_path}.yaml"
        if not path.exists():
            raise ScenarioError(f"unknown scenario '{name_or_path}' (known: {', '.join(available_scenarios())})")
    if not path.is_file():
        raise ScenarioError(f"scenario file not found: {name_or_path}")
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read(MAX_CHARACTERS + 1)   # read_yaml refuses more: a huge file is not read whole
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: not a readable scenario file ({type(exc).__name__}: {exc})") from None
    return parse_scenario(text, origin=str(path))
