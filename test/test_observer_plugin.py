"""A user's observer as a plug-in (core/fdi/observer_plugin.py, docs/observers.md): found by entry point, dotted path
or file; stepped by the offline tools exactly as ours are; trained, fitted and screened by the same commands; the
worked example (examples/kalman_observer) against its closed form."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from rw_fdi_ros.core.fdi.observer_plugin import (ObserverError, ObserverModels, PluginRun, WheelObserver, load_observer,
                                             save_state, load_state)
from rw_fdi_ros.fdi_config import FdiConfig

from conftest import KALMAN, ROOT, cli


class ModelCopy(WheelObserver):
    """The nominal wheel model as a plug-in: must give our model observer's residuals exactly."""
    slot = "model_copy"

    def estimate(self, sample):
        return sample.model_torque


class Wrong(WheelObserver):
    slot = "wrong"

    def estimate(self, sample):
        return np.zeros(2)


def test_the_kalman_gain_is_the_riccati_equations():
    kalman = sys.modules[load_observer(KALMAN).__module__]
    phi, _, c, _ = kalman.discrete_wheel(1.0)
    for ratio in (1e-4, 0.3, 1e3):
        p = solve_discrete_are(np.array([[phi]]), np.array([[c]]), np.array([[ratio]]), np.array([[1.0]]))[0, 0]
        assert kalman.steady_state_gain(phi, c, ratio) == pytest.approx(p * c / (c * c * p + 1.0), rel=1e-9)


@pytest.mark.parametrize("spec, words", [
    ("no_such_observer", "not an entry point"),
    ("no_such_module:Thing", "cannot load it"),
    ("numpy:ndarray", "not a subclass"),
    (f"{ROOT}/nowhere.py:X", "no file"),
])
def test_a_bad_plugin_is_one_line_naming_it(spec, words):
    with pytest.raises(ObserverError, match=words) as info:
        load_observer(spec)
    assert "\n" not in str(info.value)


def test_a_slot_of_ours_is_refused(tmp_path):
    (tmp_path / "dup.py").write_text("from rw_fdi_ros.core.fdi.observer_plugin import WheelObserver\n"
                                     "class Dup(WheelObserver):\n    slot = 'model'\n")
    with pytest.raises(ObserverError, match="not one of elman, linear, model"):
        load_observer(f"{tmp_path}/dup.py:Dup")


def test_an_entry_point_names_it(tmp_path, monkeypatch):
    dist = tmp_path / "my_observer-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my-observer\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[rw_fdi_ros.observers]\nmine = test_observer_plugin:ModelCopy\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert load_observer("mine") is ModelCopy


def test_a_plugin_equal_to_our_model_gives_its_residuals_with_and_without_calibration(fault_free_samples):
    from rw_fdi_ros.tools.design.offline import observe
    models = FdiConfig().load_models()
    for calibration in (0, 150):
        run = observe(fault_free_samples, ObserverModels(models, [(ModelCopy, {})]), calibration_samples=calibration)
        np.testing.assert_array_equal(run.residual["model_copy"], run.residual["model"])
        np.testing.assert_array_equal(run.bound["model_copy"], run.bound["model"])


def test_an_estimate_of_the_wrong_size_is_said(fault_free_samples):
    with pytest.raises(ObserverError, match="gave 2 values for 4 wheels"):
        PluginRun(Wrong, fault_free_samples.wheels, 1.0).series(fault_free_samples)


def test_a_state_that_is_not_data_is_refused_and_data_comes_back(tmp_path):
    with pytest.raises(ObserverError, match="JSON data"):
        save_state(tmp_path, ModelCopy, "x:ModelCopy", {"gain": object()})
    save_state(tmp_path, ModelCopy, "x:ModelCopy", {"gain": [1.0, 2.0]}, seeds=[3])
    assert load_state([tmp_path / "none", tmp_path], "model_copy") == {"gain": [1.0, 2.0]}
    assert json.loads((tmp_path / "observer_model_copy.json").read_text())["seeds"] == [3]


@pytest.fixture(scope="module")
def fault_free_samples():
    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.tools.design.samples import simulated_samples
    scenario = load_scenario("fault_free").with_seed(61_000_500)
    return simulated_samples([scenario])[scenario.seed]


def test_train_and_fit_thresholds_write_its_state_and_bands_beside_ours(kalman_fdi):
    out, said = kalman_fdi
    state = json.loads((out / "observer_kalman.json").read_text())
    assert set(state["state"]["q_over_rho"]) == {"x", "y", "z"} and state["seeds"][0] == 61_000_000
    assert all(k > 0 for k in state["state"]["uncertainty_gain"].values())
    bands = json.loads((out / "thresholds_kalman.json").read_text())
    assert bands["observer"] == "kalman" and "KalmanObserver" in bands["model"]
    # its kappa spends half of the designed rate, as the Elman and Luenberger observers' do
    assert bands["calibration"]["alpha_per_axis"] == pytest.approx(0.5 * 0.005 / 3)
    assert (out / "thresholds_model.json").is_file() and "kalman  band c" in said


def test_screen_judges_it_beside_ours(kalman_fdi):
    out, _ = kalman_fdi
    r = cli("screen", "--observer", KALMAN, "--thresholds", str(out), "--scenario", "current_0p6_x",
            "--seeds", "100..103", "--jobs", "1", "--json")
    assert r.returncode == 0, r.stderr
    counts = json.loads(r.stdout)["current_0p6_x"]
    assert list(counts) == ["elman", "linear", "model", "kalman", "verdict"]
    assert counts["kalman"]["correct"] == 4 and counts["verdict"]["correct"] == 4


def test_a_plugin_untrained_or_without_bands_is_one_line(kalman_fdi, tmp_path):
    r = cli("screen", "--observer", KALMAN, "--scenario", "current_0p6_x", "--seeds", "100..100")
    assert r.returncode != 0 and "is not trained" in r.stderr and "train --observer" in r.stderr
    assert "Traceback" not in r.stderr and r.stderr.strip().count("\n") == 0
    out, _ = kalman_fdi
    (tmp_path / "observer_kalman.json").write_text((out / "observer_kalman.json").read_text())   # no bands
    r = cli("screen", "--observer", KALMAN, "--thresholds", str(tmp_path), "--scenario", "current_0p6_x",
            "--seeds", "100..100")
    assert r.returncode != 0 and "no bands for observer" in r.stderr and "fit-thresholds --observer" in r.stderr
    assert "Traceback" not in r.stderr and r.stderr.strip().count("\n") == 0


def test_a_bench_judges_it_beside_ours(kalman_fdi, tmp_path):
    from rw_fdi_ros.tools.benches.detection_bench import bench_detection
    from rw_fdi_ros.tools.campaigns.campaign import LocalExecutor
    out, _ = kalman_fdi
    report = bench_detection(fault_free_runs=2, runs_per_cell=1, out=tmp_path, executor=LocalExecutor(1),
                             fdi=FdiConfig(thresholds=str(out), plugins=(KALMAN,)))
    assert "| kalman |" in report["text"] and "| model |" in report["text"]


@pytest.mark.graph
def test_it_runs_as_a_node_of_the_graph_with_the_screens_verdict(kalman_fdi, tmp_path):
    """The plug-in's node in the live graph (composed with the FDI nodes) alarms the wheels and at the times the
    screen does, and its topics are in the bag."""
    from rw_fdi_ros.core.mission.scenario import load_scenario
    from rw_fdi_ros.storage.bag import bag_info
    from rw_fdi_ros.runner.fdi_run import run_with_fdi
    from rw_fdi_ros.tools.evaluation.screen import screen_runs
    from rw_fdi_ros.scoring.metrics import judge
    out, _ = kalman_fdi
    scenario = tmp_path / "loss_y.yaml"
    scenario.write_text("name: loss_y\nduration: 130.0\nseed: 61000900\n"
                        "faults: [{kind: current_limiter, wheel: y, onset: 50.0, value: 0.6}]\n")
    fdi = FdiConfig(thresholds=str(out), plugins=(KALMAN,), fdir=False)
    graph = run_with_fdi(str(scenario), out_dir=tmp_path / "bags", fdi=fdi)
    assert graph.ok, graph.reason
    assert "/fdi/kalman/residual" in bag_info(graph.bag).types
    weights, curves = fdi.load()
    screened = screen_runs([load_scenario(str(scenario))], weights, curves)[0]
    verdict = graph.summary["fdi"]
    assert verdict["observers"] == ["elman", "linear", "model", "kalman"]
    assert [a for a, iv in verdict["kalman"].items() if iv] == judge(screened, "kalman")["alarmed_wheels"] == ["y"]
    first = {a: iv[0][0] for a, iv in verdict["kalman"].items() if iv}
    assert first["y"] - 50.0 == pytest.approx(judge(screened, "kalman")["axes"]["y"]["delay"])
    # and a replay of the bag through the FDI graph judges it as the core engine does
    from rw_fdi_ros.tools.evaluation.evaluate import evaluate
    reports = {engine: evaluate(tmp_path / "bags", tmp_path / f"report_{engine}", fdi, engine=engine)
               for engine in ("graph", "core")}
    assert reports["graph"]["runs"] == reports["core"]["runs"] == 1
    assert "kalman" in (tmp_path / "report_graph" / "report.md").read_text()


def test_a_file_spec_is_made_absolute_and_each_observer_has_its_own_state(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    fdi = FdiConfig(plugins=("examples/kalman_observer/kalman_observer.py:KalmanObserver",))
    assert fdi.plugins == (KALMAN,) and fdi.plugin_slots == ("kalman",)
    state = {"uncertainty_gain": {"x": 0.1}}
    a, b = ModelCopy(("x",), 1.0, state), ModelCopy(("x",), 1.0, state)
    a.state["uncertainty_gain"]["x"] = 9.0
    assert b.uncertainty_gain("x") == 0.1 and state["uncertainty_gain"]["x"] == 0.1


def test_a_network_of_the_model_error_without_the_model_torque_is_said():
    from rw_fdi_ros.core.fdi.elman import ElmanWeights, recall_series
    w = ElmanWeights.random(np.random.default_rng(1), speed_scale=45.0)
    w.model_error = True
    with pytest.raises(ValueError, match="nominal model's torque"):
        recall_series(w, np.zeros(5), 0.0, np.zeros(5))


class Broken(WheelObserver):
    """A plug-in with a bug in its estimate."""
    slot = "broken"

    def estimate(self, sample):
        return {}["x"]


def test_whatever_a_plugin_raises_is_one_line_naming_it(fault_free_samples):
    with pytest.raises(ObserverError, match=r"^observer broken: estimate\(\) raised KeyError: 'x'$"):
        PluginRun(Broken, fault_free_samples.wheels, 1.0).series(fault_free_samples)

    class BadInit(ModelCopy):
        slot = "bad_init"

        def reset(self):
            raise RuntimeError("no memory")
    with pytest.raises(ObserverError, match=r"^observer bad_init: __init__\(\) raised RuntimeError: no memory$"):
        PluginRun(BadInit, fault_free_samples.wheels, 1.0)


def test_a_state_file_of_another_observer_is_refused(tmp_path):
    from rw_fdi_ros.core.fdi.observer_plugin import read_state
    path = save_state(tmp_path, ModelCopy, "x:ModelCopy", {"gain": [1.0]})
    assert read_state(path, "model_copy") == {"gain": [1.0]}
    with pytest.raises(ObserverError, match="not the state of observer kalman"):
        read_state(path, "kalman")


@pytest.mark.graph
def test_the_node_says_a_state_of_another_observer_and_a_plugins_failure_in_one_line(tmp_path):
    from rw_fdi_ros.runner.launcher import DomainLease
    path = save_state(tmp_path, ModelCopy, "x:ModelCopy", {"gain": [1.0]})
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONPATH=str(ROOT / "test"))
    with DomainLease() as lease:
        env["ROS_DOMAIN_ID"] = str(lease.domain_id)
        r = subprocess.run([sys.executable, "-m", "rw_fdi_ros.nodes.plugin_observer", "--ros-args", "-p",
                            f"observer:={KALMAN}", "-p", f"observer_state:={path}"],
                           capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 2 and "not the state of observer kalman" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.graph
def test_a_plugins_failure_inside_the_node_ends_it_in_one_line_naming_it(fault_free_samples, monkeypatch):
    import rclpy
    from rw_fdi_ros.graph.runtime import EXIT_ERROR, NodeError
    from rw_fdi_ros.nodes.plugin_observer import PluginObserverNode
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
    rclpy.init(args=["--ros-args", "-p", "observer:=test_observer_plugin:Broken"])
    try:
        node = PluginObserverNode()
        with pytest.raises(NodeError, match=r"^observer broken: estimate\(\) raised KeyError") as info:
            node.estimate(next(fault_free_samples.rows()))
        assert info.value.code == EXIT_ERROR and "\n" not in str(info.value)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()


BLIND = '''
import numpy as np
from rw_fdi_ros.core.fdi.observer_plugin import WheelObserver


class Blind(WheelObserver):
    """The nominal model, blind on wheel y from 30 s (a filter that diverged to NaN)."""
    slot = "blind"

    def estimate(self, sample):
        out = np.array(sample.model_torque, float)
        if sample.stamp_ns >= 30 * 10**9:
            out[1] = np.nan
        return out
'''


def _blind_fdi(tmp_path):
    """An FDI directory with the shipped bands and the Blind plug-in's (the model observer's, renamed)."""
    import shutil
    spec = tmp_path / "blind.py"
    spec.write_text(BLIND)
    fdi_dir = tmp_path / "fdi"
    shutil.copytree(FdiConfig().threshold_path("model").parent, fdi_dir,
                    ignore=shutil.ignore_patterns("thesis", "unit_calibrated", "vehicles", "service", "*.md"))
    bands = json.loads((fdi_dir / "thresholds_model.json").read_text())
    (fdi_dir / "thresholds_blind.json").write_text(json.dumps({**bands, "observer": "blind"}))
    return FdiConfig(thresholds=str(fdi_dir), plugins=(f"{spec}:Blind",), fdir=False)


def test_a_blind_plugin_gets_no_band_fitted(fault_free_samples, tmp_path):
    from rw_fdi_ros.core.mission.plant_choices import DEFAULT
    from rw_fdi_ros.tools.design.offline import fit_thresholds
    fdi = _blind_fdi(tmp_path)
    cls = load_observer(fdi.plugins[0])
    with pytest.raises(ValueError, match=r"^observer blind: non-finite estimates in 10 of 10 fitting runs"):
        fit_thresholds([fault_free_samples] * 10, ObserverModels(FdiConfig().load_models(), [(cls, {})]),
                       tmp_path / "o", false_alarm_rate=0.5, plant=DEFAULT.as_dict())
    assert not (tmp_path / "o" / "thresholds_blind.json").exists()


@pytest.mark.graph
def test_a_plugin_that_goes_blind_is_named_in_diagnostics_and_in_the_runs_health(tmp_path):
    """estimate() returning NaN gave a silent 'no alarm' and 'health: every sample judged'."""
    from rw_fdi_ros.runner.fdi_run import run_with_fdi
    from rw_fdi_ros.runner.verdict import format_verdict
    from rw_fdi_ros.storage.bag import read_bag
    scenario = tmp_path / "blind.yaml"
    scenario.write_text("name: blind\nduration: 60.0\nseed: 61000901\nfaults: []\n")
    graph = run_with_fdi(str(scenario), out_dir=tmp_path / "bags", fdi=_blind_fdi(tmp_path))
    assert graph.ok, graph.reason
    health = graph.summary["fdi"]["health"]["/fdi/blind/status"]
    assert list(health) == ["y"] and health["y"]["cannot_judge"]["samples"] >= 25
    assert health["y"]["cannot_judge"]["first_s"] == pytest.approx(30.0)
    assert "health of the" in format_verdict(graph.summary["fdi"]) and "blind" in format_verdict(graph.summary["fdi"])
    named = {(s.hardware_id, kv.value) for _, m in read_bag(graph.bag, ["/diagnostics"]).topic("/diagnostics")
             for s in m.status for kv in s.values if kv.key == "blind_observers"}
    assert named == {("reaction_wheel_y", "blind")}
