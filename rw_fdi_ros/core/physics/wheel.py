"""High-fidelity reaction wheel (Bialke model, thesis 2.2.2, Fig. 2.2).

Plain functions over numpy arrays: every argument broadcasts, so the same
code steps one wheel in the live plant node and a batch of wheels in a
Monte-Carlo study. The reconstructed parts of the block diagram follow
``shared/spec/physics.md``; the items it marks [choice] are fields of
:class:`WheelParams`.

Sign convention: a positive torque command voltage (tcv) asks for a positive
motor torque, which spins the wheel up and pushes the body the other way
(reaction torque = -net wheel torque, eq. 2.18).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

EMF_LIMITS = ("kf_scaled", "pwm_saturation")


@dataclass(frozen=True)
class WheelParams:
    """Thesis Table 2.2 (ITHACO Type A) plus the modelling choices of physics.md."""

    driver_gain: float = 0.19            # G_d [A/V]
    driver_bandwidth: float = 2000.0     # w_d [rad/s]; treated as algebraic (0.5 ms << 0.1 s step)
    torque_constant: float = 0.029       # k_t [N m/A]
    emf_constant: float = 0.029          # k_e [V/(rad/s)]
    overspeed_gain: float = 95.0         # k_s [V/(rad/s)]
    overspeed_threshold: float = 690.0   # w_s [rad/s]
    coulomb_friction: float = 0.002      # tau_c [N m]
    inertia: float = 0.0077              # J [kg m^2]
    poles: int = 36                      # N
    ripple_coefficient: float = 0.22     # B (peak-to-peak share of motor torque)
    input_resistance: float = 2.0        # R_IN [ohm]
    quiescent_power: float = 3.0         # P_q [W]
    bridge_resistance: float = 2.0       # R_B [ohm]
    voltage_feedback_gain: float = 0.5   # K_f [V/V]
    noise_angle: float = 0.05            # theta_a [rad]
    noise_frequency: float = 0.2         # w_a [rad/s]
    command_limit: float = 5.0           # +-5 V torque command range
    diode_drop: float = 1.0              # reverse-polarity diode [V], eq. 2.13
    bus_voltage: float = 8.0             # V_bus [V]: the bus the wheel's drive runs on (Table 2.3's normal op.)
    # [choice] EMF torque limiting: 'kf_scaled' (default) or 'pwm_saturation'.
    emf_limit: str = "kf_scaled"
    # [choice] ripple amplitude as a share of B: 0.5 reads B as peak-to-peak.
    ripple_amplitude_share: float = 0.5
    # [choice] coulomb friction tau_c*tanh(w/w_c): smooth through zero speed so
    # the integrator does not chatter; 0.05 rad/s is far below the 20-30 rad/s regime.
    coulomb_smoothing_speed: float = 0.05
    # unit-to-unit variation (unit_wheel): this unit's viscous friction over eq. 2.15's
    viscous_scale: float = 1.0
    # sigma of the tachometer's speed [rad/s]: what a torque derived from speeds carries (residuals.py,
    # speed_noise_reach); 0: the speed is exact, as our plant's telemetry is
    speed_noise: float = 0.0

    def __post_init__(self):
        if self.emf_limit not in EMF_LIMITS:
            raise ValueError(f"emf_limit must be one of {EMF_LIMITS}, got {self.emf_limit!r}")

    def as_dict(self) -> dict:
        """Every parameter by name.

        Returns
        -------
        dict
            Field -> value.
        """
        return asdict(self)


@dataclass(frozen=True)
class OperatingPoint:
    """Thesis Table 2.3 normal operation; faults move these values."""

    bus_voltage: float = 8.0       # V_bus [V]
    current_limiter: float = 1.0   # share of motor current that reaches the motor
    temperature: float = 23.0      # T [deg C]
    ripple_gain: float = 1.0       # multiplies the ripple coefficient B


NOMINAL = OperatingPoint()   # the thesis wheel's (8 V bus); a wheel type's own: nominal_point(params)


def nominal_point(params: WheelParams = WheelParams()) -> OperatingPoint:
    """Normal operation (Table 2.3) on the wheel type's own bus, V_bus = ``params.bus_voltage``.

    Parameters
    ----------
    params : WheelParams
        The wheel type.

    Returns
    -------
    OperatingPoint
        NOMINAL with the wheel's bus voltage.
    """
    return replace(NOMINAL, bus_voltage=params.bus_voltage)


def viscous_coefficient(temperature, params: WheelParams = WheelParams()):
    """Viscous friction coefficient tau_v(T) [N m s/rad], eq. 2.15, clamped at 0.

    tau_v = (0.049 - 0.0002 (T + 30)) 1e-2; 3.84e-4 at 23 C, 0 from 215 C on.

    Parameters
    ----------
    temperature : float or array_like
        Wheel temperature T [C], any shape.
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    float or ndarray
        tau_v [N m s/rad], ``temperature``'s shape broadcast with ``params.viscous_scale``.
    """
    tau_v = np.maximum((0.049 - 0.0002 * (np.asarray(temperature, float) + 30.0)) * 1e-2, 0.0)
    scale = params.viscous_scale   # a unit's own bearing drag (unit_wheel); the datasheet's law is 1
    return tau_v if isinstance(scale, float) and scale == 1.0 else tau_v * scale


def emf_current_limit(bus_voltage, speed, params: WheelParams = WheelParams()):
    """Largest motoring current |I| the bridge can drive, eqs. 2.9-2.14.

    With the bus current of eq. 2.12 (motoring, so w I = |w| |I|)
        I_bus = (R_B I^2 + 0.04 |I| V_bus + P_q + k_e |w| |I|) / (V_bus - 1)
    and the available voltage V_avail = V_bus - 1 - R_IN I_bus, the limit
        R_B |I| + k_e |w| <= g V_avail      (g = K_f or 1, the [choice])
    is a quadratic a I^2 + b I + c <= 0 whose positive root is returned
    (0 when there is none: the back-EMF alone eats the headroom).

    Parameters
    ----------
    bus_voltage : float or array_like
        Bus voltage V_bus [V].
    speed : float or array_like
        Wheel speed w [rad/s]; its sign does not matter. Broadcasts with ``bus_voltage``.
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    ndarray
        The current limit I_max >= 0 [A], the broadcast shape of ``bus_voltage`` and ``speed``.
    """
    p = params
    g = p.voltage_feedback_gain if p.emf_limit == "kf_scaled" else 1.0
    v_bus = np.asarray(bus_voltage, float)
    w = np.abs(np.asarray(speed, float))
    vd = np.maximum(v_bus - p.diode_drop, 1e-9)
    a = g * p.input_resistance * p.bridge_resistance
    b = vd * p.bridge_resistance + g * p.input_resistance * (0.04 * v_bus + p.emf_constant * w)
    c = vd * p.emf_constant * w - g * vd**2 + g * p.input_resistance * p.quiescent_power
    disc = np.maximum(b * b - 4.0 * a * c, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):   # a = 0 (R_IN = 0): the limit is linear, b I + c <= 0
        root = np.where(a > 0.0, (-b + np.sqrt(disc)) / (2.0 * a), -c / b)
    return np.where(c < 0.0, root, 0.0)


def motor_current(tcv, speed, bus_voltage, current_limiter, params: WheelParams = WheelParams()):
    """Motor current I_m [A] for a torque command voltage (Fig. 2.2, steps 1-5).

    Clamp to +-5 V, speed limiter (eq. 2.8), driver gain G_d (its 0.5 ms lag
    is algebraic at our 0.1 s step), EMF limiting in the motoring quadrant
    only (H_b, eq. 2.13), then the current-loss fault (current limiter).

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage [V]; clamped to +-``params.command_limit``.
    speed : float or array_like
        Wheel speed [rad/s].
    bus_voltage : float or array_like
        Bus voltage V_bus [V].
    current_limiter : float or array_like
        Share of the bridge current that reaches the motor (1 healthy, less under a current-loss fault).
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    ndarray
        I_m [A], the broadcast shape of the arguments ((B, N) in the plant).
    """
    return bridge(tcv, speed, bus_voltage, params)[0] * current_limiter


def bridge(tcv, speed, bus_voltage, params: WheelParams = WheelParams()):
    """(current the bridge drives, whether the EMF limit clipped it) before the current limiter. Where it
    clips, the motor torque is k_t I_max whatever the driver gain: a unit's G_d shows only elsewhere.

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage [V]; clamped to +-``params.command_limit``.
    speed : float or array_like
        Wheel speed [rad/s].
    bus_voltage : float or array_like
        Bus voltage V_bus [V].
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    current : ndarray
        The bridge current [A], the broadcast shape of the arguments.
    clipped : ndarray of bool
        Where the EMF limit cut it (motoring quadrant only), same shape.
    """
    p = params
    w = np.asarray(speed, float)
    # minimum/maximum, not np.clip: the same numbers at a fifth of the cost on 3-vectors (the plant
    # evaluates this seven times a step)
    v = np.minimum(np.maximum(np.asarray(tcv, float), -p.command_limit), p.command_limit)
    over = np.abs(w) >= p.overspeed_threshold
    if over.any():
        v = v - np.where(over, p.overspeed_gain * (np.abs(w) - p.overspeed_threshold) * np.sign(w), 0.0)
    current = p.driver_gain * v
    motoring = current * w > 0.0
    i_max = emf_current_limit(bus_voltage, w, p)
    clipped = motoring & (np.abs(current) > i_max)
    return np.where(clipped, np.sign(current) * i_max, current), clipped


def friction_torque(speed, temperature, params: WheelParams = WheelParams()):
    """Bearing friction [N m]: viscous tau_v(T) w (eq. 2.15) plus smoothed coulomb tau_c.

    Parameters
    ----------
    speed : float or array_like
        Wheel speed w [rad/s].
    temperature : float or array_like
        Wheel temperature T [C]; broadcasts with ``speed``.
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    ndarray
        Friction torque [N m], signed with ``speed``, the broadcast shape of the arguments.
    """
    w = np.asarray(speed, float)
    coulomb = params.coulomb_friction * np.tanh(w / params.coulomb_smoothing_speed)
    return viscous_coefficient(temperature, params) * w + coulomb


def bearing_noise_amplitude(params: WheelParams = WheelParams()):
    """The bearing noise's amplitude A = J theta_a w_a^2 [N m], eq. 2.16 (the Type A's 1.54e-5 N m).

    Parameters
    ----------
    params : WheelParams
        The wheel type; its fields may be arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    float or ndarray
        A [N m], shaped as the fields of ``params``.
    """
    return params.inertia * params.noise_angle * params.noise_frequency ** 2


def torque_noise(t, params: WheelParams = WheelParams()):
    """Bearing torque noise A sin(w_a t) [N m], eq. 2.16, A = J theta_a w_a^2 (:func:`bearing_noise_amplitude`).

    Parameters
    ----------
    t : float or array_like
        Time [s].
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    float or ndarray
        Noise torque [N m], ``t``'s shape broadcast with the fields of ``params``.
    """
    return bearing_noise_amplitude(params) * np.sin(params.noise_frequency * np.asarray(t, float))


def net_torque(tcv, speed, t, op, params: WheelParams = WheelParams()):
    """Net torque on the flywheel without ripple, tau_n = tau_m - friction + noise (eqs. 2.11, 2.19-2.20).

    ``op`` is anything with bus_voltage, current_limiter and temperature
    attributes (an :class:`OperatingPoint` or arrays of them per wheel).

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage [V], e.g. (B, N).
    speed : float or array_like
        Wheel speed [rad/s], broadcasting with ``tcv``.
    t : float
        Time [s] (the bearing noise's phase).
    op : OperatingPoint or namespace
        ``bus_voltage`` [V], ``current_limiter`` (share), ``temperature`` [C]: floats or arrays broadcasting
        with ``tcv``.
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    net : ndarray
        tau_n [N m], the broadcast shape of the arguments.
    motor : ndarray
        tau_m = k_t I_m [N m], same shape (what the ripple scales).
    """
    tau_m = params.torque_constant * motor_current(tcv, speed, op.bus_voltage, op.current_limiter, params)
    return tau_m - friction_torque(speed, op.temperature, params) + torque_noise(t, params), tau_m


def torque_ripple(motor_torque, wheel_angle, ripple_gain, params: WheelParams = WheelParams()):
    """Commutation torque ripple [N m]: (B/2) gain tau_m sin(N theta) (Fig. 2.2, [choice]).

    At ~143 Hz it averages out of the body motion over a 0.1 s step, so the
    plant applies it to the sampled output torque at the sampled wheel angle.

    Parameters
    ----------
    motor_torque : float or array_like
        Motor torque tau_m [N m], e.g. (B, N).
    wheel_angle : float or array_like
        Wheel angle theta [rad], broadcasting with ``motor_torque``.
    ripple_gain : float or array_like
        Multiplier of the ripple coefficient B (1 healthy; the ripple fault raises it).
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    ndarray
        Ripple torque [N m], the broadcast shape of the arguments.
    """
    amp = params.ripple_amplitude_share * params.ripple_coefficient * np.asarray(ripple_gain, float)
    return amp * motor_torque * np.sin(params.poles * np.asarray(wheel_angle, float))


def holding_tcv(speed, temperature=23.0, params: WheelParams = WheelParams()):
    """Command voltage whose motor torque cancels friction at ``speed`` (wheel in equilibrium).

    Parameters
    ----------
    speed : float or array_like
        Wheel speed [rad/s].
    temperature : float or array_like, optional
        Wheel temperature [C].
    params : WheelParams
        The wheel type; its fields may be (B, N) arrays, one unit per wheel (:func:`unit_wheel`).

    Returns
    -------
    ndarray
        tcv [V], not clamped to the command range; the broadcast shape of the arguments.
    """
    return friction_torque(speed, temperature, params) / (params.driver_gain * params.torque_constant)


def bearing_noise_mean(params: WheelParams = WheelParams(), seconds: float = 40.0) -> float:
    """The largest |mean| of eq. 2.16's bearing noise A sin(w_a t), A = J theta_a w_a^2, over any ``seconds``
    [N m]: A min(1, 2 / (w_a seconds)). The nominal model leaves this noise out, so no residual averaged over
    that window can promise less (the Type A over 40 s: 3.9e-6 N m).

    Parameters
    ----------
    params : WheelParams
        The wheel type.
    seconds : float
        The averaging window [s].

    Returns
    -------
    float
        The bound [N m].
    """
    return float(bearing_noise_amplitude(params) * min(1.0, 2.0 / max(params.noise_frequency * seconds, 1e-12)))


def torque_scale(params: WheelParams = WheelParams()) -> float:
    """tau_max / tau_max of the thesis' Type A, tau_max = G_d k_t V_limit (27.6 mN m): how much smaller or larger
    this wheel type's torques are. What the FDI takes as a torque too small to matter (noise floors, a command
    too small to judge a wheel by) was set on the Type A and scales with it.

    Parameters
    ----------
    params : WheelParams
        The wheel type.

    Returns
    -------
    float
        The ratio.
    """
    thesis = WheelParams()
    return float(params.driver_gain * params.torque_constant * params.command_limit
                 / (thesis.driver_gain * thesis.torque_constant * thesis.command_limit))


def top_speed(params: WheelParams = WheelParams(), op: OperatingPoint | None = None) -> float:
    """Omega_top [rad/s]: the highest speed the wheel holds at the full command at the operating point ``op``,
    where the motor torque the bridge can drive, k_t min(G_d V_limit, I_max(V_bus, Omega)) (eqs. 2.9-2.14),
    no longer exceeds the friction (eqs. 2.15-2.16); at most the overspeed threshold w_s. The thesis' Type A
    at 23 C: 47.3 rad/s, friction-bound. Found by bisection (the surplus falls with speed).

    Parameters
    ----------
    params : WheelParams
        The wheel type (scalar fields).
    op : OperatingPoint or None
        The bus voltage and temperature (default: normal operation on the wheel's bus, :func:`nominal_point`).

    Returns
    -------
    float
        Omega_top [rad/s].
    """
    op = nominal_point(params) if op is None else op

    def surplus(w):
        drive = min(params.driver_gain * params.command_limit, float(emf_current_limit(op.bus_voltage, w, params)))
        return params.torque_constant * drive - float(friction_torque(w, op.temperature, params))
    low, high = 0.0, float(params.overspeed_threshold)
    if surplus(high) >= 0.0:
        return high
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if surplus(mid) >= 0.0 else (low, mid)
    return low


# Unit-to-unit variation: the parameters that differ between wheels of one type and drift over life,
# with the default 1-sigma spread of each unit's value over the datasheet's (a share). Bearing drag
# depends on lubricant quantity, state and temperature and differs by tens of per cent between
# units and over life (Bialke, "High fidelity mathematical modeling of reaction wheel performance",
# 1998, on drag torque; the ITHACO datasheet gives typical, not guaranteed, friction); the torque
# constant and the driver's transconductance are set by magnets, windings and a sense resistor,
# matched to a few per cent. Each scale is drawn N(1, spread), cut at 3 sigma.
UNIT_PARAMETERS = ("torque_constant", "driver_gain", "viscous_friction", "coulomb_friction")
DEFAULT_UNIT_SPREAD = {"torque_constant": 0.02, "driver_gain": 0.02, "viscous_friction": 0.20,
                       "coulomb_friction": 0.20}


def unit_wheel(base: WheelParams, scales: dict) -> WheelParams:
    """``base`` with each unit's parameters scaled: ``scales`` maps UNIT_PARAMETERS names to arrays of
    shape (N,) (one per wheel of the set) or (B, N) (a batch); the physics broadcasts them per wheel.

    Parameters
    ----------
    base : WheelParams
        The datasheet wheel (or any base).
    scales : dict of str to float or array_like
        Every name of UNIT_PARAMETERS to its scale over ``base`` (a share, 1 = datasheet), of shape (N,) for
        one run's wheels or (B, N) for a batch.

    Returns
    -------
    WheelParams
        ``base`` with ``torque_constant``, ``driver_gain``, ``coulomb_friction`` and ``viscous_scale`` (the type's
        own scale times the unit's) as arrays of the scales' shape.
    """
    return replace(base, torque_constant=base.torque_constant * np.asarray(scales["torque_constant"], float),
                   driver_gain=base.driver_gain * np.asarray(scales["driver_gain"], float),
                   coulomb_friction=base.coulomb_friction * np.asarray(scales["coulomb_friction"], float),
                   viscous_scale=base.viscous_scale * np.asarray(scales["viscous_friction"], float))


@dataclass(frozen=True)
class LinearWheel:
    """State-space form of the linearised wheel, eq. 2.22.

    F_w(s) = -G_d k_t J s / (J s + tau_v) = D + B C / (s - A) with
    A = -tau_v/J, D = -G_d k_t, B C = G_d k_t tau_v / J.
    """

    A: float
    B: float
    C: float
    D: float


def linearised_wheel(temperature=23.0, params: WheelParams = WheelParams(), output_gain=0.01759) -> LinearWheel:
    """Thesis 3.3 numbers: A=-0.04987, B=0.01563, C=0.01759, D=-0.00551 at 23 C.

    Only B C is fixed by eq. 2.22; ``output_gain`` is the thesis' C, B follows.

    Parameters
    ----------
    temperature : float, optional
        Wheel temperature [C] at which tau_v is taken.
    params : WheelParams
        The wheel type, scalar fields (one wheel).
    output_gain : float, optional
        The state-space C; B = G_d k_t tau_v / (J C).

    Returns
    -------
    LinearWheel
        A [1/s], B, C, D [N m/V] of eq. 2.22 (input tcv [V], output torque [N m]).
    """
    tau_v = float(viscous_coefficient(temperature, params))
    gk = params.driver_gain * params.torque_constant
    a = -tau_v / params.inertia
    bc = gk * tau_v / params.inertia
    return LinearWheel(A=a, B=bc / output_gain, C=output_gain, D=-gk)


def bus_fault_visible_above(bus_voltage, temperature=23.0, params: WheelParams = WheelParams()):
    """Wheel speed [rad/s] above which holding it needs more current than the EMF limit allows.

    Below it a bus-voltage drop leaves the wheel voltage headroom and is physically
    invisible while the spacecraft holds attitude (physics.md, EMF limiting).

    Parameters
    ----------
    bus_voltage : float
        Bus voltage V_bus [V].
    temperature : float, optional
        Wheel temperature [C] (the friction to hold).
    params : WheelParams
        The wheel type, scalar fields (one wheel).

    Returns
    -------
    float
        The speed [rad/s], on a 0.01 rad/s grid over 0-100 rad/s; inf when no speed up to 100 rad/s is short.
    """
    speeds = np.linspace(0.0, 100.0, 10001)
    holding = friction_torque(speeds, temperature, params) / params.torque_constant
    short = emf_current_limit(bus_voltage, speeds, params) < holding
    return float(speeds[np.argmax(short)]) if short.any() else float("inf")
