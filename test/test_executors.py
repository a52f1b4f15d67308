"""The Monte-Carlo commands give the same results whatever the executor: local processes, or a Dask cluster of
two workers in processes of their own (`--scheduler`). A screen and the service bench, run for run."""
import numpy as np
import pytest

from rw_fdi_ros.core.mission.scenario import parse_scenario
from rw_fdi_ros.tools.benches.service_bench import SEED_BASES, run_service
from rw_fdi_ros.tools.campaigns.campaign import DaskExecutor, LocalExecutor
from rw_fdi_ros.tools.evaluation.screen import screen

# no ROS graph and nothing timed: it runs in the session beside the graph tests, whose slack it fills

SCENARIO = """name: executors
duration: 90.0
faults: [{kind: current_limiter, wheel: y, onset: 30.0, value: 0.6}]
"""
SEEDS = range(23_000_000, 23_000_005)   # disjoint from every other seed range (docs/fdi.md "Seeds")


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
            Client(c) as client:
        yield DaskExecutor(client)


def test_a_screen_gives_the_same_runs_on_local_processes_and_on_a_cluster(cluster):
    scenario = parse_scenario(SCENARIO, "executors")
    local_counts, local = screen(scenario, SEEDS, executor=LocalExecutor(2))
    dask_counts, dask = screen(scenario, SEEDS, executor=cluster)
    assert [r.seed for r in local] == [r.seed for r in dask] == list(SEEDS)
    assert local_counts == dask_counts and local_counts["verdict"]["correct"] == len(SEEDS)
    for a, b in zip(local, dask):
        assert a.identification == b.identification
        for obs in a.series:
            np.testing.assert_array_equal(a.series[obs].residual, b.series[obs].residual)
            np.testing.assert_array_equal(a.series[obs].alarm, b.series[obs].alarm)


def test_the_service_bench_gives_the_same_runs_on_local_processes_and_on_a_cluster(cluster):
    seeds, free = range(SEED_BASES["net"] + 10, SEED_BASES["net"] + 11), [SEED_BASES["net"] + 500_000]
    local = run_service(seeds, LocalExecutor(2), max_duration=600.0, fault_free_seeds=free)
    dask = run_service(seeds, cluster, max_duration=600.0, fault_free_seeds=free)
    assert [r["seed"] for r in local] == [*seeds, *free] and local == dask


def test_bags_are_read_into_the_same_samples_on_any_executor(cluster, tmp_path):
    """fit-thresholds' bag loading: three core-engine bags and a damaged one, read here, on local processes and on
    the cluster: the same samples in bag order, the same bag skipped with the same reason."""
    from rw_fdi_ros.tools.campaigns.campaign import run_campaign
    from rw_fdi_ros.tools.design.samples import load_samples
    scenario = tmp_path / "ff.yaml"
    scenario.write_text("name: ff\nduration: 40.0\nseed: 0\n")
    result = run_campaign(str(scenario), 3, 23_000_100, tmp_path / "bags", engine="core", desc="bags")
    assert not result.failed and len(result.done) == 3
    damaged = tmp_path / "bags" / "zz_damaged"
    damaged.mkdir()
    (damaged / "zz_damaged_0.mcap").write_bytes(b"not an mcap file")
    read = {}
    for name, executor in (("here", None), ("local", LocalExecutor(2)), ("dask", cluster)):
        skipped = []
        read[name] = (load_samples(tmp_path / "bags", on_skip=skipped.append, fault_free=True, executor=executor),
                      skipped)
    here, skipped = read["here"]
    assert len(here) == 3 and len(skipped) == 1 and "zz_damaged" in skipped[0]
    for name in ("local", "dask"):
        samples, why = read[name]
        assert why == skipped and [s.seed for s in samples] == [s.seed for s in here]
        for a, b in zip(samples, here):
            np.testing.assert_array_equal(a.reaction_torque, b.reaction_torque)
            np.testing.assert_array_equal(a.time, b.time)
