"""The spacecraft as data: a vehicle file (YAML, docs/vehicles.md) read into one typed value.

A vehicle is what the FDIR flies on: the body's inertia (full 3x3, wheels locked), the wheel type's
datasheet (every parameter of the Bialke model, wheel.WheelParams, each with its unit), the wheel set
(spin axes, standby wheels), the attitude controller's design targets, the magnetorquers and their
dumping law, and the dispersions a run draws from (initial conditions, set-point changes, unit-to-unit
spreads, fault sizes). The thesis' MakSat (``config/vehicles/maksat.yaml``, Tables 2.2 and 2.3) is the
default.

A vehicle that cannot fly is refused with its reason, one line naming the field:

* the inertia must be symmetric positive definite and its principal moments obey the triangle
  inequality I_3 <= I_1 + I_2 (the largest at most the sum of the others: no rigid body has more);
* the active wheels must span the three body axes;
* the controller's targets must be within the wheels' torque: a rest-to-rest slew of the largest
  set-point change theta in the settling time T needs, bang-bang, alpha = 4 theta / T^2 about an axis,
  so I_kk alpha must not exceed what the active wheels give about it, tau_max sum_i |g_ik|
  (tau_max = G_d k_t V_limit, one wheel's torque at its command limit). A quick necessary condition; the
  sufficient one is controller_design.design_controller, which a run of the vehicle makes before it starts.

The wheel type is the vehicle's everywhere a wheel is modelled: the plant, the controllers' volts per
torque, the allocation's command limit and hold feed-forward, FDIR's delivered share and envelope, and the
whole FDI (nominal model, ripple bound, calibration, identification, envelope speed); the nodes take it as
their ``wheel_type`` parameter (:func:`wheel_parameter`).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...paths import DEFAULT_VEHICLE, config_dir, file_name
from ..control.allocation import NULL_SPACE_TIME_CONSTANT
from ..physics.environment import DEFAULT_RESIDUAL_DIPOLE
from ..physics.magnetorquers import MomentumDumping
from ..physics.spacecraft import DISTURBANCE_SIGMA, INERTIA
from ..physics.wheel import DEFAULT_UNIT_SPREAD, EMF_LIMITS, NOMINAL, UNIT_PARAMETERS, WheelParams
from ..physics.wheel_set import WHEEL_SETS, WheelSet
from .yaml_text import YamlError, read_yaml_file

# every WheelParams field with its unit as a vehicle file writes it ("": a pure number; None: a named choice)
WHEEL_UNITS = {
    "driver_gain": "A/V", "driver_bandwidth": "rad/s", "torque_constant": "N m/A", "emf_constant": "V/(rad/s)",
    "overspeed_gain": "V/(rad/s)", "overspeed_threshold": "rad/s", "coulomb_friction": "N m",
    "inertia": "kg m^2", "poles": "", "ripple_coefficient": "", "input_resistance": "ohm",
    "quiescent_power": "W", "bridge_resistance": "ohm", "voltage_feedback_gain": "V/V", "noise_angle": "rad",
    "noise_frequency": "rad/s", "command_limit": "V", "diode_drop": "V", "bus_voltage": "V", "emf_limit": None,
    "ripple_amplitude_share": "", "coulomb_smoothing_speed": "rad/s", "viscous_scale": "", "speed_noise": "rad/s",
}
# fields a vehicle file may leave out, and where their default comes from
WHEEL_DEFAULTS = {"bus_voltage": "8 V",    # the ITHACO Type A's bus (thesis Table 2.3)
                  "speed_noise": "0 rad/s"}   # an exact tachometer: our plant's
# fields that may be zero (the rest of WHEEL_UNITS' numbers must be > 0)
WHEEL_MAY_BE_ZERO = {"coulomb_friction", "ripple_coefficient", "noise_angle", "noise_frequency", "diode_drop",
                     "quiescent_power", "input_resistance", "viscous_scale", "speed_noise"}
# the largest value of each wheel field any reaction wheel has (generous: 10-1000x the largest flown), so that
# what `rw-fdi vehicle` accepts flies: torque_constant 1e308 passed as "inf mN m" and failed inside the plant
WHEEL_MAX = {
    "driver_gain": 100.0, "driver_bandwidth": 1e6, "torque_constant": 10.0, "emf_constant": 10.0,
    "overspeed_gain": 1e4, "overspeed_threshold": 1e4, "coulomb_friction": 1.0, "inertia": 10.0, "poles": 1000,
    "ripple_coefficient": 1.0, "input_resistance": 1e3, "quiescent_power": 1e3, "bridge_resistance": 1e3,
    "voltage_feedback_gain": 100.0, "noise_angle": 6.3, "noise_frequency": 1e4, "command_limit": 100.0,
    "diode_drop": 40.0, "bus_voltage": 40.0, "ripple_amplitude_share": 1.0, "coulomb_smoothing_speed": 100.0,
    "viscous_scale": 1e4, "speed_noise": 100.0,
}
NUMBER_MAX = 1e9   # any other number of a vehicle file, in its unit: nothing of a spacecraft is larger
MAGNETORQUER_UNITS = {"dipole_limit": "A m^2", "gain": "1/s", "start_speed": "rad/s", "stop_speed": "rad/s"}
CONTROLLER_UNITS = {"overshoot": "", "settling_time": "s", "pointing": "deg", "null_space_time_constant": "s"}
REQUIRED_KEYS = ("name", "inertia", "disturbance_sigma", "wheel", "wheel_set", "controller", "magnetorquers",
                 "dispersions")
# the largest a dispersion may reach (what a scenario may ask: scenario.ANGLE_LIMIT_DEG, INITIAL_LIMITS)
# (the initial wheel speeds: the vehicle's own wheel's speed limiter, check_flyable)
DISPERSION_LIMITS = {"attitude_deg": 180.0, "body_rate": 1.0, "setpoint_change_deg": 180.0}
UNIT_SPREAD_MAX = 0.3   # scenario.UNIT_SPREAD_MAX: cut at 3 sigma, every unit's scale stays positive
FAULT_SIZE_UNITS = {"current_limiter": "", "temperature": "C", "bus_voltage": "V"}
TOP_KEYS = {"name", "description", "sources", "inertia", "disturbance_sigma", "wheel", "wheel_set", "controller",
            "magnetorquers", "dispersions", "residual_dipole"}


class VehicleError(ValueError):
    """A vehicle file that cannot be read or a vehicle that cannot fly; the message is one line naming the
    field."""


@dataclass(frozen=True)
class ControllerTargets:
    """What the attitude controller is designed to meet (thesis 2.2.5)."""

    overshoot: float = 0.20        # largest overshoot of a set-point step, a share
    settling_time: float = 30.0    # [s] 5 % settling time of a step of the largest set-point change
    pointing: float = 0.2          # [deg] pointing requirement on every axis
    # the wheels' modelled friction cancelled by feed-forward (allocation.friction_feedforward); the thesis
    # has none: its PID integrators hold the friction
    friction_feedforward: bool = False
    # [s] the null-space speed hold's time constant (allocation.null_projector), 0 for none; only a set with more
    # wheels in use than axes has a null space, so the thesis' three wheels never feel it
    null_space_time_constant: float = NULL_SPACE_TIME_CONSTANT


@dataclass(frozen=True)
class Dispersions:
    """What a run draws (uniform ranges, thesis Table 2.3) and the unit-to-unit spreads (1 sigma shares)."""

    attitude_deg: tuple = (-180.0, 180.0)          # initial attitude per axis
    body_rate: tuple = (-1.0e-4, 1.0e-4)           # [rad/s] initial body rate per axis
    wheel_speed: tuple = (20.0, 30.0)              # [rad/s] initial speed of each active wheel
    setpoint_change_deg: tuple = (-5.0, 5.0)       # a set-point change per axis
    unit_spread: tuple = tuple(sorted(DEFAULT_UNIT_SPREAD.items()))   # (parameter, share) pairs
    fault_sizes: tuple = (("bus_voltage", (4.0, 5.5)), ("current_limiter", (0.5, 0.92)),
                          ("temperature", (48.0, 173.0)))   # (kind, (low, high)): the in-service envelope

    @property
    def unit_spreads(self) -> dict:
        return dict(self.unit_spread)

    @property
    def fault_ranges(self) -> dict:
        return dict(self.fault_sizes)


@dataclass(frozen=True)
class Vehicle:
    """A spacecraft: see the module docstring; ``inertia`` the 3x3 rows [kg m^2] with the wheels locked."""

    name: str
    inertia: tuple
    wheel: WheelParams = WheelParams()
    wheel_set: WheelSet = WHEEL_SETS["orthogonal_skew"]
    controller: ControllerTargets = ControllerTargets()
    magnetorquers: MomentumDumping = MomentumDumping()
    dispersions: Dispersions = Dispersions()
    disturbance_sigma: float = DISTURBANCE_SIGMA   # [N m] per axis, eq. 2.34
    # [A m^2] body axes: what it carries magnetised into orbit (environment.py), where a scenario's
    # environment does not say; optional in a file (the thesis' value: its worst-case magnetic torque)
    residual_dipole: tuple = DEFAULT_RESIDUAL_DIPOLE
    # words, not physics: two vehicles that fly alike are equal
    description: str = field(default="", compare=False)
    wheel_type: str = field(default="", compare=False)    # the wheel's make and model, as its datasheet names it
    sources: tuple = field(default=(), compare=False)     # (field, where its value comes from) pairs

    @property
    def inertia_matrix(self) -> np.ndarray:
        """I (3, 3) [kg m^2], body axes, wheels locked."""
        return np.asarray(self.inertia, float)

    @property
    def body_inertia(self) -> np.ndarray:
        """What the physics takes (spacecraft.body_acceleration): the diagonal (3,) where I is diagonal
        (the thesis' principal axes, the fast and exact path), else I (3, 3)."""
        matrix = self.inertia_matrix
        return np.diag(matrix).copy() if not (matrix - np.diag(np.diag(matrix))).any() else matrix

    @property
    def axis_inertia(self) -> np.ndarray:
        """I_kk (3,) [kg m^2]: what each per-axis controller is designed on (thesis 2.3: one per axis)."""
        return np.diag(self.inertia_matrix).copy()

    @property
    def principal_inertia(self) -> np.ndarray:
        """The principal moments (3,) [kg m^2], ascending."""
        return np.linalg.eigvalsh(self.inertia_matrix)

    def wheel_torque_limit(self) -> float:
        """tau_max = G_d k_t V_limit [N m]: one datasheet wheel's torque at its command limit, at rest.

        Returns
        -------
        float
            tau_max [N m].
        """
        w = self.wheel
        return float(w.driver_gain * w.torque_constant * w.command_limit)

    def axis_torque_limit(self) -> np.ndarray:
        """(3,) [N m]: the most torque the active wheels give about each body axis, tau_max sum_i |g_ik|.

        Returns
        -------
        numpy.ndarray
            (3,) torque [N m].
        """
        g = self.wheel_set.matrix[:, self.wheel_set.mask(self.wheel_set.active)]
        return self.wheel_torque_limit() * np.abs(g).sum(axis=1)

    def slew_torque(self) -> np.ndarray:
        """(3,) [N m]: I_kk 4 theta / T^2, the torque a bang-bang slew of the largest set-point change theta
        takes about each axis in the settling time T.

        Returns
        -------
        numpy.ndarray
            (3,) torque [N m].
        """
        theta = np.radians(max(abs(v) for v in self.dispersions.setpoint_change_deg))
        return self.axis_inertia * 4.0 * theta / self.controller.settling_time ** 2

    def as_dict(self) -> dict:
        """The vehicle as its file writes it (units in the values): what a bag records.

        Returns
        -------
        dict
            The vehicle file's mapping (:func:`to_mapping`).
        """
        return to_mapping(self)


# the thesis' MakSat in the code's own constants (Tables 2.2, 2.3): what a scenario without a vehicle flies,
# with no file to read; config/vehicles/maksat.yaml is the same vehicle as data (test_vehicle.py)
THESIS = Vehicle(DEFAULT_VEHICLE, tuple(tuple(float(v) for v in row) for row in np.diag(INERTIA)),
                 description="the thesis' MakSat", wheel_type="ITHACO Type A")


# -- reading ---------------------------------------------------------------------------------------------

_QUANTITY = re.compile(r"^\s*([-+0-9.eE]+)\s*(.*?)\s*$")
_RANGE = re.compile(r"^\s*([-+0-9.eE]+)\s+to\s+([-+0-9.eE]+)\s*(.*?)\s*$")


def _number(where: str, text) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError, OverflowError):
        raise VehicleError(f"{where}: expected a number, got {text!r}"[:300]) from None
    if isinstance(text, bool) or not np.isfinite(value):
        raise VehicleError(f"{where}: expected a finite number, got {text!r}"[:300])
    if abs(value) > NUMBER_MAX:
        raise VehicleError(f"{where}: {value:g} is beyond any spacecraft's (at most {NUMBER_MAX:g} in its unit)")
    return value


def quantity(where: str, raw, unit: str) -> float:
    """A number with its unit as a vehicle file writes it, ``"0.19 A/V"``; a bare number only where
    ``unit`` is "" (a pure number). The unit must be the one the field is in: units are not converted.

    Parameters
    ----------
    where : str
        The field's place in the file, for the error.
    raw : object
        The value as written.
    unit : str
        The field's unit ('' for a pure number).

    Returns
    -------
    float
        The number.
    """
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        if unit:
            raise VehicleError(f"{where}: give its unit, e.g. '{raw} {unit}'")
        return _number(where, raw)
    match = _QUANTITY.match(raw) if isinstance(raw, str) else None
    if match is None:
        raise VehicleError(f"{where}: expected a number{' and its unit ' + unit if unit else ''}, got {raw!r}"[:300])
    if " ".join(match.group(2).split()) != unit:
        raise VehicleError(f"{where}: the unit must be {unit or 'none (a pure number)'!s}, got {match.group(2)!r}")
    return _number(where, match.group(1))


def interval(where: str, raw, unit: str) -> tuple:
    """A range as a vehicle file writes it, ``"20 to 30 rad/s"``: (low, high) with low <= high.

    Parameters
    ----------
    where : str
        The field's place in the file, for the error.
    raw : object
        The value as written.
    unit : str
        The field's unit ('' for pure numbers).

    Returns
    -------
    tuple of float
        (low, high).
    """
    match = _RANGE.match(raw) if isinstance(raw, str) else None
    if match is None:
        raise VehicleError(f"{where}: expected a range 'low to high{' ' + unit if unit else ''}', got {raw!r}"[:300])
    if " ".join(match.group(3).split()) != unit:
        raise VehicleError(f"{where}: the unit must be {unit or 'none (pure numbers)'}, got {match.group(3)!r}")
    lo, hi = _number(where, match.group(1)), _number(where, match.group(2))
    if lo > hi:
        raise VehicleError(f"{where}: the low end {lo:g} is above the high end {hi:g}")
    return lo, hi


def _mapping(where: str, raw, known) -> dict:
    if not isinstance(raw, dict):
        raise VehicleError(f"{where}: expected a mapping of {', '.join(sorted(known))}")
    unknown = sorted(map(str, set(raw) - set(known)))   # str: YAML keys may be numbers or booleans
    if unknown:
        raise VehicleError(f"{where}: unknown field(s) {unknown}; known: {', '.join(sorted(known))}")
    return raw


def _inertia(where: str, raw) -> tuple:
    raw = _mapping(where, raw, {"unit", "matrix"})
    if raw.get("unit") != "kg m^2":
        raise VehicleError(f"{where}.unit: must be 'kg m^2', got {raw.get('unit')!r}")
    rows = raw.get("matrix")
    if not (isinstance(rows, list) and len(rows) == 3 and all(isinstance(r, list) and len(r) == 3 for r in rows)):
        raise VehicleError(f"{where}.matrix: expected 3 rows of 3 numbers")
    matrix = np.array([[_number(f"{where}.matrix[{i}][{j}]", v) for j, v in enumerate(r)] for i, r in enumerate(rows)])
    check_inertia(where, matrix)
    return tuple(tuple(float(v) for v in r) for r in matrix)


def _residual_dipole(where: str, raw) -> tuple:
    raw = _mapping(where, raw, {"unit", "vector"})
    if raw.get("unit") != "A m^2":
        raise VehicleError(f"{where}.unit: must be 'A m^2', got {raw.get('unit')!r}")
    vector = raw.get("vector")
    if not (isinstance(vector, list) and len(vector) == 3):
        raise VehicleError(f"{where}.vector: expected 3 numbers (body x, y, z)")
    values = tuple(_number(f"{where}.vector[{i}]", v) for i, v in enumerate(vector))
    if max(map(abs, values)) > 100.0:
        raise VehicleError(f"{where}.vector: beyond 100 A m^2 per axis, got {values}")
    return tuple(float(v) for v in values)


def check_inertia(where: str, matrix) -> None:
    """VehicleError unless I is symmetric positive definite with principal moments obeying the triangle
    inequality (each at most the sum of the other two).

    Parameters
    ----------
    where : str
        The field's place in the file, for the error.
    matrix : array_like
        (3, 3) inertia I [kg m^2].
    """
    matrix = np.asarray(matrix, float)
    scale = np.abs(matrix).max()
    if not np.allclose(matrix, matrix.T, rtol=0.0, atol=1e-9 * scale):
        raise VehicleError(f"{where}: not symmetric (I_ij must equal I_ji)")
    moments = np.linalg.eigvalsh(matrix)
    if moments[0] <= 0.0:
        listed = ", ".join(f"{m:.4g}" for m in moments)
        raise VehicleError(f"{where}: not positive definite (principal moments {listed} kg m^2)")
    if moments[2] > moments[0] + moments[1] + 1e-9 * scale:
        raise VehicleError(f"{where}: its principal moments {', '.join(f'{m:.4g}' for m in moments)} kg m^2 break the "
                           "triangle inequality (the largest exceeds the sum of the other two): no rigid body has them")


def _wheel(where: str, raw) -> WheelParams:
    raw = {**WHEEL_DEFAULTS, **_mapping(where, raw, {"type", *WHEEL_UNITS})}
    missing = sorted(set(WHEEL_UNITS) - set(raw))
    if missing:
        raise VehicleError(f"{where}: missing {', '.join(missing)} (every parameter of the wheel model, with units)")
    values = {}
    for name, unit in WHEEL_UNITS.items():
        if unit is None:
            if raw[name] not in EMF_LIMITS:
                raise VehicleError(f"{where}.{name}: must be one of {', '.join(EMF_LIMITS)}, got {raw[name]!r}")
            values[name] = raw[name]
            continue
        value = quantity(f"{where}.{name}", raw[name], unit)
        if value < 0.0 or (value == 0.0 and name not in WHEEL_MAY_BE_ZERO):
            bound = ">= 0" if name in WHEEL_MAY_BE_ZERO else "> 0"
            raise VehicleError(f"{where}.{name}: must be {bound}, got {value:g}")
        if value > WHEEL_MAX[name]:
            raise VehicleError(f"{where}.{name}: {value:g} {unit} is beyond any reaction wheel's (at most "
                               f"{WHEEL_MAX[name]:g} {unit})")
        values[name] = value
    if values["poles"] != int(values["poles"]):
        raise VehicleError(f"{where}.poles: must be a whole number, got {values['poles']:g}")
    values["poles"] = int(values["poles"])
    if values["diode_drop"] >= values["bus_voltage"]:
        raise VehicleError(f"{where}.diode_drop: {values['diode_drop']:g} V leaves no bus voltage to drive with "
                           f"(bus_voltage {values['bus_voltage']:g} V)")
    return WheelParams(**values)


def _wheel_set(where: str, raw) -> WheelSet:
    if isinstance(raw, str):
        if raw not in WHEEL_SETS:
            raise VehicleError(f"{where}: a shipped set ({', '.join(WHEEL_SETS)}) or a mapping of name, wheels, "
                               f"standby; got {raw!r}")
        return WHEEL_SETS[raw]
    raw = _mapping(where, raw, {"name", "wheels", "standby"})
    wheels = raw.get("wheels")
    # a list, not a mapping: the wheels' order is their index everywhere (faults, telemetry), and a YAML tool
    # may reorder a mapping's keys
    if not isinstance(wheels, list) or not wheels:
        raise VehicleError(f"{where}.wheels: expected a list of {{name, spin_axis: [x, y, z]}}")
    names, axes = [], []
    for i, wheel in enumerate(wheels):
        at = f"{where}.wheels[{i}]"
        wheel = _mapping(at, wheel, {"name", "spin_axis"})
        direction = wheel.get("spin_axis")
        if not isinstance(wheel.get("name"), str) or not (isinstance(direction, list) and len(direction) == 3):
            raise VehicleError(f"{at}: expected a name and a spin_axis direction [x, y, z]")
        v = np.array([_number(f"{at}.spin_axis[{k}]", x) for k, x in enumerate(direction)])
        norm = np.linalg.norm(v)
        if not norm > 0.0:
            raise VehicleError(f"{at}.spin_axis: a zero vector has no direction")
        if wheel["name"] in names:
            raise VehicleError(f"{at}.name: wheel {wheel['name']!r} twice")
        names.append(wheel["name"])
        # a unit vector read back stays as it was (a bag's vehicle equals its file's, bit for bit)
        axes.append(tuple(float(x) for x in (v if abs(norm - 1.0) <= 1e-12 else v / norm)))
    standby = raw.get("standby", [])
    if not isinstance(standby, list) or set(map(str, standby)) - set(names):
        raise VehicleError(f"{where}.standby: a list of wheel names among {', '.join(names)}")
    try:
        out = WheelSet(str(raw.get("name", "custom")), tuple(names), tuple(axes), tuple(map(str, standby)))
    except ValueError as error:
        raise VehicleError(f"{where}: {str(error).split(': ', 1)[-1]}") from None
    if shipped_set_name(out) is None:   # refused here, not by the first run: what the check passes flies
        raise VehicleError(f"{where}: a wheel set of a vehicle's own ({out.name!r}) is not flown yet; name one of "
                           f"the shipped sets ({', '.join(WHEEL_SETS)}) or spell one out (docs/vehicles.md)")
    return out


def shipped_set_name(wheel_set: WheelSet):
    """The shipped set (WHEEL_SETS) ``wheel_set`` is, wheel for wheel (names, spin axes, standby), or None.

    Parameters
    ----------
    wheel_set : WheelSet
        The set.

    Returns
    -------
    str or None
        Its name in WHEEL_SETS.
    """
    return next((name for name, ws in WHEEL_SETS.items() if ws.names == wheel_set.names
                 and np.allclose(ws.spin_axes, wheel_set.spin_axes, rtol=0.0, atol=1e-12)
                 and ws.standby == wheel_set.standby), None)


def _dispersions(where: str, raw, bus_voltage: float = 8.0) -> Dispersions:
    units = {"attitude_deg": "deg", "body_rate": "rad/s", "wheel_speed": "rad/s", "setpoint_change_deg": "deg"}
    raw = _mapping(where, raw, {"initial_attitude", "initial_body_rate", "initial_wheel_speed",
                                "setpoint_change", "unit_spread", "fault_sizes"})
    keys = {"attitude_deg": "initial_attitude", "body_rate": "initial_body_rate",
            "wheel_speed": "initial_wheel_speed", "setpoint_change_deg": "setpoint_change"}
    values = {f: interval(f"{where}.{k}", raw[k], units[f]) for f, k in keys.items() if k in raw}
    for f, k in keys.items():   # what a scenario may ask (scenario.INITIAL_LIMITS, ANGLE_LIMIT_DEG)
        if f in values and f in DISPERSION_LIMITS and max(abs(v) for v in values[f]) > DISPERSION_LIMITS[f]:
            raise VehicleError(f"{where}.{k}: beyond +-{DISPERSION_LIMITS[f]:g} {units[f]}")
    if "unit_spread" in raw:
        spread = _mapping(f"{where}.unit_spread", raw["unit_spread"], UNIT_PARAMETERS)
        values["unit_spread"] = tuple(sorted((k, quantity(f"{where}.unit_spread.{k}", v, ""))
                                             for k, v in spread.items()))
        for k, v in values["unit_spread"]:
            if not 0.0 <= v <= UNIT_SPREAD_MAX:   # cut at 3 sigma, a unit's scale stays positive
                raise VehicleError(f"{where}.unit_spread.{k}: a 1-sigma share in [0, {UNIT_SPREAD_MAX:g}], got {v:g}")
    if "fault_sizes" in raw:
        sizes = _mapping(f"{where}.fault_sizes", raw["fault_sizes"], FAULT_SIZE_UNITS)
        values["fault_sizes"] = tuple(sorted((k, interval(f"{where}.fault_sizes.{k}", v, FAULT_SIZE_UNITS[k]))
                                             for k, v in sizes.items()))
        low, high = dict(values["fault_sizes"]).get("bus_voltage", (0.0, 0.0))
        if high >= bus_voltage:
            raise VehicleError(f"{where}.fault_sizes.bus_voltage: a drop is below the wheel's bus "
                               f"({bus_voltage:g} V), got up to {high:g} V")
    elif bus_voltage != NOMINAL.bus_voltage:   # the default drops (4-5.5 V of the Type A's 8 V), as shares
        scale = bus_voltage / NOMINAL.bus_voltage
        values["fault_sizes"] = tuple((k, tuple(v * scale for v in r) if k == "bus_voltage" else r)
                                      for k, r in Dispersions.fault_sizes)
    return Dispersions(**values)


def _positive(where: str, raw, units: dict, may_be_zero=()) -> dict:
    """The quantities of ``raw`` (a mapping of ``units``' fields), each > 0 (>= 0 for ``may_be_zero``)."""
    values = {k: quantity(f"{where}.{k}", v, units[k]) for k, v in raw.items()}
    for k, v in values.items():
        if v < 0.0 or (v == 0.0 and k not in may_be_zero):
            raise VehicleError(f"{where}.{k}: must be {'>= 0' if k in may_be_zero else '> 0'}, got {v:g}")
    return values


def _controller(where: str, raw) -> ControllerTargets:
    raw = _mapping(where, raw, {*CONTROLLER_UNITS, "friction_feedforward"})
    values = _positive(where, {k: v for k, v in raw.items() if k != "friction_feedforward"}, CONTROLLER_UNITS,
                       ("null_space_time_constant",))
    if values.get("overshoot", 0.0) >= 1.0:
        raise VehicleError(f"{where}.overshoot: a share below 1, got {values['overshoot']:g}")
    if "friction_feedforward" in raw:
        if not isinstance(raw["friction_feedforward"], bool):
            raise VehicleError(f"{where}.friction_feedforward: true or false, got {raw['friction_feedforward']!r}")
        values["friction_feedforward"] = raw["friction_feedforward"]
    return ControllerTargets(**values)


def _magnetorquers(where: str, raw) -> MomentumDumping:
    raw = _mapping(where, raw, {*MAGNETORQUER_UNITS, "enabled"})
    values = _positive(where, {k: v for k, v in raw.items() if k != "enabled"}, MAGNETORQUER_UNITS, ("stop_speed",))
    if "enabled" in raw:
        if not isinstance(raw["enabled"], bool):
            raise VehicleError(f"{where}.enabled: true or false, got {raw['enabled']!r}")
        values["enabled"] = raw["enabled"]
    rods = MomentumDumping(**values)
    if rods.stop_speed > rods.start_speed:
        raise VehicleError(f"{where}.stop_speed: {rods.stop_speed:g} rad/s is above start_speed {rods.start_speed:g}")
    return rods


def _text(value) -> str:
    return "" if value is None else str(value)


def vehicle_of(raw, where: str = "vehicle") -> Vehicle:
    """A Vehicle from a vehicle file's mapping, checked (module docstring); VehicleError otherwise.

    Parameters
    ----------
    raw : dict
        The vehicle file's mapping.
    where : str
        Its name, for the errors.

    Returns
    -------
    Vehicle
        The vehicle.
    """
    raw = _mapping(where, raw, TOP_KEYS)
    # every section is the vehicle's own: nothing of the thesis' spacecraft is taken in silently
    missing = [k for k in REQUIRED_KEYS if k not in raw]
    if missing:
        raise VehicleError(f"{where}: missing {', '.join(repr(k) for k in missing)} (docs/vehicles.md)")
    if not isinstance(raw["name"], str) or not raw["name"].strip():
        raise VehicleError(f"{where}.name: a name (text), got {raw['name']!r}")
    try:   # it names the vehicle's FDI folder (rw-fdi defaults)
        file_name(raw["name"].strip())
    except ValueError as exc:
        raise VehicleError(f"{where}.name: {exc}") from None
    sources = raw.get("sources") or {}
    if not isinstance(sources, dict):
        raise VehicleError(f"{where}.sources: expected a mapping of field -> where its value comes from")
    wheel = _wheel(f"{where}.wheel", raw["wheel"])
    vehicle = Vehicle(
        name=raw["name"].strip(), inertia=_inertia(f"{where}.inertia", raw["inertia"]), wheel=wheel,
        wheel_set=_wheel_set(f"{where}.wheel_set", raw["wheel_set"]),
        controller=_controller(f"{where}.controller", raw["controller"]),
        magnetorquers=_magnetorquers(f"{where}.magnetorquers", raw["magnetorquers"]),
        dispersions=_dispersions(f"{where}.dispersions", raw["dispersions"], wheel.bus_voltage),
        disturbance_sigma=_positive(where, {"disturbance_sigma": raw["disturbance_sigma"]},
                                    {"disturbance_sigma": "N m"}, ("disturbance_sigma",))["disturbance_sigma"],
        **({"residual_dipole": _residual_dipole(f"{where}.residual_dipole", raw["residual_dipole"])}
           if "residual_dipole" in raw else {}),
        description=_text(raw.get("description")), wheel_type=_text(raw["wheel"].get("type")),
        sources=tuple((str(k), _text(v)) for k, v in sources.items()))
    check_flyable(vehicle, where)
    return vehicle


def check_flyable(vehicle: Vehicle, where: str = "vehicle") -> None:
    """VehicleError when the controller's targets are beyond the wheels' torque (module docstring).

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.
    where : str
        Its name, for the error.
    """
    need, have = vehicle.slew_torque(), vehicle.axis_torque_limit()
    short = np.flatnonzero(need > have)
    if short.size:
        k = int(short[0])
        theta = max(abs(v) for v in vehicle.dispersions.setpoint_change_deg)
        raise VehicleError(
            f"{where}.controller.settling_time: a {theta:g} deg slew in {vehicle.controller.settling_time:g} s needs "
            f"{need[k]:.3g} N m about {'xyz'[k]} (I_{'xyz'[k] * 2} {vehicle.axis_inertia[k]:g} kg m^2), the active "
            f"wheels give at most {have[k]:.3g} N m there")
    lo, hi = vehicle.dispersions.wheel_speed
    if hi >= vehicle.wheel.overspeed_threshold:
        raise VehicleError(f"{where}.dispersions.initial_wheel_speed: up to {hi:g} rad/s is beyond the wheel's speed "
                           f"limiter ({vehicle.wheel.overspeed_threshold:g} rad/s)")


def wheel_parameter(wheel: WheelParams, wheel_type: str = "") -> str:
    """The nodes' ``wheel_type`` parameter for ``wheel``: its datasheet as a vehicle file writes it, every value
    with its unit, as ``name=value; name=value; ...`` (a plain string through every YAML layer of a launch: a
    mapping would be retyped); '' for the thesis' Type A (the nodes' default).

    Parameters
    ----------
    wheel : core.physics.wheel.WheelParams
        The wheel type.
    wheel_type : str
        Its make and model.

    Returns
    -------
    str
        The parameter's value.
    """
    if wheel == WheelParams():
        return ""
    words = re.sub(r"[;=#:]", " ", wheel_type).strip()   # a make and model in words only
    parts = [f"type={words}"] if words else []
    for name, unit in WHEEL_UNITS.items():
        value = getattr(wheel, name)
        parts.append(f"{name}={value if unit is None else _with_unit(float(value) if unit else value, unit)}")
    return "; ".join(parts)


def wheel_from_parameter(text: str) -> WheelParams:
    """The WheelParams of a ``wheel_type`` parameter (:func:`wheel_parameter`; '' the thesis' Type A);
    VehicleError, one line naming the field, for one that does not read.

    Parameters
    ----------
    text : str
        The parameter's value.

    Returns
    -------
    core.physics.wheel.WheelParams
        The wheel type.
    """
    if not text.strip():
        return WheelParams()
    raw = {}
    for part in text.split(";"):
        name, sep, value = part.partition("=")
        if not sep or not name.strip():
            raise VehicleError(f"wheel_type: {part.strip()!r} is not name=value (name=value; name=value; ...)")
        if name.strip() in raw:
            raise VehicleError(f"wheel_type.{name.strip()}: given twice")
        raw[name.strip()] = value.strip()
    return _wheel("wheel_type", raw)


VEHICLE_FILE = "vehicle.yaml"   # the vehicle in its FDI directory (`rw-fdi defaults --out DIR`)


def shipped_vehicles() -> dict:
    """name -> path of the vehicle files shipped in config/vehicles.

    Returns
    -------
    dict
        Name -> pathlib.Path.
    """
    folder = config_dir() / "vehicles"
    return {p.stem: p for p in sorted(folder.glob("*.yaml"))} if folder.is_dir() else {}


def load_vehicle(source=None) -> Vehicle:
    """The vehicle named ``source``: a shipped name (config/vehicles/NAME.yaml), a path to a vehicle file or to
    a vehicle's FDI directory (its vehicle.yaml: what `rw-fdi defaults --vehicle FILE --out DIR` wrote), a
    mapping (a bag's record), or None for the default (the thesis' MakSat).

    Parameters
    ----------
    source : str, pathlib.Path, dict, Vehicle or None
        A shipped name, a file, an FDI directory, a mapping or a Vehicle (returned as is).

    Returns
    -------
    Vehicle
        The vehicle.
    """
    if isinstance(source, Vehicle):
        return source
    if isinstance(source, dict):
        return vehicle_of(source)
    name = DEFAULT_VEHICLE if source is None else str(source)
    shipped = shipped_vehicles()
    path = shipped.get(name, Path(name))
    if path.is_dir():
        path = path / VEHICLE_FILE
    if not path.is_file():
        raise VehicleError(f"vehicle {name!r}: no such file, nor a shipped vehicle ({', '.join(shipped) or 'none'})")
    try:
        raw = read_yaml_file(path)   # a key given twice refused, as in a scenario
    except (OSError, UnicodeDecodeError) as error:
        raise VehicleError(f"{path}: not a readable file ({str(error).splitlines()[0]})") from None
    except YamlError as error:
        raise VehicleError(str(error)) from None
    return vehicle_of(raw, where=str(path.name))


# -- writing ---------------------------------------------------------------------------------------------

def _with_unit(value, unit: str):
    return value if not unit else f"{float(value)!r} {unit}"   # repr: every digit, read back exactly


def _range(values, unit: str) -> str:
    return f"{float(values[0])!r} to {float(values[1])!r}" + (f" {unit}" if unit else "")


def to_mapping(vehicle: Vehicle) -> dict:
    """The vehicle file's mapping of ``vehicle`` (vehicle_of reads it back to an equal Vehicle).

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.

    Returns
    -------
    dict
        The mapping, every value with its unit.
    """
    d = vehicle.dispersions
    wheel = {"type": vehicle.wheel_type}
    for name, unit in WHEEL_UNITS.items():
        value = getattr(vehicle.wheel, name)
        wheel[name] = value if unit is None else _with_unit(float(value) if unit else value, unit)
    ws = vehicle.wheel_set
    return {
        "name": vehicle.name, "description": vehicle.description,
        "inertia": {"unit": "kg m^2", "matrix": [list(r) for r in vehicle.inertia]},
        "disturbance_sigma": _with_unit(vehicle.disturbance_sigma, "N m"),
        # written where it is not the thesis' default: a vehicle without it records as it did before
        **({"residual_dipole": {"unit": "A m^2", "vector": list(vehicle.residual_dipole)}}
           if tuple(vehicle.residual_dipole) != tuple(DEFAULT_RESIDUAL_DIPOLE) else {}),
        "wheel": wheel,
        "wheel_set": {"name": ws.name, "wheels": [{"name": n, "spin_axis": list(a)}
                                                  for n, a in zip(ws.names, ws.spin_axes)],
                      "standby": list(ws.standby)},
        "controller": {"overshoot": vehicle.controller.overshoot,
                       "settling_time": _with_unit(vehicle.controller.settling_time, "s"),
                       "pointing": _with_unit(vehicle.controller.pointing, "deg"),
                       "null_space_time_constant": _with_unit(vehicle.controller.null_space_time_constant, "s"),
                       # written where set: a vehicle without it records as it did before the option
                       **({"friction_feedforward": True} if vehicle.controller.friction_feedforward else {})},
        "magnetorquers": {**{k: _with_unit(getattr(vehicle.magnetorquers, k), u)
                             for k, u in MAGNETORQUER_UNITS.items()}, "enabled": vehicle.magnetorquers.enabled},
        "dispersions": {"initial_attitude": _range(d.attitude_deg, "deg"),
                        "initial_body_rate": _range(d.body_rate, "rad/s"),
                        "initial_wheel_speed": _range(d.wheel_speed, "rad/s"),
                        "setpoint_change": _range(d.setpoint_change_deg, "deg"),
                        "unit_spread": dict(d.unit_spread),
                        "fault_sizes": {k: _range(v, FAULT_SIZE_UNITS[k]) for k, v in d.fault_sizes}},
        "sources": dict(vehicle.sources),
    }


def summary(vehicle: Vehicle) -> str:
    """A few lines a person reads: what the vehicle is and what its wheels can do about each axis.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.

    Returns
    -------
    str
        The lines.
    """
    moments = ", ".join(f"{m:.4g}" for m in vehicle.principal_inertia)
    have, need = vehicle.axis_torque_limit(), vehicle.slew_torque()
    ws = vehicle.wheel_set
    lines = [f"vehicle {vehicle.name}: {vehicle.description}".rstrip(": "),
             f"  inertia: principal moments {moments} kg m^2",
             f"  wheels: {ws.count} ({', '.join(ws.names)}; standby {', '.join(ws.standby) or 'none'}), "
             f"J {vehicle.wheel.inertia:g} kg m^2, {vehicle.wheel_torque_limit() * 1e3:.3g} mN m each at "
             f"{vehicle.wheel.command_limit:g} V",
             "  torque about x, y, z: the active wheels give " + ", ".join(f"{v * 1e3:.3g}" for v in have)
             + " mN m; the largest slew in the settling time needs " + ", ".join(f"{v * 1e3:.3g}" for v in need)
             + " mN m"]
    return "\n".join(lines)
