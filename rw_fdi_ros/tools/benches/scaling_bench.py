"""`rw-fdi bench scaling`: in-service runs per second on 1 and 2 workers, and what 100,000 would take.

The runs are the service bench's family (campaigns/service_family.draw), on seeds of their own (93,000,000 on),
shortened to ``max_hours`` so that the bench takes a few minutes; the time of a run grows with its
simulated time, so the projection for 100,000 runs of the whole family (600 s to 6 h, 0.61 h each on
average: service_family.DURATIONS) goes by simulated hours per wall second. Each worker count runs the
same runs, on local processes, or on a Dask cluster given its scheduler (its own worker count).

The core loop steps the runs that share a duration, wheel units and orbit as one batch (numpy lanes,
service_family.batches): a run in a batch of a dozen or more costs a quarter of one flown alone, and a campaign
of thousands fills its batches. So the bench draws enough runs (100 by default) that most batches hold ten or
more; it prints the batches it flew.
"""
from __future__ import annotations

import os
import time

from ..campaigns.campaign import DaskExecutor, LocalExecutor
from ..campaigns.service_family import DURATIONS, batches, draw
from .service_bench import run_service

SEED_BASE = 93_000_000
PROJECTED_RUNS = 100_000


def bench_scaling(runs: int = 100, max_hours: float = 0.25, workers=(1, 2), scheduler: str | None = None,
                  progress=None) -> dict:
    """Runs per second and simulated hours per wall second for each count of ``workers`` (or, with
    ``scheduler``, the cluster's), and the wall time projected for PROJECTED_RUNS in-service runs."""
    seeds = range(SEED_BASE, SEED_BASE + runs)
    draws = [draw(s, 3600.0 * max_hours) for s in seeds]
    simulated_h = sum(d.duration for d in draws) / 3600.0
    sizes = sorted((len(b) for b in batches(draws)), reverse=True)
    family_h = sum(d * share for d, share in DURATIONS) / 3600.0   # a run of the family, on average
    rows = []
    for n in ([None] if scheduler else workers):
        executor = DaskExecutor(scheduler) if scheduler else LocalExecutor(n)
        t0 = time.monotonic()
        done = run_service(seeds, executor, progress, 3600.0 * max_hours)
        wall = time.monotonic() - t0
        rate = simulated_h / wall
        rows.append({"workers": n or scheduler, "runs": len(done), "wall_s": wall, "runs_per_s": len(done) / wall,
                     "simulated_h_per_wall_s": rate,
                     "projected_h": PROJECTED_RUNS * family_h / rate / 3600.0})
    lines = [f"scaling bench: {runs} in-service runs of at most {max_hours:g} h ({simulated_h:.1f} simulated h), "
             f"seeds {seeds.start}-{seeds.stop - 1}, on {os.cpu_count()} cores",
             f"  projection: {PROJECTED_RUNS:,} runs of the whole family ({family_h:.2f} h each on average, "
             f"{PROJECTED_RUNS * family_h:,.0f} simulated h) at the measured simulated hours per wall second",
             f"  batches flown (runs each): {', '.join(map(str, sizes))}"]
    for r in rows:
        who = f"{r['workers']} worker(s)" if isinstance(r["workers"], int) else f"cluster {r['workers']}"
        lines.append(f"  {who}: {r['runs_per_s']:.3f} runs/s, "
                     f"{r['simulated_h_per_wall_s']:.2f} simulated h per wall s -> {PROJECTED_RUNS:,} runs in "
                     f"{r['projected_h']:.1f} h")
    if len(rows) > 1:
        speedup = rows[-1]["simulated_h_per_wall_s"] / rows[0]["simulated_h_per_wall_s"]
        lines.append(f"  speed-up {rows[0]['workers']} -> {rows[-1]['workers']} workers: {speedup:.2f}x")
    return {"schema": "rw_fdi_ros/scaling_bench/1", "runs": runs, "max_hours": max_hours,
            "seeds": [seeds.start, seeds.stop - 1], "simulated_h": simulated_h, "family_h_per_run": family_h,
            "rows": rows, "text": "\n".join(lines), "ok": all(r["runs"] == runs for r in rows)}
