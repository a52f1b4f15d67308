"""Thesis fault behaviours in the core plant + PID loop (no ROS), same seed faulty vs fault-free.

Measured signals: pointing error, X's torque command voltage (tcv) and the
recorded fault effect (reaction torque minus a healthy wheel's in the same
state for the same command).

Wheels Y and Z stay healthy in every case (fault effect exactly 0). With the
wheels' momentum coupled into the body (the default) a fault on X moves the Y
and Z controllers a little: X's motion w_x crosses the stored momenta h_y, h_z
(w x h_w); with eq. 2.27 alone (coupling off) they see nothing at all.
"""
import numpy as np
import pytest

from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.mission.scenario import Fault, Scenario
from rw_fdi_ros.core.physics.wheel import WheelParams, bus_fault_visible_above

SEEDS = range(20, 26)
ONSET = 200.0


def pair(kind, value, wheel=0, emf_limit="kf_scaled", seeds=SEEDS, duration=300.0, coupling=True):
    runs = [Scenario("f", duration=duration, seed=s, faults=(Fault(kind, wheel, ONSET, value),)) for s in seeds]
    w = WheelParams(emf_limit=emf_limit)
    return (simulate(runs, wheel=w, wheel_momentum_coupling=coupling),
            simulate([r.fault_free() for r in runs], wheel=w, wheel_momentum_coupling=coupling))


def after(traj):
    return traj.time >= ONSET


def assert_y_z_unaffected(faulty, healthy, tcv_volts=0.05, attitude_deg=0.01):
    """Y and Z healthy, pointing as in the fault-free run; their tcv moves by at most ``tcv_volts``."""
    a = after(faulty)
    assert np.abs(faulty.tcv[a][..., 1:] - healthy.tcv[a][..., 1:]).max() < tcv_volts
    assert np.rad2deg(np.abs(faulty.attitude[a][..., 1:] - healthy.attitude[a][..., 1:])).max() < attitude_deg
    assert np.abs(faulty.fault_effect[..., 1:]).max() == 0.0


def test_bus_4v_on_x_diverges_while_y_z_hold():
    """Thesis Fig. 3.1: 8 -> 4 V on X at 200 s."""
    f, h = pair("bus_voltage", 4.0)
    final_x = np.rad2deg(np.abs(f.error[-1, :, 0]))
    assert final_x.min() > 10.0                         # X diverges on every seed
    assert np.rad2deg(np.abs(h.error[-1, :, 0])).max() < 0.05
    assert np.rad2deg(np.abs(f.error[after(f)][..., 1:])).max() < 0.1
    # a tumbling X crosses h_y, h_z: Y and Z work against w_x x h_w (volts) and still point
    assert_y_z_unaffected(f, h, tcv_volts=5.0, attitude_deg=0.1)


def test_without_coupling_y_z_see_nothing_of_a_fault_on_x():
    """Eq. 2.27 as the thesis writes it: the axes are decoupled but for w x (I w)."""
    f, h = pair("bus_voltage", 4.0, seeds=range(20, 23), coupling=False)
    assert_y_z_unaffected(f, h, tcv_volts=0.01, attitude_deg=0.01)


def test_bus_5v5_on_x_shows_only_above_the_headroom_speed():
    """kf_scaled: visible above 23.5 rad/s, invisible below (physics.md)."""
    threshold = bus_fault_visible_above(5.5)
    assert threshold == pytest.approx(23.5, abs=0.1)
    f, h = pair("bus_voltage", 5.5, seeds=range(40))
    speed = h.wheel_speed[int(ONSET / 0.1), :, 0]
    effect = np.abs(f.fault_effect[after(f)][..., 0]).max(axis=0)
    fast, slow = speed > threshold + 0.5, speed < threshold - 0.5
    assert fast.sum() >= 5 and slow.sum() >= 5
    assert effect[fast].min() > 5e-3                    # > 5 mN m on the reaction torque
    assert effect[slow].max() == 0.0
    assert_y_z_unaffected(f, h, tcv_volts=1.0)   # the fast runs' X drifts off and crosses h_y, h_z


def test_bus_5v5_invisible_under_pwm_saturation_while_holding():
    assert bus_fault_visible_above(5.5, params=WheelParams(emf_limit="pwm_saturation")) > 40.0
    f, h = pair("bus_voltage", 5.5, emf_limit="pwm_saturation")
    assert np.abs(f.fault_effect).max() == 0.0
    np.testing.assert_array_equal(f.attitude, h.attitude)


def test_current_limiter_0p6_on_x():
    """Same reaction torque needs 1/0.6 the voltage: X's tcv rises by > 1 V, pointing holds."""
    f, h = pair("current_limiter", 0.6)
    a = after(f)
    assert (f.tcv[a][..., 0] - h.tcv[a][..., 0]).max(axis=0).min() > 1.0
    assert np.rad2deg(np.abs(f.error[a][..., 0])).max() < 0.2
    assert np.abs(f.fault_effect[a][..., 0]).max(axis=0).min() > 5e-3
    assert_y_z_unaffected(f, h)


def test_temperature_plus_150_on_x():
    """Eq. 2.15: friction falls from 3.84e-4 to 0.84e-4; X's holding tcv drops by > 1 V."""
    f, h = pair("temperature", 173.0)
    a = after(f)
    end = -1
    assert (h.tcv[end, :, 0] - f.tcv[end, :, 0]).min() > 1.0
    assert np.abs(f.fault_effect[a][..., 0]).max(axis=0).min() > 3e-3
    assert_y_z_unaffected(f, h)


def test_ripple_increase_changes_only_the_sampled_torque():
    f, h = pair("ripple_gain", 1.4)
    np.testing.assert_array_equal(f.tcv, h.tcv)                  # a disturbance, not a fault
    effect = np.abs(f.fault_effect[after(f)][..., 0])
    motor = np.abs(h.reaction_torque).max()
    assert 0 < effect.max() <= 0.4 * 0.11 * 0.03 and motor > 0
