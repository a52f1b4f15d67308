"""The three fault families of a wheel: their names, their parameters' grids and the reaction torque each
grid point predicts.

Each family is a one-parameter family of the nominal Bialke wheel (core/physics/wheel.py) driven by the measured
command u and wheel speed Omega, every term the mean over one FDI period of its control-rate values:

    current_limiter  a [-]:   r^ = -a tau_m(u, Omega; 8 V) + tau_f(Omega; 23 C)           (limiter)
    temperature      T [C]:   r^ = -tau_m(u, Omega; 8 V) + tau_v(T) Omega + tau_c tanh(.)  (eq. 2.15)
    bus_voltage      V [V]:   r^ = -tau_m(u, Omega; V)   + tau_f(Omega; 23 C)             (eqs. 2.9-2.14)

The names are the scenario's fault kinds (core/mission/scenario.FAULT_KINDS), from the scenario to the report.
"""
from __future__ import annotations

import numpy as np

from ...physics import wheel as wm

KINDS = ("current_limiter", "temperature", "bus_voltage")
UNKNOWN = "unknown"
# Grids of each family's parameter, nominal value first (it is the healthy wheel in all three).
# Fine enough that a grid step changes the torque by less than the noise floor: a coarser grid
# makes the family whose parameter falls between two points look worse than it is.
CURRENT_LIMITER_GRID = np.round(np.arange(1.0, -1e-9, -0.001), 6)           # share of motor current
TEMPERATURE_GRID = np.round(np.arange(23.0, 215.0 + 1e-9, 0.25), 6)          # [C]; tau_v = 0 from 215 C
BUS_VOLTAGE_GRID = np.round(np.arange(8.0, 1.5 - 1e-9, -0.01), 6)           # [V] the 8-V thesis wheel's
UNITS = {"current_limiter": "", "temperature": "C", "bus_voltage": "V"}
# The two families that show only through the motor torque: at one operating point a limiter share and a bus
# voltage that clips to the same current are the same wheel, and a few samples may not tell them apart
DRIVE = ("current_limiter", "bus_voltage")
# How far from a wheel's reported bus voltage or temperature (its housekeeping telemetry, wheel_reports.py) a family's
# size may lie and still be that wheel: a bus monitor's few per cent (on the 8-V grid), a housing thermistor's
# lag behind the bearing's lubricant
REPORTED_TOLERANCE = {"bus_voltage": 0.25, "temperature": 10.0}
# [N m] per FDI sample, the smallest misfit taken for real: the bearing torque noise the models
# leave out (1.5e-5, eq. 2.16) plus half a grid step, up to 4e-5 N m where the bus family is steep.
SIGMA_FLOOR = 5e-5
# a driver that is off leaves only the bearing noise: a noiseless model's floor is still no finer than this share of
# the driven one (the decision divides by it)
UNPOWERED_FLOOR_MIN = 0.01


def noise_floors(params=None) -> tuple:
    """(driven, unpowered) [N m]: the smallest misfit taken for real in an FDI sample of a wheel type, its driver on
    and off. Driven: SIGMA_FLOOR scaled by wheel.torque_scale (the bus family's grid step is a torque of the drive).
    Off: eq. 2.16's bearing noise alone, A = J theta_a w_a^2 (the Type A's 1.5e-5 N m): no drive family acts, and
    a small wheel's friction (where a temperature shows) lies far under its drive's torque.

    Parameters
    ----------
    params : WheelParams, optional
        The wheel type; None: the thesis' Type A.

    Returns
    -------
    tuple of float
        The two floors [N m].
    """
    params = wm.WheelParams() if params is None else params
    driven = SIGMA_FLOOR * wm.torque_scale(params)
    return driven, max(wm.bearing_noise_amplitude(params), UNPOWERED_FLOOR_MIN * driven)


def bus_voltage_grid(bus_voltage: float = 8.0) -> np.ndarray:
    """The bus family's grid on a wheel type's nominal bus V_nom [V]: BUS_VOLTAGE_GRID (8 to 1.5 V by 0.01 V)
    scaled by V_nom / 8, so 100 % down to 18.75 % of V_nom in 651 points whatever the bus.

    Parameters
    ----------
    bus_voltage : float
        V_nom [V] (WheelParams.bus_voltage).

    Returns
    -------
    ndarray, shape (651,)
        Bus voltages [V], V_nom first.
    """
    scale = float(bus_voltage) / BUS_VOLTAGE_GRID[0]
    return BUS_VOLTAGE_GRID if scale == 1.0 else np.round(BUS_VOLTAGE_GRID * scale, 6)


def bus_motor_torque(tcv, wheel_speed, params: wm.WheelParams = wm.WheelParams(), grid=None):
    """Motor torque k_t I_m(u, Omega; V) of a healthy wheel at every bus voltage of ``grid``: (..., len(grid)).

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage u [V], any shape (...), e.g. (N,) for one sample of the set.
    wheel_speed : float or array_like
        Wheel speed Omega [rad/s], broadcasting with ``tcv``.
    params : WheelParams
        The wheel type, scalar fields (one datasheet wheel).
    grid : array_like, shape (G,), optional
        Bus voltages V [V]; default the wheel type's :func:`bus_voltage_grid`.

    Returns
    -------
    ndarray, shape (..., G)
        tau_m [N m] at current limiter 1.
    """
    grid = bus_voltage_grid(params.bus_voltage) if grid is None else grid
    u = np.asarray(tcv, float)[..., None]
    w = np.asarray(wheel_speed, float)[..., None]
    return params.torque_constant * wm.motor_current(u, w, grid, 1.0, params)


def family_predictions(motor_torque, friction_torque, wheel_speed, bus_torque, scales=None, free_motor_torque=None,
                       fraction=None, viscous_scale: float = 1.0):
    """Predicted reaction torque of every grid point of every family, (sum of grid sizes, n), families
    in KINDS order, for n FDI samples of one wheel: the definition of the families (ProfileSums keeps their
    sums without evaluating the two linear ones point by point, sums.py).

    ``motor_torque``, ``friction_torque``, ``wheel_speed``: (n,) period means of the nominal
    wheel's tau_m and tau_f and of Omega; ``bus_torque``: (n, len(BUS_VOLTAGE_GRID)); ``scales``:
    the unit's (1 + d_kt, 1 + d_Gd, 1 + b_v, 1 + b_c) (None: the datasheet wheel), whose driver gain
    acts on ``free_motor_torque`` (tau_m where the bridge does not clip; default tau_m).

    ``fraction`` (H,), for one sample (n = 1): how far each of H ramps has come towards the grid value,
    theta = theta_0 + phi (theta_grid - theta_0); then (H, sum of grid sizes). The bus family's torque at a
    voltage between two grid points is interpolated (the grid is 0.01 V). ``viscous_scale``: the wheel type's
    viscous friction over eq. 2.15's law (WheelParams.viscous_scale; the thesis' type 1).

    Parameters
    ----------
    motor_torque : float or array_like, shape (n,)
        The nominal wheel's tau_m(u, Omega; 8 V) [N m].
    friction_torque : float or array_like, shape (n,)
        The nominal wheel's tau_f(Omega; 23 C) [N m].
    wheel_speed : float or array_like, shape (n,)
        Omega [rad/s].
    bus_torque : array_like, shape (n, G)
        tau_m at every voltage of BUS_VOLTAGE_GRID [N m] (:func:`bus_motor_torque`).
    scales : sequence of 4 float, optional
        The unit's scales (dimensionless); None for the datasheet wheel.
    free_motor_torque : float or array_like, shape (n,), optional
        tau_m where the bridge does not clip, else 0 [N m]; None: ``motor_torque``.
    fraction : array_like, shape (H,), optional
        phi of each ramp (dimensionless, :func:`ramp_fractions`), with n = 1.

    Returns
    -------
    ndarray, shape (S, n) or (H, S)
        Predicted reaction torque r^ [N m]; S = the sum of the grid sizes (the grids of GRIDS in KINDS order).
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    if fraction is None:      # grid points down axis 0, samples along axis 1
        limiter, tv = CURRENT_LIMITER_GRID[:, None], viscous_scale * _VISCOUS_GRID[:, None]
    else:                     # ramps down axis 0, grid points along axis 1, the one sample along axis 2
        phi = np.asarray(fraction, float)[:, None]
        limiter = (1.0 + phi * (CURRENT_LIMITER_GRID - 1.0))[..., None]
        tv = viscous_scale * wm.viscous_coefficient(TEMPERATURE_GRID[0] + phi * (TEMPERATURE_GRID
                                                                                 - TEMPERATURE_GRID[0]))[..., None]
    viscous = viscous_scale * _VISCOUS_NOMINAL * w
    coulomb = tf - viscous
    bus = bus_predictions(tm, tf, w, bus_torque, scales, free_motor_torque, fraction, viscous_scale)
    if fraction is not None:
        bus = bus[..., None]
    if scales is None:
        out = np.concatenate([-limiter * tm + tf, -tm + tv * w + coulomb, bus], axis=-2)
    else:
        kt, gd, sv, sc = (float(x) for x in scales)
        motor = kt * (tm + (gd - 1.0) * _free(tm, free_motor_torque))   # k_t clip((1 + d_Gd) G_d u, I_max), 1st order
        friction = sv * viscous + sc * coulomb
        out = np.concatenate([-limiter * motor + friction, -motor + sv * tv * w + sc * coulomb, bus], axis=-2)
    return out if fraction is None else out[..., 0]


def bus_predictions(motor_torque, friction_torque, wheel_speed, bus_torque, scales=None, free_motor_torque=None,
                    fraction=None, viscous_scale: float = 1.0, first: int = 0):
    """The bus family's predicted reaction torque, r^ = -tau_m(u, Omega; V) + tau_f(Omega; 23 C) at every voltage
    of BUS_VOLTAGE_GRID: (G, n), or (H, G - first) for one sample on H ramps (``fraction``) at the grid's points
    from ``first`` on.

    Parameters
    ----------
    motor_torque, friction_torque, wheel_speed, bus_torque, scales, free_motor_torque, fraction, viscous_scale
        As :func:`family_predictions` takes them.
    first : int, optional
        With ``fraction``: the first grid point predicted (those before it clip no current: sums.ProfileSums).

    Returns
    -------
    ndarray, shape (G, n) or (H, G - first)
        Predicted reaction torque r^ [N m].
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    bus = np.atleast_2d(np.asarray(bus_torque, float)).T          # (len(BUS_VOLTAGE_GRID), n)
    if fraction is not None:   # the one sample's torque at each ramp's voltage now (8-V units: any bus's, scaled)
        phi = np.asarray(fraction, float)[:, None]
        volts = BUS_VOLTAGE_GRID[0] + phi * (BUS_VOLTAGE_GRID[first:] - BUS_VOLTAGE_GRID[0])
        bus = np.interp(volts, BUS_VOLTAGE_GRID[::-1], bus[::-1, 0])[..., None]
    if scales is None:
        out = -bus + tf
    else:
        kt, gd, sv, sc = (float(x) for x in scales)
        viscous = viscous_scale * _VISCOUS_NOMINAL * w
        free = _free(tm, free_motor_torque)
        out = -kt * (bus + (gd - 1.0) * _bus_free(tm, free, bus)) + sv * viscous + sc * (tf - viscous)
    return out if fraction is None else out[..., 0]


def unit_sensitivities(motor_torque, friction_torque, wheel_speed, bus_torque, free_motor_torque=None,
                       viscous_scale: float = 1.0, kinds=KINDS):
    """dr^/d(d_kt, d_Gd, b_v, b_c) of every grid point, (sum of grid sizes, n, 4): the directions in which
    what the calibration does not know of the unit moves each family's prediction (to first order).

    Parameters
    ----------
    motor_torque : float or array_like, shape (n,)
        The nominal wheel's tau_m [N m].
    friction_torque : float or array_like, shape (n,)
        The nominal wheel's tau_f(Omega; 23 C) [N m].
    wheel_speed : float or array_like, shape (n,)
        Omega [rad/s].
    bus_torque : array_like, shape (n, G)
        tau_m at every voltage of BUS_VOLTAGE_GRID [N m].
    free_motor_torque : float or array_like, shape (n,), optional
        tau_m where the bridge does not clip, else 0 [N m]; None: ``motor_torque``.
    viscous_scale : float, optional
        The wheel type's viscous friction over eq. 2.15's law.
    kinds : sequence of str, optional
        The families, in KINDS order (``("bus_voltage",)``: the bus family's grid alone).

    Returns
    -------
    ndarray, shape (S, n, 4)
        dr^/db [N m] per unit share, S = the sum of the kinds' grid sizes.
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    bus = np.atleast_2d(np.asarray(bus_torque, float)).T
    free = _free(tm, free_motor_torque)
    n, temperatures, limiters = len(tm), len(TEMPERATURE_GRID), CURRENT_LIMITER_GRID[:, None]
    viscous = viscous_scale * _VISCOUS_NOMINAL * w
    parts = {"current_limiter": lambda: (-limiters * tm[None], -limiters * free[None],
                                         np.broadcast_to(viscous[None], (len(CURRENT_LIMITER_GRID), n))),
             "temperature": lambda: (np.broadcast_to(-tm[None], (temperatures, n)),
                                     np.broadcast_to(-free[None], (temperatures, n)),
                                     viscous_scale * _VISCOUS_GRID[:, None] * w[None]),
             "bus_voltage": lambda: (-bus, -_bus_free(tm, free, bus),
                                     np.broadcast_to(viscous[None], (len(BUS_VOLTAGE_GRID), n)))}
    columns = [parts[k]() for k in kinds]
    motor, gain, visc = (np.concatenate([c[i] for c in columns]) for i in range(3))
    return np.stack([motor, gain, visc, np.broadcast_to((tf - viscous)[None], motor.shape)], axis=-1)


def _free(tm, free_motor_torque):
    return tm if free_motor_torque is None else np.atleast_1d(np.asarray(free_motor_torque, float))


def _bus_free(tm, free, bus):
    """The bus family's unclipped motor torque: the 8 V wheel's where the bus at V clips no more than 8 V
    does (equal torques), else 0."""
    return np.where(np.abs(bus - tm) <= 1e-12 + 1e-9 * np.abs(tm), free, 0.0)


_VISCOUS_GRID = wm.viscous_coefficient(TEMPERATURE_GRID)
_VISCOUS_NOMINAL = float(wm.viscous_coefficient(wm.NOMINAL.temperature))
# The two families linear in their parameter's change Delta = theta - theta_0 (the bus family is not: the bridge
# clips): the limiter's share scales the motor torque (1 per share), the temperature moves eq. 2.15's viscous
# coefficient by its slope [N m s/rad per C] (linear up to 215 C, the grid's end); the unit's directions
# dr^/db they scale (motor, gain, viscous, coulomb), per unit of Delta (sums.ProfileSums)
LINEAR_SLOPES = {"current_limiter": 1.0,
                 "temperature": float(wm.viscous_coefficient(123.0) - wm.viscous_coefficient(23.0)) / 100.0}
LINEAR_DIRECTIONS = {"current_limiter": np.array([1.0, 1.0, 0.0, 0.0]),
                     "temperature": np.array([0.0, 0.0, LINEAR_SLOPES["temperature"] / _VISCOUS_NOMINAL, 0.0])}
GRIDS = {"current_limiter": CURRENT_LIMITER_GRID, "temperature": TEMPERATURE_GRID, "bus_voltage": BUS_VOLTAGE_GRID}
