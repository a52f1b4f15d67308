"""Closed loop without ROS: the same Plant and PidController the nodes run, in one loop.

Used for controller design and fast tests; the graph runs the identical
step sequence across processes (plant step k -> controllers -> plant step k+1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .pid import PidController, PidGains, design_gains
from .plant import Plant
from .scenario import Scenario, setpoint_at
from .wheel import WheelParams


@dataclass
class Trajectory:
    """Time series of a batch of runs: arrays (steps + 1, B, 3) and the time vector."""

    time: np.ndarray
    attitude: np.ndarray
    setpoint: np.ndarray
    body_rate: np.ndarray
    wheel_speed: np.ndarray
    tcv: np.ndarray
    reaction_torque: np.ndarray
    fault_effect: np.ndarray

    @property
    def error(self):
        return self.attitude - self.setpoint


def simulate(scenarios, gains: PidGains | None = None, wheel: WheelParams = WheelParams(),
             control_period=0.1, duration=None, disturbance=True, wheel_momentum_coupling=True) -> Trajectory:
    """Run scenarios (one or a list) to their end; returns every control-period sample."""
    if isinstance(scenarios, Scenario):
        scenarios = [scenarios]
    plant = Plant(scenarios, wheel=wheel, control_period=control_period, disturbance=disturbance,
                  wheel_momentum_coupling=wheel_momentum_coupling)
    gains = gains or design_gains()
    pid = PidController(gains, control_period, initial_tcv=plant.tcv, wheel=wheel)
    schedules = [s.setpoint_schedule() for s in scenarios]
    duration = duration or scenarios[0].duration
    steps = int(round(duration / control_period))
    rec = {k: [] for k in ("attitude", "setpoint", "body_rate", "wheel_speed", "tcv", "reaction_torque",
                           "fault_effect")}
    sample = plant.sample()
    for _ in range(steps + 1):
        sp = np.array([setpoint_at(t, v, sample.time) for t, v in schedules])
        for key in rec:
            rec[key].append(sp if key == "setpoint" else getattr(sample, key))
        if plant.step_index == steps:
            break
        sample = plant.step(pid.update(sp, sample.attitude, sample.body_rate))
    time = np.arange(len(rec["attitude"])) * control_period
    return Trajectory(time=time, **{k: np.array(v) for k, v in rec.items()})


def step_metrics(traj: Trajectory, start: float = 0.0, band: float = 0.05, floor: float = np.deg2rad(0.01)):
    """Overshoot [share of step], settling time [s] and the largest |error| after settling [rad].

    Per run and axis, for the set-point step applied at ``start``. Overshoot counts what lies
    more than ``floor`` past the set point. Settled means within
    ``band`` of the step or ``floor`` radians of the set point, whichever is wider: a 0.04 deg
    step on one axis is moved by more than its 5 % by the gyroscopic torque w x h_w of a
    5 deg slew on another, and 0.01 deg is 20x finer than the 0.2 deg pointing requirement.
    """
    i0 = int(np.searchsorted(traj.time, start))
    initial = traj.attitude[i0]
    target = traj.setpoint[min(i0 + 1, len(traj.time) - 1)]
    step = target - initial
    travel = (traj.attitude[i0:] - initial) / np.where(step == 0, 1.0, step)
    beyond = ((traj.attitude[i0:] - target) * np.sign(step)).max(axis=0)   # past the set point [rad]
    overshoot = np.maximum(beyond - floor, 0.0) / np.where(step == 0, np.inf, np.abs(step))
    outside = (np.abs(travel - 1.0) > band) & (np.abs(traj.attitude[i0:] - target) > floor)
    last_out = np.where(outside.any(axis=0), outside.shape[0] - 1 - np.argmax(outside[::-1], axis=0), -1)
    settling = traj.time[i0:][np.clip(last_out + 1, 0, outside.shape[0] - 1)] - traj.time[i0]
    settled_error = np.array([[np.abs(traj.error[i0 + last_out[b, a] + 1:, b, a]).max(initial=0.0)
                               for a in range(3)] for b in range(step.shape[0])])
    return overshoot, settling, settled_error
