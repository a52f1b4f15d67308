"""Basilisk's own closed loop flying three Honeywell HR16 wheels, exported as wheel telemetry for `rw-fdi telemetry`.

Nothing here is ours: the spacecraft, the wheels (`simIncludeRW`'s Honeywell HR16, 50 N m s, Basilisk's
friction model, not the Bialke wheel), the flight software (`inertial3D`, `attTrackingError`, `mrpFeedback`,
`rwMotorTorque`, `rwMotorVoltage`) and the voltage-to-torque drive (`motorVoltageInterface`) are Basilisk's,
as in its scenarioAttitudeFeedbackRW. Faults are injected through Basilisk's own wheel parameters. Runs in
the Basilisk environment (scripts/setup_basilisk.sh); docs/basilisk.md gives the whole study:

    .venv-bsk/bin/python examples/basilisk/closed_loop.py --seeds 0..99 --faults none --out healthy/

Each run writes ``bsk_<seed>.csv`` (the telemetry table of docs/telemetry.md: the tachometer's speed with
noise, the command voltage, the ground truth) and ``bsk_<seed>.json`` (the draw: slews, disturbance, the
fault's kind, wheel, size and onset, and its largest 1-s torque on the wheel, the fault's visible size).
"""
import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np
from Basilisk.architecture import messaging
from Basilisk.fswAlgorithms import attTrackingError, inertial3D, mrpFeedback, rwMotorTorque, rwMotorVoltage
from Basilisk.simulation import extForceTorque, motorVoltageInterface, reactionWheelStateEffector, simpleNav
from Basilisk.simulation import spacecraft
from Basilisk.utilities import RigidBodyKinematics as rbk
from Basilisk.utilities import SimulationBaseClass, macros, simIncludeRW

INERTIA = [900.0, 800.0, 600.0]   # kg m^2, scenarioAttitudeFeedbackRW's hub
JOINTS = ("rw1", "rw2", "rw3")    # on the body axes
V_MAX = 5.0                       # V: the drive's command range, u_max at 5 V
FSW_PERIOD = 0.1                  # s
DYN_PERIOD = 0.01                 # s
SPEED_NOISE = 0.01                # rad/s, 1 sigma: the tachometer's
# Basilisk's own wheel parameters a fault moves, with the in-service range of each (a share, or the new value)
FAULTS = {
    "torque_limit": (0.15, 0.5),     # u_max to this share of 0.2 N m: seen only while a slew asks for more
    "motor_gain": (0.3, 0.7),        # motorVoltageInterface's voltage-to-torque gain to this share
    "coulomb": (4e-3, 15e-3),        # fCoulomb [N m] from 0.5 mN m to this
    "viscous": (2e-5, 1e-4),         # cViscous [N m s/rad] from 2e-6 to this
}
# --envelope small: faults from the band up, where detection ends
SMALL_FAULTS = {"torque_limit": (0.5, 0.95), "motor_gain": (0.9, 0.99), "coulomb": (0.6e-3, 4e-3),
                "viscous": (3e-6, 2e-5)}
# --units: each wheel its own unit, the 1-sigma shares our unit calibration assumes of a wheel type
# (rw_fdi_ros.core.physics.wheel.DEFAULT_UNIT_SPREAD), each N(1, share) cut at 3 sigma. The wheel's torque per volt
# is k_t G_d; as in hr16_sat.yaml (whose bridge the EMF never limits on its 28-V bus) nothing but the 5-V command
# limits it, so a unit's u_max is its torque at 5 V
UNIT_SPREAD = {"torque_constant": 0.02, "driver_gain": 0.02, "viscous": 0.2, "coulomb": 0.2}


def draw(seed: int, faults: str, duration: float, envelope: dict = FAULTS, units: bool = False) -> dict:
    """One run's draw: initial wheel speeds, slews, a constant disturbance torque, the fault (or none) and, with
    ``units``, each wheel's unit (its own stream: the rest of the draw is the datasheet run's)."""
    rng = np.random.default_rng(seed)
    slews = []
    for start in sorted(rng.uniform(20.0, duration - 60.0, size=rng.integers(1, 4))):
        axis = rng.normal(size=3)
        slews.append({"start_s": float(start), "axis": (axis / np.linalg.norm(axis)).tolist(),
                      "angle_deg": float(rng.uniform(5.0, 20.0) * rng.choice([-1, 1]))})
    run = {"seed": seed, "duration_s": duration, "slews": slews,
           "wheel_speed_rpm": (rng.uniform(500.0, 2000.0, 3) * rng.choice([-1, 1], 3)).tolist(),
           "disturbance_nm": rng.uniform(-5e-4, 5e-4, 3).tolist(), "fault": None}
    kinds = list(FAULTS) if faults == "random" else [] if faults == "none" else faults.split(",")
    if kinds:
        kind = kinds[rng.integers(len(kinds))]
        low, high = envelope[kind]
        run["fault"] = {"kind": kind, "wheel": int(rng.integers(3)), "size": float(rng.uniform(low, high)),
                        "onset_s": float(np.round(rng.uniform(0.25 * duration, 0.625 * duration), 1))}
    if units:
        spread = np.random.default_rng(seed + 5_000_000)
        run["units"] = {k: np.clip(spread.normal(1.0, s, 3), 1 - 3 * s, 1 + 3 * s).tolist()   # per wheel
                        for k, s in UNIT_SPREAD.items()}
    return run


def fly(run: dict) -> tuple:
    """Basilisk's closed loop through the run: (rows of the table, the fault's largest 1-s torque [N m])."""
    sim = SimulationBaseClass.SimBaseClass()
    fsw = sim.CreateNewProcess("fsw", 20)   # runs before the dynamics at each time: its command applies at once
    dyn = sim.CreateNewProcess("dyn", 10)
    fsw.addTask(sim.CreateNewTask("fsw_task", macros.sec2nano(FSW_PERIOD)))
    dyn.addTask(sim.CreateNewTask("dyn_task", macros.sec2nano(DYN_PERIOD)))

    sc = spacecraft.Spacecraft()
    sc.hub.mHub = 750.0
    sc.hub.IHubPntBc_B = np.diag(INERTIA).tolist()
    factory = simIncludeRW.rwFactory()
    units = run.get("units") or {k: [1.0] * 3 for k in UNIT_SPREAD}
    wheels = [factory.create("Honeywell_HR16", axis, maxMomentum=50.0, Omega=rpm, useRWfriction=True,
                             cViscous=2e-6 * viscous, fCoulomb=5e-4 * coulomb, RWModel=messaging.BalancedWheels)
              for axis, rpm, viscous, coulomb in zip(np.eye(3).tolist(), run["wheel_speed_rpm"], units["viscous"],
                                                     units["coulomb"])]
    for wheel, kt, gd in zip(wheels, units["torque_constant"], units["driver_gain"]):
        wheel.u_max *= kt * gd
    rw = reactionWheelStateEffector.ReactionWheelStateEffector()
    factory.addToSpacecraft("wheels", rw, sc)
    disturbance = extForceTorque.ExtForceTorque()
    disturbance.extTorquePntB_B = [[d] for d in run["disturbance_nm"]]
    sc.addDynamicEffector(disturbance)
    nav = simpleNav.SimpleNav()
    nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    drive = motorVoltageInterface.MotorVoltageInterface()
    gain = [w.u_max / V_MAX for w in wheels]   # each unit's torque per volt
    drive.setGains(gain)
    rw.rwMotorCmdInMsg.subscribeTo(drive.motorTorqueOutMsg)
    for model, priority in ((drive, 30), (rw, 20), (sc, 10), (disturbance, 5)):
        sim.AddModelToTask("dyn_task", model, priority)

    config = messaging.VehicleConfigMsgPayload(ISCPntB_B=np.diag(INERTIA).ravel().tolist())
    vehicle_msg = messaging.VehicleConfigMsg().write(config)
    rw_params = factory.getConfigMessage()
    reference = inertial3D.inertial3D()
    reference.sigma_R0N = [0.0, 0.0, 0.0]
    tracking = attTrackingError.attTrackingError()
    tracking.attRefInMsg.subscribeTo(reference.attRefOutMsg)
    tracking.attNavInMsg.subscribeTo(nav.attOutMsg)
    control = mrpFeedback.mrpFeedback()
    control.K, control.P, control.Ki, control.integralLimit = 3.5, 30.0, 0.0002, 2.0 / 0.0002 * 0.1
    control.guidInMsg.subscribeTo(tracking.attGuidOutMsg)
    control.vehConfigInMsg.subscribeTo(vehicle_msg)
    control.rwParamsInMsg.subscribeTo(rw_params)
    control.rwSpeedsInMsg.subscribeTo(rw.rwSpeedOutMsg)
    allocation = rwMotorTorque.rwMotorTorque()
    allocation.controlAxes_B = np.eye(3).ravel().tolist()
    allocation.vehControlInMsg.subscribeTo(control.cmdTorqueOutMsg)
    allocation.rwParamsInMsg.subscribeTo(rw_params)
    voltage = rwMotorVoltage.rwMotorVoltage()
    voltage.VMin, voltage.VMax = 0.0, V_MAX
    voltage.torqueInMsg.subscribeTo(allocation.rwMotorTorqueOutMsg)
    voltage.rwParamsInMsg.subscribeTo(rw_params)
    drive.motorVoltageInMsg.subscribeTo(voltage.voltageOutMsg)
    for model, priority in ((nav, 60), (reference, 50), (tracking, 40), (control, 30), (allocation, 20), (voltage, 10)):
        sim.AddModelToTask("fsw_task", model, priority)
    sim.InitializeSimulation()

    rng = np.random.default_rng(run["seed"] + 7_000_000)   # the tachometer's noise, its own stream
    fault, slews = run["fault"], list(run["slews"])
    target = np.zeros(3)   # the reference attitude (MRP)
    rows, effect, window, gains = [], 0.0, [], list(gain)
    steps = int(round(run["duration_s"] / FSW_PERIOD))
    for k in range(steps + 1):
        t = k * FSW_PERIOD
        while slews and slews[0]["start_s"] <= t:
            s = slews.pop(0)
            turn = rbk.PRV2MRP(np.radians(s["angle_deg"]) * np.asarray(s["axis"]))
            target = rbk.addMRP(np.asarray(target), turn)
            reference.sigma_R0N = list(target)
        if fault and abs(t - fault["onset_s"]) < FSW_PERIOD / 2:
            gains = inject(rw, drive, gain, fault)
        sim.ConfigureStopTime(macros.sec2nano(t))
        sim.ExecuteSimulation()
        speed = np.asarray(rw.rwSpeedOutMsg.read().wheelSpeeds[:3])
        volts = np.asarray(voltage.voltageOutMsg.read().voltage[:3])
        faulty = [int(bool(fault) and fault["wheel"] == i and t >= fault["onset_s"] - 1e-9) for i in range(3)]
        rows.append([round(t, 3), *(speed + rng.normal(0.0, SPEED_NOISE, 3)), *volts, *faulty])
        if fault and t >= fault["onset_s"]:   # the fault's own torque on its wheel: faulty less healthy
            i = fault["wheel"]
            window.append(wheel_torque(rw.ReactionWheelData[i], gains[i], volts[i], speed[i])
                          - wheel_torque(wheels[i], gain[i], volts[i], speed[i], healthy=True))
            window = window[-int(round(1.0 / FSW_PERIOD)):]
            effect = max(effect, abs(float(np.mean(window))))
    return rows, effect


HEALTHY = {}   # the faulty wheel's healthy u_max, fCoulomb, cViscous (a fault changes the payload the effector shares)


def inject(rw, drive, gain: list, fault: dict) -> list:
    """The fault through Basilisk's own parameters of the wheel (shared with the effector); the drive's gains."""
    wheel = rw.ReactionWheelData[fault["wheel"]]
    HEALTHY["u_max"], HEALTHY["fCoulomb"], HEALTHY["cViscous"] = wheel.u_max, wheel.fCoulomb, wheel.cViscous
    if fault["kind"] == "torque_limit":
        wheel.u_max = wheel.u_max * fault["size"]
    elif fault["kind"] == "coulomb":
        wheel.fCoulomb = fault["size"]
    elif fault["kind"] == "viscous":
        wheel.cViscous = fault["size"]
    gains = list(gain)
    if fault["kind"] == "motor_gain":
        gains[fault["wheel"]] = gain[fault["wheel"]] * fault["size"]
        drive.setGains(gains)
    return gains


def wheel_torque(wheel, gain: float, volts: float, speed: float, healthy: bool = False) -> float:
    """The wheel's net torque in Basilisk's model: the drive's gain V clipped to u_max, less Coulomb and viscous
    friction (away from zero speed)."""
    u_max = HEALTHY.get("u_max", wheel.u_max) if healthy else wheel.u_max
    coulomb = HEALTHY.get("fCoulomb", wheel.fCoulomb) if healthy else wheel.fCoulomb
    viscous = HEALTHY.get("cViscous", wheel.cViscous) if healthy else wheel.cViscous
    return float(np.clip(gain * volts, -u_max, u_max) - coulomb * np.sign(speed) - viscous * speed)


def write(rows: list, run: dict, effect: float, out: Path, speed_every: int = 1, speed_offset: int = 0) -> None:
    """bsk_<seed>.csv (docs/telemetry.md's layout) and bsk_<seed>.json (the draw and the fault's size); the speed
    in every ``speed_every``-th row only, from row ``speed_offset`` on (a slower tachometer, its reports between
    the FDI's stamps: the commands stay at the FSW's rate)."""
    rows = [row if k % speed_every == speed_offset % speed_every
            else [row[0], *[""] * len(JOINTS), *row[1 + len(JOINTS):]] for k, row in enumerate(rows)]
    header = (["time [s]"] + [f"{j}.speed [rad/s]" for j in JOINTS] + [f"{j}.command [V]" for j in JOINTS]
              + [f"{j}.fault [1]" for j in JOINTS])
    with open(out / f"bsk_{run['seed']}.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        writer.writerows([[f"{v:.6g}" if isinstance(v, float) else v for v in row] for row in rows])
    if run["fault"]:
        run["fault"]["effect_nm"] = effect
    (out / f"bsk_{run['seed']}.json").write_text(json.dumps(run, indent=1))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", required=True, help="A..B (inclusive)")
    parser.add_argument("--faults", default="random",
                        help=f"none, random, or kinds among {', '.join(FAULTS)} (comma-separated); default random")
    parser.add_argument("--duration", type=float, default=400.0, help="s (default 400)")
    parser.add_argument("--envelope", choices=("service", "small"), default="service",
                        help="fault sizes: the in-service ranges (default) or small ones, from the band up")
    parser.add_argument("--units", action="store_true",
                        help="each wheel its own unit: gain, Coulomb and viscous friction drawn around the datasheet's")
    parser.add_argument("--speed-rate", type=float, default=1.0 / FSW_PERIOD,
                        help=f"Hz the speed is reported at, a divisor of the FSW's {1.0 / FSW_PERIOD:g} Hz (default)")
    parser.add_argument("--speed-offset", type=float, default=0.0,
                        help="s after each FSW step the tachometer's reports are stamped at (default 0: on them)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    speed_every = round(1.0 / (FSW_PERIOD * args.speed_rate))
    speed_offset = round(args.speed_offset / FSW_PERIOD)
    if speed_every < 1 or abs(speed_every * FSW_PERIOD * args.speed_rate - 1.0) > 1e-9:
        parser.error(f"--speed-rate: {args.speed_rate:g} Hz does not divide the FSW's {1.0 / FSW_PERIOD:g} Hz")
    low, _, high = args.seeds.partition("..")
    seeds = range(int(low), int(high or low) + 1)
    unknown = [k for k in args.faults.split(",") if k not in FAULTS]
    if unknown and args.faults not in ("none", "random"):
        parser.error(f"--faults: {unknown[0]!r} is not none, random or a kind among {', '.join(FAULTS)}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for n, seed in enumerate(seeds, 1):
        HEALTHY.clear()
        run = draw(seed, args.faults, args.duration, SMALL_FAULTS if args.envelope == "small" else FAULTS,
                   args.units)
        rows, effect = fly(run)
        write(rows, run, effect, out, speed_every, speed_offset)
        print(f"\r{n}/{len(seeds)} runs", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
