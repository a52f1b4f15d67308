"""End to end: `rw-fdi reproduce --scale small`, its report against the schema, replay, bad bags, Dask.

One small study (22 runs of 120 s: fitting, held-out, Table 4.2 kinds on x/y/z,
a grid cell per kind, ripple, multiple faults), then the evaluation of bad
bags next to good ones, and a campaign on a Dask LocalCluster.
"""
import json
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from rw_fdi_ros.core.physics.wheel_set import AXIS_WHEELS
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.storage.bag import BagError, read_bag
from rw_fdi_ros.storage.writer import BagWriter
from rw_fdi_ros.tools.campaigns.campaign import DaskExecutor, LocalExecutor, run_campaign
from rw_fdi_ros.tools.evaluation.evaluate import evaluate
from rw_fdi_ros.tools.evaluation.report import validate_report
from rw_fdi_ros.tools.evaluation.reproduce import plan, reproduce
from rw_fdi_ros.runner.scenario_run import short_step_topics

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro")
    report = reproduce(out, "small")
    return out, report


def test_plan_puts_faults_on_every_axis(tmp_path):
    jobs = plan(tmp_path, "thesis")
    assert sum(n for g, _, n, _ in jobs if g == "table42") == 300
    assert sum(n for g, _, n, _ in jobs if g == "grid") == 120
    wheels = {Path(f).stem[-1] for g, f, _, _ in jobs if g in ("table42", "grid")}
    assert wheels == set(AXIS_WHEELS)
    seeds = [range(s, s + n) for _, _, n, s in jobs]
    flat = [x for r in seeds for x in r]
    assert len(flat) == len(set(flat))            # every run its own seed


def test_small_reproduce_writes_a_report_that_passes_its_schema(study):
    out, report = study
    raw = json.loads((out / "report" / "report.json").read_text())
    validate_report(raw)
    assert raw["runs"] == 22 and raw["skipped"] == []
    assert list(raw["observers"]) == ["elman", "linear", "model"]   # the speed-aware method's three
    for obs in raw["observers"]:
        figs = raw["observers"][obs]
        assert figs["reliability"]["runs"] == 10     # 12 fit-group runs: 2 train, 10 fit thresholds (enough for 0.006)
        assert figs["false_alarm_heldout"]["n"] == 2
        kinds = {c["kind"] for c in figs["faults"]}
        assert {"bus_voltage", "current_limiter", "temperature", "multiple"} <= kinds
    text = (out / "report" / "report.md").read_text()
    assert "Threshold reliability" in text and "thesis" in text and "runs per minute" in text
    assert (out / "report" / "detection_grid.png").stat().st_size > 5000
    assert {"record fit", "train", "evaluate (core)", "graph sample (record, replay, compare)", "total"} <= set(
        raw["stages"])
    # recorded and judged by the core engine; one run per group through the graph as well: the same bags,
    # the same evaluation
    check = raw["engines"]["graph_sample"]
    assert raw["engines"]["recorded_and_judged_by"] == "core" and raw["engine"] == "core"
    assert check["runs"] == 6 and check["identical_bags"] == 6 and check["differing"] == [], check["differing"]
    assert check["evaluated"] == 6 and check["evaluation_agrees"]
    assert "6 of 6** bags the same" in text
    from rw_fdi_ros.storage.bag import bag_engine
    assert {bag_engine(b) for b in (out / "bags").glob("*/*")} == {"core"}
    # the report names no path of the machine that made it, and says what the FDI said of itself
    for made_here in (str(out.resolve()), str(out.parent.resolve())):
        assert made_here not in text and made_here not in json.dumps(raw)
    assert "## The FDI's own health" in text and raw["health"] == []


def _same_fdi_result(live_bag, replayed_bag):
    a, b = read_bag(live_bag), read_bag(replayed_bag)
    for obs in T.OBSERVERS:
        for key in ("alarm", "threshold"):
            ta, va = a.wheel_values(T.fdi_output_topics(obs)[key])
            tb, vb = b.wheel_values(T.fdi_output_topics(obs)[key])
            np.testing.assert_array_equal(ta, tb)
            np.testing.assert_array_equal(va, vb)
    for wheel in ("x", "y", "z", "s"):
        np.testing.assert_array_equal(a.wheel_values(T.observer_topic("elman", "residual", wheel))[1],
                                      b.wheel_values(T.observer_topic("elman", "residual", wheel))[1])
    assert [m.status for _, m in a.topic(T.IDENTIFICATION)] == [m.status for _, m in b.topic(T.IDENTIFICATION)]
    return a


def test_replay_equals_the_live_result(study):
    """Bags replayed one after another through one graph (the FDI nodes start over at each run) give
    exactly the FDI result recorded live in each; so does a replay paced by the wall clock."""
    from rw_fdi_ros.runner.fdi_run import run_with_fdi
    from rw_fdi_ros.tools.campaigns.replay import replay_bag, replay_bags
    out, _ = study
    scenario = next((out / "scenarios").glob("current_*pct_*.yaml"))
    models = out / "models"
    with ThreadPoolExecutor(2) as pool:   # each graph in its own domain
        live = list(pool.map(lambda seed: run_with_fdi(str(scenario), seed=seed, out_dir=out / "live",
                                                      fdi={"models": models}), (77, 78)))
    assert all(run.ok for run in live), [run.reason for run in live]
    order = [live[0].bag, live[1].bag, live[0].bag]    # a run after a different one, and again
    outcomes = replay_bags(order, [out / f"replayed_{i}" for i in range(3)], {"models": models})
    assert [o.ok for o in outcomes] == [True] * 3, [o.reason for o in outcomes]
    alarmed = [_same_fdi_result(bag, o.bag) for bag, o in zip(order, outcomes)]
    assert any(np.any(a.wheel_values(T.fdi_output_topics("elman")["alarm"])[1]) for a in alarmed)   # a fault seen
    paced = replay_bag(live[0].bag, out / "replayed_paced", {"models": models}, rate=40.0)
    assert paced.ok, paced.reason
    _same_fdi_result(live[0].bag, paced.bag)


def test_bad_bags_are_skipped_with_a_reason_and_the_rest_goes_on(study, tmp_path):
    out, _ = study
    good = sorted((out / "bags" / "table42").iterdir())[0]
    bags = tmp_path / "bags"
    shutil.copytree(good, bags / "good")
    shutil.copytree(good, bags / "truncated")
    (bags / "truncated" / "metadata.yaml").unlink()
    mcap = next((bags / "truncated").glob("*.mcap"))
    with open(mcap, "r+b") as fh:
        fh.truncate(mcap.stat().st_size // 3)
    w = BagWriter(bags / "no_truth")
    w.add_topic(T.ATTITUDE, T.JOINT_STATE)
    w.write("/attitude", 0, bytes(read_bag(good, topics=[T.ATTITUDE], raw=True).topic(T.ATTITUDE)[0][1]))
    w.close()
    whole = read_bag(good, raw=True)   # a run stopped at 30 s (interrupted): complete file, no /plant/done
    w = BagWriter(bags / "interrupted")
    for topic in whole.messages:
        w.add_topic(topic, whole.types[topic])
    for t, topic, raw in sorted(((t, topic, raw) for topic, msgs in whole.messages.items() for t, raw in msgs
                                 if topic != T.PLANT_DONE and t <= 30 * 10**9), key=lambda r: r[0]):
        w.write(topic, t, raw)
    w.close()
    w = BagWriter(bags / "lost_attitude")   # what a CI run once recorded: every step, not one /attitude
    for topic in whole.messages:
        w.add_topic(topic, whole.types[topic])
    for t, topic, raw in sorted(((t, topic, raw) for topic, msgs in whole.messages.items() for t, raw in msgs
                                 if topic != T.ATTITUDE), key=lambda r: r[0]):
        w.write(topic, t, raw)
    w.close()
    assert short_step_topics(bags / "lost_attitude") == [T.ATTITUDE] and short_step_topics(good) == []
    (bags / "metadata_only").mkdir()   # its data file gone: answered, not passed over in silence
    shutil.copy(good / "metadata.yaml", bags / "metadata_only")
    models = out / "models"
    report = evaluate(bags, tmp_path / "report", {"models": models}, plots=False)
    assert report["runs"] == 1
    reasons = {Path(s["bag"]).name: s["reason"] for s in report["skipped"]}
    assert "incomplete bag" in reasons["truncated"]
    assert "no /scenario message (no ground truth)" in reasons["no_truth"]
    assert "no .mcap data file (only metadata.yaml)" in reasons["metadata_only"]
    assert "short: the run stopped at 30 s of" in reasons["interrupted"] and "interrupted" in reasons["interrupted"]
    assert "/attitude short of the run's end (its recorder lost messages" in reasons["lost_attitude"]
    # what training and fitting learn from, and what a resumed campaign keeps: only the whole run (issue 56)
    from rw_fdi_ros.runner.scenario_run import not_whole
    from rw_fdi_ros.tools.design.samples import load_samples
    said = []
    assert [s.bag.name for s in load_samples(bags, on_skip=said.append)] == ["good"]
    why = {Path(line.split(":")[0]).name: line for line in said}
    assert {"truncated", "interrupted", "lost_attitude"} <= set(why), said
    assert "run interrupted" in why["interrupted"] and "lost messages on /attitude" in why["lost_attitude"]
    assert [b.name for b in sorted(bags.iterdir()) if not not_whole(b)] == ["good"]

    with pytest.raises(BagError, match="no bags to evaluate"):
        (tmp_path / "empty").mkdir()
        evaluate(tmp_path / "empty", tmp_path / "r2", {"models": models})

    mismatched = tmp_path / "mismatched"
    shutil.copytree(models, mismatched)
    for obs in ("elman", "linear", "model"):
        p = mismatched / f"thresholds_{obs}.json"
        raw = json.loads(p.read_text())
        raw["plant"]["emf_limit"] = "pwm_saturation"
        p.write_text(json.dumps(raw))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)   # nothing evaluated: no plots of nothing (matplotlib warned)
        report = evaluate(bags, tmp_path / "r3", {"models": models, "thresholds": mismatched})
    assert report["runs"] == 0 and not list((tmp_path / "r3").glob("*.png"))
    assert "fitted with emf_limit='pwm_saturation' but the graph runs emf_limit='kf_scaled'" in \
        {Path(s["bag"]).name: s["reason"] for s in report["skipped"]}["good"]


def test_dask_local_cluster_gives_the_same_bags_as_local_processes(tmp_path, study):
    from distributed import Client, LocalCluster
    out, _ = study
    scenario = str(out / "scenarios" / "fault_free.yaml")
    local = run_campaign(scenario, 2, 900, tmp_path / "local", executor=LocalExecutor(2))
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        dask = run_campaign(scenario, 2, 900, tmp_path / "dask", executor=DaskExecutor(client))
    assert not local.failed and not dask.failed
    for bag in sorted(local.done):
        a, b = read_bag(bag), read_bag(tmp_path / "dask" / bag.name)
        for topic in (T.ATTITUDE, T.WHEELS):
            for x, y in zip(a.joint_states(topic), b.joint_states(topic)):
                np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(a.vectors(T.tcv_command("z"))[1], b.vectors(T.tcv_command("z"))[1])
        for topic in (T.FDI_TELEMETRY, T.FDI_BUS_GRID):   # the very bytes
            raw_a, raw_b = (read_bag(p, topics=[topic], raw=True).topic(topic)
                            for p in (bag, tmp_path / "dask" / bag.name))
            assert raw_a and raw_a == raw_b, topic


def test_a_resumed_study_keeps_its_stage_times(study):
    """Run last: reproducing again finds every recording and the training done, keeps the first session's
    figures, adds a session (the core engine's evaluation, seconds long, is done again; the graph sample, which
    test_small_reproduce_... judges, is left out of it)."""
    out, first = study
    again = reproduce(out, "small", graph_sample=0)
    for stage in ("record fit", "record table42", "train"):
        assert again["stages"][stage] == first["stages"][stage]
    assert again["runs"] == first["runs"] and again["observers"] == first["observers"]
    sessions = again["provenance"]["sessions"]
    assert len(sessions) == 2 and all(s["commit"] == sessions[0]["commit"] for s in sessions)
    assert again["stages"]["total"]["seconds"] > first["stages"]["total"]["seconds"]
    assert "Sessions (a resumed study" in (out / "report" / "report.md").read_text()
    validate_report(json.loads((out / "report" / "report.json").read_text()))


def test_a_bad_bag_in_a_replay_graph_fails_alone(study, tmp_path):
    """One graph for [good, a bag without FDI telemetry, good]: the recorder refuses to close the bad run
    as finished, the graph is split, and both good bags are still replayed; a bag that cannot be read
    at all is answered before any graph starts."""
    from rw_fdi_ros.tools.campaigns.replay import replay_bags, replay_finished
    out, _ = study
    good = sorted((out / "bags" / "table42").iterdir())[:2]
    data = read_bag(good[0], topics=[T.SCENARIO, T.PLANT_DONE], raw=True)
    bad = tmp_path / "no_telemetry"
    w = BagWriter(bad)
    for topic in (T.SCENARIO, T.PLANT_DONE):
        w.add_topic(topic, data.types[topic])
        for t, raw in data.topic(topic):
            w.write(topic, t, raw)
    w.close()
    outs = [tmp_path / f"replayed_{i}" for i in range(4)]
    models = out / "models"
    outcomes = replay_bags([good[0], bad, good[1], tmp_path / "nothing_here"], outs, {"models": models})
    assert [o.ok for o in outcomes] == [True, False, True, False], [o.reason for o in outcomes]
    assert "did not reach the run's end" in outcomes[1].reason and "no .mcap file" in outcomes[3].reason
    assert replay_finished(outs[0]) and replay_finished(outs[2]) and not outs[1].exists()
