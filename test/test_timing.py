"""graph/timing.summary: what `rw-fdi bench fdi` and `bench graph` report of each node's durations."""
import numpy as np

from rw_fdi_ros.graph.timing import summary


def test_a_series_gives_its_median_p99_and_worst_in_ms_and_an_empty_one_nothing():
    durations = [0.001] * 98 + [0.002, 0.050]   # [s]: one slow period among a hundred
    out = summary(callback=durations, idle=[])
    assert out["callback_median_ms"] == 1.0 and out["callback_max_ms"] == 50.0 and out["callback_count"] == 100
    assert out["callback_p99_ms"] == np.percentile(np.array(durations) * 1e3, 99) and 2.0 < out["callback_p99_ms"] < 50
    assert not any(k.startswith("idle") for k in out)
