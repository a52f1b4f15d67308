"""`rw-fdi screen` (node code on the core loop) gives the graph's verdicts, run for run.

8 runs through the full live graph and through the screen: 3 of 130 s, each
with a small current loss, a small temperature rise and a ripple increase on
its three wheels (a Latin square: every kind on every wheel), onsets spread
over 30-54 s, and the 5 speed-aware runs (300 s, a fault-free one among them)
that test_fdi_graph judges too (conftest.fdi_runs). Same alarmed
wheels, same first-alarm times, same verdict from scoring.metrics.judge, for
every observer, and the same fault identification. Two more, of varied
wheels, with the observers calibrated to their units (core/fdi/calibration.py).
"""
from concurrent.futures import ThreadPoolExecutor

import pytest

from rw_fdi_ros.fdi_config import FdiConfig

from conftest import CASES
from rw_fdi_ros.core.fdi.calibration import calibration_samples
from rw_fdi_ros.core.mission.scenario import load_scenario
from rw_fdi_ros.core.physics.wheel_set import AXIS_WHEELS
from rw_fdi_ros.runner.fdi_run import run_with_fdi
from rw_fdi_ros.scoring.metrics import judge
from rw_fdi_ros.tools.evaluation.screen import screen_runs

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

# (kind, value): run j puts kind i on wheel (i + j) mod 3, at 30 + 3 (3 j + i) s
KINDS = (("current_limiter", 0.9), ("temperature", 53.0), ("ripple_gain", 1.6))
SEED0 = 20_000_000   # disjoint from every other seed range (docs/fdi.md "Seeds")


def scenario_files(root):
    out = []
    for j in range(len(AXIS_WHEELS)):
        faults = ", ".join(f"{{kind: {kind}, wheel: {AXIS_WHEELS[(i + j) % 3]}, onset: {30.0 + 3.0 * (3 * j + i):g}, "
                           f"value: {value}}}" for i, (kind, value) in enumerate(KINDS))
        path = root / f"screen_{j:02d}.yaml"
        path.write_text(f"name: screen_{j:02d}\nduration: 130.0\nseed: {SEED0 + j}\nfaults: [{faults}]\n")
        out.append(path)
    return out


def unit_files(root):
    """Varied wheels (scenario wheels: variation), fault-free and a 10 % loss on y after the 150 s window."""
    runs = [("[]", SEED0 + 100), ("[{kind: current_limiter, wheel: y, onset: 170.0, value: 0.9}]", SEED0 + 101)]
    out = []
    for i, (faults, seed) in enumerate(runs):
        out.append(root / f"units_{i}.yaml")
        out[-1].write_text(f"name: units_{i}\nduration: 220.0\nseed: {seed}\nwheels: {{variation: true}}\n"
                           f"faults: {faults}\n")
    return out


@pytest.fixture(scope="module")
def both(tmp_path_factory, fdi_runs):
    root = tmp_path_factory.mktemp("screen_vs_graph")
    files = scenario_files(root)
    units = unit_files(root)
    with ThreadPoolExecutor(2) as pool:   # one pool: the calibrated runs fill the gaps of the others
        # the screen judges detection without reconfiguration: the graph's fdir off (the chain: test_fdir_graph.py)
        jobs = [pool.submit(run_with_fdi, str(f), out_dir=root / "bags", fdi={"fdir": False}) for f in files]
        unit_jobs = [pool.submit(run_with_fdi, str(f), out_dir=root / "bags",
                                 fdi={"unit_calibration": 150.0, "fdir": False})
                     for f in units]
        graph = [j.result() for j in jobs]
        calibrated = [j.result() for j in unit_jobs]
    weights, curves = FdiConfig().load()
    screened = screen_runs([load_scenario(str(f)) for f in files], weights, curves, identification=True)
    shared = [k for k, case in CASES.items() if case[2] == "speed_aware"]
    graph += [fdi_runs[k] for k in shared]
    screened += screen_runs([fdi_runs[k].scenario for k in shared], weights, curves,
                            identification=True)   # one batch of its own: longer runs
    assert len(graph) == len(screened) >= 8
    weights, curves = FdiConfig(unit_calibration=150.0).load()
    calibrated_screened = screen_runs([load_scenario(str(f)) for f in units], weights, curves,
                                      calibration_samples=calibration_samples(150.0))
    return graph, screened, calibrated, calibrated_screened


def warnings(outcome, most: int = 20) -> list:
    """The graph's logged warnings and errors (a report decided without its grid, an observer silent): what a
    loaded machine did differently, should the graph's identification part from the screen's."""
    logs = sorted(p for p in outcome.log_dir.rglob("*") if p.is_file()) if outcome.log_dir else []
    lines = [f"{p.name}: {line.strip()}" for p in logs for line in p.read_text(errors="replace").splitlines()
             if "WARN" in line or "ERROR" in line]
    return lines[:most]


def test_screen_gives_the_graph_verdicts(both):
    graph, screened = both[:2]
    detections = 0
    for outcome, run in zip(graph, screened):
        assert outcome.ok, outcome.reason
        live = outcome.summary["fdi"]
        # every observer, and the verdict /diagnostics gave (the decision observer's alarm, latched)
        assert live["observers"] == ["elman", "linear", "model"] and list(run.series) == live["observers"] + [
            "verdict"]
        for obs in run.series:
            series = run.series[obs]
            for i, a in enumerate(AXIS_WHEELS):
                flags = series.alarm[:, i]
                intervals = live[obs][a]
                assert bool(intervals) == bool(flags.any()), (run.bag, obs, a, intervals)
                if intervals:
                    assert intervals[0][0] == pytest.approx(float(series.time[flags.argmax()]), abs=1e-9)
                    detections += 1
            verdict = judge(run, obs)
            assert sorted(verdict["alarmed_wheels"]) == sorted(a for a in AXIS_WHEELS if live[obs][a])
        # fault identification: the isolation node's last word on every alarmed wheel, to the digit
        assert {a: {k: v for k, v in found.items() if k != "message" and k != "samples"}
                for a, found in live["identification"].items()} == run.identification, (run.bag, warnings(outcome))
    assert detections >= 15   # the faults were seen: the comparison is not between two silent FDIs


def test_calibrated_observers_give_the_screen_verdicts_on_varied_wheels(both):
    """Unit calibration live and on the core loop: two runs of varied wheels, one with a 10 % current
    loss after the 150 s the observers learn from; same alarms to the digit."""
    graph, screened = both[2:]
    alarms = 0
    for outcome, run in zip(graph, screened):
        assert outcome.ok, outcome.reason
        for obs in run.series:
            for i, a in enumerate(AXIS_WHEELS):
                flags, intervals = run.series[obs].alarm[:, i], outcome.summary["fdi"][obs][a]
                assert bool(intervals) == bool(flags.any()), (run.bag, obs, a, intervals)
                if intervals:
                    assert intervals[0][0] == pytest.approx(float(run.series[obs].time[flags.argmax()]), abs=1e-9)
                    alarms += obs not in ("linear", "verdict")
    # the fault-free units stay quiet and the 10 % loss is seen by the calibrated Elman and model observers,
    # on wheel y only (the Luenberger observer's figures are reports/units')
    assert not any(graph[0].summary["fdi"][obs][a] for obs in run.series for a in AXIS_WHEELS)
    assert alarms == 2 and all(graph[1].summary["fdi"][obs]["y"] for obs in ("elman", "model"))


FDIR_SCENARIO = """name: fdir_vote
duration: 180.0
seed: 20000300
initial: {wheel_speed: [30.0, 19.0, 17.0]}
faults:
  - {kind: bus_voltage, wheel: x, onset: 60.0, value: 4.5, ramp: 40.0}
  - {kind: current_limiter, wheel: y, onset: 90.0, value: 0.4}
"""


def recorded_states(acts) -> list:
    """What /fdir/wheels records of FDIR's acts (graph/convert.wheel_states_msg, read back by the run summary):
    per wheel and act time, the wheel's state after that time's acts (``at_limit`` is said, it changes no state)
    and the last act's reason."""
    state, out = {}, {}
    for t, wheel, action, reason in acts:
        if action != "at_limit":
            state[wheel] = "given_up" if action == "out_of_use" else action
        out[(t, wheel)] = (state.get(wheel, "in_use"), reason)
    return sorted((t, w, st, r) for (t, w), (st, r) in out.items())


@pytest.mark.parametrize("deciding", ["2of3", "kalman"])
def test_the_decision_and_fdir_act_in_the_screen_as_in_the_graph(deciding, tmp_path, kalman_fdi):
    """`--decision 2of3`, and the Kalman plug-in deciding, with FDIR on: the graph and `rw-fdi screen --fdir` (the
    core loop's FDI pipeline) give the same verdict, the same reconfiguration and the same identification."""
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import read_bag
    from rw_fdi_ros.tools.evaluation.screen import screen
    from conftest import KALMAN
    path = tmp_path / "fdir_vote.yaml"
    path.write_text(FDIR_SCENARIO)
    fdi = (FdiConfig(decision="2of3") if deciding == "2of3"
           else FdiConfig(thresholds=str(kalman_fdi[0]), plugins=(KALMAN,), decision="kalman"))
    outcome = run_with_fdi(str(path), out_dir=tmp_path / "bags", fdi=fdi)
    assert outcome.ok, outcome.reason
    scenario = load_scenario(str(path))
    _, (run,) = screen(scenario, [scenario.seed], fdi)
    live, flags = outcome.summary["fdi"]["verdict"], run.series["verdict"].alarm
    for i, a in enumerate(AXIS_WHEELS):
        assert bool(live[a]) == bool(flags[:, i].any()), (a, live[a])
        if live[a]:
            assert live[a][0][0] == pytest.approx(float(run.series["verdict"].time[flags[:, i].argmax()]), abs=1e-9)
    assert flags[:, 0].any(), "the bus drop on x was decided: the comparison is not between two silent FDIs"
    graph_acts = sorted((d["time"], d["wheel"], d["state"], d["reason"]) for d in outcome.summary["reconfiguration"])
    assert graph_acts == recorded_states(run.reconfiguration) and graph_acts, graph_acts
    assert {a: {k: v for k, v in found.items() if k not in ("message", "samples")}
            for a, found in outcome.summary["fdi"]["identification"].items()} == run.identification
    _, last = read_bag(outcome.bag, [T.DIAGNOSTICS]).topic(T.DIAGNOSTICS)[-1]
    said = "(2 of 3 observers)" if deciding == "2of3" else "(kalman observer)"
    assert all(s.name.endswith(said) for s in T.verdict_statuses(last))
