"""The magnetorquers and the momentum-dumping law (core/physics/magnetorquers.py), alone and in the closed loop."""
from dataclasses import replace

import numpy as np
import pytest

from rw_fdi_ros.core.fdi.pipeline import LoadedFdi
from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.physics.magnetorquers import (Dumper, MomentumDumping, cross_product_dipole, saturate,
                                           wheel_momentum)
from rw_fdi_ros.core.mission.scenario import ScenarioError, parse_scenario
from rw_fdi_ros.core.physics.wheel_set import wheel_set


def test_the_cross_product_dipole_makes_the_torque_across_the_field():
    rng = np.random.default_rng(1)
    b = rng.normal(0.0, 3e-5, (10, 3))
    tau = rng.normal(0.0, 1e-4, (10, 3))
    m = cross_product_dipole(b, tau)
    b_hat = b / np.linalg.norm(b, axis=1, keepdims=True)
    across = tau - np.sum(tau * b_hat, axis=1, keepdims=True) * b_hat
    assert np.allclose(np.cross(m, b), across, rtol=1e-9, atol=1e-18)   # m x b = tau's part across b
    assert np.all(cross_product_dipole(np.zeros((1, 3)), tau[:1]) == 0.0)   # no field: no dipole


def test_saturation_keeps_the_direction():
    m = np.array([[30.0, -10.0, 5.0], [1.0, 2.0, -3.0]])
    out = saturate(m, 15.0)
    assert np.abs(out).max(axis=1) == pytest.approx([15.0, 3.0])
    assert np.allclose(out[0] / np.linalg.norm(out[0]), m[0] / np.linalg.norm(m[0])) and np.array_equal(out[1], m[1])


def test_wheel_momentum_counts_the_wheels_in_use():
    wheels = wheel_set("orthogonal_skew")
    speed = np.array([[10.0, -20.0, 30.0, 40.0]])
    in_use = np.array([[True, True, False, True]])
    h = wheel_momentum(speed, 0.0077, wheels.matrix, in_use)
    expected = 0.0077 * (10.0 * wheels.matrix[:, 0] - 20.0 * wheels.matrix[:, 1] + 40.0 * wheels.matrix[:, 3])
    assert np.allclose(h[0], expected)


def test_the_law_dumps_with_hysteresis():
    """Off until a wheel in use passes the start speed, on until the net momentum is below what a wheel
    holds at the stop speed (|h| / J); the torque it asks opposes the momentum; the rods off or a run
    without rods: no dipole."""
    settings = MomentumDumping(start_speed=35.0, stop_speed=5.0)
    dumper = Dumper([settings, replace(settings, enabled=False), None])
    axes = wheel_set("orthogonal").matrix
    field = np.tile([2e-5, -1e-5, 3e-5], (3, 1))
    in_use = np.ones((3, 3), bool)

    def step(speed):
        return dumper.update(field, np.tile(speed, (3, 1)), in_use, 0.0077, axes)
    assert np.all(step([30.0, 0.0, 0.0]) == 0.0)                  # below the start: off
    m = step([36.0, 0.0, 0.0])
    assert dumper.dumping.tolist() == [True, False, False] and np.all(m[1:] == 0.0)
    torque = np.cross(m[0], field[0])
    assert torque @ (axes @ [36.0, 0.0, 0.0]) < 0.0               # against the stored momentum
    assert np.any(step([20.0, 0.0, 0.0])[0] != 0.0)               # between stop and start: still on
    assert np.any(step([4.0, -3.0, 3.0])[0] != 0.0)                # each below 5, |h| / J = 5.8: still on
    assert np.all(step([4.0, -2.0, 2.0]) == 0.0) and not dumper.dumping.any()   # |h| / J = 4.9: off


def test_scenario_fields_are_checked():
    for text, words in (("magnetorquers: {}", "need a field"),
                        ("environment: {epoch: 1800-01-01T00:00:00}", "outside"),
                        ("environment: {epoch: yesterday}", "date-time"),
                        ("environment: {orbit: {altitude_km: 50}}", "outside"),
                        ("environment: {tle: [a, b]}", "tle"),
                        ("environment: {orbit: {}, tle: [a, b]}", "not both"),
                        ("environment: {}\nmagnetorquers: {dumping: {start_speed: 3, stop_speed: 5}}", "above"),
                        ("environment: {}\nmagnetorquers: {dumping: sometimes}", "dumping"),
                        ("environment: {orbit: []}", "may set only"),
                        ("plant: {control_period: 0.3}\nenvironment: {}", "does not divide"),
                        # an element set of 2031: past the years IGRF knows
                        ("environment: {tle: ['1 25544U 98067A   31264.51782528 -.00002182  "
                         "00000-0 -11606-4 0  2927', '2 25544  51.6416 247.4627 0006703 130.5360 325.0288 "
                         "15.72125391563537']}", "its epoch.*outside")):
        with pytest.raises(ScenarioError, match=words) as info:
            parse_scenario(f"name: bad\n{text}\n")
        assert "\n" not in str(info.value)


def _orbit(extra: str = "") -> str:
    return ("name: orbit\nduration: 600.0\nseed: 5\ninitial: {wheel_speed: [38.0, -36.0, 40.0]}\n"
            "environment: {epoch: 2026-03-01T00:00:00}\nmagnetorquers: {" + extra + "}\n")


def test_dumping_in_the_closed_loop_pulls_the_wheels_back_and_keeps_the_pointing():
    """Wheels above the start speed: the rods come on at once and the wheels' momentum falls below the
    rods-off twin's while the pointing stays far inside 0.2 deg; a run without an orbit in the same batch
    is the run it is alone."""
    on, off = parse_scenario(_orbit()), parse_scenario(_orbit("dumping: false"))
    plain = parse_scenario("name: plain\nduration: 600.0\nseed: 5\n")
    traj = simulate([on, off, plain])
    assert np.all(traj.dipole[:, 1] == 0.0) and np.any(traj.dipole[1:, 0] != 0.0)
    h = np.linalg.norm(0.0077 * traj.wheel_speed @ wheel_set("orthogonal_skew").matrix.T, axis=-1)
    assert h[-1, 0] < h[-1, 1] - 0.02                              # 0.02 N m s less stored in 10 min
    error = np.rad2deg(np.abs(traj.error[traj.time > 300.0])).max(axis=(0, 2))
    assert error[0] < 0.05 and error[1] < 0.05
    alone = simulate(plain)
    assert np.array_equal(traj.attitude[:, 2], alone.attitude[:, 0])
    assert np.array_equal(traj.wheel_speed[:, 2], alone.wheel_speed[:, 0])
    assert np.all(traj.magnetic_field[:, 2] == 0.0) and np.all(traj.dipole[:, 2] == 0.0)


def test_after_a_reconfiguration_the_rods_dump_the_wheels_in_use():
    """In orbit, dumping from the start, a 40 % current loss on x at 150 s: the FDI confirms x and s comes in
    beside it; from then on the dipole is the law's for the momentum of all four wheels in use, and the
    pointing comes back within 0.2 deg."""
    from rw_fdi_ros.core.flight import Fdir
    from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
    from rw_fdi_ros.paths import fdi_dir
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "thresholds_model.json", "model")
    scenario = parse_scenario(_orbit().replace("duration: 600.0", "duration: 300.0")
                              + "faults:\n  - {kind: current_limiter, wheel: x, onset: 150.0, value: 0.6}\n")
    traj = simulate([scenario], fdir=Fdir(LoadedFdi({"model": curves})))
    decisions = traj.decisions[0]
    # x at 38 rad/s holds more momentum than y, z and s could take and slew: kept in use beside s
    assert [(d.wheel, d.action) for d in decisions] == [("x", "kept_in_use"), ("s", "in_use")]
    after = traj.time > decisions[0].time + 1.0
    settings = scenario.magnetorquers
    axes = wheel_set("orthogonal_skew").matrix
    k = np.flatnonzero(after & np.any(traj.dipole[:, 0] != 0.0, axis=-1))[0]   # a dump's dipole after it
    k -= k % 10   # the magnetometer sample the dipole was made from
    in_use = traj.in_use[k, 0]   # the wheels in use when the reading came
    assert in_use.tolist() == [True, True, True, True]
    h = wheel_momentum(traj.wheel_speed[k, 0][None], 0.0077, axes, in_use[None])
    expected = saturate(cross_product_dipole(traj.magnetic_field[k, 0][None], -settings.gain * h),
                        settings.dipole_limit)[0]
    assert np.allclose(traj.dipole[k, 0], expected, rtol=1e-12)
    error = np.degrees(np.abs(traj.error[:, 0])).max(axis=1)
    assert error[traj.time >= 220.0].max() < 0.2


def test_the_bench_finds_the_dumps_and_the_zero_crossings():
    from rw_fdi_ros.tools.benches.dumping_bench import dumps, zero_crossings
    time = np.arange(10.0)
    dipole = np.zeros((10, 3))
    dipole[2:5, 0] = 1.0
    dipole[7:, 2] = -2.0
    assert dumps(dipole, time) == [(2.0, 4.0), (7.0, 9.0)]
    assert zero_crossings(np.array([[1.0, -1.0], [-1.0, -2.0], [2.0, 3.0]])) == 3
