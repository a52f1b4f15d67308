"""Plant choices are one object: from the scenario, recorded, and refused when files were made under others."""
import numpy as np
import pytest

from rw_fdi_ros.core.detection import ThresholdCurves, ThresholdError
from rw_fdi_ros.core.plant_choices import DEFAULT, PlantChoices
from rw_fdi_ros.core.scenario import ScenarioError, parse_scenario


def test_scenario_sets_wheel_momentum_coupling_and_overrides_win():
    s = parse_scenario("plant: {wheel_momentum_coupling: false}\nfaults: []\n")
    assert s.plant_choices().wheel_momentum_coupling is False
    assert s.plant_choices(emf_limit="pwm_saturation").emf_limit == "pwm_saturation"
    assert parse_scenario("faults: []\n").plant_choices() == DEFAULT and DEFAULT.wheel_momentum_coupling
    text = s.effective_text(s.plant_choices().scenario_dict())
    assert "wheel_momentum_coupling: false" in text and "emf_limit: kf_scaled" in text


@pytest.mark.parametrize("plant, words", [
    ("{wheel_momentum_coupling: maybe}", "wheel_momentum_coupling must be true or false"),
    ("{emf_limit: magic}", "emf_limit must be one of"),
    ("{gravity: 1}", "plant may set only")])
def test_bad_plant_choices_are_one_line_scenario_errors(plant, words):
    with pytest.raises(ScenarioError, match=words):
        parse_scenario(f"plant: {plant}\nfaults: []\n", origin="my.yaml")


def test_files_without_the_coupling_key_were_made_without_it():
    """Curves fitted before the choice existed were fitted under eq. 2.27 alone: refused by default."""
    legacy = ThresholdCurves("elman", {a: np.ones(3) for a in "xyz"},
                             plant={"emf_limit": "kf_scaled", "control_period": 0.1})
    assert PlantChoices.from_recorded(legacy.plant).wheel_momentum_coupling is False
    with pytest.raises(ThresholdError, match="fitted with wheel_momentum_coupling=False but the graph runs "
                                             "wheel_momentum_coupling=True"):
        legacy.check_compatible(DEFAULT)
    legacy.check_compatible(DEFAULT.with_(wheel_momentum_coupling=False))
