"""The attitude controllers of a vehicle, designed to its targets (vehicle.ControllerTargets).

The thesis' pole placement (pid.design_gains) puts the closed loop I s^3 + k_d s^2 + k_p s + k_i at a real
pole and a pair of natural frequency w_n; the gains scale with the axis inertia I_kk, so a larger body asks
proportionally more torque of the same poles and the wheels' +-5 V limit stretches its response. The design
here keeps the thesis' poles' shape (zeta, the real pole, the set-point weight) and chooses w_n per axis:

    w_n,k = the one of NATURAL_FREQUENCIES whose step settles axis k fastest, among those that settle to
            5 % within the settling time T with an overshoot of at most the target

judged on the vehicle's own plant (its inertia, wheels, wheel set): a step of its largest set-point change
on every axis at once, either way, from rest, the wheels at either end of their initial-speed range, no
disturbance.
The chosen gains are then simulated together and must meet the targets too. MakSat's answer is the thesis'
w_n = 0.3 rad/s on every axis (test_controller_design.py). No frequency that meets them: VehicleError
naming the axis and the best it got.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .flight import fly
from .control.pid import PidGains, design_gains
from .mission.scenario import Scenario, ScenarioError, SetpointChange
from .mission.vehicle import Vehicle, VehicleError

# [rad/s] the thesis' 0.3 first, then slower: a heavier body's loop must ask less torque per radian
NATURAL_FREQUENCIES = (0.3, 0.25, 0.2, 0.16, 0.13, 0.1, 0.08, 0.065, 0.05, 0.04, 0.03, 0.02)
SETTLING_BAND = 0.05   # the 5 % settling of the thesis' targets


@dataclass(frozen=True)
class ControllerDesign:
    """The gains and what they do on the vehicle's step (per body axis x, y, z)."""

    gains: PidGains
    natural_frequency: tuple   # w_n [rad/s]
    settling_time: tuple       # [s] to within 5 % of the step, for good
    overshoot: tuple           # share of the step


def step_responses(vehicle: Vehicle, gains: list) -> tuple:
    """(settling time [s], overshoot [share]) arrays (len(gains), 3) of the vehicle's design step under each
    PidGains of ``gains``: the worst of the step up and down, the wheels starting at the low and the high end
    of their range.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.
    gains : list of PidGains
        The candidate gains.

    Returns
    -------
    tuple of numpy.ndarray
        (settling time [s], overshoot [share]), each (len(gains), 3).
    """
    step = max(abs(v) for v in vehicle.dispersions.setpoint_change_deg)
    horizon = max(3.0 * vehicle.controller.settling_time, 60.0)
    cases = [(sign, speed) for sign in (1.0, -1.0) for speed in vehicle.dispersions.wheel_speed]
    runs = [Scenario("controller_design", duration=horizon, setpoints=(SetpointChange(0.0, (sign * step,) * 3),),
                     initial={"attitude_deg": (0.0,) * 3, "body_rate": (0.0,) * 3, "wheel_speed": (speed,) * 3},
                     vehicle=vehicle)
            for sign, speed in cases for _ in gains]
    stacked = PidGains(*(np.array([getattr(g, k) for g in gains] * len(cases)) for k in ("kp", "ki", "kd")),
                       setpoint_weight=gains[0].setpoint_weight)
    traj = fly(runs, stacked, disturbance=False)
    signs = np.repeat([sign for sign, _ in cases], len(gains))[:, None]
    attitude = np.degrees(traj.attitude) * signs                  # (K, 4G, 3), each from 0 to +step
    outside = np.abs(attitude - step) > SETTLING_BAND * step
    last = len(traj.time) - 1 - np.argmax(outside[::-1], axis=0)   # the last sample outside the band
    settled_at = traj.time[np.minimum(last + 1, len(traj.time) - 1)]
    settling = np.where(outside[-1], np.inf, np.where(outside.any(axis=0), settled_at, 0.0))
    overshoot = np.maximum(attitude.max(axis=0) - step, 0.0) / step
    n = len(gains)
    return (settling.reshape(len(cases), n, 3).max(axis=0), overshoot.reshape(len(cases), n, 3).max(axis=0))


@lru_cache(maxsize=32)
def design_controller(vehicle: Vehicle) -> ControllerDesign:
    """The vehicle's gains (module docstring); VehicleError when no natural frequency meets its targets.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle.

    Returns
    -------
    ControllerDesign
        The gains, the natural frequency w_n [rad/s], settling time [s] and overshoot of each axis.
    """
    targets = vehicle.controller
    candidates = [design_gains(vehicle.axis_inertia, natural_frequency=w) for w in NATURAL_FREQUENCIES]
    settling, overshoot = step_responses(vehicle, candidates)
    meets = (settling <= targets.settling_time) & (overshoot <= targets.overshoot)
    chosen = []
    for k, axis in enumerate("xyz"):
        if not meets[:, k].any():
            best = int(np.argmin(np.where(overshoot[:, k] <= targets.overshoot, settling[:, k], np.inf)))
            took = (f"settles in {settling[best, k]:.0f} s" if np.isfinite(settling[best, k])
                    else "does not settle in the 3 settling times simulated")
            raise VehicleError(
                f"vehicle {vehicle.name}: controller: no design settles in {targets.settling_time:g} s with at most "
                f"{targets.overshoot:.0%} overshoot about {axis}; the best {took} (w_n {NATURAL_FREQUENCIES[best]:g} "
                f"rad/s, overshoot {overshoot[best, k]:.0%})")
        chosen.append(int(np.argmin(np.where(meets[:, k], settling[:, k], np.inf))))
    w = np.array([NATURAL_FREQUENCIES[i] for i in chosen])
    gains = PidGains(*(np.array([getattr(candidates[i], name)[k] for k, i in enumerate(chosen)])
                       for name in ("kp", "ki", "kd")), setpoint_weight=candidates[0].setpoint_weight)
    settled, over = (x[0] for x in step_responses(vehicle, [gains]))
    if np.any(settled > targets.settling_time) or np.any(over > targets.overshoot):   # together, not only alone
        k = int(np.argmax(settled / targets.settling_time))
        raise VehicleError(f"vehicle {vehicle.name}: controller: the axes' designs together settle {'xyz'[k]} in "
                           f"{settled[k]:.0f} s with {over[k]:.0%} overshoot (targets {targets.settling_time:g} s, "
                           f"{targets.overshoot:.0%})")
    return ControllerDesign(gains, tuple(float(v) for v in w), tuple(float(v) for v in settled),
                            tuple(float(v) for v in over))


def scenario_design(scenario: Scenario, origin: str | None = None) -> ControllerDesign | None:
    """The controllers of the vehicle a scenario names, designed before its run starts (once: cached).

    Parsing a scenario designs nothing (a bag's verdict is read without a simulation); the commands that
    run one call this first, so a vehicle whose targets cannot be met is refused in one line before any run.

    Parameters
    ----------
    scenario : Scenario
        The scenario to run.
    origin : str, optional
        Where it came from (a path or a name), for the message; None: its name.

    Returns
    -------
    ControllerDesign or None
        Its vehicle's design; None when it names no vehicle (the thesis' MakSat, whose design is the thesis').

    Raises
    ------
    ScenarioError
        One line naming the scenario, the axis and the best design, when no design meets the targets.
    """
    if scenario.vehicle is None:
        return None
    try:
        return design_controller(scenario.vehicle)
    except VehicleError as exc:
        raise ScenarioError(f"{origin or 'scenario ' + scenario.name}: vehicle: {exc}") from None
