"""Plant choices are one object: from the scenario, recorded, and refused when files were made under others."""
import numpy as np
import pytest

from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves, ThresholdError
from rw_fdi_ros.core.mission.plant_choices import DEFAULT, PlantChoices
from rw_fdi_ros.core.mission.scenario import ScenarioError, parse_scenario


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


def test_the_fdi_of_a_run_is_judged_under_the_same_choices_wherever_they_are_assembled(tmp_path):
    """Fitting on simulated runs (cli), fitting and replay on recorded bags (offline.plant_conditions),
    evaluating a bag (evaluate) and the running graph's isolation node: one PlantChoices, non-default
    plant choices and all."""
    from rosbags.typesys.stores.ros2_kilted import builtin_interfaces__msg__Time as Time
    from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__Header as Header
    from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__String as String

    from rw_fdi_ros.tools.design.samples import simulated_fault_free_runs
    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.runner.graph import graph_nodes
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.writer import BagWriter
    from rw_fdi_ros.tools.evaluation.evaluate import _check_bag
    from rw_fdi_ros.tools.design.offline import plant_conditions

    ref = tmp_path / "quiet.yaml"
    ref.write_text("name: quiet\nduration: 10.0\nseed: 4\n"
                   "plant: {wheel_momentum_coupling: false, emf_limit: pwm_saturation}\nfaults: []\n")
    scenario = load_scenario(str(ref))
    bag = tmp_path / "bag"   # what the plant node records of the run: its /scenario
    writer = BagWriter(bag)
    writer.add_topic(T.SCENARIO, "std_msgs/msg/String")
    writer.add_topic(T.FAULT_EFFECT, "geometry_msgs/msg/Vector3Stamped")
    writer.write_message(T.SCENARIO, 0, String(data=scenario.effective_text(scenario.plant_choices().scenario_dict())))
    writer.add_topic(T.PLANT_DONE, "std_msgs/msg/Header")   # a whole run: evaluation refuses an interrupted one
    writer.write_message(T.PLANT_DONE, 10 * 10**9, Header(stamp=Time(sec=10, nanosec=0), frame_id=""))
    writer.close()

    class Curves:   # what evaluate checks the bag's choices against: records them
        observer = "elman"

        def check_compatible(self, plant, origin=""):
            self.plant = plant

        def check_horizon(self, duration, origin=""):
            pass

    curves = Curves()
    _check_bag(bag, {"elman": curves})
    _, simulated = simulated_fault_free_runs(str(ref), range(0))
    isolation = next(n for n in graph_nodes(scenario, str(ref), None, fdi={}) if n.name == "isolation")
    running = PlantChoices(**{k: isolation.parameters[k] for k in DEFAULT.as_dict()})
    assert running.emf_limit == "pwm_saturation" and running.wheel_momentum_coupling is False
    assert curves.plant == PlantChoices(**plant_conditions([bag])) == PlantChoices(**simulated) == running


def _scenario_bag(path, plant: str):
    """A bag holding only what the plant node records first: its /scenario, under ``plant``."""
    from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__String as String

    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.writer import BagWriter
    ref = path.with_suffix(".yaml")
    ref.write_text(f"name: quiet\nduration: 10.0\nseed: 4\nplant: {plant}\nfaults: []\n")
    scenario = load_scenario(str(ref))
    writer = BagWriter(path)
    writer.add_topic(T.SCENARIO, "std_msgs/msg/String")
    writer.write_message(T.SCENARIO, 0, String(data=scenario.effective_text(scenario.plant_choices().scenario_dict())))
    writer.close()
    return path


def test_a_bag_recorded_under_other_plant_choices_is_skipped_by_name(tmp_path):
    """Training and fitting keep the plant most bags share and name each other bag."""
    from rw_fdi_ros.tools.design.offline import under_one_plant
    usual = [_scenario_bag(tmp_path / f"usual{i}", "{}") for i in range(2)]
    odd = _scenario_bag(tmp_path / "odd", "{emf_limit: pwm_saturation}")
    skipped = []
    kept = under_one_plant([usual[0], odd, usual[1]], skipped.append)
    assert kept == usual
    assert len(skipped) == 1 and str(odd) in skipped[0] and "pwm_saturation" in skipped[0]
    assert under_one_plant(usual, skipped.append) == usual and len(skipped) == 1
