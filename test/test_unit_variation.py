"""Wheels that are not the datasheet: each unit's parameters drawn around Table 2.2 (scenario `wheels:`)."""
import re

import numpy as np
import pytest

from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.physics.plant import Plant
from rw_fdi_ros.core.mission.scenario import ScenarioError, parse_scenario
from rw_fdi_ros.core.physics.wheel import DEFAULT_UNIT_SPREAD, UNIT_PARAMETERS, WheelParams, friction_torque, net_torque

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

BASE = "duration: 30\nseed: {seed}\nfaults: []\n"


def scenario(seed=4, wheels=""):
    return parse_scenario(BASE.format(seed=seed) + (f"wheels: {wheels}\n" if wheels else ""))


def test_without_the_option_runs_stay_exactly_as_today():
    plain = scenario()
    assert plain.unit_scales() is None and "wheels" not in plain.effective_text()
    assert Plant(plain).wheel == WheelParams()
    ones = "{scale: {" + ", ".join(f"{n}: [1, 1, 1]" for n in UNIT_PARAMETERS) + "}}"
    a, b = simulate(plain, duration=30.0), simulate(scenario(wheels=ones), duration=30.0)
    for key in ("attitude", "wheel_speed", "tcv", "reaction_torque"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))


def test_units_are_drawn_from_the_seed_without_moving_the_other_draws():
    varied = scenario(wheels="{variation: true}")
    again = scenario(wheels="{variation: true}").unit_scales()
    assert all(np.array_equal(varied.unit_scales()[n], again[n]) for n in UNIT_PARAMETERS)
    assert not np.array_equal(varied.unit_scales()["driver_gain"],
                              scenario(seed=5, wheels="{variation: true}").unit_scales()["driver_gain"])
    ic_plain, ic_varied = scenario().draws()[0], varied.draws()[0]
    np.testing.assert_array_equal(ic_plain.wheel_speed, ic_varied.wheel_speed)
    np.testing.assert_array_equal(ic_plain.attitude, ic_varied.attitude)
    # one parameter's spread moves no other parameter's draw
    only = scenario(wheels="{spread: {viscous_friction: 0.2}}").unit_scales()
    np.testing.assert_array_equal(only["viscous_friction"], varied.unit_scales()["viscous_friction"])
    assert np.all(only["torque_constant"] == 1.0)


def test_drawn_units_have_the_documented_spreads():
    draws = {n: np.array([scenario(seed=s, wheels="{variation: true}").unit_scales()[n] for s in range(1500)])
             for n in UNIT_PARAMETERS}
    for name, spread in DEFAULT_UNIT_SPREAD.items():
        x = draws[name].ravel()
        assert abs(x.mean() - 1.0) < 4 * spread / np.sqrt(x.size)
        assert x.std() == pytest.approx(spread, rel=0.05)
        assert np.all(np.abs(x - 1.0) <= 3 * spread + 1e-12)


def test_a_unit_holds_its_speed_with_its_own_command_and_scales_its_torques():
    units = scenario(wheels="{scale: {torque_constant: [1.1, 1, 1], driver_gain: [1, 0.95, 1], "
                            "viscous_friction: [1, 1, 1.3], coulomb_friction: [0.8, 1, 1]}}")
    plant = Plant(units, wheels="orthogonal")
    w, base = plant.wheel_speed[0], WheelParams()
    friction = np.array([base.coulomb_friction * np.array([0.8, 1, 1]) * np.tanh(w / base.coulomb_smoothing_speed)
                         + 3.84e-4 * np.array([1, 1, 1.3]) * w]).ravel()
    hold = friction / (base.driver_gain * np.array([1, 0.95, 1]) * base.torque_constant * np.array([1.1, 1, 1]))
    np.testing.assert_allclose(plant.tcv[0], hold, rtol=1e-3)    # eq. 2.15 at 23 C: tau_v = 3.84e-4
    np.testing.assert_allclose(friction_torque(w, 23.0, plant.wheel)[0], friction, rtol=1e-3)
    op = type("Op", (), {"bus_voltage": 8.0, "current_limiter": 1.0, "temperature": 23.0})
    _, tau_m = net_torque(np.full((1, 3), 1.0), w[None], 0.0, op, plant.wheel)
    _, tau_nominal = net_torque(np.full(3, 1.0), w, 0.0, op, base)
    np.testing.assert_allclose(tau_m[0] / tau_nominal, [1.1, 0.95, 1.0], rtol=1e-12)


def test_the_recorded_scenario_redoes_the_same_units():
    from rw_fdi_ros.core.mission.scenario import UNIT_SCALE_RANGE, UNIT_SPREAD_MAX
    assert UNIT_SCALE_RANGE[0] <= 1 - 3 * UNIT_SPREAD_MAX and 1 + 3 * UNIT_SPREAD_MAX <= UNIT_SCALE_RANGE[1]
    widest = "{spread: {" + ", ".join(f"{n}: {UNIT_SPREAD_MAX}" for n in UNIT_PARAMETERS) + "}}"
    for seed in range(200):   # the widest spreads: some draws land near the 3-sigma cut
        varied = scenario(seed=seed, wheels=widest)
        again = parse_scenario(varied.effective_text())
        assert all(np.array_equal(varied.unit_scales()[n], again.unit_scales()[n]) for n in UNIT_PARAMETERS)


@pytest.mark.parametrize("wheels, words", [
    ("{variation: maybe}", "variation: true or false"),
    ("{spread: {gearbox: 0.1}}", "may set only torque_constant"),
    ("{spread: {viscous_friction: 0.9}}", "outside [0.0, 0.3]"),
    ("{scale: {driver_gain: [1, 1]}}", "list of 3 numbers"),
    ("{scale: {driver_gain: [1, 6, 1]}}", "outside [0.05, 5.0]"),
    ("[1, 2]", "a mapping of variation, spread and scale")])
def test_bad_wheel_specs_are_one_line_errors(wheels, words):
    with pytest.raises(ScenarioError, match=re.escape(words)):
        scenario(wheels=wheels)


def test_a_run_records_its_units_in_the_scenario_and_the_ground_truth(tmp_path):
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import read_bag
    from rw_fdi_ros.runner.scenario_run import run_scenario
    path = tmp_path / "varied.yaml"
    path.write_text("name: varied\nduration: 10\nseed: 4\nwheels: {variation: true}\nfaults: []\n")
    outcome = run_scenario(str(path), out_dir=tmp_path)
    assert outcome.ok, outcome.reason
    data = read_bag(outcome.bag, topics=[T.SCENARIO, T.FAULT_TRUTH])
    units = parse_scenario(data.scenario_text).unit_scales()
    truth = {s.hardware_id: {kv.key: float(kv.value) for kv in s.values if kv.key in (
        "torque_constant", "driver_gain", "viscous_friction_scale", "coulomb_friction")}
        for s in data.topic(T.FAULT_TRUTH)[-1][1].status}
    drawn = parse_scenario(path.read_text()).unit_scales()
    base = WheelParams()
    for i, axis in enumerate("xyz"):
        assert units["torque_constant"][i] == drawn["torque_constant"][i]
        t = truth[f"reaction_wheel_{axis}"]
        assert t["torque_constant"] == base.torque_constant * drawn["torque_constant"][i]
        assert t["driver_gain"] == base.driver_gain * drawn["driver_gain"][i]
        assert t["viscous_friction_scale"] == drawn["viscous_friction"][i]
        assert t["coulomb_friction"] == base.coulomb_friction * drawn["coulomb_friction"][i]
