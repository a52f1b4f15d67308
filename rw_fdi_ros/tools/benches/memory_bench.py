"""Peak memory of reading a run back, against the run's length (bounded by design, whatever the length).

Records a fault-free run with the FDI live for each length, then measures, each in a fresh
process, the peak resident memory of what reads the bag afterwards:
- ``rw-fdi run``: the launcher and, after the graph ends, the run summary, verdict and figure;
- ``rw-fdi bag BAG --figure``: the same summary, verdict and figure from a finished bag;
- ``rw-fdi evaluate``: the replay of the bag through the FDI nodes and the report; its own
  process, and the largest of the node processes it started (the player streams the bag).

What may grow with the run is the figures themselves: the residual, threshold and alarm
series judged and drawn (about 1 kB per second of run), not the messages.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# runs a CLI command in this process and reports its own peak and its children's peak (kB)
_PROBE = """
import json, resource, sys
from rw_fdi_ros.cli import main
code = main(sys.argv[2:])
own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
with open(sys.argv[1], "w") as fh:
    json.dump({"code": code, "own_kb": own, "children_kb": kids}, fh)
sys.exit(code)
"""


def peak_memory(argv: list, env=None) -> dict:
    """Exit code, wall time [s] and peak resident memory [MB] of ``rw-fdi <argv>`` in a fresh process."""
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        start = time.monotonic()
        proc = subprocess.run([sys.executable, "-c", _PROBE, out.name, *argv], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wall = time.monotonic() - start
        text = Path(out.name).read_text()
    probe = json.loads(text) if text else {"code": proc.returncode, "own_kb": 0, "children_kb": 0}
    return {"code": probe["code"], "wall_s": wall, "own_mb": probe["own_kb"] / 1024,
            "children_mb": probe["children_kb"] / 1024, "output": proc.stdout[-2000:]}


def bench_memory(hours=(1.0, 6.0), seed: int = 7, out: str | Path = "reports/memory", work=None) -> dict:
    """Peak memory of the run summary, `rw-fdi bag` and evaluation for fault-free runs of ``hours``;
    the figures to ``out``/memory.md and .json, the bags (about 125 MB per hour) in ``work``."""
    from .kit import write_report
    work = Path(work or tempfile.mkdtemp(prefix="rw_fdi_memory_"))
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for h in hours:
        seconds = h * 3600.0
        name = f"fault_free_{h:g}h"
        scenario = work / f"{name}.yaml"
        scenario.write_text(f"name: {name}\nduration: {seconds:g}\nseed: {seed}\nfaults: []\n")
        bags = work / f"bags_{h:g}h"
        run = peak_memory(["run", "--scenario", str(scenario), "--out", str(bags)])
        bag = bags / f"{name}_s{seed:04d}"
        size = sum(f.stat().st_size for f in bag.glob("*")) / 2**20 if bag.exists() else 0.0
        read = peak_memory(["bag", str(bag), "--figure", str(work / f"{name}.png")])
        evaluation = peak_memory(["evaluate", "--bags", str(bags), "--report", str(work / f"report_{h:g}h")])
        rows.append({"hours": h, "bag_mb": size, "run": run, "bag": read, "evaluate": evaluation})
    ok = all(r[k]["code"] == 0 for r in rows for k in ("run", "bag", "evaluate"))
    # a step's output only where it failed: the rest names the work directory of this machine
    kept = [{k: ({**v, "output": v["output"] if v["code"] else ""} if isinstance(v, dict) else v)
             for k, v in r.items()} for r in rows]
    report = {"schema": "rw_fdi_ros/memory_bench/1", "date": time.strftime("%Y-%m-%d"), "seed": seed,
              "rows": kept, "command": f"rw-fdi bench memory --hours {','.join(f'{h:g}' for h in hours)} "
                                      f"--seed {seed}"}
    report = write_report(report, out, "memory", lambda r: format_memory(r["rows"], r["seed"]))
    report["ok"] = ok
    return report


def format_memory(rows: list, seed: int) -> str:
    """The bench's table: peak memory per step and run length, and what grew between the extremes."""
    lines = [f"memory bench: fault-free runs with the FDI live, seed {seed}; peak resident memory [MB] "
             "of each step in a fresh process", f"  {'run':>6s} {'bag':>7s}  {'rw-fdi run':>11s}  "
             f"{'rw-fdi bag':>11s}  {'evaluate':>9s}  {'its nodes':>9s}  wall run/bag/evaluate [s]"]
    for r in rows:
        lines.append(f"  {r['hours']:5g}h {r['bag_mb']:6.0f}M  {r['run']['own_mb']:11.0f}  {r['bag']['own_mb']:11.0f}  "
                     f"{r['evaluate']['own_mb']:9.0f}  {r['evaluate']['children_mb']:9.0f}  "
                     f"{r['run']['wall_s']:.0f} / {r['bag']['wall_s']:.0f} / {r['evaluate']['wall_s']:.0f}")
    if len(rows) >= 2:
        a, b = rows[0], rows[-1]
        grow = {k: b[k]["own_mb"] - a[k]["own_mb"] for k in ("run", "bag", "evaluate")}
        grow["nodes"] = b["evaluate"]["children_mb"] - a["evaluate"]["children_mb"]
        lines.append(f"  {b['hours']:g}h - {a['hours']:g}h: " + ", ".join(f"{k} {v:+.0f} MB" for k, v in grow.items())
                     + f" (the figures' own series: about {_series_mb(b['hours']) - _series_mb(a['hours']):.0f} MB)")
    for r in rows:
        for k in ("run", "bag", "evaluate"):
            if r[k]["code"] != 0:
                lines.append(f"  FAILED {k} ({r['hours']:g}h): exit {r[k]['code']}: {r[k]['output'][-300:]}")
    return "\n".join(lines)


def _series_mb(hours: float) -> float:
    """What the verdict and the figure keep: per FDI sample one row of each Vector3Stamped topic they
    read (a stamp and 3 float64: 32 bytes), twice (as read, then sorted by stamp)."""
    from ...core.mission.plant_choices import FDI_PERIOD
    from ...runner.verdict import verdict_topics
    vector_topics = len(verdict_topics()) - 2   # all but /scenario and /fdi/identification
    return 2 * hours * 3600.0 / FDI_PERIOD * vector_topics * 32 / 2**20
