"""The speed-aware FDI's pieces against closed-form answers (telemetry, residuals, threshold_fit, isolation)."""
import numpy as np
import pytest

from rw_fdi_ros.core.physics import wheel as wm
from rw_fdi_ros.core.fdi.residuals import SignedResidual
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
from rw_fdi_ros.core.fdi.threshold_fit import fit_band, gumbel_fit, gumbel_quantile, run_statistic
from rw_fdi_ros.core.fdi.verdict import ObserverChannel
from rw_fdi_ros.core.physics.plant import Plant
from rw_fdi_ros.core.mission.scenario import Fault, Scenario, parse_scenario
from rw_fdi_ros.core.fdi.telemetry import TelemetrySampler, model_reaction_torque
from rw_fdi_ros.scoring.metrics import wilson


def drive(plant, steps, tcv_of_k):
    """Control-rate samples (stamp_ns, tcv, reaction torque, speed) of a plant under a command law."""
    rows = []
    s = plant.sample()
    for k in range(steps + 1):
        rows.append((int(round(s.time * 1e9)), s.tcv[0].copy(), s.reaction_torque[0].copy(), s.wheel_speed[0].copy()))
        if k < steps:
            s = plant.step(tcv_of_k(k)[None])
    return rows


def test_model_torque_is_the_healthy_wheel_without_ripple_and_noise():
    wheel = wm.WheelParams(ripple_amplitude_share=0.0, noise_angle=0.0)
    plant = Plant(Scenario("s", duration=60.0, seed=3), wheel=wheel, disturbance=False, wheels="orthogonal")
    rng = np.random.default_rng(0)
    for stamp, u, r, w in drive(plant, 300, lambda k: rng.uniform(-4, 4, 3)):
        np.testing.assert_allclose(model_reaction_torque(u, w, wheel)[0], r, rtol=0, atol=1e-15)


def test_ripple_bound_of_a_steady_wheel_is_the_dirichlet_kernel():
    """Constant u and Omega: the FDI samples' phasors are p_k = A e^{i k psi} with
    A = tau_m |sin(m phi / 2) / (m sin(phi / 2))| (m control samples each, phi per control sample,
    psi = m phi), so every partial sum is A |sin(j psi / 2) / sin(psi / 2)| and the bound is
    A max_j |sin(j psi / 2) / sin(psi / 2)| / n (residuals.ripple_reach)."""
    omega, u, dt, n_fdi, per = 25.3, 2.0, 0.1, 40, 10
    sampler, residual = TelemetrySampler(1.0), SignedResidual(n_fdi, share=1.0, ripple_gain_max=1.0)
    for k in range(n_fdi * per + 1):
        sample = sampler.add(int(round(k * dt * 1e9)), np.full(3, u), np.zeros(3), np.full(3, omega))
        if sample is not None:
            _, bound = residual.update(0.0, 0.0, sample.ripple_phasor[0])
    tau_m = wm.WheelParams().torque_constant * wm.WheelParams().driver_gain * u
    phi = wm.WheelParams().poles * omega * dt
    psi = per * phi
    amplitude = tau_m * abs(np.sin(per * phi / 2) / (per * np.sin(phi / 2)))
    # the window holds FDI samples 1..40 of the 41 (the first, at t = 0, left it)
    reach = amplitude * max(abs(np.sin(j * psi / 2) / np.sin(psi / 2)) for j in range(n_fdi + 1))
    assert bound == pytest.approx(reach / n_fdi, rel=1e-9)
    # a constant gain alone would give the whole window's Dirichlet kernel, never more than the reach
    n = n_fdi * per
    assert bound >= tau_m * abs(np.sin(n * phi / 2) / (n * np.sin(phi / 2))) - 1e-15


@pytest.mark.parametrize("speed", [27.925, 26.3])   # 16 x 2 pi / (36 x 0.1 s), and between aliases
def test_ripple_in_the_residual_never_exceeds_its_bound(speed):
    """A healthy wheel with ripple +60 % holding at an alias speed: |signed residual| <= bound all along."""
    scenario = parse_scenario(f"duration: 200\ninitial: {{attitude_deg: [0, 0, 0], body_rate: [0, 0, 0], "
                              f"wheel_speed: [{speed}, {speed}, {speed}]}}\nsetpoints: []\n"
                              f"faults: [{{kind: ripple_gain, wheel: x, onset: 0, value: 1.6}}]\n")
    plant = Plant(scenario, disturbance=False, wheels="orthogonal")
    hold = plant.tcv[0].copy()
    sampler, filters = TelemetrySampler(1.0), [SignedResidual() for _ in range(3)]
    worst = 0.0
    for stamp, u, r, w in drive(plant, 2000, lambda k: hold):
        sample = sampler.add(stamp, u, r, w)
        if sample is not None:
            for f, ri, mi, pi in zip(filters, sample.reaction_torque, sample.model_torque, sample.ripple_phasor):
                res, bound = f.update(ri, mi, pi)
                worst = max(worst, abs(res) - bound)
    assert worst < 2e-5     # torque noise (eq. 2.16, 1.5e-5 N m) is all that is left


def test_a_current_loss_rises_far_above_the_bound():
    scenario = Scenario("c", duration=120.0, seed=8, setpoints=(),
                        faults=(Fault("current_limiter", 1, 20.0, 0.9),))
    plant = Plant(scenario, disturbance=False, wheels="orthogonal")
    hold = plant.tcv[0].copy()
    sampler, f = TelemetrySampler(1.0), SignedResidual()
    last = None
    for stamp, u, r, w in drive(plant, 1200, lambda k: hold):
        sample = sampler.add(stamp, u, r, w)
        if sample is not None:
            last = f.update(sample.reaction_torque[1], sample.model_torque[1], sample.ripple_phasor[1])
    tau_m = wm.WheelParams().torque_constant * wm.WheelParams().driver_gain * abs(hold[1])
    # 10 % of the motor torque, give or take what ripple (the bound at g_max = 2) and noise may add
    assert abs(abs(last[0]) - 0.1 * tau_m) <= last[1] / 2 + 2e-5
    assert abs(last[0]) > 2 * last[1]


def test_run_statistic_is_the_level_the_persistence_rule_crosses():
    excess = np.array([[0.1], [0.5], [0.4], [0.9], [0.2], [0.6], [0.7], [0.65]])
    assert run_statistic(excess, 1)[0] == 0.9
    assert run_statistic(excess, 3)[0] == 0.6     # samples 6-8: min(0.6, 0.7, 0.65)
    assert run_statistic(excess[:2], 3)[0] == -np.inf


def test_gumbel_band_gives_the_designed_rate_on_new_runs():
    rng = np.random.default_rng(11)
    mu, beta = 2e-4, 3e-5
    fit = rng.gumbel(mu, beta, size=(300, 3))
    bands = fit_band(fit, false_alarm_rate=0.003)
    m, b = gumbel_fit(fit[:, 0])
    assert m == pytest.approx(mu, rel=0.05) and b == pytest.approx(beta, rel=0.2)
    # runs far below the tail (a large bound all run long) must not widen the fit
    low = np.concatenate([fit[:, 0], np.full(40, mu - 50 * beta)])
    assert gumbel_fit(low)[1] == pytest.approx(b, rel=0.35)
    new = rng.gumbel(mu, beta, size=(400_000, 3))
    any_axis = np.any(new > np.array([bands[a]["band"] for a in "xyz"]), axis=1).mean()
    assert 0.0015 < any_axis < 0.006   # designed 0.003 (the band never sits below a fitting run's maximum)
    assert gumbel_quantile(0.0, 1.0, np.exp(-1.0)) == pytest.approx(0.0, abs=1e-12)


def test_wilson_interval_known_values():
    lo, hi = wilson(0, 1000)
    assert lo == 0.0 and hi == pytest.approx(0.00383, abs=2e-5)
    lo, hi = wilson(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-3) and hi == pytest.approx(0.5962, abs=1e-3)


def test_channel_compares_magnitude_with_band_plus_bound():
    curves = ThresholdCurves("linear", {a: np.array([1.0]) for a in "xyz"}, method="speed_aware", persistence=2)
    ch = ObserverChannel("linear", curves)
    rows = ch.update(10**9, [-1.5, 0.5, 1.5], [0.0, 0.0, 1.0])
    assert rows["x"][:3] == (-1.5, 1.0, False) and rows["z"][1] == 2.0
    rows = ch.update(2 * 10**9, [-1.5, 0.5, 1.5], [0.0, 0.0, 1.0])
    assert rows["x"][2] and rows["x"][3] == 2.0 and not rows["y"][2] and not rows["z"][2]


def test_ripple_reach_bounds_every_monotone_gain_and_no_less():
    """|sum g_k p_k| <= reach(p) for any g in [0, 1] monotone across the window; a step in g can
    exceed |sum p_k| (what a constant-gain bound covers), and the reach is attained by a step."""
    from rw_fdi_ros.core.fdi.residuals import ripple_reach
    rng = np.random.default_rng(3)
    for _ in range(200):
        p = np.exp(1j * np.cumsum(rng.uniform(0.0, 0.4, 40))) * rng.uniform(0.5, 1.0, 40)
        reach = ripple_reach(p)
        assert reach >= abs(p.sum()) - 1e-12
        for g in (np.sort(rng.uniform(0, 1, 40)), np.sort(rng.uniform(0, 1, 40))[::-1], np.full(40, 0.7)):
            assert abs((g * p).sum()) <= reach + 1e-12
        steps = [abs(p[j:].sum()) for j in range(41)] + [abs(p[:j].sum()) for j in range(41)]
        assert max(steps) == pytest.approx(reach, rel=1e-12)
    p = np.exp(1j * np.linspace(0, 2 * np.pi, 40, endpoint=False))   # a full turn: the sum cancels
    assert abs(p.sum()) < 1e-12 and ripple_reach(p) > 10.0


def test_a_band_is_fitted_only_from_enough_runs_for_the_rate_it_promises():
    """One or two runs cannot carry a 1e-3 band (issue 39): the Gumbel tail reaches at most EXTRAPOLATION times
    beyond 1/n, so 1e-3 per run needs 60 runs for an Elman band (half of alpha) and 30 for the model's."""
    from rw_fdi_ros.core.fdi.threshold_file import ThresholdError
    from rw_fdi_ros.core.fdi.threshold_fit import fitting_runs_needed
    assert fitting_runs_needed(1e-3, share=0.5) == 60 and fitting_runs_needed(1e-3) == 30
    assert fitting_runs_needed(0.5) == 10   # never fewer than MIN_FIT_RUNS
    stats = np.random.default_rng(3).gumbel(2e-4, 3e-5, size=(29, 3))
    with pytest.raises(ThresholdError, match=r"29 fitting run\(s\) cannot promise .* at least 30 fault-free runs"):
        fit_band(stats, false_alarm_rate=1e-3)
    assert set(fit_band(np.vstack([stats, stats[:1]]), false_alarm_rate=1e-3)) == {"x", "y", "z"}


def test_a_tachometers_noise_telescopes_in_the_window_and_its_reach_bounds_it():
    """Torques derived from noisy speeds, r_k = -J (Omega_k - Omega_(k-1)) / T: the window's mean carries
    sqrt(2) J sigma / (n T) of the noise whatever the window (closed form), and the bound's s / n covers it at
    3 sigma (residuals.speed_noise_reach)."""
    from rw_fdi_ros.core.fdi.residuals import speed_noise_reach
    from rw_fdi_ros.core.fdi.wheel_reports import speed_noise
    wheel = wm.WheelParams(inertia=0.08, speed_noise=0.01)
    reach = speed_noise_reach(wheel, 1.0)
    assert reach == pytest.approx(3.0 * np.sqrt(2.0) * 0.08 * 0.01)
    assert speed_noise_reach(wm.WheelParams(), 1.0) == 0.0   # exact speeds: the bound as before
    rng = np.random.default_rng(3)
    runs, n = 4000, 40
    speeds = 100.0 + rng.normal(0.0, 0.01, (runs, n + 1))
    torque = -0.08 * np.diff(speeds, axis=1)                  # T = 1 s, the healthy torque 0
    window_means = torque.mean(axis=1)
    assert np.std(window_means) == pytest.approx(np.sqrt(2.0) * 0.08 * 0.01 / n, rel=0.05)
    f = SignedResidual(window=n, share=0.0, noise_reach=reach)
    rows = [f.update(r, 0.0, 0j) for r in torque[0]]
    assert rows[0][1] == pytest.approx(reach) and rows[-1][1] == pytest.approx(reach / n)
    bounds = np.array([reach / k for k in range(1, n + 1)])
    means = np.cumsum(torque, axis=1) / np.arange(1, n + 1)
    assert np.mean(np.abs(means) > bounds) < 0.005            # 3 sigma: 0.27 % two-sided
    # the check's estimate of sigma from the speeds' second differences
    t = np.arange(2000) * 0.1
    assert speed_noise(t, 50.0 + 0.3 * t + rng.normal(0.0, 0.01, t.size)) == pytest.approx(0.01, rel=0.1)


def test_the_bus_grid_is_the_period_mean_of_each_control_samples_grid():
    """The FDI sample's bus grid (computed where it is read, telemetry.PeriodBusGrid) is the mean over the
    period's control samples of tau_m(u_k, Omega_k; V) at every V of the grid, wheel by wheel and for the
    whole set alike, summed in the samples' order (FdiSampler's mean, bit for bit)."""
    from rw_fdi_ros.core.fdi.identification import bus_motor_torque
    rng = np.random.default_rng(4)
    sampler = TelemetrySampler(1.0, identification=True)
    u, w = rng.uniform(-5.0, 5.0, (10, 4)), rng.uniform(5.0, 60.0, (10, 4))
    for k in range(10):
        sample = sampler.add((k + 1) * 100_000_000, u[k], np.zeros(4), w[k])
    grids = bus_motor_torque(u, w)                      # (10, 4, G), each control sample's
    expected = grids[0]
    for g in grids[1:]:
        expected = expected + g
    expected = expected / 10
    whole = np.asarray(sample.bus_motor_torque)
    assert whole.shape == (4, len(grids[0, 0])) and np.array_equal(whole, expected)
    assert np.array_equal(np.asarray(sample.bus_motor_torque[2]), expected[2])
    assert not np.allclose(expected[2], expected[2][0])    # the grid's low voltages clip: a grid, not a value
    assert sample.bus_motor_torque.shape == whole.shape and sample.bus_motor_torque[2].shape == whole[2].shape
    with pytest.raises(TypeError):
        sample.bus_motor_torque[1:3]
