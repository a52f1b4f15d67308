"""Wheel model against the closed-form figures of physics.md and the thesis."""
import numpy as np
import pytest

from rw_fdi_ros.core.physics import wheel as wm


def test_viscous_friction_eq_2_15():
    assert wm.viscous_coefficient(23.0) == pytest.approx(3.84e-4, rel=1e-12)
    # falls with temperature, reaches 0 at 215 C and stays clamped there
    assert wm.viscous_coefficient(173.0) == pytest.approx(0.84e-4, rel=1e-9)
    assert wm.viscous_coefficient(215.0) == pytest.approx(0.0, abs=1e-18)
    assert wm.viscous_coefficient(300.0) == 0.0


@pytest.mark.parametrize("emf_limit, expected", [
    ("kf_scaled", [0.97, 0.78, 0.59, 0.36, 0.17]),
    ("pwm_saturation", [1.67, 1.40, 1.12, 0.78, 0.50]),
])
def test_emf_current_limit_worked_figures(emf_limit, expected):
    params = wm.WheelParams(emf_limit=emf_limit)
    got = wm.emf_current_limit(np.array([8.0, 7.2, 6.4, 5.5, 4.8]), 25.0, params)
    np.testing.assert_allclose(got, expected, atol=0.006)


def test_emf_current_limit_without_input_resistance_is_the_linear_limit():
    # R_IN = 0 (a wheel whose bus has no input filter, Basilisk's HR16 file): R_B I + k_e w = K_f (V_bus - diode)
    params = wm.WheelParams(input_resistance=0.0)
    got = wm.emf_current_limit(np.array([8.0, 5.0]), np.array([20.0, 300.0]), params)
    np.testing.assert_allclose(got, [(0.5 * 7.0 - 0.029 * 20.0) / 2.0, 0.0], rtol=1e-12)


def test_emf_limit_zero_without_headroom_and_only_when_motoring():
    assert wm.emf_current_limit(4.0, 25.0) == 0.0            # kf_scaled at 4 V: no positive root
    # generating (current against speed) is never EMF-limited
    i = wm.motor_current(-5.0, 25.0, 4.0, 1.0)
    assert i == pytest.approx(-5.0 * 0.19)
    # motoring is clamped
    assert wm.motor_current(5.0, 25.0, 5.5, 1.0) == pytest.approx(wm.emf_current_limit(5.5, 25.0))


def test_command_clamp_and_current_limiter():
    assert wm.motor_current(9.0, 0.0, 8.0, 1.0) == pytest.approx(5.0 * 0.19)
    assert wm.motor_current(2.0, -10.0, 8.0, 0.6) == pytest.approx(0.6 * 2.0 * 0.19)


def test_holding_current_at_25_rad_s():
    # physics.md: holding attitude at 25 rad/s needs about 0.40 A
    v = wm.holding_tcv(25.0)
    assert 0.19 * v == pytest.approx(0.40, abs=0.005)
    assert wm.net_torque(v, 25.0, 0.0, wm.NOMINAL)[0] == pytest.approx(0.0, abs=1e-12)


def test_full_command_holds_wheel_near_66_rad_s():
    # physics.md: with viscous friction the full command saturates the wheel near 66 rad/s
    speeds = np.linspace(50, 80, 30001)
    tau, _ = wm.net_torque(5.0, speeds, np.pi / 0.2, wm.OperatingPoint(bus_voltage=40.0))  # noise = 0 there
    assert speeds[np.argmin(np.abs(tau))] == pytest.approx(66.5, abs=0.5)


def test_torque_noise_amplitude_eq_2_16():
    t = np.linspace(0, 2 * np.pi / 0.2, 1001)
    assert np.abs(wm.torque_noise(t)).max() == pytest.approx(1.54e-5, rel=0.01)
    # its amplitude, the one the FDI's floors and bounds take (J theta_a w_a^2, one implementation)
    assert wm.bearing_noise_amplitude() == pytest.approx(np.abs(wm.torque_noise(t)).max(), rel=1e-3)


def test_ripple_amplitude_half_b():
    angles = np.linspace(0, 2 * np.pi, 3601)
    r = wm.torque_ripple(0.01, angles, 1.0)
    assert r.max() == pytest.approx(0.11 * 0.01, rel=1e-4)
    assert wm.torque_ripple(0.01, angles, 1.4).max() == pytest.approx(1.4 * 0.11 * 0.01, rel=1e-4)


def test_linearised_wheel_thesis_numbers():
    lw = wm.linearised_wheel()
    assert lw.A == pytest.approx(-0.04987, abs=1e-5)
    assert lw.B * lw.C == pytest.approx(2.749e-4, rel=1e-3)
    assert lw.D == pytest.approx(-0.00551, abs=1e-6)
    assert lw.C == 0.01759 and lw.B == pytest.approx(0.01563, abs=1e-4)


def test_linear_wheel_matches_nonlinear_small_signal():
    """eq. 2.22 is the small-signal model: a 0.1 V step from equilibrium, both decay alike."""
    from rw_fdi_ros.core.physics.wheel import net_torque, WheelParams
    p = WheelParams(coulomb_friction=0.0)
    lw = wm.linearised_wheel(params=p)
    dt, w, dv = 0.01, 25.0, 0.1
    v0 = wm.holding_tcv(w, params=p)
    t = np.arange(0, 40, dt)
    rt = []
    for ti in t:
        tau, _ = net_torque(v0 + dv, w, np.pi / 0.2, wm.OperatingPoint(bus_voltage=40.0), p)
        tau -= wm.torque_noise(np.pi / 0.2, p)
        rt.append(-tau)
        w += dt * tau / p.inertia
    expected = lw.D * dv * np.exp(lw.A * t)   # step response of F_w = D + BC/(s - A)
    np.testing.assert_allclose(rt, expected, atol=2e-6)


def test_the_top_speed_is_where_the_drive_no_longer_beats_friction():
    """Omega_top of the thesis' Type A at 23 C and 8 V: 47.3 rad/s (the FDI envelope's 45 is 0.95 of it), where
    k_t min(G_d V_limit, I_max) equals the friction; without friction only the overspeed loop bounds it."""
    from rw_fdi_ros.core.fdi.verdict import WHEEL_SPEED_ENVELOPE, speed_envelope
    from rw_fdi_ros.core.physics.wheel import NOMINAL, WheelParams, emf_current_limit, friction_torque, top_speed
    p = WheelParams()
    w = top_speed(p)
    assert w == pytest.approx(47.345, abs=1e-3)
    limit = float(emf_current_limit(NOMINAL.bus_voltage, w, p))
    drive = p.torque_constant * min(p.driver_gain * p.command_limit, limit)
    assert drive == pytest.approx(float(friction_torque(w, 23.0, p)), rel=1e-9)
    free = WheelParams(coulomb_friction=0.0, viscous_scale=0.0)
    assert top_speed(free) == free.overspeed_threshold
    assert speed_envelope(p) == speed_envelope(None) == WHEEL_SPEED_ENVELOPE == 45.0
    assert speed_envelope(WheelParams(emf_limit="pwm_saturation")) == 45.0   # the wheel's, not the plant choice's
    small = WheelParams(coulomb_friction=0.001)
    assert speed_envelope(small) == pytest.approx(45.0 * top_speed(small) / w)


def test_a_units_drag_is_a_share_of_its_types_not_of_the_thesis_wheels():
    """unit_wheel scales the type's own viscous friction: a small wheel's unit keeps a small wheel's drag."""
    from rw_fdi_ros.core.physics.wheel import WheelParams, unit_wheel, viscous_coefficient
    small = WheelParams(viscous_scale=7.8e-4)
    unit = unit_wheel(small, {"torque_constant": [1.0], "driver_gain": [1.0], "coulomb_friction": [1.0],
                              "viscous_friction": [1.2]})
    assert float(viscous_coefficient(23.0, unit)[0]) == pytest.approx(1.2 * float(viscous_coefficient(23.0, small)))
