"""Our plant against Basilisk (AVS Lab), the same spacecraft and wheels under one motor-torque profile.

Basilisk runs in its own environment (.venv-bsk, made by scripts/setup_basilisk.sh:
its pins clash with ours) through test/basilisk/bsk_run.py; our side is
core.physics.plant.Plant with torque noise and disturbance off, driven by the command
voltage that gives the same motor torque (tcv = tau_m / (G_d k_t), far from
every current limit at 20-30 rad/s and 8 V).
"""
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.core.physics.plant import Plant
from rw_fdi_ros.core.mission.scenario import parse_scenario
from rw_fdi_ros.core.physics.spacecraft import INERTIA
from rw_fdi_ros.core.physics.wheel import WheelParams, viscous_coefficient
from rw_fdi_ros.core.physics.wheel_set import WHEEL_SETS

ROOT = Path(__file__).resolve().parents[1]
BSK_PYTHON = ROOT / ".venv-bsk" / "bin" / "python"
PERIOD, STEPS = 0.1, 4000          # 400 s
WHEEL_SPEED = [22.0, 25.0, 28.0]   # rad/s, inside Table 2.3's 20-30
BODY_RATE = [2e-4, -1e-4, 1e-4]


def torque_profile(coulomb):
    """Holding torque plus two sines per axis (0.004 and 0.002 N m), all three axes excited."""
    t = np.arange(STEPS) * PERIOD
    hold = float(viscous_coefficient(23.0)) * np.array(WHEEL_SPEED) + coulomb
    return (hold + 0.004 * np.sin(2 * np.pi * t[:, None] / [100.0, 120.0, 90.0] + [0.0, 1.0, 2.0])
            + 0.002 * np.sin(2 * np.pi * t[:, None] / [37.0, 29.0, 43.0]))


def skew_profile():
    """The three axis wheels' profile (no coulomb) and the standby wheel s spun up from rest by 2 mN m
    plus a 3 mN m sine: every wheel of orthogonal_skew turning, s off the body axes."""
    t = np.arange(STEPS) * PERIOD
    return np.concatenate([torque_profile(0.0), (0.002 + 0.003 * np.sin(2 * np.pi * t / 70.0))[:, None]], axis=1)


def basilisk(tmp_path, coulomb, use_rw_friction=None, wheels=None):
    profile = torque_profile(coulomb) if wheels is None else skew_profile()
    spec = dict(inertia=INERTIA.tolist(), wheel_inertia=WheelParams().inertia, viscous=float(viscous_coefficient(23.0)),
                coulomb=coulomb, wheel_speed=WHEEL_SPEED + ([0.0] if wheels else []), body_rate=BODY_RATE,
                period=PERIOD, motor_torque=profile.tolist(),
                use_rw_friction=coulomb > 0 if use_rw_friction is None else use_rw_friction)
    if wheels is not None:
        spec["spin_axes"] = wheels.matrix.T.tolist()
    spec_path, out = tmp_path / "spec.json", tmp_path / "bsk.npz"
    spec_path.write_text(json.dumps(spec))
    assert BSK_PYTHON.exists(), "Basilisk environment missing: run scripts/setup_basilisk.sh"
    subprocess.run([str(BSK_PYTHON), str(ROOT / "test" / "basilisk" / "bsk_run.py"), str(spec_path), str(out)],
                   check=True, timeout=300, capture_output=True)
    d = np.load(out)
    return d["body_rate"], d["wheel_speed"]


def ours(coulomb, coupling, wheels="orthogonal"):
    scenario = parse_scenario(f"duration: 400\ninitial: {{attitude_deg: [0, 0, 0], body_rate: {BODY_RATE}, "
                              f"wheel_speed: {WHEEL_SPEED}}}\nfaults: []\n")
    wheel = WheelParams(noise_angle=0.0, coulomb_friction=coulomb)
    plant = Plant(scenario, wheel=wheel, control_period=PERIOD, disturbance=False, wheel_momentum_coupling=coupling,
                  wheels=wheels)
    volts_per_nm = 1.0 / (wheel.driver_gain * wheel.torque_constant)
    rates, speeds = [plant.body_rate[0].copy()], [plant.wheel_speed[0].copy()]
    for torque in (torque_profile(coulomb) if plant.wheels.count == 3 else skew_profile()):
        plant.step(torque[None] * volts_per_nm)
        rates.append(plant.body_rate[0].copy())
        speeds.append(plant.wheel_speed[0].copy())
    return np.array(rates), np.array(speeds)


@pytest.mark.parametrize("coulomb", [0.0, WheelParams().coulomb_friction])
def test_plant_matches_basilisk_with_wheel_momentum_coupling(tmp_path, coulomb):
    bsk_rate, bsk_speed = basilisk(tmp_path, coulomb)
    rate, speed = ours(coulomb, coupling=True)
    assert np.abs(bsk_rate).max() > 3e-3           # the profile really moves the body
    assert np.abs(rate - bsk_rate).max() < 5e-6    # rad/s
    assert np.abs(speed - bsk_speed).max() < 4e-3  # rad/s


def test_plant_matches_basilisk_with_the_skew_wheel_in_use(tmp_path):
    """orthogonal_skew with all four wheels driven: s along (1, 1, 1)/sqrt(3) couples the axes through
    the wheels' inertia matrix sum J g g^T and its momentum; Basilisk's BalancedWheels with the same
    spin axes gives the same body rates and wheel speeds."""
    wheels = WHEEL_SETS["orthogonal_skew"]
    bsk_rate, bsk_speed = basilisk(tmp_path, 0.0, wheels=wheels)
    rate, speed = ours(0.0, coupling=True, wheels=wheels)
    assert bsk_speed.shape[1] == 4 and np.abs(bsk_speed[:, 3]).max() > 5.0   # s spun up
    assert np.abs(rate - bsk_rate).max() < 5e-6    # rad/s
    assert np.abs(speed - bsk_speed).max() < 4e-3  # rad/s


def test_thesis_euler_equations_disagree_with_basilisk(tmp_path):
    """Eq. 2.27 without h_w: the body rates differ by as much as the rates themselves."""
    bsk_rate, bsk_speed = basilisk(tmp_path, 0.0)
    rate, speed = ours(0.0, coupling=False)
    assert np.abs(rate - bsk_rate).max() > 1e-3
    assert np.abs(rate - bsk_rate).max() > 0.2 * np.abs(bsk_rate).max()


def test_basilisk_factory_drops_coulomb_friction_without_use_rw_friction(tmp_path):
    """Basilisk's rwFactory zeroes fCoulomb unless useRWfriction=True: the wheel then lacks tau_c, and
    with viscous friction the speed offset settles at tau_c / tau_v = 5.2 rad/s with time constant
    J / tau_v = 20 s (the 5.2 rad/s difference seen when the flag was left at its default)."""
    wheel = WheelParams()
    tau_v = float(viscous_coefficient(23.0))
    _, bsk_speed = basilisk(tmp_path, wheel.coulomb_friction, use_rw_friction=False)
    _, speed = ours(wheel.coulomb_friction, coupling=True)
    offset = bsk_speed - speed
    settled = offset[int(150 / PERIOD):]
    assert np.allclose(settled, wheel.coulomb_friction / tau_v, rtol=0.01)
    tau = wheel.inertia / tau_v
    assert offset[int(tau / PERIOD)] == pytest.approx((1 - np.exp(-1)) * wheel.coulomb_friction / tau_v, rel=0.02)
