"""Unit calibration (core/fdi/calibration.py): the Bayesian least squares against its closed form, the
learning window, and on the core loop a varied wheel judged against its own unit."""
import numpy as np
import pytest

from rw_fdi_ros.fdi_config import FdiConfig

from rw_fdi_ros.core.fdi.calibration import (UnitCalibration, calibration_samples, prior_variances, regressors,
                                         tolerances)
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves, ThresholdError


def synthetic(n, b, noise, seed=0):
    rng = np.random.default_rng(seed)
    motor = rng.uniform(-0.03, 0.03, n)
    free = np.where(rng.uniform(size=n) < 0.3, 0.0, motor)   # the bridge clips 3 samples in 10
    x = np.column_stack([motor, free, rng.uniform(0.005, 0.02, n), np.full(n, 0.002),
                         rng.normal(0, 1e-3, n), rng.normal(0, 1e-3, n)])
    return x, x @ b + rng.normal(0, noise, n)


def test_posterior_is_the_closed_form_ridge_solution():
    b = np.array([0.03, -0.02, -0.2, 0.15, 0.05, -0.1])
    x, e = synthetic(120, b, 2e-4)
    cal = UnitCalibration(samples=120)
    for xi, ei in zip(x, e):
        cal.update(ei, xi)
    est = cal.estimate
    s2 = 10.0 * est.noise ** 2   # CORRELATION x s^2
    information = np.diag(1 / prior_variances()) + x.T @ x / s2
    assert est.covariance == pytest.approx(np.linalg.inv(information), rel=1e-9)
    assert est.mean == pytest.approx(np.linalg.solve(information, x.T @ e / s2), rel=1e-9, abs=1e-12)
    # and it finds the unit: each physical share within 3 posterior sigma of the truth
    sd = np.sqrt(np.diag(est.covariance))
    assert np.all(np.abs(est.mean[:4] - b[:4]) < 3 * sd[:4])
    assert est.noise == pytest.approx(2e-4, rel=0.2)
    assert est.scales()["viscous_friction"][0] == pytest.approx(1 + est.mean[2])


def test_a_wheel_type_without_ripple_holds_the_phasor_terms_at_zero():
    """Basilisk's wheel (docs/basilisk.md): no ripple, B = 0, so the prior holds the phasor's two terms at 0 and the
    posterior is the closed-form ridge solution on the four physical shares alone."""
    from dataclasses import replace
    from rw_fdi_ros.core.physics.wheel import WheelParams
    b = np.array([0.03, -0.02, -0.2, 0.15, 0.0, 0.0])
    x, e = synthetic(120, b, 2e-4)
    wheel = replace(WheelParams(), ripple_coefficient=0.0)
    assert np.all(prior_variances(params=wheel)[4:] == 0.0)
    cal = UnitCalibration(samples=120, params=wheel)
    for xi, ei in zip(x, e):
        cal.update(ei, xi)
    est = cal.estimate
    s2 = 10.0 * est.noise ** 2
    p = x[:, :4]
    information = np.diag(1 / prior_variances()[:4]) + p.T @ p / s2
    assert est.mean[:4] == pytest.approx(np.linalg.solve(information, p.T @ e / s2), rel=1e-9, abs=1e-12)
    assert est.covariance[:4, :4] == pytest.approx(np.linalg.inv(information), rel=1e-9)
    assert np.all(est.mean[4:] == 0.0) and np.all(est.covariance[4:] == 0.0)


def test_a_torque_derived_from_a_noisy_tachometer_is_fitted_by_generalised_least_squares():
    """r = -J dOmega/dt from speeds with noise sigma: the noise enters as differences d_k - d_(k-1), sigma_d = J sigma /
    T. The posterior is the closed-form GLS solution under V = c s^2 I + sigma_d^2 tridiag(-1, 2, -1), holds the true
    unit within 3 sigma, and is sharper than the white-noise fit, which takes the 2 sigma_d^2 per sample for noise
    that does not cancel."""
    from dataclasses import replace
    from rw_fdi_ros.core.physics.wheel import WheelParams
    n, b = 150, np.array([0.03, -0.02, -0.2, 0.15, 0.05, -0.1])
    x, _ = synthetic(n, b, 0.0)
    wheel = replace(WheelParams(), speed_noise=0.01)   # sigma_d = 0.0077 * 0.01 = 7.7e-5 N m
    sd = wheel.inertia * wheel.speed_noise
    d = np.random.default_rng(3).normal(0.0, sd, n + 1)
    e = x @ b + np.diff(d)
    cal, white = UnitCalibration(samples=n, params=wheel), UnitCalibration(samples=n)
    for xi, ei in zip(x, e):
        cal.update(ei, xi)
        white.update(ei, xi)
    est = cal.estimate
    s2 = est.noise ** 2
    v = (10.0 * s2 + 2 * sd ** 2) * np.eye(n) - sd ** 2 * (np.eye(n, k=1) + np.eye(n, k=-1))
    vi = np.linalg.inv(v)
    information = np.diag(1 / prior_variances()) + x.T @ vi @ x
    assert est.covariance == pytest.approx(np.linalg.inv(information), rel=1e-6)
    assert est.mean == pytest.approx(np.linalg.solve(information, x.T @ vi @ e), rel=1e-6, abs=1e-10)
    sigma = np.sqrt(np.diag(est.covariance))[:4]
    assert np.all(np.abs(est.mean[:4] - b[:4]) < 3 * sigma)
    assert np.all(sigma < 0.6 * np.sqrt(np.diag(white.estimate.covariance))[:4])   # the white fit: wider


def test_learning_window_judges_against_the_prior_then_freezes():
    b = np.array([0.03, 0.02, 0.3, -0.2, 0.0, 0.0])
    x, e = synthetic(80, b, 1e-5)
    cal = UnitCalibration(samples=50)
    p0 = prior_variances()
    box = [0.02, 0.02, 0.2, 0.2]
    assert tolerances() == pytest.approx(box)
    for k in range(50):
        correction, u = cal.update(e[k], x[k])
        assert correction == 0.0   # no correction while learning, the type's tolerance box as uncertainty
        assert u == pytest.approx(np.abs(x[k, :4]) @ box)
        # 3 u covers every unit whose parameters each lie within 3 sigma, at any corner of the box
        assert 3 * u >= np.abs(x[k, :4] @ (3 * np.array(box) * np.sign(x[k, :4]))) - 1e-15
    frozen = cal.estimate
    assert cal.frozen and frozen.samples == 50
    for k in range(50, 80):
        correction, u = cal.update(1.0, x[k])   # a fault after the window is not learnt
        assert correction == pytest.approx(x[k, :4] @ frozen.mean[:4])
        assert u < np.sqrt(x[k, :4] ** 2 @ p0[:4]) / 5   # the data narrowed the excited directions
    assert cal.estimate is frozen
    # 50 clean samples: the prediction error is what the noise allows, far below the unit's offsets
    assert np.max(np.abs(x[50:, :4] @ (frozen.mean[:4] - b[:4]))) < 1e-4


def test_what_the_data_cannot_separate_stays_at_the_prior():
    # coulomb friction is constant at positive speed: with the viscous regressor constant too the
    # two are one column, and their difference keeps the prior's spread
    column = np.array([0.0, 0.0, 0.0096, 0.002, 0.0, 0.0])
    x = np.tile(column, (100, 1))
    cal = UnitCalibration(samples=100)
    for xi in x:
        cal.update(0.3 * 0.0096, xi)
    cov = cal.estimate.covariance
    sum_sd = np.sqrt(column @ cov @ column)
    assert sum_sd < 2e-4                                  # the torque they give together is learnt
    # each alone is not: the coulomb share (the smaller column) keeps most of its prior spread
    assert np.sqrt(cov[3, 3]) > 0.9 * np.sqrt(prior_variances()[3])


def test_the_driver_gain_is_told_from_the_torque_constant_where_the_bridge_clips():
    """Wheel-model data of a unit with k_t +3 % and G_d -5 %: unclipped the torque scales with their
    product, clipped at the EMF limit with k_t alone; the four-share calibration finds each, and the
    identification's view of the unit (UnitShares) carries them."""
    from rw_fdi_ros.core.physics import wheel as wm
    rng = np.random.default_rng(3)
    n = 150
    u, w = rng.uniform(-2.0, 5.0, n), rng.uniform(35.0, 50.0, n)   # high speed: large commands clip
    unit = wm.unit_wheel(wm.WheelParams(), {"torque_constant": 1.03, "driver_gain": 0.95, "viscous_friction": 1.1,
                                            "coulomb_friction": 0.9})
    r_unit = -(unit.torque_constant * wm.motor_current(u, w, 8.0, 1.0, unit) - wm.friction_torque(w, 23.0, unit))
    current, clipped = wm.bridge(u, w, 8.0)
    assert 0.1 < clipped.mean() < 0.9
    tm = wm.WheelParams().torque_constant * current
    tf = wm.friction_torque(w, 23.0)
    cal = UnitCalibration(samples=n)
    x = regressors(tm, tf, w, np.zeros(n), np.where(clipped, 0.0, tm))
    for k in range(n):
        cal.update(r_unit[k] - (-(tm[k] - tf[k])), x[k])
    shares = cal.unit()
    assert shares.source == "calibrated"
    truth = np.array([0.03, -0.05, 0.1, -0.1])
    sd = np.sqrt(np.diag(shares.covariance))
    assert np.all(np.abs(shares.mean - truth) < 3 * sd), (shares.mean, sd)
    assert sd[0] < wm.DEFAULT_UNIT_SPREAD["torque_constant"] / 4   # the clipped samples told k_t apart
    assert abs(shares.mean[0] - 0.03) < 0.01 and abs(shares.mean[1] + 0.05) < 0.01
    # one motor share (no free torque: the model before) is sure of a wrong unit: its k_t is off by
    # many of its own sigmas, the clipped samples' error pushed into the friction
    one = UnitCalibration(samples=n)
    for k in range(n):
        one.update(r_unit[k] - (-(tm[k] - tf[k])), regressors(tm[k], tf[k], w[k], 0.0))
    wrong = one.unit()
    assert np.any(np.abs(wrong.mean - truth) > 3 * np.sqrt(np.diag(wrong.covariance))), wrong.mean


def test_bad_priors_and_mismatched_bands_are_refused(tmp_path):
    with pytest.raises(ValueError, match="prior"):
        UnitCalibration(prior=[1, 1, 1, -1, 1, 1])
    with pytest.raises(ValueError, match="prior"):
        UnitCalibration(prior=[1, 1, 1, np.inf, 1, 1])
    assert calibration_samples(150.0, 1.0) == 150 and calibration_samples(150.0, 0.5) == 300
    c = ThresholdCurves("linear", {a: np.array([1e-4]) for a in "xyz"}, method="speed_aware",
                        unit_calibration_time=150.0)
    c.save(tmp_path / "t.json")
    loaded = ThresholdCurves.load(tmp_path / "t.json")
    loaded.check_unit_calibration(150.0)
    with pytest.raises(ThresholdError, match="unit_calibration_time=150 s but the observers run unit_calibration"):
        loaded.check_unit_calibration(0.0)


def test_a_varied_wheel_is_judged_against_its_own_unit():
    """Core loop: on wheels drawn around the datasheet, the calibrated nominal model leaves a residual
    several times smaller than the datasheet's after the window."""
    from rw_fdi_ros.core.mission.scenario import parse_scenario
    from rw_fdi_ros.tools.design.offline import observe
    from rw_fdi_ros.tools.design.samples import simulated_runs
    weights, _ = FdiConfig().load()
    scenario = parse_scenario("duration: 300\nseed: 7\nwheels: {variation: true, spread: {viscous_friction: 0.3}}\n"
                              "faults: []\n")
    (_, samples, _), = simulated_runs([scenario])
    raw = observe(samples, weights).residual["model"][190:]
    calibrated = observe(samples, weights, calibration_samples=150).residual["model"][190:]
    assert np.abs(calibrated).max() < np.abs(raw).max() / 3
    x = regressors(samples.motor_torque, samples.friction_torque, samples.wheel_speed, samples.ripple_phasor,
                   samples.free_motor_torque)
    assert x.shape == (len(samples.time), len(samples.wheels), 6)   # every wheel of the set, s included
