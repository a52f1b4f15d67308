"""`rw-fdi screen` (node code on the core loop) gives the graph's verdicts, run for run.

20 runs through the full live graph and through the screen: 15 of 130 s
(small faults on every wheel with onsets spread over the run, a ripple
increase, fault-free runs; two at a time) and the 5 distinct speed-aware
runs (300 s) that test_fdi_graph judges too (conftest.fdi_runs). Same alarmed
wheels, same first-alarm times, same verdict from tools.metrics.judge, for
both observers, and the same fault identification.
"""
from concurrent.futures import ThreadPoolExecutor

import pytest

from conftest import CASES
from rw_fdi_ros.core.scenario import AXES, load_scenario
from rw_fdi_ros.tools.fdi import run_with_fdi
from rw_fdi_ros.tools.metrics import judge
from rw_fdi_ros.tools.screen import load_fdi, screen_runs

# (kind, value) per run; wheel = index mod 3, onset spread over 30..72 s
KINDS = [("current_limiter", 0.9)] * 5 + [("temperature", 53.0)] * 4 + [("ripple_gain", 1.6)] * 3 + [None] * 3
SEED0 = 20_000_000   # disjoint from every other seed range (README "Seeds")


def scenario_files(root):
    out = []
    for i, kind in enumerate(KINDS):
        faults = "[]" if kind is None else (f"[{{kind: {kind[0]}, wheel: {AXES[i % 3]}, "
                                            f"onset: {30.0 + 3.0 * i:g}, value: {kind[1]}}}]")
        path = root / f"screen_{i:02d}.yaml"
        path.write_text(f"name: screen_{i:02d}\nduration: 130.0\nseed: {SEED0 + i}\nfaults: {faults}\n")
        out.append(path)
    return out


@pytest.fixture(scope="module")
def both(tmp_path_factory, fdi_runs):
    root = tmp_path_factory.mktemp("screen_vs_graph")
    files = scenario_files(root)
    with ThreadPoolExecutor(2) as pool:
        graph = list(pool.map(lambda f: run_with_fdi(str(f), out_dir=root / "bags"), files))
    weights, curves = load_fdi()
    screened = screen_runs([load_scenario(str(f)) for f in files], weights, curves, identification=True)
    shared = [k for k, case in CASES.items() if case[2] == "speed_aware" and not k.endswith("_again")]
    graph += [fdi_runs[k] for k in shared]
    screened += screen_runs([fdi_runs[k].scenario for k in shared], weights, curves,
                            identification=True)   # one batch of its own: longer runs
    assert len(graph) == len(screened) >= 20
    return graph, screened


def test_screen_gives_the_graph_verdicts(both):
    graph, screened = both
    detections = 0
    for outcome, run in zip(graph, screened):
        assert outcome.ok, outcome.reason
        live = outcome.summary["fdi"]
        for obs in ("elman", "linear"):
            series = run.series[obs]
            for i, a in enumerate(AXES):
                flags = series.alarm[:, i]
                intervals = live[obs][a]
                assert bool(intervals) == bool(flags.any()), (run.bag, obs, a, intervals)
                if intervals:
                    assert intervals[0][0] == pytest.approx(float(series.time[flags.argmax()]), abs=1e-9)
                    detections += 1
            verdict = judge(run, obs)
            assert sorted(verdict["alarmed_axes"]) == sorted(a for a in AXES if live[obs][a])
        # fault identification: the isolation node's last word on every alarmed wheel, to the digit
        assert {a: {k: v for k, v in found.items() if k != "message" and k != "samples"}
                for a, found in live["identification"].items()} == run.identification, run.bag
    assert detections >= 20   # the faults were seen: the comparison is not between two silent FDIs
