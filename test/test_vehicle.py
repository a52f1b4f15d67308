"""The vehicle as data (core/mission/vehicle.py): the shipped file is the thesis' spacecraft, a full inertia moves the
body as Euler's equations say, a vehicle file flies through scenarios, the core loop and the launcher, and a bad
file or a vehicle that cannot fly gets one line naming the field."""
import copy
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.fdi_config import FdiConfig
import yaml

from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.controller_design import design_controller
from rw_fdi_ros.core.physics.magnetorquers import MomentumDumping
from rw_fdi_ros.core.physics.plant import Plant
from rw_fdi_ros.core.fdir import slew_excursion
from rw_fdi_ros.core.mission.plant_choices import PlantChoiceError, PlantChoices
from rw_fdi_ros.core.mission.scenario import Scenario, ScenarioError, parse_scenario
from rw_fdi_ros.core.physics.spacecraft import DISTURBANCE_SIGMA, INERTIA, body_acceleration
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves, ThresholdError
from rw_fdi_ros.core.mission.vehicle import (THESIS, Dispersions, VehicleError, load_vehicle, shipped_vehicles,
                                             to_mapping, vehicle_of)
from rw_fdi_ros.core.physics.wheel import DEFAULT_UNIT_SPREAD, WheelParams
from rw_fdi_ros.core.physics.wheel_set import WHEEL_SETS
from rw_fdi_ros.paths import fdi_dir


def _rotation(roll, pitch, yaw):
    """R = Rz(yaw) Ry(pitch) Rx(roll) [deg]."""
    a, b, c = np.radians([roll, pitch, yaw])
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_the_shipped_default_is_the_thesis_spacecraft():
    v = load_vehicle()
    assert v.name == "maksat" and "maksat" in shipped_vehicles()
    assert v == THESIS   # the file and the code's constants: one vehicle
    np.testing.assert_array_equal(v.body_inertia, INERTIA)          # Table 2.3, diagonal: the exact fast path
    assert v.wheel == WheelParams()                                   # Table 2.2
    assert v.wheel_set == WHEEL_SETS["orthogonal_skew"]              # the skew axis exactly (1, 1, 1)/sqrt(3)
    assert v.magnetorquers == MomentumDumping()
    assert v.disturbance_sigma == DISTURBANCE_SIGMA
    assert v.dispersions == Dispersions() and v.dispersions.unit_spreads == DEFAULT_UNIT_SPREAD
    assert (v.controller.overshoot, v.controller.settling_time, v.controller.pointing) == (0.2, 30.0, 0.2)
    assert not v.controller.friction_feedforward   # the thesis' PID integrators hold the friction


@pytest.mark.parametrize("name", sorted(shipped_vehicles()))
def test_a_vehicle_reads_back_from_what_it_writes(name):
    v = load_vehicle(name)
    assert vehicle_of(yaml.safe_load(yaml.safe_dump(to_mapping(v)))) == v   # sorted keys: the order is a list's


def test_a_full_inertia_is_eulers_equations_in_the_principal_frame():
    """I = R D R^T: in body axes dw/dt = R (Euler's equations of D for R^T w, R^T tau, R^T h)."""
    rot = _rotation(20.0, -35.0, 50.0)
    principal = np.array([12.0, 15.0, 22.0])
    inertia = rot @ np.diag(principal) @ rot.T
    w, tau, h = np.array([0.01, -0.02, 0.03]), np.array([1e-3, 2e-3, -1e-3]), np.array([0.1, 0.05, -0.2])
    spun = 0.0077 * np.eye(3)   # isotropic: the same in either frame
    body = body_acceleration(w, tau, inertia, wheel_momentum=h, wheel_inertia=spun)
    frame = body_acceleration(w @ rot, tau @ rot, principal, wheel_momentum=h @ rot,
                              wheel_inertia=np.full(3, 0.0077)) @ rot.T
    np.testing.assert_allclose(body, frame, rtol=1e-12, atol=1e-18)
    # spin about a principal axis that is not a body axis: steady, torque free
    for k in range(3):
        np.testing.assert_allclose(body_acceleration(0.2 * rot[:, k], np.zeros(3), inertia), 0.0, atol=1e-15)


def test_a_full_inertia_conserves_momentum_and_energy_torque_free():
    rot = _rotation(10.0, 25.0, -40.0)
    inertia = rot @ np.diag([12.0, 15.0, 22.0]) @ rot.T
    w, dt = np.array([0.01, 0.02, -0.015]), 0.05
    h0, e0 = np.linalg.norm(inertia @ w), 0.5 * w @ inertia @ w
    for _ in range(2000):   # RK4
        k1 = body_acceleration(w, np.zeros(3), inertia)
        k2 = body_acceleration(w + dt / 2 * k1, np.zeros(3), inertia)
        k3 = body_acceleration(w + dt / 2 * k2, np.zeros(3), inertia)
        k4 = body_acceleration(w + dt * k3, np.zeros(3), inertia)
        w = w + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert abs(np.linalg.norm(inertia @ w) - h0) < 1e-10 * h0
    assert abs(0.5 * w @ inertia @ w - e0) < 1e-10 * e0


def _raw():
    return yaml.safe_load(shipped_vehicles()["maksat"].read_text())


def _set(raw, path, value):
    keys = path.split(".")
    for k in keys[:-1]:
        raw = raw[k]
    if value is None:
        del raw[keys[-1]]
    else:
        raw[keys[-1]] = value


BAD = [
    ("inertia.matrix", [[17, 0, 0], [0, -15, 0], [0, 0, 22]], "inertia: not positive definite"),
    ("inertia.matrix", [[1, 0, 0], [0, 1, 0], [0, 0, 3]], "triangle inequality"),
    ("inertia.matrix", [[17, 1, 0], [0, 15, 0], [0, 0, 22]], "inertia: not symmetric"),
    ("inertia.matrix", [[17, 0], [0, 15]], "inertia.matrix: expected 3 rows of 3 numbers"),
    ("wheel.driver_gain", "0.19 mA/V", "wheel.driver_gain: the unit must be A/V"),
    ("wheel.driver_gain", 0.19, "wheel.driver_gain: give its unit"),
    ("wheel.inertia", "-0.0077 kg m^2", "wheel.inertia: must be > 0"),
    ("wheel.poles", 36.5, "wheel.poles: must be a whole number"),
    ("wheel.emf_limit", "magic", "wheel.emf_limit: must be one of"),
    ("wheel.torque_constant", None, "wheel: missing torque_constant"),
    ("wheel.colour", "blue", "wheel: unknown field(s) ['colour']"),
    ("wheel_set", {"wheels": [{"name": n, "spin_axis": a} for n, a in (("x", [1, 0, 0]), ("y", [0, 1, 0]),
                                                                         ("z", [1, 1, 0]))]},
     "wheel_set: its active wheels do not span the three body axes"),
    ("wheel_set.wheels", {"x": [1, 0, 0]}, "wheel_set.wheels: expected a list"),
    ("wheel_set.wheels", [{"name": "x", "spin_axis": [0, 0, 0]}], "wheel_set.wheels[0].spin_axis: a zero vector"),
    ("wheel_set.standby", ["q"], "wheel_set.standby"),
    ("controller.settling_time", "5 s", "controller.settling_time: a 5 deg slew in 5 s needs"),
    ("dispersions.initial_wheel_speed", "30 to 20 rad/s", "dispersions.initial_wheel_speed: the low end 30"),
    ("dispersions.initial_wheel_speed", "20 to 900 rad/s", "beyond the wheel's speed limiter"),
    ("magnetorquers.dipole_limit", "15 A", "magnetorquers.dipole_limit: the unit must be A m^2"),
    ("name", None, "missing 'name'"),
    ("name", "  ", "name: a name (text)"),
    ("controller", None, "missing 'controller'"),
    ("controller.overshoot", 1.5, "controller.overshoot: a share below 1"),
    ("controller.friction_feedforward", "yes please", "controller.friction_feedforward: true or false"),
    ("controller.null_space_time_constant", "-1 s", "controller.null_space_time_constant: must be >= 0"),
    ("controller.null_space_time_constant", "10 rad/s", "controller.null_space_time_constant: the unit must be s"),
    ("residual_dipole", {"unit": "A m2", "vector": [0, 0, 0]}, "residual_dipole.unit: must be 'A m^2'"),
    ("residual_dipole", {"unit": "A m^2", "vector": [0, 0]}, "residual_dipole.vector: expected 3 numbers"),
    ("disturbance_sigma", "-1e-5 N m", "disturbance_sigma: must be >= 0"),
    ("magnetorquers.stop_speed", "40 rad/s", "magnetorquers.stop_speed: 40 rad/s is above start_speed 35"),
    ("magnetorquers.gain", "-0.002 1/s", "magnetorquers.gain: must be > 0"),
    ("dispersions.unit_spread.driver_gain", 0.5, "dispersions.unit_spread.driver_gain: a 1-sigma share in [0, 0.3]"),
    ("dispersions.initial_attitude", "-200 to 200 deg", "dispersions.initial_attitude: beyond +-180 deg"),
    ("dispersions.initial_body_rate", "-2 to 2 rad/s", "dispersions.initial_body_rate: beyond +-1 rad/s"),
    ("wheel_set.wheels", [{"name": n, "spin_axis": a} for n, a in (("x", [1, 0, 0]), ("x", [0, 1, 0]))],
     "wheel_set.wheels[1].name: wheel 'x' twice"),
    ("wheel.1", "odd", "wheel: unknown field(s) ['1']"),
    ("wheel_set", {"name": "tilted", "wheels": [{"name": n, "spin_axis": a} for n, a in (
        ("x", [1, 0, 0]), ("y", [0, 1, 0]), ("z", [0, 0, 1]), ("s", [1, 1, 0]))], "standby": ["s"]},
     "wheel_set: a wheel set of a vehicle's own ('tilted') is not flown yet"),
    ("mass", "100 kg", "unknown field(s) ['mass']"),
]


@pytest.mark.parametrize("path, value, message", BAD, ids=[f"{p}={v}" for p, v, _ in BAD])
def test_a_bad_vehicle_gets_one_line_naming_the_field(path, value, message):
    raw = copy.deepcopy(_raw())
    _set(raw, path, value)
    with pytest.raises(VehicleError) as error:
        vehicle_of(raw, "v.yaml")
    text = str(error.value)
    assert message in text and "\n" not in text and text.startswith("v.yaml")


def _vehicle_file(tmp_path, scale=2.0, name="heavy"):
    raw = _raw()
    raw["name"] = name
    raw["inertia"]["matrix"] = (scale * np.diag(INERTIA)).tolist()
    raw["controller"]["settling_time"] = "60 s"   # the same wheels take longer to turn a heavier body
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_naming_the_default_vehicle_changes_no_number():
    plain = parse_scenario("name: a\nduration: 30\nseed: 3\n")
    named = parse_scenario("name: a\nduration: 30\nseed: 3\nvehicle: maksat\n")
    a, b = simulate(plain), simulate(named)
    np.testing.assert_array_equal(a.attitude, b.attitude)
    np.testing.assert_array_equal(a.wheel_speed, b.wheel_speed)


def test_a_scenario_flies_its_vehicle_and_the_bag_records_it(tmp_path):
    path = _vehicle_file(tmp_path)
    (tmp_path / "run.yaml").write_text("name: heavy_run\nduration: 120\nseed: 5\nvehicle: heavy.yaml\n")
    from rw_fdi_ros.core.mission.scenario import load_scenario
    scenario = load_scenario(str(tmp_path / "run.yaml"))
    assert scenario.vehicle == load_vehicle(path) and scenario.plant["vehicle"] == "heavy"
    np.testing.assert_array_equal(Plant(scenario).inertia, 2.0 * INERTIA)
    assert scenario.plant_choices().vehicle == "heavy"
    again = parse_scenario(scenario.effective_text(scenario.plant_choices().scenario_dict()))
    assert again.vehicle == scenario.vehicle   # the bag alone redoes the run: the whole vehicle is in it
    # its controllers are designed on its inertia: the doubled body still settles its 5-deg steps
    heavy, thesis = simulate(scenario), simulate(Scenario("t", duration=120.0, seed=5))
    assert np.abs(np.degrees(heavy.error[-1])).max() < 0.2
    assert not np.allclose(heavy.attitude, thesis.attitude)


def test_the_launcher_gives_the_nodes_the_vehicle(tmp_path):
    from rw_fdi_ros.core.control.pid import design_gains
    from rw_fdi_ros.runner.graph import graph_nodes
    _vehicle_file(tmp_path)
    scenario = parse_scenario("name: h\nduration: 10\nvehicle: heavy.yaml\n", origin=str(tmp_path / "h.yaml"))
    nodes = {n.name: n.parameters for n in graph_nodes(scenario, "h", None, fdi=None)}
    gains = design_gains(2.0 * INERTIA)
    assert nodes["pid_controller_y"]["kp"] == pytest.approx(gains.kp[1])
    assert nodes["wheel_allocation"]["body_inertia"] == pytest.approx(np.diag(2.0 * INERTIA).ravel().tolist())
    thesis = {n.name: n.parameters for n in graph_nodes(parse_scenario("name: t\n"), "t", None, fdi=None)}
    assert "kp" not in thesis["pid_controller_y"] and "body_inertia" not in thesis["wheel_allocation"]


def test_the_launcher_gives_a_shipped_vehicles_nodes_its_own_fdi():
    """A scenario naming the microsatellite: each Elman node runs its wheel's network and the isolation node
    its bands, all from config/fdi/vehicles/microsat_pyramid; the thesis' runs keep the nodes' own defaults."""
    from rw_fdi_ros.runner.graph import graph_nodes
    scenario = parse_scenario("name: m\nduration: 10\nvehicle: microsat_pyramid\n")
    nodes = {n.name: n.parameters for n in graph_nodes(scenario, "m", None, fdi={})}
    own = fdi_dir("speed_aware", "microsat_pyramid")
    assert own.name == "microsat_pyramid" and own.parent.name == "vehicles"

    def read_back(params):   # what each node's graph/fdi_parameters.declare_fdi gives
        return FdiConfig(**{k: tuple(v) if k == "plugins" else v for k, v in params["fdi"].items()})
    for wheel in ("p1", "p2", "p3", "p4"):
        assert read_back(nodes[f"elman_observer_{wheel}"]).model_path(wheel) == own / f"elman_{wheel}.npz"
    assert read_back(nodes["isolation"]).threshold_path("model") == own / "thresholds_model.json"
    calibrated = {n.name: n.parameters for n in graph_nodes(scenario, "m", None, fdi={"unit_calibration": 150.0})}
    assert read_back(calibrated["isolation"]).threshold_path("model") == \
        own / "unit_calibrated" / "thresholds_model.json"
    thesis = {n.name: n.parameters for n in graph_nodes(parse_scenario("name: t\n"), "t", None, fdi={})}
    assert "vehicle" not in thesis["isolation"]["fdi"]
    assert read_back(thesis["isolation"]).threshold_path("model") == fdi_dir("speed_aware") / "thresholds_model.json"


def test_the_fdi_refuses_bands_fitted_for_another_vehicle():
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "thresholds_model.json", "model")
    curves.check_compatible(PlantChoices())   # the shipped bands: the thesis' vehicle
    with pytest.raises(ThresholdError, match="fitted with vehicle='maksat' but the graph runs vehicle='heavy'"):
        curves.check_compatible(PlantChoices(vehicle="heavy"))


def test_a_key_given_twice_is_refused_not_overwritten(tmp_path):
    line = "  torque_constant: 0.029 N m/A"
    text = shipped_vehicles()["maksat"].read_text().replace(line, f"{line}\n  torque_constant: 1 N m/A")
    (tmp_path / "twice.yaml").write_text(text)
    with pytest.raises(VehicleError, match=r"twice.yaml: line \d+ is not valid YAML \(duplicate key 'torque_const"):
        load_vehicle(tmp_path / "twice.yaml")


def test_another_wheel_type_flies_and_every_node_is_told_it(tmp_path):
    """A vehicle's own wheel type: the scenario flies it, the nodes that model the wheel get it as their
    wheel_type parameter (read back equal), the thesis' type leaves them at their default."""
    from rw_fdi_ros.core.mission.vehicle import wheel_from_parameter
    from rw_fdi_ros.runner.graph import graph_nodes
    raw = _raw()
    raw["name"], raw["wheel"]["torque_constant"] = "other_wheel", "0.035 N m/A"
    (tmp_path / "other_wheel.yaml").write_text(yaml.safe_dump(raw))
    scenario = parse_scenario("name: o\nvehicle: other_wheel.yaml\n", origin=str(tmp_path / "o.yaml"))
    assert scenario.spacecraft.wheel.torque_constant == 0.035
    nodes = {n.name: n.parameters for n in graph_nodes(scenario, str(tmp_path / "o.yaml"), None, fdi={})}
    modelling = [name for name, p in nodes.items() if "wheel_type" in p]
    assert sorted(modelling) == sorted(["pid_controller_x", "pid_controller_y", "pid_controller_z", "wheel_allocation",
                                        "wheel_telemetry", "elman_observer_x", "elman_observer_y", "elman_observer_z",
                                        "elman_observer_s",
                                        "linear_observer", "model_observer", "isolation"])
    assert all(wheel_from_parameter(nodes[n]["wheel_type"]) == scenario.spacecraft.wheel for n in modelling)
    thesis = parse_scenario("name: t\n", origin=str(tmp_path / "t.yaml"))
    assert not any("wheel_type" in n.parameters for n in graph_nodes(thesis, "t", None, fdi={}))


def test_a_vehicle_gives_a_scenario_what_it_leaves_open(tmp_path):
    raw = _raw()
    raw["name"], raw["wheel"]["emf_limit"] = "pwm", "pwm_saturation"
    raw["dispersions"]["setpoint_change"] = "-2 to 2 deg"
    (tmp_path / "pwm.yaml").write_text(yaml.safe_dump(raw))
    scenario = parse_scenario("name: p\nvehicle: pwm.yaml\nmanoeuvres: {interval_s: [60, 90]}\n",
                              origin=str(tmp_path / "p.yaml"))
    assert scenario.plant_choices().emf_limit == "pwm_saturation"   # one source: the graph and the bag read it
    assert scenario.manoeuvres.size_deg == (-2.0, 2.0)
    with pytest.raises(PlantChoiceError, match="flies vehicle pwm, whose wheel set is orthogonal_skew"):
        scenario.plant_choices(wheel_set="pyramid")   # the plant node's parameter: the bag would not parse


def test_a_slew_with_products_of_inertia_moves_the_wheels_of_every_axis_it_couples():
    """Orthogonal wheels (D = identity on x, y, z): dOmega_i = s sum_a |I_ia| / J."""
    inertia = np.array([[30.0, 2.0, 0.0], [2.0, 26.0, -1.0], [0.0, -1.0, 40.0]])
    wheels = WHEEL_SETS["orthogonal"]
    got = slew_excursion(wheels, wheels.names, 0.01, inertia, 0.0077)
    np.testing.assert_allclose(got, np.abs(inertia).sum(axis=1) * 0.01 / 0.0077, rtol=1e-12)
    np.testing.assert_array_equal(slew_excursion(wheels, wheels.names, 0.01, np.diag(INERTIA), 0.0077),
                                  slew_excursion(wheels, wheels.names, 0.01, INERTIA, 0.0077))


def test_a_scenario_that_records_another_vehicle_is_refused(tmp_path):
    _vehicle_file(tmp_path)
    with pytest.raises(ScenarioError, match="plant.vehicle 'other' records another vehicle"):
        parse_scenario("name: h\nvehicle: heavy.yaml\nplant: {vehicle: other}\n", origin=str(tmp_path / "h.yaml"))
    with pytest.raises(ScenarioError, match="vehicle: vehicle 'nowhere'"):
        parse_scenario("name: h\nvehicle: nowhere\n")


def test_the_command_line_checks_a_vehicle_file(tmp_path):
    path = _vehicle_file(tmp_path)
    ok = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "vehicle", str(path)], capture_output=True, text=True)
    assert ok.returncode == 0 and "principal moments 30, 34, 44 kg m^2" in ok.stdout
    raw = yaml.safe_load(path.read_text())
    raw["inertia"]["matrix"][0][0] = 200.0
    path.write_text(yaml.safe_dump(raw))
    bad = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "vehicle", str(path)], capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "heavy.yaml.inertia" in bad.stderr and "triangle" in bad.stderr


CLI = [sys.executable, "-m", "rw_fdi_ros.cli"]


def _rw_fdi(cwd, *args):
    return subprocess.run(CLI + list(args) + ["--jobs", "1"], cwd=cwd, capture_output=True, text=True)


def _fit_then_screen(cwd, fit_seeds: str) -> dict:
    """Bands fitted on ff.yaml's ``fit_seeds`` into fdi/, then cl.yaml screened with them on 4 other seeds:
    /diagnostics' verdict line as {column: count}."""
    fit = _rw_fdi(cwd, "fit-thresholds", "--simulate", "ff.yaml", "--seeds", fit_seeds, "--out", "fdi")
    assert fit.returncode == 0, fit.stderr
    own = _rw_fdi(cwd, "screen", "--scenario", "cl.yaml", "--seeds", "8000..8003", "--thresholds", "fdi")
    assert own.returncode == 0, own.stderr
    words = next(line for line in own.stdout.splitlines() if " verdict " in line).split()
    return {"correct": int(words[words.index("correct") + 1]), "false alarm": int(words[words.index("false") + 2]),
            "wrong axis": int(words[words.index("wrong") + 2])}


def test_your_vehicle_gets_its_own_bands_and_the_fdi_judges_it(tmp_path):
    """A vehicle with products of inertia: bands fitted on its own fault-free runs (the shipped ones refused),
    then a current loss on y found on the right wheel by /diagnostics' verdict, on other seeds."""
    raw = _raw()
    raw["name"], raw["inertia"]["matrix"] = "coupled", [[30, 2, 0], [2, 26, -1], [0, -1, 40]]
    raw["controller"]["settling_time"] = "60 s"
    (tmp_path / "coupled.yaml").write_text(yaml.safe_dump(raw))
    (tmp_path / "ff.yaml").write_text("name: coupled_ff\nduration: 300\nvehicle: coupled.yaml\n")
    (tmp_path / "cl.yaml").write_text("name: coupled_cl\nduration: 300\nvehicle: coupled.yaml\nfaults: "
                                      "[{kind: current_limiter, wheel: y, onset: 150, value: 0.6}]\n")
    shipped = _rw_fdi(tmp_path, "screen", "--scenario", "cl.yaml", "--seeds", "8000..8001")
    assert shipped.returncode == 2
    assert "no shipped speed_aware FDI for vehicle coupled" in shipped.stderr and "defaults --vehicle" in shipped.stderr
    maksat = _rw_fdi(tmp_path, "screen", "--scenario", "cl.yaml", "--seeds", "8000..8001", "--models",
                     str(fdi_dir()))   # the thesis' set given by hand: its bands refuse the vehicle
    assert maksat.returncode == 2
    assert "fitted with vehicle='maksat' but the graph runs vehicle='coupled'" in maksat.stderr
    verdict = _fit_then_screen(tmp_path, "7000..7059")
    assert yaml.safe_load((tmp_path / "fdi" / "thresholds_model.json").read_text())["plant"]["vehicle"] == "coupled"
    assert verdict == {"correct": 4, "false alarm": 0, "wrong axis": 0}


def test_a_pyramid_vehicle_gets_a_band_per_wheel_and_the_fdi_judges_it(tmp_path):
    """The shipped microsatellite: four wheels in a pyramid, all in use; its bands are fitted per wheel (p1-p4,
    not the thesis' x, y, z) and a current loss on p2 is found on p2."""
    (tmp_path / "ff.yaml").write_text("name: micro_ff\nduration: 200\nvehicle: microsat_pyramid\n")
    (tmp_path / "cl.yaml").write_text("name: micro_cl\nduration: 200\nvehicle: microsat_pyramid\nfaults: "
                                      "[{kind: current_limiter, wheel: p2, onset: 100, value: 0.6}]\n")
    verdict = _fit_then_screen(tmp_path, "7000..7079")   # four wheels: 80 runs for a 0.1 % per-run rate
    curves = ThresholdCurves.load(tmp_path / "fdi" / "thresholds_model.json", "model")
    assert sorted(curves.curves) == ["p1", "p2", "p3", "p4"] and curves.calibration["alpha_per_axis"] == 1e-3 / 4
    assert verdict == {"correct": 4, "false alarm": 0, "wrong axis": 0}


def test_one_command_makes_the_fdi_of_a_vehicle_and_every_command_takes_it(tmp_path):
    """`rw-fdi defaults --vehicle` from nothing (small numbers here; the full run's figures: docs/vehicles.md):
    the controllers designed, a network per wheel of the pyramid, datasheet and unit-calibrated bands, a report;
    then `screen --models DIR` judges the vehicle's faults with them, calibrated observers too."""
    out = tmp_path / "micro_fdi"
    made = _rw_fdi(tmp_path, "defaults", "--vehicle", "microsat_pyramid", "--out", str(out), "--train-runs", "3",
                   "--fit-runs", "20", "--heldout-runs", "4", "--unit-runs", "20", "--epochs", "3",
                   "--false-alarm-rate", "0.05", "--fault-runs", "3")
    assert made.returncode == 0, made.stderr
    assert "networks for p1, p2, p3, p4" in made.stdout
    card = yaml.safe_load((out / "model_set.json").read_text())
    assert card["wheels"] == ["p1", "p2", "p3", "p4"]
    assert all((out / f"elman_{a}.npz").is_file() for a in card["wheels"])
    for folder, calibration in ((out, 0.0), (out / "unit_calibrated", 150.0)):
        curves = ThresholdCurves.load(folder / "thresholds_model.json", "model")
        assert sorted(curves.curves) == ["p1", "p2", "p3", "p4"] and curves.unit_calibration_time == calibration
        assert curves.plant["vehicle"] == "microsat_pyramid"
    report = yaml.safe_load((out / "defaults.json").read_text())
    assert report["controller"]["natural_frequency"] == list(design_controller(load_vehicle("microsat_pyramid"))
                                                             .natural_frequency)
    assert "## Held-out fault-free runs" in (out / "defaults_report.md").read_text()
    # each observer judged alone on faults it must see; one that missed is named, with its cause and figure
    caught = report["faults_caught"]
    assert list(caught) == ["current loss 10 %", "temperature +30 C"] and report["seeds"]["faults"] == [5400, 5402]
    assert all(sorted(rows) == ["elman", "linear", "model"] and all(x["runs"] == 3 for x in rows.values())
               for rows in caught.values())
    for case, rows in caught.items():
        for obs, x in rows.items():
            assert ("why" in x) == (x["right"] < 3)
            if "why" in x:
                assert Path(x["worst_miss"]["figure"]).is_file()
                assert f"{obs} observer: {case} right in {x['right']} of 3 runs" in made.stdout
    assert "## Each observer on its own" in (out / "defaults_report.md").read_text()
    (tmp_path / "cl.yaml").write_text("name: micro_cl\nduration: 300\nvehicle: microsat_pyramid\nfaults: "
                                      "[{kind: current_limiter, wheel: p2, onset: 200, value: 0.6}]\n")
    for extra in ([], ["--unit-calibration", "150"]):
        judged = _rw_fdi(tmp_path, "screen", "--scenario", "cl.yaml", "--seeds", "8000..8001", "--models", str(out),
                         *extra)
        assert judged.returncode == 0, judged.stderr
        words = next(line for line in judged.stdout.splitlines() if " verdict " in line).split()
        assert int(words[words.index("correct") + 1]) == 2, judged.stdout
    # --vehicle DIR: a scenario naming no vehicle flies it, judged by its FDI; one naming another is refused
    (tmp_path / "mine.yaml").write_text("name: mine\nduration: 300\nfaults: [{kind: current_limiter, wheel: p2, "
                                        "onset: 200, value: 0.6}]\n")
    flown = _rw_fdi(tmp_path, "screen", "--vehicle", str(out), "--scenario", "mine.yaml", "--seeds", "8000..8001")
    assert flown.returncode == 0, flown.stderr
    words = next(line for line in flown.stdout.splitlines() if " verdict " in line).split()
    assert int(words[words.index("correct") + 1]) == 2, flown.stdout
    camp = _rw_fdi(tmp_path, "campaign", "--vehicle", str(out), "--scenario", "mine.yaml", "--runs", "1", "--out",
                   "camp", "--engine", "core")
    assert camp.returncode == 0, camp.stderr
    from rw_fdi_ros.storage.bag import read_bag
    recorded = yaml.safe_load(read_bag(tmp_path / "camp" / "mine_s0001", topics=["/scenario"]).last("/scenario").data)
    assert recorded["vehicle"]["name"] == "microsat_pyramid" and recorded["faults"][0]["wheel"] == "p2"
    judged = _rw_fdi(tmp_path, "evaluate", "--bags", "camp", "--vehicle", str(out), "--report", "rep", "--engine",
                     "core")
    assert judged.returncode == 0, judged.stderr
    assert json.loads((tmp_path / "rep" / "report.json").read_text())["runs"] == 1
    other = subprocess.run(CLI + ["run", "--vehicle", str(out), "--scenario", "fdir_bus_x"], cwd=tmp_path,
                           capture_output=True, text=True)
    assert other.returncode == 2 and "wheel must be one of p1, p2, p3, p4, got 'x'" in other.stderr
    # the benches fly it as they fly a shipped vehicle: its directory is the vehicle with its FDI
    bench = _rw_fdi(tmp_path, "bench", "detection", "--vehicle", str(out), "--fault-free-runs", "2",
                    "--runs-per-cell", "1")
    assert "Traceback" not in bench.stderr and bench.returncode in (0, 1), bench.stderr
    text = (out / "reports" / "detection" / "detection.md").read_text()
    assert f"vehicle microsat_pyramid (its FDI in `{out}`)" in text
    rows = list(csv.DictReader((out / "reports" / "detection" / "detection_runs.csv").open()))
    faults = [f for row in rows for f in json.loads(row["faults"])]
    assert len(rows) >= 10 and faults and {f["wheel"] for f in faults} <= {"p1", "p2", "p3", "p4"}
    alone = _rw_fdi(tmp_path, "bench", "detection", "--vehicle", str(out / "vehicle.yaml"))
    assert alone.returncode != 0 and "rw-fdi defaults --vehicle FILE --out DIR" in alone.stderr


def test_the_calibrated_bands_of_a_vehicle_are_fitted_on_runs_as_in_service(tmp_path):
    """A calibrated observer learns its unit at the speed it then holds: its bands are fitted where the speed moves
    on (the in-service family's fault-free draws: 600 s, manoeuvres every 60-900 s, drawn units), flown from the
    vehicle file `defaults` writes, without FDIR."""
    from rw_fdi_ros.tools.design.vehicle_defaults import service_unit_runs
    vehicle_file = tmp_path / "vehicle.yaml"
    vehicle_file.write_text(yaml.safe_dump(to_mapping(load_vehicle("cubesat_6u")), sort_keys=False))
    seeds = (60_000_000, 60_000_001)
    samples, plant = service_unit_runs(vehicle_file, seeds)
    assert [s.seed for s in samples] == list(seeds) and plant["vehicle"] == "cubesat_6u"
    for s in samples:
        assert s.time[-1] == pytest.approx(600.0, abs=1.0) and list(s.wheels) == ["x", "y", "z", "s"]
        assert s.wheel_params.inertia == load_vehicle("cubesat_6u").wheel.inertia   # its own wheel type
        # slews after the calibration move the wheels to speeds it never saw (a one-slew run's hold still)
        assert np.ptp(s.wheel_speed[150:, :3], axis=0).max() > 1.0


def test_in_orbit_the_body_carries_its_vehicles_residual_dipole_unless_the_scenario_says():
    """The magnetic disturbance m_res x b is the vehicle's: the CubeSat's 0.005 A m^2 per axis, not the thesis'
    0.5 (2.5 times its rods' 0.2 A m^2: no dumping could win); a scenario's environment may still name its own."""
    cubesat = load_vehicle("cubesat_6u")
    assert cubesat.residual_dipole == (0.005, 0.005, 0.005) and THESIS.residual_dipole == (0.5, 0.5, 0.5)
    text = "name: t\nduration: 20\nvehicle: cubesat_6u\nenvironment: {epoch: 2026-01-01T00:00:00%s}\nfaults: []\n"
    own = Plant(parse_scenario(text % "", origin="t.yaml"))
    said = Plant(parse_scenario(text % ", residual_dipole: [0.1, 0, 0]", origin="t.yaml"))
    thesis = Plant(parse_scenario("name: t\nduration: 20\nenvironment: {epoch: 2026-01-01T00:00:00}\nfaults: []\n",
                                  origin="t.yaml"))
    np.testing.assert_array_equal(own.environment.residual, [[0.005, 0.005, 0.005]])
    np.testing.assert_array_equal(said.environment.residual, [[0.1, 0.0, 0.0]])
    np.testing.assert_array_equal(thesis.environment.residual, [[0.5, 0.5, 0.5]])


def test_a_bad_vehicle_file_stops_the_defaults_before_any_run(tmp_path):
    raw = _raw()
    raw["inertia"]["matrix"][0][0] = -1.0
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(raw))
    bad = _rw_fdi(tmp_path, "defaults", "--vehicle", "bad.yaml", "--out", "x")
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "inertia" in bad.stderr
    assert not (tmp_path / "x").exists()


def test_evaluate_judges_a_vehicles_bags_with_its_shipped_fdi(tmp_path):
    """Bags of a microsatellite run (recorded by the core engine): `evaluate` takes the vehicle's shipped FDI
    from what the bags recorded, and finds the fault on its wheel."""
    from rw_fdi_ros.tools.campaigns.campaign import run_campaign
    from rw_fdi_ros.tools.evaluation.evaluate import evaluate
    (tmp_path / "cl.yaml").write_text("name: micro_cl\nduration: 200\nvehicle: microsat_pyramid\nfaults: "
                                      "[{kind: current_limiter, wheel: p2, onset: 100, value: 0.6}]\n")
    done = run_campaign(str(tmp_path / "cl.yaml"), 1, 8000, tmp_path / "bags", engine="core")
    assert not done.failed, done.failed
    report = evaluate(tmp_path / "bags", tmp_path / "report", engine="core", plots=False)
    assert report["runs"] == 1 and "vehicles/microsat_pyramid" in report["thresholds"]
    assert report["identification"] and report["identification"][0]["kind"] == "current_limiter"


def test_the_recovery_bench_flies_a_vehicle_with_its_wheels_left_taking_over():
    """bench recovery --vehicle: the pyramid's runs (no standby wheel: no cell with a second fault on one), its
    FDI acting, the three wheels left holding the lost one's momentum; the thesis' cells unchanged."""
    from rw_fdi_ros.tools.benches import recovery_bench as rb
    assert [c for _, c in rb.cells_of()] == list(rb.CELLS)
    assert all(c.second is None for _, c in rb.cells_of("microsat_pyramid"))
    scenarios = rb.cell_scenarios(rb.CELLS[2], 3, 2, rb.SEED_BASES["tuning"], "microsat_pyramid")
    assert {s.wheel_set().name for s in scenarios} == {"pyramid"} and all(
        s.spacecraft.name == "microsat_pyramid" for s in scenarios)
    # one initial speed per wheel in use, none near zero (three body-axis speeds over the pyramid start two there)
    lo, hi = rb.CELLS[2].speeds
    assert all(len(s.initial["wheel_speed"]) == 4 and min(s.initial["wheel_speed"]) >= lo
               and max(s.initial["wheel_speed"]) <= hi for s in scenarios)
    i, runs = rb._batch((2, rb.SEED_BASES["tuning"], range(0, 2), "microsat_pyramid"))   # current loss 40 %
    assert i == 2 and all(r["wheel"].startswith("p") for r in runs)
    assert all(any(w == r["wheel"] for _, w, _ in r["decisions"]) for r in runs), runs   # the faulty wheel acted on
    assert all(not r["healthy_given_up"] for r in runs)


def test_the_units_bench_judges_a_vehicles_varied_wheels_with_its_calibrated_bands():
    from rw_fdi_ros.tools.benches import units_bench as ub
    sets = ub._fdi_sets("microsat_pyramid")
    assert {c.plant["vehicle"] for _, curves, _ in sets.values() for c in curves.values()} == {"microsat_pyramid"}
    assert sets["calibrated"][1]["model"].unit_calibration_time == 150.0
    out = ub._judge_chunk("varied", 0, range(0, 2), vehicle="microsat_pyramid")   # fault-free, drawn units
    assert set(out) == set(ub.SETS) and all(len(runs) == 2 for runs in out.values())
    assert all(r.wheels == ("p1", "p2", "p3", "p4") for runs in out.values() for r in runs)
    # units the datasheet model does not know: its bands alarm; observers that learnt their wheel do not
    assert all(r.series["verdict"].alarm.any() for r in out["datasheet model"])
    assert not any(r.series["verdict"].alarm.any() for r in out["calibrated"])


def test_the_operations_bench_flies_a_vehicle_with_its_fdi():
    from rw_fdi_ros.tools.benches import operations_bench as ob
    from rw_fdi_ros.tools.benches.kit import SpeedAwareChunk
    from functools import partial
    scenarios = ob.cell_scenarios(ob.CELLS[2], range(3), 2, ob.SEED_BASES["tuning"], "microsat_pyramid")
    assert all(s.spacecraft.name == "microsat_pyramid" and s.faults[0].wheel in range(4) for s in scenarios)
    assert ob.cell_scenarios(ob.CELLS[2], range(3), 2, 1) == ob.cell_scenarios(ob.CELLS[2], range(3), 2, 1, "maksat")
    chunk = SpeedAwareChunk(partial(ob._cell_runs, vehicle="microsat_pyramid"), ob.SEED_BASES["tuning"],
                            decisions=("2of3",), vehicle="microsat_pyramid")
    runs = chunk(4, range(0, 2))["speed_aware"]   # current loss 40 % in operations, judged by its own FDI
    assert all(r.wheels == ("p1", "p2", "p3", "p4") and "verdict 2of3" in r.series for r in runs)
    assert all(r.series["verdict"].alarm[:, r.faults[0].wheel].any() for r in runs)


def test_the_identification_bench_identifies_a_vehicles_faults_with_its_fdi():
    from rw_fdi_ros.core.fdi.identification import Identification
    from rw_fdi_ros.tools.benches import identification_bench as ib
    runs = ib._chunk(0, range(0, 2), vehicle="microsat_pyramid")["speed_aware"]   # current loss 40 %
    assert all(r.wheels == ("p1", "p2", "p3", "p4") for r in runs)
    assert all(Identification.from_values(r.identification[r.wheels[r.faults[0].wheel]]).kind == "current_limiter"
               for r in runs)
    units = ib.units_scenarios(2, 3, "microsat_pyramid")
    assert all(s.spacecraft.name == "microsat_pyramid" and s.wheels == {"variation": True} for s in units)
    assert ib.units_scenarios(2, 3) == ib.units_scenarios(2, 3, "maksat")
