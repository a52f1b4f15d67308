"""The plant: rigid body (eq. 2.27) driven by three Bialke wheels (Fig. 2.2) with faults.

[choice] ``wheel_momentum_coupling`` (default on): the wheels' stored momentum
h_w = J Omega enters the body's Euler equations and the body's angular
acceleration enters the wheels' (see :func:`body_acceleration`), as in every
multibody simulator (Basilisk's BalancedWheels, test/test_basilisk.py); off is
eq. 2.27 as the thesis writes it, body and wheels driven only by tau_n.

One class, batched over runs: shape (B, 3) arrays, axis order x, y, z. The
live plant node holds a batch of one; Monte-Carlo tools hold many.

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
from .scenario import FAULT_KINDS, Scenario, operating_point_at
from .spacecraft import INERTIA, body_acceleration, disturbance_torque


_HEALTHY = operating_point_at((), 0.0)


@dataclass
class PlantSample:
    """What the plant publishes at one instant, shape (B, 3) each."""

    time: float
    attitude: np.ndarray
    body_rate: np.ndarray
    wheel_speed: np.ndarray
    tcv: np.ndarray              # command in force (clamped to +-5 V)
    reaction_torque: np.ndarray  # -(tau_n + ripple), eq. 2.18
    fault_effect: np.ndarray     # reaction torque minus a healthy wheel's in the same state
    operating_point: dict        # kind -> (B, 3)


def hold_command(wheel_speed, params: wm.WheelParams = wm.WheelParams()):
    """The command a controller that was holding attitude had before t=0 (wheel at equilibrium)."""
    return wm.holding_tcv(wheel_speed, 23.0, params)


def units_of(scenarios, base: wm.WheelParams) -> wm.WheelParams:
    """The wheels of a batch of scenarios: ``base`` (the datasheet) unless some scenario draws its
    units (Scenario.unit_scales); then each parameter of wm.UNIT_PARAMETERS as a (B, 3) array."""
    scales = [s.unit_scales() for s in scenarios]
    if all(sc is None for sc in scales):
        return base
    ones = {name: np.ones(3) for name in wm.UNIT_PARAMETERS}
    return wm.unit_wheel(base, {name: np.array([(sc or ones)[name] for sc in scales])
                                for name in wm.UNIT_PARAMETERS})


class Plant:
    """Spacecraft with three reaction wheels for a batch of scenarios."""

    def __init__(self, scenarios, wheel: wm.WheelParams = wm.WheelParams(), control_period=0.1,
                 substeps=1, inertia=INERTIA, disturbance=True, wheel_momentum_coupling=True):
        if isinstance(scenarios, Scenario):
            scenarios = [scenarios]
        self.scenarios = list(scenarios)
        self.wheel = units_of(self.scenarios, wheel)
        self.dt = float(control_period)
        self.substeps = int(substeps)
        self.inertia = np.asarray(inertia, float)
        self.disturbance = disturbance
        self.wheel_momentum_coupling = bool(wheel_momentum_coupling)
        draws = [s.draws()[0] for s in self.scenarios]
        self.attitude = np.array([d.attitude for d in draws])
        self.body_rate = np.array([d.body_rate for d in draws])
        self.wheel_speed = np.array([d.wheel_speed for d in draws])
        self.wheel_angle = np.zeros_like(self.wheel_speed)
        self.rngs = [s.disturbance_rng() for s in self.scenarios]
        self.extra_faults = [[] for _ in self.scenarios]  # injected live
        self.step_index = 0
        self.tcv = np.clip(hold_command(self.wheel_speed, self.wheel), -wheel.command_limit, wheel.command_limit)

    @property
    def batch(self) -> int:
        return len(self.scenarios)

    @property
    def time(self) -> float:
        return self.step_index * self.dt

    def faults(self, b: int = 0):
        return tuple(self.scenarios[b].faults) + tuple(self.extra_faults[b])

    def inject(self, fault, b: int = 0):
        """Add a fault while running (live injection); it joins the ground truth."""
        self.extra_faults[b].append(fault)

    def operating_point(self, t) -> dict:
        ops = [operating_point_at(self.faults(b), t) for b in range(self.batch)]
        return {k: np.array([op[k] for op in ops]) for k in FAULT_KINDS}

    def _derivatives(self, t, state, tcv, op, dist):
        rate, _att, speed, _ang = state
        tau_n, _ = wm.net_torque(tcv, speed, t, op, self.wheel)
        torque = -tau_n + dist  # reaction torque of each wheel on its axis, eq. 2.18
        j = self.wheel.inertia
        if not self.wheel_momentum_coupling:
            return body_acceleration(rate, torque, self.inertia), rate, tau_n / j, speed
        rate_dot = body_acceleration(rate, torque, self.inertia, wheel_momentum=j * speed, wheel_inertia=j)
        # J (dOmega/dt + dw/dt) = tau_n: the tachometer's Omega is relative to the accelerating body
        return rate_dot, rate, tau_n / j - rate_dot, speed

    def step(self, tcv) -> PlantSample:
        """Hold ``tcv`` (B, 3) over one control period and return the sample at its end."""
        tcv = np.asarray(tcv, float).reshape(self.batch, 3)
        if not np.all(np.isfinite(tcv)):
            raise ValueError("torque command voltage is not finite")
        self.tcv = np.clip(tcv, -self.wheel.command_limit, self.wheel.command_limit)
        t0 = self.time
        op = SimpleNamespace(**self.operating_point(t0))
        if self.disturbance:
            dist = np.array([disturbance_torque(r) for r in self.rngs])
        else:
            dist = np.zeros((self.batch, 3))
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
        """Sampled reaction torque of the wheels in state now with the command in force (eq. 2.18)."""
        t = self.time if t is None else t
        ns = SimpleNamespace(**op)
        tau_n, tau_m = wm.net_torque(self.tcv, self.wheel_speed, t, ns, self.wheel)
        ripple = wm.torque_ripple(tau_m, self.wheel_angle, ns.ripple_gain, self.wheel)
        return -(tau_n + ripple)

    def sample(self) -> PlantSample:
        t = self.time
        op = self.operating_point(t)
        rt = self.reaction_torque(op, t)
        nominal = all(np.all(op[k] == _HEALTHY[k]) for k in FAULT_KINDS)
        healthy = rt if nominal else self.reaction_torque(_HEALTHY, t)   # no fault: the same torque, exactly
        return PlantSample(time=t, attitude=self.attitude.copy(), body_rate=self.body_rate.copy(),
                           wheel_speed=self.wheel_speed.copy(), tcv=self.tcv.copy(), reaction_torque=rt,
                           fault_effect=rt - healthy, operating_point=op)
