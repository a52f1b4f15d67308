"""Timing figures the nodes report to `rw-fdi bench` (median and p99, milliseconds)."""
import numpy as np


def summary(**series) -> dict:
    """Median, 99th percentile, maximum [ms] and count of each series of durations [s] (the empty ones left out).

    Parameters
    ----------
    **series : sequence of float
        name -> durations [s].

    Returns
    -------
    dict
        '<name>_median_ms', '<name>_p99_ms', '<name>_max_ms', '<name>_count' -> value.
    """
    out = {}
    for name, values in series.items():
        if len(values):
            v = np.asarray(values) * 1e3
            out[f"{name}_median_ms"] = float(np.median(v))
            out[f"{name}_p99_ms"] = float(np.percentile(v, 99))
            out[f"{name}_max_ms"] = float(v.max())   # a flight computer's deadline is the worst period's
            out[f"{name}_count"] = int(len(v))
    return out
