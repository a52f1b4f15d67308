"""Benchmarks: figures printed, never asserted in tests."""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path


def _timing_reports(log_dir: Path):
    reports = {}
    for log in sorted(Path(log_dir).glob("*.log")):
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith("RW_FDI_TIMING "):
                r = json.loads(line.split(" ", 1)[1])
                reports[r["node"]] = r
    return reports


def bench_graph(duration: float = 400.0, seed: int = 1) -> dict:
    """Real-time factor of a recorded fault-free run and where the time goes."""
    from .run import run_scenario
    os.environ["RW_FDI_TIMING"] = "1"
    out = Path(tempfile.mkdtemp(prefix="rw_fdi_bench_"))
    scenario = out / "bench.yaml"
    scenario.write_text(f"name: bench\nduration: {duration}\nseed: {seed}\nfaults: []\n")
    outcome = run_scenario(str(scenario), out_dir=out, keep_logs=True)
    reports = _timing_reports(outcome.log_dir) if outcome.log_dir else {}
    plant = reports.get("plant", {})
    steps = plant.get("steps", 0)
    report = {"ok": outcome.ok, "reason": outcome.reason, "sim_seconds": duration,
              "wall_seconds": outcome.wall_time, "real_time_factor": duration / outcome.wall_time,
              "steps": steps, "nodes": reports}
    lines = [f"graph bench: {duration:g} s fault-free run, plant + 3 PID controllers + recorder",
             f"  wall {outcome.wall_time:.2f} s (process start-up included) -> {duration / outcome.wall_time:.1f}x real time"]
    if plant:
        lines.append(f"  lockstep step: median {plant['step_median_ms']:.3f} ms, p99 {plant['step_p99_ms']:.3f} ms "
                     f"(publish k -> all commands k in); plant physics median {plant['compute_median_ms']:.3f} ms")
        loop = steps * (plant["step_median_ms"] + plant["compute_median_ms"]) / 1e3
        lines.append(f"  stepping loop ~{loop:.2f} s; the rest is process start-up, discovery and bag finalising")
    lines.append("  CPU seconds per node (2 cores shared by all):")
    for name, r in reports.items():
        lines.append(f"    {name:18s} cpu {r['cpu_s']:6.2f} s  max RSS {r['max_rss_mb']:6.1f} MB")
    if not outcome.ok:
        lines.append(f"  FAILED: {outcome.reason}")
    report["text"] = "\n".join(lines)
    return report
