"""The plant: rigid body (eq. 2.27) driven by a set of Bialke wheels (Fig. 2.2) with faults.

[choice] ``wheel_momentum_coupling`` (default on): the wheels' stored momentum
h_w = J G Omega enters the body's Euler equations and the body's angular
acceleration enters the wheels' (see :func:`body_acceleration`), as in every
multibody simulator (Basilisk's BalancedWheels, test/test_basilisk.py); off is
eq. 2.27 as the thesis writes it, body and wheels driven only by tau_n.

The wheels are a :class:`~.wheel_set.WheelSet`: N wheels of one type with spin
axes g_i (columns of G); wheel i's reaction torque -tau_n,i acts along g_i.
A standby wheel is unpowered and held at rest by its bearing (part of the
locked body) until its first non-zero command releases it (wheel_set.py).

One class, batched over runs: shape (B, N) wheel arrays in the set's order,
(B, 3) body arrays (x, y, z). The live plant node holds a batch of one;
Monte-Carlo tools hold many.

Time is stepped in lockstep with the controllers: the torque command
voltage (tcv) for step k is held over [t_k, t_k+1) (zero-order hold) and
the plant integrates the wheel and body states with one RK4 step over that
period (the fastest dynamics, the coulomb smoothing near zero speed, have
a time constant of ~0.2 s; halving the step changes attitude by < 1e-6 rad).
"""
from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from . import wheel as wm
from .environment import Environments, magnetometer_steps
from .faults import FAULT_KINDS, nominal_values, operating_points
from .spacecraft import body_acceleration, disturbance_torque
from .wheel_set import WheelSet, wheel_set as named_wheel_set


@dataclass
class PlantSample:
    """What the plant publishes at one instant: body arrays (B, 3), wheel arrays (B, N)."""

    time: float
    attitude: np.ndarray
    body_rate: np.ndarray
    wheel_speed: np.ndarray
    tcv: np.ndarray              # command in force (clamped to +-5 V)
    reaction_torque: np.ndarray  # -(tau_n + ripple) along each wheel's spin axis, eq. 2.18
    fault_effect: np.ndarray     # reaction torque minus a healthy wheel's in the same state
    operating_point: dict        # kind -> (B, N)
    magnetic_field: np.ndarray | None = None   # the magnetometer's reading (B, 3) [T] at its samples, in orbit


def hold_command(wheel_speed, params: wm.WheelParams = wm.WheelParams()):
    """The command a controller that was holding attitude had before t=0 (wheel at equilibrium).

    Parameters
    ----------
    wheel_speed : float or array_like
        Wheel speed [rad/s], e.g. (B, N).
    params : WheelParams
        The wheel type; fields may be (B, N) arrays (:func:`units_of`).

    Returns
    -------
    ndarray
        tcv [V] that cancels friction at 23 C (not clamped), the broadcast shape.
    """
    return wm.holding_tcv(wheel_speed, 23.0, params)


def units_of(scenarios, base: wm.WheelParams, count: int = 3) -> wm.WheelParams:
    """The ``count`` wheels of a batch of scenarios: ``base`` (the datasheet) unless some scenario draws its
    units (Scenario.unit_scales); then each parameter of wm.UNIT_PARAMETERS as a (B, count) array.

    Parameters
    ----------
    scenarios : list of Scenario
        The B runs of the batch.
    base : WheelParams
        The datasheet wheel.
    count : int, optional
        Wheels per run, N.

    Returns
    -------
    WheelParams
        ``base``, or its units with (B, N) arrays (wheel.unit_wheel); datasheet scales for runs that draw none.
    """
    scales = [s.unit_scales(count) for s in scenarios]
    if all(sc is None for sc in scales):
        return base
    ones = {name: np.ones(count) for name in wm.UNIT_PARAMETERS}
    return wm.unit_wheel(base, {name: np.array([(sc or ones)[name] for sc in scales])
                                for name in wm.UNIT_PARAMETERS})


def batch_vehicle(scenarios):
    """The one vehicle a batch of scenarios flies (vehicle.py); ValueError when they name different ones.

    Parameters
    ----------
    scenarios : iterable of Scenario
        The batch.

    Returns
    -------
    Vehicle
        The vehicle.
    """
    vehicles = {s.spacecraft for s in scenarios}
    if len(vehicles) > 1:
        raise ValueError("a batch of runs flies one vehicle; these scenarios name "
                         + ", ".join(sorted(v.name for v in vehicles)))
    return vehicles.pop()


class Plant:
    """Spacecraft with a set of reaction wheels (the scenarios' ``wheel_set``) for a batch of scenarios."""

    def __init__(self, scenarios, wheel: wm.WheelParams | None = None, control_period=0.1,
                 substeps=1, inertia=None, disturbance=True, wheel_momentum_coupling=True,
                 wheels: WheelSet | str | None = None, duration: float | None = None,
                 magnetic_field: str | None = None):
        """``scenarios``: one scenario.Scenario or a list of them; ``wheel``, ``inertia``: the wheel type and the
        body's inertia; None: the scenarios' vehicle's."""
        if hasattr(scenarios, "faults"):   # one scenario, not a batch (duck-typed: the physics imports no scenario)
            scenarios = [scenarios]
        self.scenarios = list(scenarios)
        self.vehicle = vehicle = batch_vehicle(self.scenarios)
        # the wheel type's datasheet (what the controllers and FDIR know); self.wheel: the units flown
        self.datasheet = wheel = vehicle.wheel if wheel is None else wheel
        if inertia is None:
            inertia = vehicle.body_inertia
        self.disturbance_sigma = vehicle.disturbance_sigma
        if wheels is None:
            wheels = self.scenarios[0].plant_choices().wheel_set
        self.wheels = named_wheel_set(wheels) if isinstance(wheels, str) else wheels
        self.spin_axes = self.wheels.matrix
        n = self.wheels.count
        self.wheel = units_of(self.scenarios, wheel, n)
        self.nominal = nominal_values(wheel)   # its healthy operating point: the type's own bus voltage
        self.dt = float(control_period)
        self.substeps = int(substeps)
        self.inertia = np.asarray(inertia, float)
        self.disturbance = disturbance
        self.wheel_momentum_coupling = bool(wheel_momentum_coupling)
        # in orbit (environment.py): the track is computed on first use (the first sample), not for a look at
        # the initial state (runner/graph.py)
        self.duration = float(duration or max(s.duration for s in self.scenarios))
        self.field_model = magnetic_field or self.scenarios[0].plant_choices().magnetic_field
        self.in_orbit = any(s.environment is not None for s in self.scenarios)
        self._environment = None
        self.dipole = np.zeros((self.batch, 3))   # the magnetorquers' dipole in force [A m^2]
        self.magnetometer_steps = magnetometer_steps(self.dt) if self.in_orbit else None
        draws = [s.draws()[0] for s in self.scenarios]
        self.attitude = np.array([d.attitude for d in draws])
        self.body_rate = np.array([d.body_rate for d in draws])
        self.wheel_speed = np.array([self.wheels.initial_speeds(d.wheel_speed) for d in draws], float)
        self.wheel_angle = np.zeros_like(self.wheel_speed)
        # standby wheels: unpowered, held at rest by their bearing until their first non-zero command
        self.locked = np.tile(self.wheels.mask(self.wheels.standby), (self.batch, 1))
        self._locked_inertia()
        self.rngs = [s.disturbance_rng() for s in self.scenarios]
        self.extra_faults = [[] for _ in self.scenarios]  # injected live
        self.step_index = 0
        self.tcv = np.where(self.locked, 0.0, np.clip(hold_command(self.wheel_speed, self.wheel),
                                                       -wheel.command_limit, wheel.command_limit))

    @property
    def environment(self) -> Environments | None:
        if self.in_orbit and self._environment is None:
            self._environment = Environments([s.environment for s in self.scenarios],
                                             [s.seed for s in self.scenarios], self.duration, self.field_model,
                                             [s.spacecraft.residual_dipole for s in self.scenarios])
        return self._environment

    def command_dipole(self, dipole):
        """Hold the magnetorquers' ``dipole`` (B, 3) [A m^2] from now on (magnetorquers.py).

        Parameters
        ----------
        dipole : array_like
            (B, 3) dipole [A m^2].
        """
        dipole = np.asarray(dipole, float).reshape(self.batch, 3)
        if not np.all(np.isfinite(dipole)):
            raise ValueError("magnetorquer dipole is not finite")
        self.dipole = dipole

    @property
    def batch(self) -> int:
        return len(self.scenarios)

    @property
    def time(self) -> float:
        return self.step_index * self.dt

    def faults(self, b: int = 0):
        """Run ``b``'s faults: its scenario's and those injected live.

        Parameters
        ----------
        b : int
            The run's index in the batch.

        Returns
        -------
        tuple of Fault
            The faults.
        """
        return tuple(self.scenarios[b].faults) + tuple(self.extra_faults[b])

    def inject(self, fault, b: int = 0):
        """Add a fault while running (live injection); it joins the ground truth.

        Parameters
        ----------
        fault : Fault
            The fault.
        b : int
            The run's index in the batch.
        """
        self.extra_faults[b].append(fault)

    def operating_point(self, t) -> dict:
        """The wheels' operating point at ``t`` under each run's faults.

        Parameters
        ----------
        t : float
            Sim time [s].

        Returns
        -------
        dict
            Kind -> (B, N) values (bus voltage [V], current limiter, temperature [deg C], ripple gain).
        """
        return operating_points([self.faults(b) for b in range(self.batch)], t, self.wheels.count, self.nominal)

    def _locked_inertia(self):
        """Sum over the free wheels of J g g^T (B, 3, 3), the part of the locked inertia that spins apart;
        kept as its diagonal (B, 3) when that is all of it (wheels along body axes: eq. as the thesis')."""
        j = np.broadcast_to(np.asarray(self.wheel.inertia, float), self.wheel_speed.shape)
        free = np.where(self.locked, 0.0, j)
        g = self.spin_axes
        spun = np.einsum("in,bn,kn->bik", g, free, g)
        off = spun - np.einsum("bii->bi", spun)[..., None] * np.eye(3)
        self.spun_inertia = np.einsum("bii->bi", spun).copy() if not off.any() else spun

    def _derivatives(self, t, state, tcv, op, dist):
        rate, _att, speed, _ang = state
        tau_n, _ = wm.net_torque(tcv, speed, t, op, self.wheel)
        tau_n = np.where(self.locked, 0.0, tau_n)   # a locked wheel turns with the body: no relative torque
        g = self.spin_axes
        torque = -(tau_n @ g.T) + dist   # reaction torques along the spin axes, eq. 2.18
        j = self.wheel.inertia
        if not self.wheel_momentum_coupling:
            return body_acceleration(rate, torque, self.inertia), rate, tau_n / j, speed
        rate_dot = body_acceleration(rate, torque, self.inertia, wheel_momentum=(j * speed) @ g.T,
                                     wheel_inertia=self.spun_inertia)
        # J (dOmega/dt + g^T dw/dt) = tau_n: the tachometer's Omega is relative to the accelerating body
        speed_dot = np.where(self.locked, 0.0, tau_n / j - rate_dot @ g)
        return rate_dot, rate, speed_dot, speed

    def step(self, tcv) -> PlantSample:
        """Hold ``tcv`` (B, N) over one control period and return the sample at its end.

        Parameters
        ----------
        tcv : array_like
            (B, N) torque command voltages u [V].

        Returns
        -------
        PlantSample
            The sample at the period's end.
        """
        tcv = np.asarray(tcv, float).reshape(self.batch, self.wheels.count)
        if not np.all(np.isfinite(tcv)):
            raise ValueError("torque command voltage is not finite")
        self.tcv = np.clip(tcv, -self.wheel.command_limit, self.wheel.command_limit)
        released = self.locked & (self.tcv != 0.0)
        if released.any():   # powered: the driver holds it from now on
            self.locked = self.locked & ~released
            self._locked_inertia()
        t0 = self.time
        op = SimpleNamespace(**self.operating_point(t0))
        if self.disturbance:
            dist = np.array([disturbance_torque(r, sigma=self.disturbance_sigma) for r in self.rngs])
        else:
            dist = np.zeros((self.batch, 3))
        if self.in_orbit:   # secular torques and the rods', held over the period like eq. 2.34's
            dist = dist + self.environment.torque(t0, self.attitude, self.inertia, self.dipole)
        state = (self.body_rate, self.attitude, self.wheel_speed, self.wheel_angle)
        h = self.dt / self.substeps
        t = t0
        for _ in range(self.substeps):  # classic RK4
            k1 = self._derivatives(t, state, self.tcv, op, dist)
            s2 = tuple(s + 0.5 * h * k for s, k in zip(state, k1))
            k2 = self._derivatives(t + 0.5 * h, s2, self.tcv, op, dist)
            s3 = tuple(s + 0.5 * h * k for s, k in zip(state, k2))
            k3 = self._derivatives(t + 0.5 * h, s3, self.tcv, op, dist)
            s4 = tuple(s + h * k for s, k in zip(state, k3))
            k4 = self._derivatives(t + h, s4, self.tcv, op, dist)
            state = tuple(s + h / 6.0 * (a + 2 * b + 2 * c + d) for s, a, b, c, d in zip(state, k1, k2, k3, k4))
            t += h
        self.body_rate, self.attitude, self.wheel_speed, self.wheel_angle = state
        self.step_index += 1
        return self.sample()

    def reaction_torque(self, op: dict, t=None):
        """Sampled reaction torque of the wheels in state now with the command in force (eq. 2.18).

        Parameters
        ----------
        op : dict
            The operating point, kind -> (B, N).
        t : float or None
            Sim time [s] (default: now).

        Returns
        -------
        numpy.ndarray
            (B, N) reaction torque r [N m] (0 for a locked wheel).
        """
        t = self.time if t is None else t
        ns = SimpleNamespace(**op)
        tau_n, tau_m = wm.net_torque(self.tcv, self.wheel_speed, t, ns, self.wheel)
        ripple = wm.torque_ripple(tau_m, self.wheel_angle, ns.ripple_gain, self.wheel)
        return np.where(self.locked, 0.0, -(tau_n + ripple))

    def sample(self) -> PlantSample:
        """The plant's state now: attitude, rates, wheel speeds, command, reaction torque and the faults' effect.

        Returns
        -------
        PlantSample
            The sample (with the magnetometer's reading on its steps in orbit).
        """
        t = self.time
        op = self.operating_point(t)
        rt = self.reaction_torque(op, t)
        healthy_op = {k: np.full_like(op[k], self.nominal[k]) for k in FAULT_KINDS}
        nominal = all(np.array_equal(op[k], healthy_op[k]) for k in FAULT_KINDS)
        healthy = rt if nominal else self.reaction_torque(healthy_op, t)   # no fault: the same torque, exactly
        field = None
        if self.in_orbit and self.step_index % self.magnetometer_steps == 0:
            field = self.environment.magnetometer(t, self.attitude, self.step_index)
        return PlantSample(magnetic_field=field, time=t, attitude=self.attitude.copy(), body_rate=self.body_rate.copy(),
                           wheel_speed=self.wheel_speed.copy(), tcv=self.tcv.copy(), reaction_torque=rt,
                           fault_effect=rt - healthy, operating_point=op)
