"""Replay recorded bags through the observer and isolation nodes (rosbag replay for evaluation).

Many bags go through one graph (player + the method's observers + isolation
+ a recorder of the FDI outputs): the FDI nodes start a new run when the
stamps go back to the start, and the recorder writes one bag per run. Only
the FDI telemetry and its bus-voltage grid (one message each per FDI period), the ground truth and the
scenario are played, so a replay costs a few hundred messages per bag and
the processes start once per graph, not once per bag.
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from ...fdi_config import FdiConfig
from ...core.mission.plant_choices import PlantChoices
from ...runner.graph import NodeSpec, fdi_nodes, plugin_parameters, with_reader_counts
from ...runner.graph import DEFAULT_GROUPING
from ...runner.launcher import DomainLease, GraphProcesses, cleanup
from ...graph import topics as T
from ...storage.bag import BagError, bag_is_complete, message_counts, read_bag
from ..design.offline import plant_conditions
from ...runner.scenario_run import RunOutcome


def replay_nodes(bags: list, out_bags: list, fdi, plant: dict, rate: float = 0.0, wheel_type: str = ""):
    """Player + the FDI nodes of the method (graph.fdi_nodes) + a recorder of their outputs, for ``bags``
    in order; ``wheel_type``: the wheel type their vehicle flew (core/mission/vehicle.wheel_parameter)."""
    choices = PlantChoices(**plant)
    fdi = FdiConfig.of(fdi)
    # every bag with a grid per report (any bag of today's recorder): each report waits for its own
    nodes = fdi_nodes(fdi, choices, await_bus_grid=all(_has_bus_grid(b) for b in bags), wheel_type=wheel_type)
    for node in nodes:
        node.parameters["end_with_run"] = False   # they stay for the next bag; the launcher stops them
    nodes.append(NodeSpec("player", "player", {"bags": [str(b) for b in bags], "rate": float(rate),
                                               "pace_period": choices.fdi_period, "topics": T.FDI_INPUTS,
                                               "await_recorder": True}))
    nodes.append(NodeSpec("recorder", "recorder", {"outputs": [str(b) for b in out_bags],
                                                   "fdi_period": choices.fdi_period, "fdi_method": fdi.method,
                                                   "record_plant": False, "wheel_set": choices.wheel_set,
                                                   **plugin_parameters(fdi)}))
    return with_reader_counts(nodes)


def _wheel_type(bag) -> str:
    """The wheel_type parameter of the vehicle a bag's run flew (the bags of one replay share their plant
    choices, the vehicle among them)."""
    from ...core.mission.scenario import ScenarioError, parse_scenario
    from ...core.mission.vehicle import wheel_parameter
    text = read_bag(bag, topics=["/scenario"]).scenario_text
    if not text:
        return ""
    try:
        spacecraft = parse_scenario(text, origin=f"{bag} /scenario").spacecraft
    except ScenarioError as exc:
        raise BagError(str(exc)) from None
    return wheel_parameter(spacecraft.wheel, spacecraft.wheel_type)


def _has_bus_grid(bag) -> bool:
    try:
        return message_counts(bag).get(T.FDI_BUS_GRID, 0) > 0
    except BagError:   # said when the player reads it
        return False


def replay_bags(bags, out_bags, fdi=None, rate: float = 0.0, keep_logs: bool = False, watchdog: float | None = None,
                grouping: str = DEFAULT_GROUPING) -> list:
    """Replay ``bags`` (recorded under the same plant choices) through one graph of the FDI ``fdi`` (FdiConfig
    or its mapping; None: the shipped one) (``grouping``: which nodes
    share a process, runner/graph.GROUPINGS); the FDI outputs of bag i go to ``out_bags[i]``. Returns one
    RunOutcome per bag, in order. A graph that fails part way keeps the bags it finished; the first
    unfinished bag gets a graph alone and the rest another, so a bad bag fails alone."""
    bags, out_bags = [Path(b) for b in bags], [Path(b) for b in out_bags]
    outcomes = [None] * len(bags)
    readable = []
    for i, bag in enumerate(bags):   # a bag that cannot even be read is answered before any graph starts
        try:
            read_bag(bag, topics=[T.SCENARIO])
            readable.append(i)
        except (BagError, OSError) as exc:
            outcomes[i] = RunOutcome(False, str(exc), out_bags[i], 0.0)
    if not readable:
        return outcomes
    plant = plant_conditions([bags[i] for i in readable])
    wheel_type = _wheel_type(bags[readable[0]])   # one plant, so one vehicle
    fdi = FdiConfig.of(fdi)
    groups = [readable]
    retried = False
    while groups:
        todo = groups.pop(0)
        for i in todo:
            if out_bags[i].exists():
                shutil.rmtree(out_bags[i])
        nodes = replay_nodes([bags[i] for i in todo], [out_bags[i] for i in todo], fdi, plant, rate, wheel_type)
        with DomainLease() as lease:
            work = Path(tempfile.mkdtemp(prefix=f"rw_fdi_replay_{bags[todo[0]].name}_"))
            limit = watchdog if watchdog is not None else 120.0 + 60.0 * len(todo)
            result = GraphProcesses(nodes, lease.domain_id, work, grouping=grouping).start().run(main="player",
                                                                                                  watchdog=limit)
        for i in todo:
            ok = result.ok or replay_finished(out_bags[i])
            outcomes[i] = RunOutcome(ok, "completed" if ok else result.reason, out_bags[i],
                                     result.wall_time / len(todo), log_dir=work)
            if not ok and out_bags[i].exists():   # a half replay must not be taken for a result later
                shutil.rmtree(out_bags[i])
        cleanup(result, keep=keep_logs or not result.ok)
        failed = [i for i in todo if not outcomes[i].ok]
        if len(failed) > 1:
            # one bad bag must not take the others with it: the first alone, the rest again together
            # (a group that fails again splits again)
            groups += [failed[:1], failed[1:]]
        elif failed and not retried and "stalled" in result.reason:
            # a consumer's DDS reader that matched the player's writer only after the first burst stalls
            # the graph at start-up (seen under full load); a fresh graph starts the bag over
            retried = True
            groups.append(failed)
    return outcomes


def replay_finished(out_bag: Path) -> bool:
    """A replay bag the recorder closed at its run's end (the player sends /plant/done only once the
    consumers have finished the run's last FDI sample), not one closed on the way out of a failure."""
    if not bag_is_complete(out_bag):
        return False
    try:
        return bool(read_bag(out_bag, topics=[T.PLANT_DONE]).topic(T.PLANT_DONE))
    except BagError:
        return False


def replay_bag(bag, out_bag, fdi=None, rate: float = 0.0, keep_logs: bool = False, watchdog: float = 300.0,
               grouping: str = DEFAULT_GROUPING) -> RunOutcome:
    """Replay one bag; its FDI outputs are recorded to ``out_bag``."""
    return replay_bags([bag], [out_bag], fdi, rate, keep_logs, watchdog, grouping)[0]
