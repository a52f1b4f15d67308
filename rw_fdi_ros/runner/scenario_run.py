"""One recorded run of the graph: scenario in, bag and summary out."""
from __future__ import annotations

import contextlib

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..core.controller_design import scenario_design
from ..paths import under
from ..core.mission.scenario import Scenario, load_scenario
from .graph import DEFAULT_GROUPING, graph_nodes
from .launcher import DomainLease, GraphProcesses, cleanup
from ..graph import topics as T
from ..storage.bag import BagError, message_counts
from .summary import run_summary


@dataclass
class RunOutcome:
    ok: bool
    reason: str
    bag: Path
    wall_time: float
    summary: dict | None = None
    log_dir: Path | None = None


def bag_name(scenario: Scenario) -> str:
    return f"{scenario.name}_s{scenario.seed:04d}"


def resolve_scenario(ref: str, seed: int | None = None):
    """(scenario, absolute file path the nodes can load) for a name or a path; a vehicle whose controllers
    cannot meet its targets is refused here, in one line, before any node starts."""
    scenario = load_scenario(ref)
    scenario_design(scenario, ref)
    path = Path(ref) if Path(ref).is_file() else None
    if path is None:
        from ..core.mission.scenario import scenario_dir
        path = scenario_dir() / f"{ref}.yaml"
    if seed is not None:
        scenario = scenario.with_seed(seed)
    return scenario, str(path.resolve())


def short_step_topics(bag) -> list:
    """The per-step topics (topics.STEP_TOPICS) of a finished bag with fewer messages than the others: its
    recorder lost messages and exited non-zero (a whole run has one of each per control step). Empty for a
    bag that records no step topic (a replay's)."""
    counts = message_counts(bag)
    most = max((counts.get(t, 0) for t in T.STEP_TOPICS), default=0)
    return [t for t in T.STEP_TOPICS if counts.get(t, 0) < most]


def not_whole(bag) -> str:
    """Why ``bag`` is not one whole, undamaged run ('' when it is): what a resumed campaign keeps and what
    training and fitting learn from. Reads the whole file (its CRCs).

    Parameters
    ----------
    bag : str or Path
        A bag directory.

    Returns
    -------
    str
        '' for a whole run, else one line saying what is wrong.
    """
    from ..storage.bag import bag_info, bag_is_complete
    if not bag_is_complete(bag):
        return "incomplete bag (no metadata.yaml or MCAP footer)"
    try:
        info = bag_info(bag)
    except BagError as exc:
        return str(exc)
    if info.damaged or not info.complete:
        return info.damage() or info.note
    if T.PLANT_DONE not in info.counts:
        return f"run interrupted: no {T.PLANT_DONE} (the plant did not reach the run's end)"
    short = short_step_topics(bag)
    return f"its recorder lost messages on {', '.join(short)}" if short else ""


def run_scenario(ref: str, seed: int | None = None, out_dir="bags", name: str | None = None,
                 command_timeout: float = 5.0, watchdog: float | None = None, keep_logs: bool = False,
                 emf_limit: str | None = None, fdi=None, grouping: str = DEFAULT_GROUPING,
                 progress=None, live: int | None = None, namespace: str = "",
                 domain_id: int | None = None) -> RunOutcome:
    """Run the whole graph once, recording ``out_dir/<name>``; never raises for a failed run. ``grouping``:
    which nodes share a process (runner/graph.GROUPINGS); ``progress(simulated_s, duration_s)``: told how
    far the run is, each wall second; ``live``: the port of a live view in Foxglove (None: none);
    ``namespace``: every node's (the graph's topics under it); ``domain_id``: a ROS domain shared with other
    graphs (None: a private one, leased)."""
    scenario, path = resolve_scenario(ref, seed)
    bag = under(out_dir, name or bag_name(scenario))
    if bag.exists():
        shutil.rmtree(bag)
    nodes = graph_nodes(scenario, path, bag, command_timeout=command_timeout, emf_limit=emf_limit, fdi=fdi,
                        live=live)
    watchdog = watchdog or max(120.0, scenario.duration)
    with DomainLease() if domain_id is None else contextlib.nullcontext() as lease:
        work = Path(tempfile.mkdtemp(prefix=f"rw_fdi_{bag.name}_"))
        domain = lease.domain_id if domain_id is None else domain_id
        result = GraphProcesses(nodes, domain, work, grouping=grouping, namespace=namespace).start().run(
            watchdog=watchdog, progress=progress)
    outcome = RunOutcome(result.ok, result.reason, bag, result.wall_time, log_dir=work)
    if bag.exists():
        try:
            outcome.summary = run_summary(bag)
        except (BagError, ValueError) as exc:
            if outcome.ok:
                outcome.ok, outcome.reason = False, str(exc)
    cleanup(result, keep=keep_logs or not outcome.ok or outcome.reason != "completed")
    return outcome
