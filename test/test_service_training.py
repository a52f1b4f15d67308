"""The Elman networks' training for service (tools/design/service_training.py): what a wheel's healthy running
stretches are, window by window."""
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.tools.benches import service_bench as sb
from rw_fdi_ros.tools.design.samples import FdiSamples
from rw_fdi_ros.tools.design.service_training import healthy_windows


def run(n: int, standby_until: int):
    """x, y, z running from the start; s at rest and unpowered until ``standby_until``, then running."""
    t = np.arange(n, dtype=float)
    tcv = np.ones((n, 4))
    torque = np.full((n, 4), 1e-3)
    tcv[:standby_until, 3] = torque[:standby_until, 3] = 0.0
    return FdiSamples(None, 1, t, tcv, torque, wheel_speed=np.zeros((n, 4)), ripple_phasor=np.zeros((n, 4), complex),
                      model_torque=np.full((n, 4), 0.9e-3), wheels=("x", "y", "z", "s"))


def test_a_faulty_wheel_from_its_onset_and_a_standby_wheel_are_left_out():
    fault = {"kind": "current_limiter", "wheel": "y", "onset": 250.0, "value": 0.7, "ramp": 0.0}
    draw = sb.Draw(1, 1000.0, False, False, (60.0, 120.0), 5.0, (fault,))
    windows = healthy_windows(draw, run(1000, standby_until=420), length=200)
    assert {a: len(w) for a, w in windows.items()} == {"x": 5, "y": 1, "z": 5, "s": 2}
    u, r, w, p, m = windows["s"][0]
    assert len(u) == 200 and u[0] == 1.0 and r[0] == 1e-3 and p.dtype == complex and m[0] == 0.9e-3   # running


def test_a_run_shorter_than_a_window_gives_none():
    draw = sb.Draw(2, 150.0, False, False, (60.0, 120.0), 5.0, ())
    assert healthy_windows(draw, run(150, standby_until=150), length=200) == {}


def test_a_network_of_the_model_error_that_learnt_nothing_is_the_model_observer(tmp_path):
    """A grey-box network (ElmanWeights.model_error) whose output is 0 estimates r_model exactly: its residuals
    are the model observer's, and its weights come back from the file as they went."""
    from rw_fdi_ros.core.fdi.elman import ElmanWeights, recall_series
    from rw_fdi_ros.core.fdi.observer_plugin import ObserverModels
    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.tools.design.offline import observe
    from rw_fdi_ros.tools.design.samples import simulated_samples
    rng = np.random.default_rng(0)
    w = ElmanWeights.random(rng, speed_scale=45.0, torque_scale=1e-3)
    w.w_ho[:] = 0.0
    w.b_o[:] = 0.0
    w.model_error = True
    w.save(tmp_path / "elman_x.npz")
    back = ElmanWeights.load(tmp_path / "elman_x.npz")
    assert back.model_error and np.array_equal(back.w_ih, w.w_ih)
    scenario = load_scenario("current_0p6_x").with_seed(61_000_700)
    samples = simulated_samples([scenario])[scenario.seed]
    run = observe(samples, ObserverModels({"x": back}))
    np.testing.assert_array_equal(run.residual["elman"], run.residual["model"])
    est = recall_series(back, samples.tcv[:, 0], samples.reaction_torque[0, 0], samples.wheel_speed[:, 0],
                        model_torque=samples.model_torque[:, 0])
    np.testing.assert_array_equal(est, samples.model_torque[:, 0])


def test_beyond_the_speeds_it_learnt_a_grey_box_is_the_nominal_model(tmp_path):
    """elman.speed_coverage: the bins of Omega its training held (COVERAGE_MIN samples each); outside them
    WheelRecall's estimate is r_model exactly (its state runs on), inside them r_model plus the network."""
    from rw_fdi_ros.core.fdi.elman import COVERAGE_BINS, COVERAGE_MIN, ElmanWeights, WheelRecall, speed_coverage
    scale = 50.0   # [rad/s]: bins of 1 rad/s
    trained = np.concatenate([np.full(COVERAGE_MIN, 20.5), np.full(COVERAGE_MIN - 1, 30.5), np.linspace(22, 28, 600)])
    coverage = speed_coverage(trained, scale)
    assert coverage.shape == (COVERAGE_BINS,)
    learnt = np.flatnonzero(coverage)
    assert learnt[0] == 70 and learnt[-1] == 77 and 80 not in learnt   # 20-28 rad/s; 30.5 held 29 samples
    w = ElmanWeights.random(np.random.default_rng(1), speed_scale=scale, torque_scale=1e-3, model_error=True,
                            speed_coverage=coverage)
    w.save(tmp_path / "elman_x.npz")
    back = ElmanWeights.load(tmp_path / "elman_x.npz")
    assert np.array_equal(back.speed_coverage, coverage) and back.covers(25.0) and not back.covers(-25.0)
    assert not back.covers(0.0) and not back.covers(60.0)
    recall = WheelRecall(back)
    model = 2e-4
    inside = recall.update(1.0, model, 25.0, model)
    assert inside != model
    assert recall.update(1.0, model, 0.3, model) == model      # through zero, never learnt
    assert recall.update(1.0, model, -24.0, model) == model    # the other direction
    assert recall.update(1.0, model, 24.0, model) != model
    older = ElmanWeights.random(np.random.default_rng(1), speed_scale=scale, torque_scale=1e-3, model_error=True)
    assert older.covers(0.0)   # a network without coverage (config/fdi/service): every speed, as before


@pytest.mark.graph
def test_the_service_trained_set_runs_in_the_graph_with_the_screens_verdict(tmp_path):
    """config/fdi/service's grey-box networks in the Elman nodes (the model torque from the FDI telemetry): the
    graph alarms the wheels and at the times the screen does."""
    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.fdi_config import FdiConfig
    from rw_fdi_ros.paths import config_dir
    from rw_fdi_ros.runner.fdi_run import run_with_fdi
    from rw_fdi_ros.tools.evaluation.screen import screen_runs
    from rw_fdi_ros.scoring.metrics import judge
    scenario = tmp_path / "loss_z.yaml"
    scenario.write_text("name: loss_z\nduration: 130.0\nseed: 61000901\n"
                        "faults: [{kind: current_limiter, wheel: z, onset: 50.0, value: 0.8}]\n")
    fdi = FdiConfig(models=str(config_dir() / "fdi" / "service"), fdir=False)
    graph = run_with_fdi(str(scenario), out_dir=tmp_path / "bags", fdi=fdi)
    assert graph.ok, graph.reason
    weights, curves = fdi.load()
    assert all(w.model_error for w in weights.values())
    screened = screen_runs([load_scenario(str(scenario))], weights, curves)[0]
    verdict = graph.summary["fdi"]
    assert [a for a, iv in verdict["elman"].items() if iv] == judge(screened, "elman")["alarmed_wheels"] == ["z"]
    first = verdict["elman"]["z"][0][0]
    assert first - 50.0 == pytest.approx(judge(screened, "elman")["axes"]["z"]["delay"])


def test_a_grey_box_whose_model_is_the_telemetry_learns_a_zero_correction(tmp_path):
    """Basilisk's HR16 wheel as a vehicle (examples/basilisk/hr16_sat.yaml) has no noise, ripple or back-EMF:
    the nominal model gives its torque to the bit, r - r_model is 0, and a target scale of 0 made the network
    non-finite (`defaults --vehicle` stopped at its stage 2). The grey box now learns nothing, finite, and its
    correction is exactly 0: its estimate is the model's."""
    from rw_fdi_ros.core.fdi.elman import ElmanObserver, ElmanWeights
    from rw_fdi_ros.tools.design.service_training import family_runs, train_type_network
    vehicle = (Path(__file__).parents[1] / "examples" / "basilisk" / "hr16_sat.yaml").resolve()
    runs = family_runs(range(61_000_000, 61_000_002), "datasheet", True, None, "hr16", vehicle=vehicle, act=False)
    assert all(not np.any(s.reaction_torque - s.model_torque) for _, s in runs)   # what makes this case
    card = train_type_network(runs, tmp_path, ("x", "y", "z"), epochs=2, units="datasheet")
    assert card["final_loss"] == 0.0
    weights = ElmanWeights.load(tmp_path / "elman_x.npz").validate()
    observer = ElmanObserver(weights)
    observer.reset(0.0)
    assert all(observer.update(u, None, w) == 0.0 for u, w in ((1.0, 50.0), (-3.0, 200.0), (5.0, 10.0)))


def test_a_fault_under_the_tachometers_noise_floor_is_said_invisible_not_missed():
    """Basilisk's HR16 reads speeds with sigma 0.01 rad/s: every threshold carries the noise's reach
    s / n = 3 sqrt(2) J sigma / (n T) above a band of 0, and a +30 C (a 5e-5 N m torque change) under it is
    physically invisible. The level left the floor out (0 N m) and counted such runs as observers' misses."""
    from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
    from rw_fdi_ros.core.physics.wheel import WheelParams
    from rw_fdi_ros.scoring.metrics import RunEval, observable, observable_level
    from rw_fdi_ros.tools.design.observer_check import invisible_why, why_missed
    from rw_fdi_ros.core.physics.faults import Fault
    curves = {obs: ThresholdCurves(obs, {a: np.zeros(1) for a in "xyz"}, window=40) for obs in ("model", "elman")}
    hr16 = WheelParams(inertia=0.0796, speed_noise=0.01)
    level = observable_level(curves, hr16)
    assert level["y"] == pytest.approx(3.0 * np.sqrt(2.0) * 0.0796 * 0.01 / 40, rel=1e-12)   # 8.44e-5 N m
    assert observable_level(curves) == {"x": 0.0, "y": 0.0, "z": 0.0}                          # exact speeds
    def run(peak):
        return RunEval(bag="b", scenario="s", seed=1, faults=[Fault("temperature", 1, 100.0, 53.0)], series={},
                       fault_effect_peak=np.array([0.0, peak, 0.0]), wheels=["x", "y", "z"])
    small, large = run(5.5e-5), run(2e-4)
    assert not observable(small, level) and observable(large, level)
    said = invisible_why([small], level)
    assert "at most 0.055 mN m" in said and "under the 0.0844 mN m" in said and "physically invisible" in said
    assert invisible_why([], level) is None
    seen = why_missed("linear", {"peak_over_band": 0.3, "seed": 1, "wheel": "x", "model_peak_over_band": 37.0})
    assert "invisible" not in seen and "A / (A - L C) = 0.25" in seen
