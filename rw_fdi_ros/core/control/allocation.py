"""Torque allocation: the controllers' body-axis commands over the wheels in use (minimum norm).

The per-axis PID controllers (pid.py) command a torque command voltage v_a
for a wheel along their axis: a body torque demand tau = -G_d k_t v_a
(eq. 2.21; every wheel of the set has the same type, so volts and torque
differ by one factor for all). The wheel commands u (N,) that give it with
the wheels in use are the minimum-norm solution of G_u u = v,

    u = G_u^T (G_u G_u^T)^-1 v                        (G_u: G with out-of-use columns zeroed)

as Basilisk's ``rwMotorTorque`` computes it over the available wheels and
NASA 42's wheel distribution matrix does; a wheel out of use gets 0. For
three orthogonal wheels in use the distribution is the identity and u = v
exactly, so the thesis' loop is unchanged until a reconfiguration.

Voltage limit: where the largest |u_i| exceeds the +-5 V command range
the whole vector is scaled down to it. A per-wheel clip (Basilisk's
``rwMotorVoltage``) would turn the body torque away from the demand and
couple the axes; scaling keeps its direction and loses only magnitude.

A wheel FDIR holds (fdir.py: confirmed faulty, but the wheels in use could
not take its momentum) is out of the allocation and gets the speed-hold
command of :func:`hold_command` instead, from its measured speed.

Friction feed-forward (a vehicle's choice, vehicle.ControllerTargets): the
wheels' modelled friction is cancelled from their measured speeds
(:func:`friction_feedforward`), so the controllers' integrators no longer
have to find it, which they do slowly: on a light body a wheel crossing
zero speed flips its coulomb friction, and a wheel given up coasts on its
friction until it stops, and either step costs the pointing until the
integrator has caught up.

Null-space speed hold (a set with more wheels in use than axes, e.g. the pyramid): the commands along
the null space of G_u turn no axis, so the axis controllers never see their effect. Without it a
torque error of one wheel (a hot wheel's friction, a fault) drives the wheels apart along the null
vector until one saturates. The allocation holds the null-space part of the speeds where it was when
the wheels in use last changed (:func:`null_projector`, :func:`null_space_gain`), as flight software
does; with three wheels in use there is no null space and the commands are the thesis' to the digit.
"""
from __future__ import annotations

import numpy as np

from ..physics.wheel import WheelParams, holding_tcv
from ..physics.wheel_set import WheelSet

# [s] the null-space speed hold's time constant: slow beside the attitude loop's 30-s settling is not needed (the
# hold turns no axis), fast beside the minutes a hot wheel's friction error takes to drive the wheels apart
NULL_SPACE_TIME_CONSTANT = 10.0
HOLD_GAIN = 2.0   # [V/(rad/s)] speed-hold gain: a 0.7 s time constant on the datasheet wheel, stable at 0.1 s


def distribution(spin_axes, in_use) -> np.ndarray:
    """D (N, 3) with u = D v the minimum-norm wheel commands for axis commands v; zero rows for the
    wheels not ``in_use`` ((N,) bool). ValueError when the wheels in use do not span the body.

    Parameters
    ----------
    spin_axes : array_like, shape (3, N)
        G: column i is wheel i's unit spin axis, body frame (WheelSet.matrix).
    in_use : array_like of bool, shape (N,)
        Which wheels take commands.

    Returns
    -------
    ndarray, shape (N, 3)
        D = G_u^T (G_u G_u^T)^-1, dimensionless (volts per axis volt).
    """
    g = np.asarray(spin_axes, float) * np.asarray(in_use, bool)   # (3, N), columns out of use zeroed
    gram = g @ g.T
    if np.linalg.matrix_rank(gram) < 3:
        raise ValueError("the wheels in use do not span the three body axes")
    return g.T @ np.linalg.inv(gram)


def null_projector(spin_axes, in_use):
    """P_N (N, N), the projector onto the null space of the wheels in use, or None where it is empty:

        P_N = M - D G_u                (M: diag(in_use); D = G_u^T (G_u G_u^T)^-1, :func:`distribution`)

    P_N Omega is the part of the wheel speeds that turns no body axis; G P_N = 0 and P_N is symmetric.

    Parameters
    ----------
    spin_axes : array_like, shape (3, N)
        G (WheelSet.matrix).
    in_use : array_like of bool, shape (N,)
        The wheels in use (spanning the body).

    Returns
    -------
    ndarray, shape (N, N), or None
        P_N, None with three wheels in use or fewer.
    """
    m = np.asarray(in_use, bool)
    if m.sum() <= 3:
        return None
    g = np.asarray(spin_axes, float) * m
    return np.diag(m.astype(float)) - distribution(spin_axes, m) @ g


def null_space_gain(time_constant: float, params: WheelParams = WheelParams()) -> float:
    """k_n [V/(rad/s)] of the null-space speed hold u_n = -k_n P_N (Omega - Omega_0): the wheels' speeds
    along the null space return to their hold with the time constant ``time_constant`` [s],

        J dOmega/dt = G_d k_t u   =>   k_n = J / (G_d k_t tau_n)            (0 for tau_n = 0: no hold)

    Parameters
    ----------
    time_constant : float
        tau_n [s]; 0 turns the hold off.
    params : WheelParams
        The wheel type (J, G_d, k_t).

    Returns
    -------
    float
        k_n [V/(rad/s)].
    """
    if time_constant <= 0.0:
        return 0.0
    return params.inertia / (params.driver_gain * params.torque_constant * time_constant)


def limited(wheel_commands, limit: float):
    """``wheel_commands`` (..., N) scaled down, per run, so that none exceeds ``limit`` [V] in magnitude.

    Parameters
    ----------
    wheel_commands : array_like, shape (..., N)
        Commands u [V], e.g. (B, N).
    limit : float
        The command range [V] (5 V on the datasheet wheel).

    Returns
    -------
    ndarray, shape (..., N)
        u [V], each run's row scaled by one factor where its largest |u_i| exceeds ``limit``.
    """
    u = np.asarray(wheel_commands, float)
    peak = np.abs(u).max(axis=-1, keepdims=True)
    return np.where(peak > limit, u * (limit / np.maximum(peak, 1e-300)), u)


def hold_command(reference, speed, gain: float = HOLD_GAIN, limit: float = 5.0,
                 params: WheelParams = WheelParams()):
    """Command [V] that holds a wheel at ``reference`` [rad/s] from its measured ``speed``:

        u = u_f(Omega_ref) + k (Omega_ref - Omega),   clipped to +-``limit``

    u_f the datasheet wheel's friction-cancelling voltage at 23 C (wheel.holding_tcv), k = ``gain``. The
    proportional term takes up what the feed-forward misses (a unit's own drag, a current loss); where the
    fault leaves less torque than friction (a bus drop's back-EMF limit), the wheel slows to the speed it
    can hold and the wheels in use take the momentum it sheds.

    Parameters
    ----------
    reference : float or array_like
        Speed to hold Omega_ref [rad/s], e.g. (K,) for K held wheels.
    speed : float or array_like
        Measured wheel speed Omega [rad/s], broadcasting with ``reference``.
    gain : float, optional
        k [V/(rad/s)].
    limit : float, optional
        Command range [V].
    params : WheelParams
        The wheel type whose friction the feed-forward cancels (scalar fields).

    Returns
    -------
    ndarray
        u [V] within +-``limit``, the broadcast shape of ``reference`` and ``speed``.
    """
    ref = np.asarray(reference, float)
    u = holding_tcv(ref, 23.0, params) + gain * (ref - np.asarray(speed, float))
    return np.minimum(np.maximum(u, -limit), limit)


def friction_feedforward(speed, in_use, coasting, dist, spin_axes, params: WheelParams = WheelParams()) -> np.ndarray:
    """u_ff (B, N) [V]: the commands that cancel the wheels' modelled friction at their measured speeds,

        u_ff = m u_f(Omega) + D G (c u_f(Omega))        (m: wheels in use, c: wheels coasting)

    u_f the datasheet wheel's friction-cancelling voltage at 23 C (wheel.holding_tcv). A wheel in use cancels
    its own friction. A wheel that coasts (out of use and not commanded: given up, or at rest standing by, where
    u_f = 0) passes its friction to the body as it slows; the wheels in use give the body the torque its own
    motor would have given at u_f, its spin axis times u_f distributed over them by D (:func:`distribution`).

    Parameters
    ----------
    speed : array_like, shape (B, N)
        Measured wheel speeds Omega [rad/s].
    in_use : array_like of bool, shape (B, N)
        m: the wheels the allocation commands.
    coasting : array_like of bool, shape (B, N)
        c: the wheels not commanded at all (a held wheel is neither: its own command cancels its friction).
    dist : array_like, shape (B, N, 3)
        D of each run.
    spin_axes : array_like, shape (3, N)
        G.
    params : WheelParams
        The wheel type whose friction is modelled.

    Returns
    -------
    ndarray, shape (B, N)
        u_ff [V], not limited.
    """
    u_f = holding_tcv(np.asarray(speed, float), 23.0, params)
    axis_volts = np.einsum("kn,bn->bk", np.asarray(spin_axes, float), np.where(coasting, u_f, 0.0))   # (B, 3)
    return np.where(in_use, u_f, 0.0) + np.einsum("bnk,bk->bn", dist, axis_volts)


class TorqueAllocator:
    """Wheel commands of a batch of runs, each with its own wheels in use (``in_use``: (B, N) bool)."""

    def __init__(self, wheels: WheelSet, batch: int = 1, limit: float = 5.0, params: WheelParams = WheelParams(),
                 feedforward: bool = False, null_time_constant: float = NULL_SPACE_TIME_CONSTANT):
        self.wheels = wheels
        self.limit = float(limit)
        self.params = params   # the wheel type whose friction a held wheel's feed-forward cancels
        self.feedforward = bool(feedforward)   # every wheel's friction cancelled (friction_feedforward)
        self.in_use = np.tile(wheels.mask(wheels.active), (batch, 1))
        self.hold_speed = np.full(self.in_use.shape, np.nan)   # [rad/s] per held wheel, NaN for the others
        self.held = np.zeros(self.in_use.shape, bool)
        self._holding = False    # any wheel held in any run: decided in use(), not on every command
        self.null_gain = null_space_gain(null_time_constant, params)   # [V/(rad/s)], 0: no null-space hold
        self._matrix = {}
        self._dist = np.stack([self._distribution(row) for row in self.in_use])
        # P_N per run (zeros without a null space) and P_N Omega_0, NaN until the run's first command
        self._null = np.stack([self._projector(row) for row in self.in_use])
        self._has_null = self._null.any(axis=(1, 2))
        self.null_hold = np.full(self.in_use.shape, np.nan)

    @property
    def needs_speeds(self) -> bool:
        """Whether a command needs its step's wheel speeds (the feed-forward, a held wheel or a null-space hold)."""
        return self.feedforward or self._holding or bool(self._has_null.any())

    def _distribution(self, row) -> np.ndarray:
        key = tuple(bool(x) for x in row)
        if key not in self._matrix:
            self._matrix[key] = distribution(self.wheels.matrix, row)
        return self._matrix[key]

    def _projector(self, row) -> np.ndarray:
        p = null_projector(self.wheels.matrix, row) if self.null_gain else None
        return np.zeros((len(row), len(row))) if p is None else p

    def use(self, names, b: int = 0, held=None):
        """Run ``b`` uses the wheels ``names`` from the next command on (ValueError: they do not span) and
        holds the wheels of ``held`` (name -> speed [rad/s]) at their speed.

        Parameters
        ----------
        names : iterable of str
            The wheels in use.
        b : int
            The run's index in the batch.
        held : dict or None
            wheel -> the speed it is held at [rad/s].
        """
        row = self.wheels.mask(names)
        self._dist[b] = self._distribution(row)
        self.in_use[b] = row
        self._null[b] = self._projector(row)
        self._has_null[b] = self._null[b].any()
        self.null_hold[b] = np.nan   # the null space changed: held where the next command finds it
        self.hold_speed[b] = np.nan
        for name, speed in (held or {}).items():
            self.hold_speed[b, self.wheels.index(name)] = speed
        self.held[b] = ~np.isnan(self.hold_speed[b])
        self._holding = bool(self.held.any())

    def wheel_commands(self, axis_commands, wheel_speed=None) -> np.ndarray:
        """u (B, N) [V] for the controllers' axis commands v (B, 3) [V], within the voltage limit; a held
        wheel's command from its ``wheel_speed`` (B, N) [rad/s] (needed once a wheel is held).

        Parameters
        ----------
        axis_commands : array_like
            (B, 3) the controllers' body-axis commands v [V].
        wheel_speed : array_like or None
            (B, N) wheel speeds Omega [rad/s] (needed with a held wheel or the feed-forward).

        Returns
        -------
        numpy.ndarray
            (B, N) torque command voltages u [V].
        """
        v = np.asarray(axis_commands, float).reshape(len(self.in_use), 3)
        u = np.einsum("bnk,bk->bn", self._dist, v)
        if self.feedforward:
            u = u + self.friction_commands(wheel_speed)
        if self._has_null.any():
            u = u + self.null_commands(wheel_speed)
        u = limited(u, self.limit)
        if self._holding:
            if wheel_speed is None:
                raise ValueError("a held wheel's command needs the wheel speeds")
            speed = np.asarray(wheel_speed, float).reshape(u.shape)
            u[self.held] = hold_command(self.hold_speed[self.held], speed[self.held], limit=self.limit,
                                         params=self.params)
        return u

    def null_commands(self, wheel_speed) -> np.ndarray:
        """u_n (B, N) [V] = -k_n P_N (Omega - Omega_0) at ``wheel_speed`` (B, N): the null-space speed hold
        (:func:`null_projector`), Omega_0 the speeds of the first command since the wheels in use changed; zeros
        for a run without a null space.

        Parameters
        ----------
        wheel_speed : array_like
            (B, N) wheel speeds Omega [rad/s].

        Returns
        -------
        numpy.ndarray
            (B, N) u_n [V], each run's in its wheels' null space (G u_n = 0).
        """
        if wheel_speed is None:
            raise ValueError("the null-space speed hold needs the wheel speeds")
        along = np.einsum("bmn,bn->bm", self._null, np.asarray(wheel_speed, float).reshape(self.in_use.shape))
        fresh = np.isnan(self.null_hold[:, 0])
        self.null_hold[fresh] = along[fresh]
        return -self.null_gain * (along - self.null_hold)

    def friction_commands(self, wheel_speed) -> np.ndarray:
        """u_ff (B, N) [V] at ``wheel_speed`` (B, N) for the wheels as they are used now (:func:`friction_feedforward`;
        zeros without the feed-forward): what the controllers' integrators need not hold.

        Parameters
        ----------
        wheel_speed : array_like
            (B, N) wheel speeds Omega [rad/s].

        Returns
        -------
        numpy.ndarray
            (B, N) u_ff [V].
        """
        if not self.feedforward:
            return np.zeros(self.in_use.shape)
        if wheel_speed is None:
            raise ValueError("the friction feed-forward needs the wheel speeds")
        speed = np.asarray(wheel_speed, float).reshape(self.in_use.shape)
        return friction_feedforward(speed, self.in_use, ~self.in_use & ~self.held, self._dist, self.wheels.matrix,
                                    self.params)

    def integrator_start(self, tcv, wheel_speed) -> np.ndarray:
        """(B, 3) [V]: the body-axis command the controllers' integrators start from, so that the first
        commands hold the wheels as the plant starts them (its holding voltages ``tcv`` (B, N) at
        ``wheel_speed`` (B, N)): what the feed-forward does not already give, G (tcv - u_ff).

        Parameters
        ----------
        tcv : array_like
            (B, N) the plant's holding voltages [V].
        wheel_speed : array_like
            (B, N) wheel speeds Omega [rad/s].

        Returns
        -------
        numpy.ndarray
            (B, 3) body-axis commands [V].
        """
        tcv = np.asarray(tcv, float).reshape(self.in_use.shape)
        return (tcv - self.friction_commands(wheel_speed)) @ np.asarray(self.wheels.matrix, float).T
