"""FDI through the live graph with the shipped models and thresholds, both FDI methods.

Runs (conftest.fdi_runs: 300 s, two at a time, each in its own domain), speed-aware (ours): fault-free,
and the thesis cases bus 5.5 V on X, current limiter 0.6 on X, +150 C on X,
bus on X with current loss on Z (that the same seed gives the same messages on every
topic: test_composed.py). Both observers must flag the faulty wheels after onset, hold the
alarm and flag no other wheel at any time. The thesis method runs the current
loss too: its linear observer loses the alarm (thesis Fig. 3.8).
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import CASE_DURATION
from rw_fdi_ros.core.fdi.detection import observers_of
from rw_fdi_ros.core.mission.scenario import load_scenario
from rw_fdi_ros.core.physics.wheel_set import AXIS_WHEELS
from rw_fdi_ros.runner.launcher import DomainLease
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.paths import config_dir, fdi_dir
from rw_fdi_ros.storage.bag import read_bag
from rw_fdi_ros.scoring.bag_series import verdict_messages
from rw_fdi_ros.tools.design.offline import load_models, observe
from rw_fdi_ros.tools.design.samples import fdi_samples

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

BIN = Path(sys.executable).parent
SHIPPED = config_dir() / "fdi"


@pytest.fixture(scope="module")
def runs(fdi_runs):
    return fdi_runs


def verdict(outcome):
    assert outcome.ok, outcome.reason
    return outcome.summary["fdi"]


def test_fault_free_run_raises_no_alarm(runs):
    """One fault-free run (seed 12). The rate over many runs is a figure, not a test: see
    `rw-fdi bench detection` (reports/detection/detection.md)."""
    v = verdict(runs["fault_free"])
    assert v["observers"] == ["elman", "linear", "model"]
    for obs in v["observers"]:
        assert all(v[obs][a] == [] for a in AXIS_WHEELS), (obs, v[obs])


@pytest.mark.parametrize("case", ["bus_5v5_x", "current_0p6_x", "temperature_150_x", "bus_x_current_z"])
def test_the_luenberger_observer_runs_beside_them_and_blames_no_healthy_wheel(runs, case):
    """The thesis' linear observer in the speed-aware graph: judged beside the others on every case, never
    blaming a healthy wheel (its figures: reports/detection)."""
    v = verdict(runs[case])
    assert "linear" in v["judged"] and not v["judged"]["linear"]["wrong_axes"], v["judged"]["linear"]
    assert all(v["linear"][a] == [] for a in AXIS_WHEELS if not v["truth"][a])


@pytest.mark.parametrize("observer", ["elman", "model"])
@pytest.mark.parametrize("case", ["bus_5v5_x", "current_0p6_x", "temperature_150_x", "bus_x_current_z"])
def test_speed_aware_observers_isolate_the_faulty_wheels(runs, case, observer):
    v = verdict(runs[case])
    for a in AXIS_WHEELS:
        faults = v["truth"][a]
        alarms = v[observer][a]
        if faults:
            onset = min(f["onset"] for f in faults)
            assert alarms and alarms[0][0] > onset, (a, alarms)
            assert len(alarms) == 1 and alarms[0][1] is None, f"{observer} alarm on {a} lost: {alarms}"
        else:
            assert alarms == [], (a, alarms)


@pytest.mark.parametrize("case, expected", [
    ("current_0p6_x", {"x": ("current_limiter", 0.6, 0.06)}),
    ("temperature_150_x", {"x": ("temperature", 173.0, 10.0)}),
    ("bus_5v5_x", {"x": ("bus_voltage", 5.5, 0.55)}),
    ("bus_x_current_z", {"x": ("bus_voltage", 5.5, 0.55), "z": ("current_limiter", 0.6, 0.06)})])
def test_the_isolation_node_identifies_each_fault_kind_and_size(runs, case, expected):
    """The wheel's /diagnostics status and /fdi/identification carry kind, size and interval."""
    data = read_bag(runs[case].bag, topics=[T.DIAGNOSTICS, T.IDENTIFICATION])
    found = verdict(runs[case])["identification"]
    assert set(found) == set(expected), found
    last = {s.hardware_id[-1]: s for s in verdict_messages(data)[-1][1].status}
    for a, (kind, value, tolerance) in expected.items():
        assert found[a]["fault_kind"] == kind, found[a]
        assert abs(float(found[a]["fault_size"]) - value) <= tolerance, found[a]
        assert float(found[a]["fault_size_low"]) <= value <= float(found[a]["fault_size_high"]), found[a]
        values = {kv.key: kv.value for kv in last[a].values}
        assert values["fault_kind"] == kind and values["fault_size"] == found[a]["fault_size"]
        assert last[a].message.endswith(found[a]["message"]), (last[a].message, found[a]["message"])
    stamps = [m.header.stamp.sec for _, m in data.topic(T.IDENTIFICATION)]
    # the first FDI sample is at 1 s: at 0 no command is in force yet (core/fdi/wheel_reports.py)
    assert stamps == list(range(1, int(CASE_DURATION) + 1)), "one identification per FDI sample, in sim time"


def test_thesis_linear_observer_loses_its_alarm_on_current_loss(runs):
    """Thesis Fig. 3.9: detected, then 'identified as nonfaulty after less than 40 s'."""
    v = verdict(runs["current_0p6_x_thesis"])
    alarms = v["linear"]["x"]
    assert alarms, "the linear observer did not see the current loss at all"
    start, end = alarms[0]
    assert end is not None and end - start < 60.0, alarms
    assert v["linear"]["y"] == [] and v["linear"]["z"] == []


@pytest.mark.parametrize("case, method", [("bus_x_current_z", "speed_aware"), ("current_0p6_x_thesis", "thesis")])
def test_live_residuals_equal_offline_residuals_of_the_same_code(runs, case, method):
    data = read_bag(runs[case].bag)
    offline = observe(fdi_samples(data), load_models(fdi_dir(method)))
    assert offline.method == method
    assert offline.wheels == ("x", "y", "z", "s")
    for i, a in enumerate(offline.wheels):   # one Elman node per wheel, the redundant s included
        _, live = data.wheel_values(T.observer_topic("elman", "residual", a))
        np.testing.assert_allclose(live[:, 0], offline.residual["elman"][:, i], rtol=0, atol=1e-15)
        _, live = data.wheel_values(T.observer_topic("elman", "ripple_bound", a))
        np.testing.assert_allclose(live[:, 0], offline.bound["elman"][:, i], rtol=0, atol=1e-15)
    assert list(offline.residual) == list(observers_of(method))
    for obs in observers_of(method)[1:]:   # the observers of every wheel at once
        _, live = data.wheel_values(T.observer_topic(obs, "residual"))
        np.testing.assert_allclose(live, offline.residual[obs], rtol=0, atol=1e-15)
        _, live = data.wheel_values(T.observer_topic(obs, "ripple_bound"))
        np.testing.assert_allclose(live, offline.bound[obs], rtol=0, atol=1e-15)


def test_a_thesis_run_replays_to_its_live_result_without_a_model_observer(runs, tmp_path):
    """The thesis' FDI has no model observer: its replay graph neither starts one nor waits for one (the
    recorder once waited its drain timeout for /fdi/model and dropped the replay), and gives the live
    alarms, thresholds and residuals to the bit."""
    from rw_fdi_ros.tools.campaigns.replay import replay_bag
    live = runs["current_0p6_x_thesis"].bag
    thesis = fdi_dir("thesis")
    replayed = replay_bag(live, tmp_path / "replayed", {"models": thesis, "method": "thesis"})
    assert replayed.ok, replayed.reason
    a, b = read_bag(live), read_bag(replayed.bag)
    assert not any(t.startswith("/fdi/model/") for t in [*a.messages, *b.messages])
    for obs in observers_of("thesis"):
        for key in ("alarm", "threshold"):
            ta, va = a.wheel_values(T.fdi_output_topics(obs)[key])
            tb, vb = b.wheel_values(T.fdi_output_topics(obs)[key])
            assert len(ta) == CASE_DURATION   # one per FDI sample, 1 s to the end
            np.testing.assert_array_equal(ta, tb)
            np.testing.assert_array_equal(va, vb)
    np.testing.assert_array_equal(a.wheel_values(T.observer_topic("linear", "residual"))[1],
                                  b.wheel_values(T.observer_topic("linear", "residual"))[1])
    assert np.any(b.wheel_values(T.fdi_output_topics("linear")["alarm"])[1])   # the fault was seen


def test_diagnostics_one_status_per_wheel_stamped_in_sim_time(runs):
    data = read_bag(runs["current_0p6_x"].bag)
    rows = verdict_messages(data)
    end = int(CASE_DURATION)
    assert len(rows) == end   # one per FDI sample: 1 s to the end
    log_time, last = rows[-1]
    assert last.header.stamp.sec == end and log_time == end * 10**9
    assert [s.hardware_id for s in last.status] == [f"reaction_wheel_{a}" for a in (*AXIS_WHEELS, "s")]
    assert [s.level for s in last.status] == [2, 0, 0, 0]
    values = {kv.key: kv.value for kv in last.status[0].values}
    assert {"residual", "threshold", "margin", "first_alarm"} <= set(values)
    assert float(values["margin"]) == pytest.approx(float(values["threshold"]) - abs(float(values["residual"])),
                                                    rel=1e-4, abs=1e-9)
    assert Path(runs["current_0p6_x"].summary["figure"]).stat().st_size > 10_000


def cli(*args):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    return subprocess.run([str(BIN / "rw-fdi"), *args], capture_output=True, text=True, timeout=60, env=env)


@pytest.fixture
def fdi_copy(tmp_path):
    d = tmp_path / "fdi"
    shutil.copytree(SHIPPED, d, ignore=shutil.ignore_patterns("variants"))
    return d


def one_line_error(r, *words):
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().count("\n") == 0 and "Traceback" not in r.stderr
    for w in words:
        assert w in r.stderr, r.stderr


def test_missing_model(tmp_path):
    one_line_error(cli("run", "--scenario", "fault_free", "--models", str(tmp_path / "none"), "--out", str(tmp_path)),
                   "model file not found", "rw-fdi train")


def test_corrupt_and_misshapen_models(fdi_copy, tmp_path):
    (fdi_copy / "elman_y.npz").write_bytes(b"garbage")
    one_line_error(cli("run", "--scenario", "fault_free", "--models", str(fdi_copy), "--out", str(tmp_path)),
                   "elman_y.npz", "not a readable Elman model", "rw-fdi train")
    with np.load(SHIPPED / "elman_x.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["w_hh"] = arrays["w_hh"][:, :10]
    np.savez(fdi_copy / "elman_y.npz", **arrays)
    one_line_error(cli("run", "--scenario", "fault_free", "--models", str(fdi_copy), "--out", str(tmp_path)),
                   "w_hh has shape", "rw-fdi train")


def test_corrupt_and_incompatible_thresholds(fdi_copy, tmp_path):
    path = fdi_copy / "thresholds_linear.json"
    raw = json.loads(path.read_text())
    path.write_text("{")
    one_line_error(cli("run", "--scenario", "fault_free", "--thresholds", str(fdi_copy), "--out", str(tmp_path)),
                   "not a readable threshold file", "rw-fdi fit-thresholds")
    raw["plant"]["emf_limit"] = "pwm_saturation"
    path.write_text(json.dumps(raw))
    one_line_error(cli("run", "--scenario", "fault_free", "--thresholds", str(fdi_copy), "--out", str(tmp_path)),
                   "fitted with emf_limit='pwm_saturation'", "rw-fdi fit-thresholds")
    raw["plant"]["emf_limit"] = "kf_scaled"
    raw["plant"]["control_period"] = 0.05
    path.write_text(json.dumps(raw))
    one_line_error(cli("run", "--scenario", "fault_free", "--thresholds", str(fdi_copy), "--out", str(tmp_path)),
                   "control_period=0.05")


def test_observer_node_alone_with_missing_model(tmp_path):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with DomainLease() as lease:
        env["ROS_DOMAIN_ID"] = str(lease.domain_id)
        r = subprocess.run([str(BIN / "elman_observer"), "--ros-args", "-p", f"fdi.models:={tmp_path}"],
                           capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 2 and "model file not found" in r.stderr and "rw-fdi train" in r.stderr


def test_model_observer_refuses_the_thesis_method():
    """The thesis' observers see no wheel speed: asked for the thesis method, the model observer says so."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    with DomainLease() as lease:
        env["ROS_DOMAIN_ID"] = str(lease.domain_id)
        r = subprocess.run([str(BIN / "model_observer"), "--ros-args", "-p", "fdi.method:=thesis"],
                           capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 2 and "needs fdi.method speed_aware" in r.stderr, r.stderr


def test_screen_without_ros_agrees_with_the_thesis_pattern():
    """The ROS-free screen (same code as the nodes), thesis method: Elman holds the current-loss alarm,
    linear loses it."""
    from rw_fdi_ros.tools.evaluation.screen import screen
    out, runs = screen(load_scenario("current_0p6_x"), range(12, 15), {"method": "thesis", "fdir": False})
    assert [r.seed for r in runs] == [12, 13, 14]
    assert out["elman"]["held"] == 3 and out["elman"]["lost"] == 0
    assert out["linear"]["lost"] >= 2 and out["linear"]["lost"] > out["linear"]["held"]
    assert all(d > 0 for d in out["elman"]["delays"])


def _tampered_bag(src, out, tamper, drop_grids=()):
    """A copy of bag ``src`` whose FDI telemetry rows go through ``tamper(log_time, msg)``, which
    returns the [(log_time, msg)] to write instead (none: dropped, two: duplicated, a later log
    time: delayed past the next sample), without the bus grids logged at ``drop_grids`` [ns]."""
    from rw_fdi_ros.storage.bag import typestore
    from rw_fdi_ros.storage.writer import BagWriter
    data, store = read_bag(src, raw=True), typestore()
    w = BagWriter(out)
    for topic in data.messages:
        w.add_topic(topic, data.types[topic])
    rows = sorted(((t, topic, raw) for topic, msgs in data.messages.items() for t, raw in msgs), key=lambda r: r[0])
    for t, topic, raw in rows:
        if topic == T.FDI_BUS_GRID and t in drop_grids:
            continue
        if topic != T.FDI_TELEMETRY:
            w.write(topic, t, raw)
            continue
        for t2, msg in tamper(t, store.deserialize_cdr(raw, data.types[topic])):
            w.write(topic, t2, store.serialize_cdr(msg, data.types[topic]))
    w.close()
    return out


def _set_value(msg, wheel, key, value):
    """Set one channel of an FDI telemetry report (a rosbags JointState: position a float64 array)."""
    position = msg.position.copy()   # read from the bag's buffer: read-only
    position[msg.name.index(f"reaction_wheel_{wheel}/{key}")] = value
    msg.position = position


def test_the_fdi_reports_its_own_health_under_bad_inputs(runs, tmp_path):
    """Dropped, delayed, duplicated and NaN observer inputs: the statuses say so (never OK while a
    wheel could not be judged), a healthy wheel gets no fault verdict, an alarm is held, not lost."""
    from rw_fdi_ros.runner.verdict import fdi_verdict, format_verdict, verdict_topics
    from rw_fdi_ros.scoring.bag_series import health_from_bag
    from rw_fdi_ros.tools.campaigns.replay import replay_bag
    from rw_fdi_ros.storage.bag import read_series
    s = 10**9
    first_alarm = runs["current_0p6_x"].summary["fdi"]["elman"]["x"][0][0]   # the live run's, on wheel x

    def tamper(t, msg):
        if t in (60 * s, 61 * s, 62 * s):
            return []                                   # dropped
        if t == 80 * s:
            return [(t + 3 * s // 2, msg)]              # delayed: arrives after the sample of 81 s
        if t == 100 * s:
            return [(t, msg), (t, msg)]                 # duplicated
        if t == 150 * s:
            _set_value(msg, "y", "reaction_torque", float("nan"))     # corrupt while every wheel is healthy
        if t == (first_alarm + 20) * s:
            _set_value(msg, "x", "reaction_torque", float("nan"))     # corrupt while wheel x is alarmed
        return [(t, msg)]
    # a report whose bus grid was lost: decided without it when the next grid comes (its identification skipped)
    bag = _tampered_bag(runs["current_0p6_x"].bag, tmp_path / "tampered", tamper, drop_grids=(120 * s,))
    outcome = replay_bag(bag, tmp_path / "replayed", watchdog=180)
    assert outcome.ok, outcome.reason
    data = read_bag(tmp_path / "replayed", topics=[T.DIAGNOSTICS, T.fdi_output_topics("linear")["status"]])
    diag = {m.header.stamp.sec: {st.hardware_id[-1]: st for st in m.status} for _, m in verdict_messages(data)}
    assert not {60, 61, 62, 80} & set(diag) and {100, 120, 121} <= set(diag)
    for t in (150, first_alarm + 20):   # never OK while it could not judge
        assert all(st.level != 0 and "cannot judge" in st.message for st in diag[t].values()), diag[t]
    assert diag[150]["y"].level == 3 and "non-finite model residual at 150 s" in diag[150]["y"].message   # the decider
    held = diag[first_alarm + 20]["x"]
    assert held.level == 2 and "alarm held: faulty since" in held.message
    assert diag[63]["x"].level == 1 and "3 samples missing before 63 s" in diag[63]["x"].message
    said = " | ".join(st.message for t in (81, 82) for st in diag[t].values())
    assert "dropped a late sample stamped 80 s" in said
    said = " | ".join(st.message for t in (100, 101) for st in diag[t].values())
    assert "dropped a duplicate sample stamped 100 s" in said
    linear = {m.header.stamp.sec: m for _, m in data.topic(T.fdi_output_topics("linear")["status"])}
    assert all(st.level == 3 for st in linear[150].status if st.hardware_id != "reaction_wheel_x")

    verdict = fdi_verdict(read_series(tmp_path / "replayed", verdict_topics()))
    assert verdict["elman"]["y"] == verdict["elman"]["z"] == []   # no fault verdict from a corrupt input
    assert verdict["elman"]["x"] == [(first_alarm, None)]         # held through the NaN, never lost
    health = health_from_bag(tmp_path / "replayed")
    assert health[T.DIAGNOSTICS]["y"]["cannot_judge"]["samples"] == 2
    assert health[T.DIAGNOSTICS]["x"]["input_trouble"]["first_s"] == 63
    text = format_verdict({**verdict, "health": health})
    assert "could not judge 2 samples, first at 150 s" in text, text


@pytest.mark.parametrize("plant, running, fitted", [
    ("{emf_limit: pwm_saturation}", "emf_limit='pwm_saturation'", "emf_limit='kf_scaled'"),
    ("{wheel_momentum_coupling: false}", "wheel_momentum_coupling=False", "wheel_momentum_coupling=True")])
def test_scenario_plant_choice_reaches_the_compatibility_check(tmp_path, plant, running, fitted):
    """Thresholds fitted under other plant choices are refused before any node starts."""
    scenario = tmp_path / "other.yaml"
    scenario.write_text(f"name: other\nplant: {plant}\nfaults: []\n")
    one_line_error(cli("run", "--scenario", str(scenario), "--out", str(tmp_path)),
                   f"fitted with {fitted} but the graph runs {running}", "rw-fdi fit-thresholds")


def test_files_of_the_other_method_are_refused(tmp_path):
    one_line_error(cli("run", "--scenario", "fault_free", "--models", str(fdi_dir("thesis")), "--out", str(tmp_path)),
                   "not a network for fdi_method='speed_aware'", "rw-fdi train")
    one_line_error(cli("run", "--scenario", "fault_free", "--models", str(fdi_dir("speed_aware")),
                       "--thresholds", str(fdi_dir("thesis")), "--out", str(tmp_path)),
                   "fitted for fdi_method='thesis' but the graph runs fdi_method='speed_aware'")


def _resolve(msg, path: str):
    """Values at a Foxglove message path below the topic ('.field', '[i]', '[:]' then filters
    '{key=="value"}' or '{key!="value"}'; math modifiers such as '.@negative' apply to a number and are
    skipped)."""
    import re
    values = [msg]
    for token in re.findall(r'\.@?\w+|\[:\]|\{\w+[!=]="[^"]*"\}|\[\d+\]', path):
        if token.startswith(".@"):
            continue
        if token.startswith("."):
            values = [getattr(v, token[1:]) for v in values]
        elif token == "[:]":
            values = [item for v in values for item in v]
        elif token.startswith("{"):
            key, op, want = re.match(r'\{(\w+)([!=])="([^"]*)"\}', token).groups()
            values = [v for v in values if (getattr(v, key) == want) == (op == "=")]
        else:
            values = [v[int(token[1:-1])] for v in values]
    return values


def test_foxglove_layout_plots_only_what_a_recorded_bag_holds(runs):
    """config/foxglove/rw_fdi.json (installed under share/): per wheel (the redundant s included) residual
    against threshold, the alarms, the injected fault and the verdict, FDIR's wheel states and the telemetry's
    reaction torques; every topic and field it names is in a bag."""
    import json
    from rw_fdi_ros.paths import config_dir
    layout = json.loads((config_dir() / "foxglove" / "rw_fdi.json").read_text())
    paths = [p["value"] for panel in layout["configById"].values() for p in panel["paths"]]
    assert len(paths) == 48   # per wheel: 4 plot lines, 3 observers' alarms, truth, verdict; FDIR; telemetry 2
    data = read_bag(runs["current_0p6_x"].bag)
    for path in paths:
        topic = next(t for t in sorted(data.messages, key=len, reverse=True) if path.startswith(t + "."))
        # the last message the path picks from (/diagnostics also carries FDIR's statuses: a filter skips them)
        values = next((v for v in (_resolve(m, path[len(topic):]) for _, m in reversed(data.messages[topic])) if v),
                      [])
        assert len(values) == 1 and isinstance(values[0], (int, float)), path
    placed = json.dumps(layout["layout"])
    assert all(f'"{panel}"' in placed for panel in layout["configById"])   # every panel is on screen
    # the telemetry is plotted by index: each index is the channel its label names
    names = data.messages[T.FDI_TELEMETRY][-1][1].name
    for p in layout["configById"]["Plot!telemetry"]["paths"]:
        channel = names[int(p["value"].split("[")[1].rstrip("]"))]
        wheel, quantity = p["label"].split(":")[0], "model" if "model" in p["label"] else "reaction_torque"
        assert channel.startswith(f"reaction_wheel_{wheel}/") and quantity in channel, (p, channel)


def test_fdi_configurations_that_cannot_judge_the_run_are_refused_before_any_node(fdi_copy, tmp_path):
    """Calibration times the bands were not fitted for, calibration with the thesis method, and thesis
    curves that end before the run: one line naming the file and the fix, exit 2, no node started."""
    one_line_error(cli("run", "--scenario", "fault_free", "--unit-calibration", "60", "--out", str(tmp_path)),
                   "unit_calibrated/thresholds_elman.json: fitted with unit_calibration_time=150 s but the "
                   "observers run unit_calibration_time=60 s", "--unit-calibration 60")
    one_line_error(cli("run", "--scenario", "fault_free", "--unit-calibration", "150", "--fdi-method", "thesis",
                       "--out", str(tmp_path)), "--unit-calibration needs --fdi-method speed_aware")
    one_line_error(cli("screen", "--scenario", "fault_free", "--seeds", "1..2", "--unit-calibration", "30"),
                   "fitted with unit_calibration_time=150 s")
    thesis = tmp_path / "thesis"
    shutil.copytree(SHIPPED / "thesis", thesis, ignore=shutil.ignore_patterns("variants"))
    raw = json.loads((thesis / "thresholds_elman.json").read_text())
    raw["curves"] = {a: c[:3] for a, c in raw["curves"].items()}
    (thesis / "thresholds_elman.json").write_text(json.dumps(raw))
    one_line_error(cli("run", "--scenario", "current_0p6_x", "--fdi-method", "thesis", "--models", str(thesis),
                       "--thresholds", str(thesis), "--out", str(tmp_path)),
                   "thresholds_elman.json: the curves cover 0-2 s but the run lasts 400 s")
    assert not list(tmp_path.glob("current_0p6_x*"))   # refused before the graph: no bag begun


def test_fit_thresholds_fits_on_fault_free_bags_only_and_on_enough_of_them(runs, tmp_path, capsys):
    """`fit-thresholds --bags` fitted a 0.001 band on one fdir_bus_x bag without a word (issue 39): a bag whose
    scenario has a fault is skipped by name and counted; one fault-free run cannot promise 0.001 (the band says
    how many runs it needs); a damaged bag is skipped."""
    import shutil

    from rw_fdi_ros.cli import main
    bags = tmp_path / "bags"
    bags.mkdir()
    for case in ("fault_free", "current_0p6_x"):
        shutil.copytree(runs[case].bag, bags / case)
    code = main(["fit-thresholds", "--bags", str(bags), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "out" / "thresholds_model.json").exists()
    assert "skipped: " in err and "current_0p6_x: records 1 fault(s) (current_limiter from" in err
    assert "skipped 1 of 2 bags" in err
    assert "1 fitting run(s): a band needs at least 10 fault-free runs, whatever the false-alarm rate" in err
    shutil.rmtree(bags / "fault_free")
    assert main(["fit-thresholds", "--bags", str(bags), "--out", str(tmp_path / "out")]) == 2
    assert "no fault-free bag to learn from" in capsys.readouterr().err
