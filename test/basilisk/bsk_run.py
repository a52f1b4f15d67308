"""Run a Basilisk spacecraft with reaction wheels (body axes, or the spin axes given) under a motor-torque profile.

Runs in the separate Basilisk environment (.venv-bsk, see scripts/setup_venv.sh):

    .venv-bsk/bin/python test/basilisk/bsk_run.py spec.json out.npz

spec.json: inertia [3], wheel_inertia, viscous, coulomb, use_rw_friction (the rwFactory flag
without which it silently zeroes fCoulomb), spin_axes [N][3] (optional: the body axes),
wheel_speed [N] (rad/s), body_rate [3] (rad/s), period (s), motor_torque [[t_1 .. t_N], ...] held
over each period.
out.npz: time, body_rate (n+1, 3), wheel_speed (n+1, N), sampled at the period boundaries.
BalancedWheels, no Stribeck, no torque or speed limits, RK4 at the period (as our plant).
"""
import json
import sys

import numpy as np
from Basilisk.architecture import messaging
from Basilisk.simulation import reactionWheelStateEffector, spacecraft
from Basilisk.utilities import SimulationBaseClass, macros, simIncludeRW


def main(spec_path, out_path):
    spec = json.load(open(spec_path))
    torque = np.asarray(spec["motor_torque"], float)
    period = float(spec["period"])
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("dyn")
    proc.addTask(sim.CreateNewTask("task", macros.sec2nano(period)))

    sc = spacecraft.Spacecraft()
    sc.hub.mHub = 500.0
    sc.hub.IHubPntBc_B = np.diag(spec["inertia"]).tolist()
    sc.hub.omega_BN_BInit = [[w] for w in spec["body_rate"]]
    sc.hub.sigma_BNInit = [[0.0], [0.0], [0.0]]

    factory = simIncludeRW.rwFactory()
    for axis, speed in zip(np.asarray(spec.get("spin_axes", np.eye(3)), float), spec["wheel_speed"]):
        factory.create("custom", axis.tolist(), Js=float(spec["wheel_inertia"]),
                       Omega=float(speed) / macros.RPM, cViscous=float(spec["viscous"]),
                       fCoulomb=float(spec["coulomb"]), useRWfriction=bool(spec["use_rw_friction"]),
                       useMaxTorque=False, RWModel=messaging.BalancedWheels)
    rw = reactionWheelStateEffector.ReactionWheelStateEffector()
    factory.addToSpacecraft("wheels", rw, sc)
    cmd = messaging.ArrayMotorTorqueMsgPayload()
    cmd_msg = messaging.ArrayMotorTorqueMsg()
    rw.rwMotorCmdInMsg.subscribeTo(cmd_msg)
    sim.AddModelToTask("task", rw, 2)
    sim.AddModelToTask("task", sc, 1)

    cmd.motorTorque = [float(v) for v in torque[0]]
    cmd_msg.write(cmd, 0)
    sim.InitializeSimulation()
    rates = [np.array(spec["body_rate"], float)]
    speeds = [np.array(spec["wheel_speed"], float)]
    omega_state = sc.dynManager.getStateObject(sc.hub.nameOfHubOmega)
    wheel_state = sc.dynManager.getStateObject(rw.nameOfReactionWheelOmegasState)
    for k in range(len(torque)):
        cmd.motorTorque = [float(v) for v in torque[k]]
        cmd_msg.write(cmd, macros.sec2nano(k * period))
        sim.ConfigureStopTime(macros.sec2nano((k + 1) * period))
        sim.ExecuteSimulation()
        rates.append(np.array(omega_state.getState()).ravel())
        speeds.append(np.array(wheel_state.getState()).ravel())
    np.savez(out_path, time=np.arange(len(torque) + 1) * period, body_rate=np.array(rates),
             wheel_speed=np.array(speeds))


if __name__ == "__main__":
    main(*sys.argv[1:3])
