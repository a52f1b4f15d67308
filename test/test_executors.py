"""The Monte-Carlo commands give the same results whatever the executor: local processes, or a Dask cluster of
two workers in processes of their own (`--scheduler`). A screen and the service bench, run for run."""
import numpy as np
import pytest

from rw_fdi_ros.core.scenario import parse_scenario
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
