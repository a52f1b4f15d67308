"""The FDI configuration: one type, one rule for its paths, every check in one place (rw_fdi_ros/fdi_config.py)."""
import shutil

import pytest

from rw_fdi_ros.core.fdi.elman import ModelError
from rw_fdi_ros.core.mission.plant_choices import DEFAULT
from rw_fdi_ros.core.fdi.threshold_file import ThresholdError
from rw_fdi_ros.fdi_config import FdiConfig
from rw_fdi_ros.paths import fdi_dir, thresholds_dir


def test_the_paths_follow_one_rule(tmp_path):
    """Shipped models and thresholds by default (calibrated bands when the observers learn their wheel); given
    models bring their own thresholds unless thresholds are given too."""
    assert FdiConfig().models_dir == fdi_dir("speed_aware") == FdiConfig().thresholds_dir
    assert FdiConfig("thesis").models_dir == fdi_dir("thesis")
    assert FdiConfig(unit_calibration=150.0).thresholds_dir == thresholds_dir("speed_aware", 150.0)
    assert FdiConfig(models=str(tmp_path)).thresholds_dir == tmp_path
    other = tmp_path / "other"
    given = FdiConfig(models=str(tmp_path), thresholds=str(other))
    assert given.threshold_path("model") == other / "thresholds_model.json"


@pytest.mark.parametrize("fields, words", [
    ({"method": "kalman"}, "fdi_method must be one of"), ({"persistence": 0}, "persistence must be"),
    ({"persistence": 1001}, "persistence must be"), ({"persistence": 2.5}, "persistence must be"),
    ({"unit_calibration": -1.0}, "--unit-calibration must be"), ({"unit_calibration": float("nan")}, "must be"),
    ({"method": "thesis", "unit_calibration": 150.0}, "needs --fdi-method speed_aware")])
def test_a_value_out_of_range_is_one_line(fields, words):
    with pytest.raises(ValueError, match=words) as caught:
        FdiConfig(**fields)
    assert "\n" not in str(caught.value)


def test_a_mapping_and_a_config_are_the_same_config():
    config = FdiConfig.of({"method": "thesis", "persistence": 4, "models": None})
    assert config == FdiConfig(method="thesis", persistence=4) and FdiConfig.of(config) is config
    assert FdiConfig.of(None) == FdiConfig() and FdiConfig.of(config.as_dict()) == config


def test_the_shipped_sets_load_and_pass_every_check():
    for config in (FdiConfig(), FdiConfig("thesis"), FdiConfig(unit_calibration=150.0)):
        weights, curves = config.load()
        assert set(curves) == set(config.observers) and len(weights) == 3
        config.check(DEFAULT, 400.0)


def test_files_of_another_method_or_calibration_are_refused_naming_the_file(tmp_path):
    mixed = tmp_path / "mixed"
    shutil.copytree(fdi_dir("speed_aware"), mixed, ignore=shutil.ignore_patterns("thesis", "unit_calibrated"))
    with pytest.raises(ModelError, match="not a network for fdi_method='thesis'"):
        FdiConfig("thesis", models=str(mixed)).load_models()
    with pytest.raises(ThresholdError, match="unit_calibration_time=150"):
        FdiConfig(models=str(mixed), unit_calibration=150.0).load_thresholds()
    with pytest.raises(ThresholdError, match="not shorter than the 100 s run"):
        FdiConfig(unit_calibration=150.0).check(DEFAULT, 100.0)
    assert FdiConfig("thesis", models=str(mixed)).following_models().method == "speed_aware"


def test_the_screens_load_fdi_is_the_configs_load():
    """`screen.load_fdi(models, thresholds, method, unit_calibration)` (what scripts call) is FdiConfig's load."""
    from rw_fdi_ros.tools.evaluation.screen import load_fdi
    _, curves = load_fdi(method="speed_aware", unit_calibration=150.0)
    assert curves["model"].unit_calibration_time == 150.0
    assert set(load_fdi(method="thesis")[1]) == set(FdiConfig("thesis").observers) == {"elman", "linear"}
