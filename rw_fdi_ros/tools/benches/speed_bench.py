"""Benchmarks: figures printed, never asserted in tests."""
from __future__ import annotations

import json
import os
import tempfile
from contextlib import closing
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
    """Real-time factor of a recorded fault-free run and where the time goes: the default grouping of the
    nodes into processes (composed) and every node its own process, in the same sitting."""
    from ...runner.graph import DEFAULT_GROUPING
    report = {"sim_seconds": duration, "groupings": {}}
    texts = []
    for grouping in (DEFAULT_GROUPING, "none"):
        r = _bench_graph_run(duration, seed, grouping)
        report["groupings"][grouping] = r
        texts.append(r["text"])
    report["ok"] = all(r["ok"] for r in report["groupings"].values())
    report["text"] = "\n".join(texts)
    return report


def _bench_graph_run(duration: float, seed: int, grouping: str) -> dict:
    from ...runner.scenario_run import run_scenario
    os.environ["RW_FDI_TIMING"] = "1"
    out = Path(tempfile.mkdtemp(prefix="rw_fdi_bench_"))
    scenario = out / "bench.yaml"
    scenario.write_text(f"name: bench\nduration: {duration}\nseed: {seed}\nfaults: []\n")
    outcome = run_scenario(str(scenario), out_dir=out, keep_logs=True, grouping=grouping)
    reports = _timing_reports(outcome.log_dir) if outcome.log_dir else {}
    plant = reports.get("plant", {})
    steps = plant.get("steps", 0)
    processes = "one process" if grouping != "none" else "one process per node"
    report = {"ok": outcome.ok, "reason": outcome.reason, "sim_seconds": duration, "grouping": grouping,
              "wall_seconds": outcome.wall_time, "real_time_factor": duration / outcome.wall_time,
              "steps": steps, "nodes": reports}
    lines = [f"graph bench ({grouping}: {processes}): {duration:g} s fault-free run, plant + 3 PID controllers "
             "+ wheel allocation + recorder",
             f"  wall {outcome.wall_time:.2f} s (process start-up included) -> "
             f"{duration / outcome.wall_time:.1f}x real time"]
    if plant:
        lines.append(f"  lockstep step: median {plant['step_median_ms']:.3f} ms, p99 {plant['step_p99_ms']:.3f} ms "
                     f"(publish k -> all commands k in); plant physics median {plant['compute_median_ms']:.3f} ms")
        if "stepping_s" in plant:
            rest = outcome.wall_time - plant["discovery_s"] - plant["stepping_s"]
            lines.append(f"  stepping {plant['stepping_s']:.2f} s ({duration / plant['stepping_s']:.0f}x real time), "
                         f"waiting for the graph to match {plant['discovery_s']:.2f} s, the rest {rest:.2f} s "
                         "(process start, imports, teardown, bag finalising)")
    lines.append("  CPU seconds per process (2 cores shared by all):")
    seen = set()
    for name, r in reports.items():
        key = r.get("pid", name)   # a composed process' nodes each report the process' figures
        if r.get("process_nodes", 1) > 1 and key in seen:
            continue
        seen.add(key)
        label = name if r.get("process_nodes", 1) == 1 else f"{name} + {r['process_nodes'] - 1} more"
        lines.append(f"    {label:24s} cpu {r['cpu_s']:6.2f} s  max RSS {r['max_rss_mb']:6.1f} MB")
    if not outcome.ok:
        lines.append(f"  FAILED: {outcome.reason}")
    report["text"] = "\n".join(lines)
    return report


def _step_times(fn, n=20000):
    import time
    import numpy as np
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn(i)
        out[i] = time.perf_counter() - t0
    return float(np.median(out) * 1e6), float(np.percentile(out, 99) * 1e6)


# the sitting `docs/benchmarks.md`'s records were measured in: `bench graph` composed at 115x real time
RECORD_REAL_TIME_FACTOR = 115.0
# bench fdi's run: what an FDI node meets in service, on the four-wheel set (x, y, z and the redundant s): manoeuvres,
# a current loss growing over 60 s on x (alarm, identification while it grows), x given up (its wheels slow enough
# for s to take it all) and spinning down beside s; then a bearing heating up on y, kept in use with no spare left
# (the worst period: identified on every sample while its ramps may still be growing)
BUDGET_SCENARIO = ("name: bench_fdi\nduration: {duration}\nseed: {seed}\ninitial: {{wheel_speed: [2.0, 2.0, 2.0]}}\n"
                   "faults: [{{kind: current_limiter, wheel: x, onset: {onset:g}, value: 0.3, ramp: 60.0}},\n"
                   "         {{kind: temperature, wheel: y, onset: {second:g}, value: 80.0}}]\n"
                   "manoeuvres: {{interval_s: [100.0, 300.0], size_deg: [-5.0, 5.0]}}\n")


def bench_fdi(duration: float = 600.0, seed: int = 1, models=None) -> dict:
    """The flight budget: compute time of one FDI step per observer (core code), and CPU per FDI period of every
    FDI node (observers, isolation with the identification, the FDIR decision in wheel_allocation) over an
    in-service run, p50 / p99 / max, scaled to the record's sitting by this sitting's `bench graph` real-time
    factor; each node's peak memory and whether its process imported torch."""
    from ...runner.fdi_run import run_with_fdi
    from ...runner.graph import DEFAULT_GROUPING
    compute, samples = _core_step_times(models)
    # the sitting: `bench graph`'s composed run, its real-time factor scales the budget to the record's
    sitting = _bench_graph_run(400.0, seed, DEFAULT_GROUPING)["real_time_factor"]
    scale = sitting / RECORD_REAL_TIME_FACTOR
    os.environ["RW_FDI_TIMING"] = "1"
    out = Path(tempfile.mkdtemp(prefix="rw_fdi_bench_"))
    scenario = out / "bench_fdi.yaml"
    scenario.write_text(BUDGET_SCENARIO.format(duration=duration, seed=seed, onset=duration / 3,
                                               second=duration * 7 / 12))
    outcome = run_with_fdi(str(scenario), out_dir=out, fdi={"models": models}, keep_logs=True)
    nodes = _timing_reports(outcome.log_dir) if outcome.log_dir else {}
    lines = [f"FDI bench: one FDI step, core code only ({samples} samples)"]
    for name, (med, p99) in compute.items():
        lines.append(f"  {name:22s} median {med:7.1f} us   p99 {p99:7.1f} us")
    acts = "; ".join(f"{d['time']:g} s {d['wheel']} {d['state']}"
                     for d in (outcome.summary or {}).get("reconfiguration", []))
    lines.append(f"live graph ({duration:g} s in service on the four-wheel set: manoeuvres, a current loss on x "
                 f"growing over 60 s from {duration / 3:g} s, +57 C on y from {duration * 7 / 12:g} s; "
                 f"{outcome.wall_time:.1f} s wall, "
                 f"{'ok' if outcome.ok else outcome.reason}); FDIR: {acts or 'nothing'}")
    budget, table = _budget(nodes, sitting, scale)
    return {"ok": outcome.ok, "compute_us": compute, "nodes": nodes, "budget": budget,
            "sitting_real_time_factor": sitting, "text": "\n".join(lines + table)}


def _core_step_times(models) -> tuple:
    """({step: (median, p99) [us]}, samples): one FDI step of each observer's core code on random inputs."""
    import numpy as np
    from ...core.fdi.residuals import SignedResidual
    from ...core.fdi.elman import ElmanObserver
    from ...core.fdi.linear_observer import LinearObserver
    from ...core.fdi.telemetry import TelemetrySampler
    from ...paths import config_dir
    from ..design.offline import load_models
    rng = np.random.default_rng(0)
    u, r = rng.uniform(-5, 5, (20000, 3)), rng.uniform(-0.01, 0.01, (20000, 3))
    w = rng.uniform(20, 30, (20000, 3))
    weights = load_models(models or config_dir() / "fdi")
    elman, resid = ElmanObserver(weights["x"]), SignedResidual(uncertainty_gain=weights["x"].uncertainty_gain)
    lin_res = [SignedResidual() for _ in range(3)]
    luenberger, luen_res = LinearObserver(1.0), [SignedResidual() for _ in range(3)]
    telemetry = TelemetrySampler(0.1)   # every control sample is an FDI sample here: the per-sample cost

    def telemetry_step(i):
        telemetry.add(i * 100_000_000, u[i], r[i], w[i])

    def elman_step(i):
        resid.update(r[i, 0], elman.update(u[i, 0], None, w[i, 0]), 1e-3j)

    def model_step(i):   # the model observer's estimate comes with the telemetry: its residuals alone
        for j in range(3):
            lin_res[j].update(r[i, j], 0.0, 1e-3j)

    def linear_step(i):
        estimate = luenberger.update(u[i], r[i])
        for j in range(3):
            luen_res[j].update(r[i, j], estimate[j], 1e-3j)
    compute = {"telemetry (per control sample)": _step_times(telemetry_step),
               "elman (one axis)": _step_times(elman_step), "linear (three axes)": _step_times(linear_step),
               "model (three axes)": _step_times(model_step)}
    return compute, len(u)


def _budget(nodes: dict, sitting: float, scale: float) -> tuple:
    """({node: its budget row}, the table's lines) of the nodes that time their FDI periods."""
    lines = [f"  this sitting: `bench graph` composed {sitting:.1f}x real time; 'at {RECORD_REAL_TIME_FACTOR:g}x' "
             f"scales a time by {scale:.2f} to the record's sitting",
             f"  CPU per FDI period [ms]: {'node':18s} {'p50':>7s} {'p99':>7s} {'max':>7s} {'p99 at':>7s} "
             f"{'max at':>7s}  peak memory, torch"]
    budget = {}
    for name, rep in sorted(nodes.items()):
        if "callback_cpu_median_ms" not in rep:
            continue
        row = {k: rep[f"callback_cpu_{k}_ms"] for k in ("median", "p99", "max")}
        row.update(p99_at_record=row["p99"] * scale, max_at_record=row["max"] * scale,
                   periods=rep["callback_cpu_count"], max_rss_mb=rep["max_rss_mb"],
                   torch_imported=rep.get("torch_imported"))
        budget[name] = row
        lines.append(f"  {'':25s} {name:18s} {row['median']:7.2f} {row['p99']:7.2f} {row['max']:7.2f} "
                     f"{row['p99_at_record']:7.2f} {row['max_at_record']:7.2f}  {row['max_rss_mb']:6.1f} MB"
                     f"{', torch' if row['torch_imported'] else ''}")
    lines.append(f"  goal: p99 <= 1 ms and max <= 5 ms per node at {RECORD_REAL_TIME_FACTOR:g}x; "
                 "memory is the node's process' (the FDI nodes share one)")
    return budget, lines


def bench_study(runs: int = 8, duration: float = 400.0, seed: int = 1, jobs: int | None = None,
                replay_repeat: int = 3) -> dict:
    """What a run and a bag cost in the stages of `rw-fdi reproduce`, by each engine and grouping, in one
    sitting: recording (core engine; graph composed; graph one process per node) and judging (core engine;
    replay through the FDI graph composed and one process per node). The bags are replayed
    ``replay_repeat`` times over, so each replay graph takes about as many bags as `rw-fdi evaluate` gives
    one (evaluate.REPLAY_CHUNK) and the figure includes its share of graph start-up."""
    import shutil
    import time
    from ...runner.graph import DEFAULT_GROUPING
    from ...paths import config_dir
    from ..campaigns.campaign import LocalExecutor, run_campaign
    from ..campaigns.replay import replay_bags
    from ..evaluation.evaluate import evaluate, replay_chunks
    from ..evaluation.reproduce import plan
    out = Path(tempfile.mkdtemp(prefix="rw_fdi_bench_study_"))
    scenario = out / "bench_study.yaml"
    scenario.write_text(f"name: bench_study\nduration: {duration}\nseed: {seed}\n"
                        f"faults: [{{kind: current_limiter, wheel: x, onset: {duration / 2:g}, value: 0.6}}]\n")
    executor = LocalExecutor(jobs)
    fdi = config_dir() / "fdi"
    record, judge, ok = {}, {}, True
    ways = (("core engine", "core", None), (f"graph ({DEFAULT_GROUPING})", "graph", DEFAULT_GROUPING),
            ("graph (none)", "graph", "none"))
    for label, engine, grouping in ways:
        t0 = time.monotonic()
        kw = {"grouping": grouping} if grouping else {}
        rec = run_campaign(str(scenario), runs, seed, out / label.replace(" ", "_"), executor=executor,
                           desc=f"bench: record, {label}", engine=engine, **kw)
        record[label] = (time.monotonic() - t0) / max(runs, 1)
        ok &= not rec.failed and len(rec.done) == runs
    bags = sorted((out / "core_engine").iterdir())
    t0 = time.monotonic()
    evaluate(out / "core_engine", out / "report_core", {"models": fdi}, executor=executor, plots=False, engine="core")
    judge["core engine"] = (time.monotonic() - t0) / max(len(bags), 1)
    for grouping in (DEFAULT_GROUPING, "none"):
        todo = [(bag, out / f"replays_{grouping}" / f"{bag.name}_{k}") for k in range(replay_repeat) for bag in bags]
        t0 = time.monotonic()
        with closing(executor.map_unordered(
                lambda pairs, g=grouping: replay_bags([b for b, _ in pairs], [o for _, o in pairs], {"models": fdi},
                                                      grouping=g),
                replay_chunks(todo, executor.jobs))) as chunks:
            replays = [o for chunk in chunks for o in chunk]
        judge[f"replay through the FDI graph ({grouping})"] = (time.monotonic() - t0) / max(len(replays), 1)
        ok &= all(r.ok for r in replays)
    study = sum(n for _, _, n, _ in plan(out / "plan", "thesis"))
    shutil.rmtree(out, ignore_errors=True)
    lines = [f"study bench: {runs} runs of {duration:g} s, {executor.jobs} at a time ({os.cpu_count()} cores)"]
    return {"ok": ok, "runs": runs, "jobs": executor.jobs, "record_s_per_run": record, "judge_s_per_bag": judge,
            "thesis_runs": study, "text": "\n".join(lines + _study_lines(record, judge, study, duration, ok))}


def _study_lines(record: dict, judge: dict, study: int, duration: float, ok: bool) -> list:
    """The study bench's report: each way's cost per run and per bag, and the thesis study's at that rate."""
    from ...runner.graph import DEFAULT_GROUPING
    lines = ["  record, per run (wall, jobs at a time):"]
    lines += [f"    {k:34s} {v:6.2f} s  ({duration / v:5.0f}x real time, {60 / v:6.1f} runs/min)"
              for k, v in record.items()]
    lines += ["  judge, per bag:"] + [f"    {k:34s} {v:6.2f} s  ({60 / v:6.1f} bags/min)" for k, v in judge.items()]

    def minutes(rec, jud):
        return study * (record[rec] + judge[jud]) / 60
    replay = "replay through the FDI graph ({})".format
    lines.append(f"  thesis scale ({study} runs), recording + judging: "
                 f"~{minutes('core engine', 'core engine'):.1f} min by the core engine, "
                 f"~{minutes(f'graph ({DEFAULT_GROUPING})', replay(DEFAULT_GROUPING)):.0f} min by the composed graph, "
                 f"~{minutes('graph (none)', replay('none')):.0f} min one process per node; plus training (~3 min)")
    return lines + (["  FAILED: a run or a replay failed"] if not ok else [])
