"""A vehicle of the user's own through the graph: a body with products of inertia flies the same run in the
graph as in the core loop, with its controllers, its bands and its FDI verdict (core/mission/vehicle.py)."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from rw_fdi_ros.core.fdi.pipeline import LoadedFdi
from rw_fdi_ros.core.flight import Fdir
from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.mission.scenario import load_scenario
from rw_fdi_ros.core.mission.vehicle import quantity
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.paths import config_dir
from rw_fdi_ros.storage.bag import read_bag
from rw_fdi_ros.runner.fdi_run import run_with_fdi

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


def test_a_coupled_vehicle_on_a_12_volt_bus_flies_the_same_run_in_the_graph_as_in_the_core_loop(tmp_path):
    raw = yaml.safe_load((config_dir() / "vehicles" / "maksat.yaml").read_text())
    raw["name"], raw["inertia"]["matrix"] = "coupled", [[30, 2, 0], [2, 26, -1], [0, -1, 40]]
    raw["controller"]["settling_time"] = "60 s"   # the same wheels take longer to turn a heavier body
    raw["wheel"]["bus_voltage"] = "12 V"   # and drive them from a bus of its own
    (tmp_path / "coupled.yaml").write_text(yaml.safe_dump(raw))
    (tmp_path / "ff.yaml").write_text("name: coupled_ff\nduration: 200\nvehicle: coupled.yaml\n")
    path = tmp_path / "cl.yaml"
    path.write_text("name: coupled_cl\nduration: 200\nseed: 8002\nvehicle: coupled.yaml\nfaults: "
                    "[{kind: current_limiter, wheel: y, onset: 100, value: 0.6}]\n")
    fit = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "fit-thresholds", "--simulate", "ff.yaml", "--seeds",
                          "7000..7059", "--out", "fdi", "--jobs", "1"], cwd=tmp_path, capture_output=True, text=True)
    assert fit.returncode == 0, fit.stderr
    outcome = run_with_fdi(str(path), out_dir=tmp_path / "bags", fdi={"thresholds": str(tmp_path / "fdi")})
    assert outcome.ok, outcome.reason
    curves = ThresholdCurves.load(tmp_path / "fdi" / "thresholds_model.json", "model")
    traj = simulate([load_scenario(str(path))], fdir=Fdir(LoadedFdi({"model": curves})))
    data = read_bag(outcome.bag, topics=[T.ATTITUDE, T.SCENARIO])
    _, attitude, _, _ = data.joint_states(T.ATTITUDE)
    np.testing.assert_allclose(attitude, traj.attitude[:, 0], rtol=0, atol=1e-12)   # the same run, products of inertia
    assert yaml.safe_load(data.scenario_text)["vehicle"]["inertia"]["matrix"][0][1] == 2.0   # the bag records it
    assert quantity("bus", yaml.safe_load(data.scenario_text)["vehicle"]["wheel"]["bus_voltage"], "V") == 12.0
    verdict = outcome.summary["fdi"]["verdict"]
    assert verdict["y"] and not verdict["x"] and not verdict["z"]
    assert traj.decisions[0], "FDIR acted on the current loss"
    assert [(d.wheel, d.action) for d in traj.decisions[0]] == [
        (d["wheel"], {"in_use": "in_use", "out_of_use": "out_of_use"}.get(d["state"], d["state"]))
        for d in outcome.summary["reconfiguration"]]


def test_a_shipped_vehicle_runs_its_own_fdi_in_the_graph_as_the_screen_does(tmp_path):
    """The microsatellite with no FDI option at all: the graph's Elman nodes run its own networks (p1-p4), the
    isolation node its bands, and every observer alarms where the screen's node code does."""
    from rw_fdi_ros.fdi_config import FdiConfig
    from rw_fdi_ros.tools.evaluation.screen import screen_runs
    path = tmp_path / "micro.yaml"
    path.write_text("name: micro_cl\nduration: 200\nseed: 8003\nvehicle: microsat_pyramid\nfaults: "
                    "[{kind: current_limiter, wheel: p3, onset: 100, value: 0.6}]\n")
    outcome = run_with_fdi(str(path), out_dir=tmp_path / "bags", fdi={"fdir": False})
    assert outcome.ok, outcome.reason
    weights, curves = FdiConfig().for_vehicle("microsat_pyramid").load()
    assert sorted(weights) == ["p1", "p2", "p3", "p4"]
    run = screen_runs([load_scenario(str(path))], weights, curves)[0]
    live = outcome.summary["fdi"]
    for obs in ("elman", "linear", "model", "verdict"):
        for i, a in enumerate(run.wheels):
            flags = run.series[obs].alarm[:, i]
            assert bool(live[obs][a]) == bool(flags.any()), (obs, a, live[obs][a])
            if live[obs][a]:
                assert live[obs][a][0][0] == pytest.approx(float(run.series[obs].time[flags.argmax()]), abs=1e-9)
    assert live["verdict"]["p3"] and not any(live["verdict"][a] for a in ("p1", "p2", "p4"))


def test_a_cubesat_with_a_wheel_type_of_its_own_flies_the_core_loops_run_in_the_graph(tmp_path):
    """The shipped CubeSat (a 20 mN m s wheel, not the thesis' Type A): every node that models the wheel is told
    its type, and the graph flies the core loop's run sample for sample, FDIR's decisions and the verdict too."""
    from rw_fdi_ros.fdi_config import FdiConfig
    path = tmp_path / "cube.yaml"
    path.write_text("name: cube_cl\nduration: 160\nseed: 8005\nvehicle: cubesat_6u\nfaults: "
                    "[{kind: current_limiter, wheel: y, onset: 80, value: 0.6}]\n")
    outcome = run_with_fdi(str(path), out_dir=tmp_path / "bags", fdi={})
    assert outcome.ok, outcome.reason
    _, curves = FdiConfig().for_vehicle("cubesat_6u").load()
    scenario = load_scenario(str(path))
    assert scenario.spacecraft.wheel.inertia == pytest.approx(2.94e-5)
    traj = simulate([scenario], fdir=Fdir(LoadedFdi(curves)))
    data = read_bag(outcome.bag, topics=[T.ATTITUDE, T.WHEELS])
    _, attitude, _, _ = data.joint_states(T.ATTITUDE)
    np.testing.assert_allclose(attitude, traj.attitude[:, 0], rtol=0, atol=1e-12)
    _, _, speed, _ = data.joint_states(T.WHEELS)
    np.testing.assert_allclose(speed, traj.wheel_speed[:, 0], rtol=0, atol=1e-9)
    assert np.abs(traj.wheel_speed[0, 0, :3]).min() > 150.0   # a CubeSat wheel's speeds, not MakSat's
    verdict = outcome.summary["fdi"]["verdict"]
    assert verdict["y"] and not any(verdict[a] for a in ("x", "z", "s")), verdict
    assert [(d.wheel, d.action) for d in traj.decisions[0]] == [("y", "out_of_use"), ("s", "in_use")]
    assert [(d["wheel"], d["state"]) for d in outcome.summary["reconfiguration"]] == [("y", "given_up"),
                                                                                   ("s", "in_use")]
