"""Residual filter, threshold fitting and the persistence rule against hand-made answers."""
import json

import numpy as np
import pytest

from rw_fdi_ros.fdi_config import FdiConfig

from rw_fdi_ros.core.fdi.detection import AlarmRule, alarm_series
from rw_fdi_ros.core.fdi.residuals import ResidualFilter, residual_series
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves, ThresholdError
from rw_fdi_ros.core.fdi.threshold_fit import fit_threshold_curve


def test_residual_is_a_causal_moving_average_of_the_absolute_error():
    f = ResidualFilter(window=3)
    got = [f.update(a, 0.0) for a in [1.0, -2.0, 3.0, -4.0, 5.0]]
    assert got == pytest.approx([1.0, 1.5, 2.0, 3.0, 4.0])
    series = residual_series(np.array([[1.0], [-2.0], [3.0], [-4.0], [5.0]]), np.zeros((5, 1)), window=3)
    assert series[:, 0] == pytest.approx(got)


def test_threshold_curve_on_synthetic_residuals_with_known_mean_and_sigma():
    t = np.arange(100)
    mean, sigma = 1e-3 + 1e-5 * t, 2e-4 * (1 + np.sin(t / 10) ** 2)
    z = np.random.default_rng(0).normal(size=(100, 100))
    z = (z - z.mean(axis=0)) / z.std(axis=0)          # exactly mean 0, std 1 per time index
    curve = fit_threshold_curve(mean + sigma * z)
    np.testing.assert_allclose(curve, mean + 3 * sigma, rtol=1e-12)


@pytest.mark.parametrize("above, persistence, alarms", [
    ("0011101111000", 3, "0000100011000"),
    ("0011101111000", 1, "0011101111000"),
    ("0101010101010", 2, "0000000000000"),
    ("1111111111111", 5, "0000111111111"),
])
def test_persistence_rule_on_hand_made_sequences(above, persistence, alarms):
    residual = np.array([2.0 if c == "1" else 0.5 for c in above])
    flags, first = alarm_series(residual, np.ones(len(residual)), np.arange(len(residual)) * 1.0, persistence)
    assert "".join("1" if f else "0" for f in flags) == alarms
    assert first == (alarms.index("1") if "1" in alarms else None)


def test_equal_to_threshold_is_not_above():
    rule = AlarmRule(1)
    assert not rule.update(1.0, 1.0, 0.0) and rule.update(1.0 + 1e-12, 1.0, 1.0)


def test_threshold_file_roundtrip_and_errors(tmp_path):
    c = ThresholdCurves("elman", {a: np.linspace(1, 2, 5) for a in "xyz"}, seeds=[1, 2],
                        plant={"emf_limit": "kf_scaled", "control_period": 0.1, "fdi_period": 1.0})
    c.save(tmp_path / "t.json")
    back = ThresholdCurves.load(tmp_path / "t.json")
    assert back.at("y", 2) == pytest.approx(1.5) and back.at("y", 99) == pytest.approx(2.0)
    back.check_compatible({"emf_limit": "kf_scaled", "control_period": 0.1})
    with pytest.raises(ThresholdError, match="emf_limit='kf_scaled' but the graph runs emf_limit='pwm_saturation'.*"
                                             "rw-fdi fit-thresholds"):
        back.check_compatible({"emf_limit": "pwm_saturation"})
    with pytest.raises(ThresholdError, match="threshold file not found.*rw-fdi fit-thresholds"):
        ThresholdCurves.load(tmp_path / "nope.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ThresholdError, match="not a readable threshold file"):
        ThresholdCurves.load(tmp_path / "bad.json")
    raw = json.loads((tmp_path / "t.json").read_text())
    raw["curves"]["z"] = [float("nan")]
    (tmp_path / "nan.json").write_text(json.dumps(raw))
    with pytest.raises(ThresholdError, match="needs a finite curve for each wheel"):
        ThresholdCurves.load(tmp_path / "nan.json")


def test_curves_that_cannot_judge_the_run_are_refused(tmp_path):
    """Issue 15: a 3-sample thesis curve held its start-up value for ever and hid a 40 % current loss; a
    negative one alarms at once. Both are refused, naming the file; a speed-aware band holds at any time."""
    from rw_fdi_ros.core.fdi.verdict import ObserverChannel
    short = ThresholdCurves("elman", {a: np.array([3e-3, 2e-3, 1e-3]) for a in "xyz"})
    short.save(tmp_path / "short.json")
    loaded = ThresholdCurves.load(tmp_path / "short.json")
    assert loaded.horizon == 2.0
    loaded.check_horizon(2.0)
    with pytest.raises(ThresholdError, match=r"short.json: the curves cover 0-2 s but the run lasts 400 s"):
        loaded.check_horizon(400.0, origin=str(tmp_path / "short.json"))
    channel = ObserverChannel("elman", loaded)
    channel.update(2_000_000_000, [0.0] * 3)
    assert not channel.beyond_horizon
    channel.update(3_000_000_000, [0.0] * 3)
    assert channel.beyond_horizon   # the isolation node reports STALE from here, never OK
    negative = ThresholdCurves("linear", {"x": np.array([1e-3, -1e-4]), "y": np.ones(2), "z": np.ones(2)})
    negative.save(tmp_path / "negative.json")
    with pytest.raises(ThresholdError, match=r"negative.json: curve x has negative values.*sample 1"):
        ThresholdCurves.load(tmp_path / "negative.json")
    band = ThresholdCurves("linear", {a: np.array([-2e-5]) for a in "xyz"}, method="speed_aware")
    band.save(tmp_path / "band.json")
    assert ThresholdCurves.load(tmp_path / "band.json").horizon == float("inf")   # c < 0 is a valid band


def test_curves_are_refused_in_another_observer_slot():
    """The shipped model observer's band (~4e-6 N m) on the Luenberger observer's residual (band ~2e-3)
    would alarm on every run: a file is used only for the observer it was fitted for."""
    from rw_fdi_ros.core.fdi.detection import OBSERVERS, observers_of
    from rw_fdi_ros.paths import config_dir
    shipped = config_dir() / "fdi"
    for obs in observers_of("speed_aware"):
        assert ThresholdCurves.load(shipped / f"thresholds_{obs}.json", obs).observer == obs
    with pytest.raises(ThresholdError, match=r"thresholds_model.json: curves of the model observer, not of the "
                                             r"linear observer; regenerate"):
        ThresholdCurves.load(shipped / "thresholds_model.json", "linear")
    assert OBSERVERS == ("elman", "linear", "model") and observers_of("thesis") == ("elman", "linear")
    with pytest.raises(ValueError, match="fdi_method must be one of"):
        observers_of("kalman")


def test_fitting_runs_of_different_lengths_are_refused(tmp_path):
    from rw_fdi_ros.tools.design.offline import fit_thresholds
    from rw_fdi_ros.tools.design.samples import FdiSamples
    def run(n, seed):
        z = np.zeros((n, 3))
        return FdiSamples(bag=None, seed=seed, time=np.arange(n, dtype=float), tcv=z, reaction_torque=z)
    weights, _ = FdiConfig("thesis").load()
    with pytest.raises(ThresholdError, match="different lengths \\(3 to 401 FDI samples; shortest: 2\\)"):
        fit_thresholds([run(401, 1), run(3, 2)], weights, tmp_path, plant={"emf_limit": "kf_scaled"})


def test_signed_residuals_of_four_wheels_need_no_gains():
    """The series of a four-wheel set (the standby s beside x, y, z): kappa defaults to 0 for every wheel, and a
    constant error e gives the residual e once the window is full, whatever the wheel count."""
    from rw_fdi_ros.core.fdi.residuals import signed_residual_series
    n = 60
    actual, estimate = np.full((n, 4), 2e-4), np.zeros((n, 4))
    res, bound = signed_residual_series(actual, estimate, np.zeros((n, 4), complex))
    assert res.shape == bound.shape == (n, 4)
    np.testing.assert_allclose(res[-1], 2e-4)
