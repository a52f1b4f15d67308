"""Campaigns: many recorded runs of one scenario, several at once, resumable.

Two engines record them (engine.py): ``graph``, the ROS graph, each run
leasing its own ROS_DOMAIN_ID so parallel runs never meet (local threads
driving graph processes by default), and ``core``, the node code on the
batched core loop (local processes, a batch of runs each). Either way a run
whose bag is already complete is skipped, so an interrupted campaign
resumes where it stopped, and a bag says which engine recorded it.
"""
from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

from ...core.controller_design import scenario_design
from ...core.mission.scenario import load_scenario
from ...extras import require
from ...paths import under
from .engine import batches, check_engine, record_batch
from ...runner.scenario_run import bag_name, not_whole, resolve_scenario, run_scenario


@dataclass
class CampaignResult:
    done: list      # bag paths recorded now
    skipped: list   # complete bags already there
    failed: list    # (seed, reason)
    retried: list = field(default_factory=list)   # (seed, why the first attempt was started over)


class LocalExecutor:
    """Runs callables on ``jobs`` threads (each call starts and supervises its own graph processes), or with
    ``processes`` on ``jobs`` worker processes (work that computes in Python: the core engine)."""

    def __init__(self, jobs: int | None = None):
        cores = os.cpu_count() or 1
        self.asked = jobs
        # more than the machine has only thrashes it (--jobs 10000 forked thousands): a cluster is --scheduler
        self.jobs = min(jobs, cores) if jobs else max(1, min(2, cores))

    def map_unordered(self, fn, items, processes: bool = False):
        if processes:
            import multiprocessing
            # fork: a caller's script is not re-imported (spawn would run an unguarded script again); the
            # workers compute with numpy only, nothing of a parent's threads is needed in them
            pool = ProcessPoolExecutor(self.jobs, mp_context=multiprocessing.get_context("fork"))
        else:
            pool = ThreadPoolExecutor(self.jobs)
        _LIVE_POOLS.add(pool)
        done = False
        try:
            futures = [pool.submit(fn, item) for item in items]
            for fut in as_completed(futures):
                yield fut.result()
            done = True
        finally:
            # interrupted (Ctrl-C, SIGTERM) or abandoned: the queued calls are dropped; a plain `with` would run
            # every queued run before exiting. Worker processes compute only (the core loop, a bench's
            # chunk): they are ended at once. Threads each supervise a graph, which ends with its run.
            _LIVE_POOLS.discard(pool)
            if done:
                pool.shutdown(wait=True)
            else:
                _end_pool(pool)


_LIVE_POOLS: set = set()   # the pools of the maps in progress (end_interrupted)


def end_interrupted():
    """End the pools of the maps in progress, their queued calls dropped: for an interrupted command.

    An interrupt that lands in a map's consumer (writing a journal, a progress bar) leaves the map's generator
    suspended, often in a reference cycle: its ``finally`` would run only after the interpreter's exit had
    waited for every queued call (a bench "hung" on Ctrl-C until it was done)."""
    for pool in list(_LIVE_POOLS):   # a map's own finally may discard its pool meanwhile
        _LIVE_POOLS.discard(pool)
        _end_pool(pool)


def _end_pool(pool):
    if isinstance(pool, ProcessPoolExecutor):
        _end_workers(pool)
    pool.shutdown(wait=True, cancel_futures=True)


def _end_workers(pool: ProcessPoolExecutor):
    """SIGKILL to a process pool's workers (Python 3.14's kill_workers; 3.11 has no API): forked, they inherit
    the command's SIGTERM handler, which would only interrupt the call in hand and take the next one."""
    processes = list((getattr(pool, "_processes", None) or {}).values())   # None once shut down
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(5.0)
    # a worker killed while it sent a large result (a bench's chunk) leaves the pool's reader waiting for the
    # rest of that message, and shutdown and exit waiting on the reader: closing our end of the pipe's write
    # side ends that wait (EOF), the pool is marked broken and shuts down
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
    if writer is not None:
        writer.close()


def apply(call):
    """``call`` = (function, *arguments): the function applied, for an executor's map over varied calls."""
    fn, *args = call
    return fn(*args)


class DaskExecutor:
    """Submits each run to a dask.distributed cluster; every worker runs whole graphs, each run in its
    own ROS_DOMAIN_ID (leased per machine), so runs on one worker or many never meet."""

    CONNECT_S = 10.0   # [s] a scheduler that does not answer by then is said at once, not after a traceback

    def __init__(self, address):
        if hasattr(address, "submit"):
            self.client = address
            return
        client, box = require("distributed", "cluster").Client, {}

        def connect():   # in a thread of its own: a server that is not Dask may never answer its handshake
            try:
                box["client"] = client(address, timeout=self.CONNECT_S)
            except BaseException as exc:   # noqa: BLE001 -- refused, unreachable, not an address, garbage
                box["error"] = exc
        thread = threading.Thread(target=connect, name="dask-connect", daemon=True)
        thread.start()
        thread.join(self.CONNECT_S + 5.0)
        if "client" not in box:
            exc = box.get("error")
            why = "no answer" if exc is None else \
                f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no reason'}"
            raise RuntimeError(f"--scheduler {address}: no Dask scheduler answered within {self.CONNECT_S:g} s "
                               f"({why})"[:300])
        self.client = box["client"]

    def map_unordered(self, fn, items, processes: bool = False):
        """``processes`` is ignored: the workers are processes already."""
        from distributed import as_completed as dask_completed
        futures = self.client.map(fn, list(items), pure=False)
        try:
            for fut in dask_completed(futures):
                yield fut.result()
        finally:   # interrupted: nothing more starts (a lost connection must not hide why we stopped)
            pending = [f for f in futures if not f.done()]
            if pending:
                try:
                    self.client.cancel(pending)
                except Exception:  # noqa: BLE001
                    pass


def make_executor(jobs: int | None = None, scheduler: str | None = None):
    """Local threads by default; a Dask cluster with ``scheduler`` (address like tcp://host:8786)."""
    return DaskExecutor(scheduler) if scheduler else LocalExecutor(jobs)


def _progress(total, desc):
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="run", file=sys.stderr, dynamic_ncols=True,
                disable=None if sys.stderr.isatty() else False, mininterval=1.0)


def pending(scenario_ref: str, runs: int, seed_start: int, out_dir) -> tuple:
    """(seeds still to record, complete bags already there) of a campaign: a bag short of its run (its
    recorder lost messages) is recorded again."""
    scenario = load_scenario(scenario_ref)
    todo, skipped = [], []
    for seed in range(seed_start, seed_start + runs):
        bag = under(out_dir, bag_name(scenario.with_seed(seed)))
        if not not_whole(bag):   # a missing, damaged or interrupted one is recorded (again)
            skipped.append(bag)
        else:
            todo.append(seed)
    return todo, skipped


def run_campaign(scenario_ref: str, runs: int, seed_start: int, out_dir, executor=None, fdi=False,
                 desc: str | None = None, engine: str = "graph", **run_kwargs) -> CampaignResult:
    """Record ``runs`` runs with seeds seed_start.. into ``out_dir`` by ``engine`` ('graph' or 'core');
    complete bags are kept, whichever engine recorded them. ``fdi``: True (the vehicle's shipped FDI) or an
    FdiConfig runs the FDI nodes live too."""
    check_engine(engine, fdi)
    out_dir = Path(out_dir)
    scenario = load_scenario(scenario_ref)
    scenario_design(scenario, scenario_ref)   # its vehicle's controllers, or one line before any run
    seeds = list(range(seed_start, seed_start + runs))
    todo, skipped = pending(scenario_ref, runs, seed_start, out_dir)
    executor = executor or LocalExecutor()
    result = CampaignResult(done=[], skipped=skipped, failed=[])
    if engine == "core":
        return _record_core(scenario_ref, todo, out_dir, executor, result, desc or scenario.name,
                            run_kwargs.get("emf_limit"))

    def attempt(seed):
        if fdi:
            from ...runner.fdi_run import run_with_fdi
            return run_with_fdi(scenario_ref, seed=seed, out_dir=out_dir, fdi=None if fdi is True else fdi,
                                **run_kwargs)
        return run_scenario(scenario_ref, seed=seed, out_dir=out_dir, **run_kwargs)

    def one(seed):
        outcome = attempt(seed)
        if outcome.ok or "(watchdog" not in outcome.reason:
            return seed, outcome, None
        # a graph whose processes all live but never finish (seen once, in a CI run's two-run campaign,
        # with nothing in any node's log) is started over: the run is deterministic, the bag the same
        return seed, attempt(seed), outcome.reason

    bar = _progress(len(seeds), desc or scenario.name)
    bar.update(len(skipped))
    try:   # closing: an interruption stops the executor at once, not when its traceback is collected
        with closing(executor.map_unordered(one, todo)) as outcomes:
            for seed, outcome, first in outcomes:
                if first is not None:
                    result.retried.append((seed, first))
                    bar.write(f"seed {seed}: started over after: {first}")
                if outcome.ok:
                    result.done.append(outcome.bag)
                else:
                    result.failed.append((seed, outcome.reason))
                    bar.write(f"seed {seed}: {outcome.reason}")
                bar.update(1)
    finally:
        bar.close()
    return result


def _record_core(scenario_ref, seeds, out_dir, executor, result, desc, emf_limit) -> CampaignResult:
    """The core engine's part of run_campaign: ``seeds`` in batches over the executor's processes."""
    return record_campaigns([(scenario_ref, seeds, out_dir, result)], executor, desc, emf_limit)[0]


def record_campaigns(campaigns, executor=None, desc: str = "core engine", emf_limit=None) -> list:
    """Several campaigns by the core engine at once: ``campaigns`` = [(scenario ref, seeds to record, out
    dir, CampaignResult to fill)]; runs of every campaign share batches where their duration and plant
    choices agree (engine.batch_key), so small campaigns (a grid of fault sizes) cost what one large one
    does. The results, filled, in order."""
    from ...core.mission.scenario import load_scenario
    from .engine import batch_key
    executor = executor or LocalExecutor()
    groups, owner = {}, {}
    for index, (ref, seeds, out_dir, _) in enumerate(campaigns):
        scenario, path = resolve_scenario(ref)   # absolute: a worker process loads it by itself
        key = batch_key(load_scenario(path), emf_limit)
        for seed in seeds:
            bag = str(under(out_dir, bag_name(scenario.with_seed(seed))))
            groups.setdefault(key, []).append((path, seed, bag, emf_limit))
            owner[bag] = index
    work = [b for items in groups.values() for b in batches(items, getattr(executor, "jobs", 2))]
    results = [c[3] for c in campaigns]
    bar = _progress(sum(len(r.skipped) for r in results) + len(owner), desc)
    bar.update(sum(len(r.skipped) for r in results))
    try:
        with closing(executor.map_unordered(record_batch, work, processes=True)) as outcomes:
            for outcome in outcomes:
                for seed, bag, _, error in outcome:
                    result = results[owner[bag]]
                    if error is None:
                        result.done.append(Path(bag))
                    else:
                        result.failed.append((seed, error))
                        bar.write(f"seed {seed}: {error}")
                bar.update(len(outcome))
    finally:
        bar.close()
    return results
