"""One flight of a batch without ROS, given the gains: the same Plant, PidController, allocation, FDI and FDIR
the nodes run, in one loop (closed_loop.simulate flies the vehicle's design).

Used for controller design, fast tests and campaigns; the graph runs the
identical step sequence across processes (plant step k -> controllers ->
allocation -> plant step k+1). With ``fdir`` the FDI's verdict is made in
the loop too (pipeline.py) and reconfigures the wheels (fdir.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .control.allocation import TorqueAllocator
from .fdir import SLEW_RATE, DecisionDelay, DeliveryLog, Reconfiguration
from .fdi.verdict import speed_envelope, stamp_seconds
from .physics.magnetorquers import Dumper
from .fdi.pipeline import FdiPipeline, LoadedFdi
from .control.pid import PidController, PidGains
from .physics.plant import Plant
from .mission.scenario import Scenario, setpoint_at
from .physics.spacecraft import inertia_times, nearest_setpoint
from .physics.wheel import WheelParams


@dataclass
class Fdir:
    """What the loop's FDIR decides on: the FDI (bands, models, decision, persistence, unit calibration), as the
    graph's isolation node decides."""

    fdi: LoadedFdi                 # pipeline.LoadedFdi (FdiConfig.loaded)
    fdi_period: float = 1.0
    identification: bool = False   # also identify each alarmed wheel's fault (the isolation node's code)
    slew_rate: float = SLEW_RATE   # [rad/s] the slews the wheels in use must still take (fdir.momentum_shortfall)
    # [rad/s] what a wheel in use may be asked to hold (inf: every wheel given up); None: the wheel type's
    # envelope (isolation.speed_envelope: the thesis' type 45)
    holdable: float | None = None
    watch: LoadedFdi = None        # observers judged beside, acted on by nothing (pipeline.FdiPipeline)
    # with one observer's bands for ``fdi``: FDI samples its observer learns each wheel's unit from
    calibration_samples: int = 0

    def __post_init__(self):
        if not isinstance(self.fdi, LoadedFdi):   # one observer's bands (ThresholdCurves): that observer decides
            self.fdi = LoadedFdi({self.fdi.observer: self.fdi}, calibration_samples=int(self.calibration_samples))
        elif self.calibration_samples:
            raise ValueError("Fdir: calibration_samples goes with one observer's bands; a LoadedFdi carries its own")


@dataclass
class Trajectory:
    """Time series of a batch of runs: body arrays (steps + 1, B, 3), wheel arrays (steps + 1, B, N),
    and the time vector; with FDIR, each run's decisions (fdir.Decision) and wheels in use."""

    time: np.ndarray
    attitude: np.ndarray
    setpoint: np.ndarray
    body_rate: np.ndarray
    wheel_speed: np.ndarray
    tcv: np.ndarray
    reaction_torque: np.ndarray
    fault_effect: np.ndarray
    wheel_names: tuple = ("x", "y", "z")
    decisions: list = None    # per run: [fdir.Decision]
    identified: list = None   # per run, with Fdir.identification: wheel -> the last identification.Identification
    watched: list = None      # per run, with Fdir.watched: observer -> wheel -> alarm intervals [[start, end], ...] [s]
    in_use: np.ndarray = None  # (steps + 1, B, N) bool
    wheel_angle: np.ndarray = None      # rotor angle [rad] (steps + 1, B, N)
    axis_command: np.ndarray = None     # the controllers' body-axis commands v of each sample [V] (steps + 1, B, 3)
    wheel_command: np.ndarray = None    # the allocation's wheel commands u of each sample [V] (steps + 1, B, N)
    operating_point: dict = None        # fault kind -> (steps + 1, B, N), core.faults.operating_point_at
    magnetic_field: np.ndarray = None   # in orbit: the magnetometer's last reading [T] (steps + 1, B, 3)
    dipole: np.ndarray = None           # in orbit: the magnetorquers' dipole in force [A m^2] (steps + 1, B, 3)

    @property
    def error(self):
        """Attitude error y - r [rad], the short way round (spacecraft.nearest_setpoint), (steps + 1, B, 3)."""
        return self.attitude - nearest_setpoint(self.setpoint, self.attitude)


def fly(scenarios, gains: PidGains, wheel: WheelParams | None = None,
             control_period=0.1, duration=None, disturbance=True, wheel_momentum_coupling=True,
             wheels=None, fdir: Fdir | None = None, magnetic_field: str | None = None,
             every: int = 1) -> Trajectory:
    """Run scenarios (one or a list) to their end; returns every ``every``-th control-period sample (and
    the last). ``wheels``: the wheel set (None: the scenarios'); ``fdir``: reconfigure on the FDI's
    confirmed failures; in orbit the magnetorquers dump momentum by the scenarios' law.

    Parameters
    ----------
    scenarios : Scenario or list of Scenario
        The B runs of the batch.
    gains : PidGains
        The controllers' gains (closed_loop.simulate: the vehicle's design by default).
    wheel : WheelParams, optional
        The wheel type (scalar fields; a scenario's units are drawn from it); None: the scenarios' vehicle's.
    control_period : float, optional
        Control period [s].
    duration : float, optional
        Run length [s]; None for the first scenario's.
    disturbance : bool, optional
        Whether eq. 2.34's random disturbance acts.
    wheel_momentum_coupling : bool, optional
        Whether the wheels' momentum enters the body's equations (plant.py).
    wheels : WheelSet or str, optional
        The wheel set; None for the scenarios'.
    fdir : Fdir, optional
        FDI bands and settings for reconfiguring in the loop; None: no FDIR.
    magnetic_field : str, optional
        Field model in orbit (``igrf``, ``tilted_dipole``); None for the first scenario's choice.
    every : int, optional
        Keep every ``every``-th control sample.

    Returns
    -------
    Trajectory
        Body arrays (K, B, 3), wheel arrays (K, B, N) over the K samples kept, time (K,) [s].
    """
    if isinstance(scenarios, Scenario):
        scenarios = [scenarios]
    duration = duration or scenarios[0].duration
    plant = Plant(scenarios, wheel=wheel, control_period=control_period, disturbance=disturbance,
                  wheel_momentum_coupling=wheel_momentum_coupling, wheels=wheels, duration=duration,
                  magnetic_field=magnetic_field)
    dumper = Dumper([s.magnetorquers for s in scenarios]) if plant.in_orbit else None
    wheel = plant.datasheet
    allocator = TorqueAllocator(plant.wheels, plant.batch, wheel.command_limit, wheel,
                                feedforward=plant.vehicle.controller.friction_feedforward,
                                null_time_constant=plant.vehicle.controller.null_space_time_constant)
    # the controllers' integrators hold the body-axis command of the wheels' holding voltages
    pid = PidController(gains, control_period, initial_tcv=allocator.integrator_start(plant.tcv, plant.wheel_speed),
                        wheel=wheel)
    schedules = [s.setpoint_schedule() for s in scenarios]
    steps = int(round(duration / control_period))
    onboard = reconfig = delays = None
    if fdir is not None:
        onboard = FdiPipeline(plant.wheels.names, fdir.fdi, plant.batch, fdir.fdi_period,
                              identification=fdir.identification, watch=fdir.watch,
                              wheel=plant.vehicle.wheel,   # the FDI's nominal model: the datasheet's
                              control_period=control_period)
        holdable = speed_envelope(wheel) if fdir.holdable is None else fdir.holdable
        reconfig = [Reconfiguration(plant.wheels, holdable, fdir.slew_rate, plant.inertia, wheel.inertia)
                    for _ in scenarios]
        delays = [DecisionDelay() for _ in scenarios]
        delivery = DeliveryLog(params=plant.vehicle.wheel)
    rec = {k: [] for k in ("attitude", "setpoint", "body_rate", "wheel_speed", "tcv", "reaction_torque",
                           "fault_effect", "in_use", "wheel_angle", "axis_command", "wheel_command",
                           "magnetic_field", "dipole")}
    operating_point = []
    field = np.zeros((plant.batch, 3))
    sample = plant.sample()
    wheel_command = None
    for _ in range(steps + 1):
        sp = np.array([setpoint_at(t, v, sample.time) for t, v in schedules])
        in_use = allocator.in_use.copy()   # as it was when the sample came, before FDIR acts on it
        if sample.magnetic_field is not None:
            # the law runs on the reading and the wheels in use as the momentum-dumping node knows them when
            # the reading comes (decisions of earlier samples: the allocation says them before its command,
            # the plant steps on the command); the rods hold its dipole
            field = sample.magnetic_field
            plant.command_dipole(dumper.update(field, sample.wheel_speed, in_use, wheel.inertia, plant.spin_axes))
        if onboard is not None:
            if wheel_command is not None:   # the command in force over the step that led to this sample
                delivery.add(wheel_command, sample.wheel_speed, sample.reaction_torque)
            stamp = int(round(sample.time * 1e9))
            confirmed = onboard.add_speed(stamp, sample.wheel_speed, sample.reaction_torque)
            _fdir_step(onboard, reconfig, delays, allocator, plant, sample, delivery)
        # the last sample is answered too, as the controllers and the allocation node answer it
        axis_command = pid.update(sp, sample.attitude, sample.body_rate)
        wheel_command = allocator.wheel_commands(axis_command, sample.wheel_speed)
        if onboard is not None:
            # the wheel_telemetry node's sample of this stamp waits for this command (wheel_reports.ControlGrid):
            # its verdict shapes the commands from fdir.DECISION_DELAY on, as in the graph
            for judged in confirmed + onboard.add_command(stamp, wheel_command):
                if judged.confirmed:
                    for b, (r, delay) in enumerate(zip(reconfig, delays)):
                        delay.confirm(judged.confirmed[b], stamp_seconds(judged.stamp_ns), r.settled)
        last = plant.step_index == steps
        if plant.step_index % every == 0 or last:
            for key in ("attitude", "body_rate", "wheel_speed", "tcv", "reaction_torque", "fault_effect"):
                rec[key].append(getattr(sample, key))
            rec["setpoint"].append(sp)
            rec["in_use"].append(in_use)
            rec["wheel_angle"].append(plant.wheel_angle.copy())
            rec["axis_command"].append(axis_command)
            rec["wheel_command"].append(wheel_command)
            rec["magnetic_field"].append(field)
            rec["dipole"].append(plant.dipole)
            operating_point.append(sample.operating_point)
        if last:
            break
        sample = plant.step(wheel_command)
    time = np.array([min(k * every, steps) for k in range(len(rec["attitude"]))]) * control_period
    return Trajectory(time=time, wheel_names=plant.wheels.names,
                      decisions=[r.decisions for r in reconfig] if reconfig else None,
                      identified=onboard.identified if onboard is not None and fdir.identification else None,
                      watched=onboard.intervals if onboard is not None and onboard.watch else None,
                      operating_point={k: np.array([op[k] for op in operating_point]) for k in operating_point[0]},
                      **{k: np.array(v) for k, v in rec.items()})


def _fdir_step(onboard, reconfig, delays, allocator, plant, sample, delivery):
    """Before the command of this sample: apply the decisions due now (fdir.DecisionDelay) and watch the wheels
    after a reconfiguration (fdir.Reconfiguration.review), to the allocation."""
    stamp = int(round(sample.time * 1e9))
    for b, (r, delay) in enumerate(zip(reconfig, delays)):
        changed = False
        momentum = inertia_times(plant.inertia, sample.body_rate[b])
        for wheel, reason in delay.due(sample.time):
            changed |= bool(r.give_up(wheel, sample.time, reason, sample.wheel_speed[b], momentum,
                                      delivered=delivery.share(r.wheels.index(wheel), b)))
        if r.decisions:   # after a reconfiguration the wheels are watched at every sample
            on_fdi = stamp % onboard.fdi_period_ns == 0   # a kept wheel's share is judged once an FDI period
            delivered = delivery.of(r.wheels.names, b) if on_fdi else None
            changed |= any(d.action != "at_limit" for d in r.review(sample.time, sample.wheel_speed[b], delivered))
        if changed:
            allocator.use(r.ordered_in_use(), b, r.held)


def step_metrics(traj: Trajectory, start: float = 0.0, band: float = 0.05, floor: float = np.deg2rad(0.01)):
    """Overshoot [share of step], settling time [s] and the largest |error| after settling [rad].

    Per run and axis, for the set-point step applied at ``start``. Overshoot counts what lies
    more than ``floor`` past the set point. Settled means within
    ``band`` of the step or ``floor`` radians of the set point, whichever is wider: a 0.04 deg
    step on one axis is moved by more than its 5 % by the gyroscopic torque w x h_w of a
    5 deg slew on another, and 0.01 deg is 20x finer than the 0.2 deg pointing requirement.

    Parameters
    ----------
    traj : Trajectory
        The runs, attitude and set-point (K, B, 3) [rad].
    start : float, optional
        Time the step is applied [s].
    band : float, optional
        Settling band, a share of the step.
    floor : float, optional
        Tolerance about the set point [rad].

    Returns
    -------
    overshoot : ndarray, shape (B, 3)
        Share of the step (0 for an axis without a step).
    settling : ndarray, shape (B, 3)
        Settling time after ``start`` [s].
    settled_error : ndarray, shape (B, 3)
        Largest |attitude - set point| after settling [rad].
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
