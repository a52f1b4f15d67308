"""FDI samples out of bags, or of runs of the core loop: the 1 s samples the observers see (core/fdi/telemetry.py, as
the nodes make them)."""
from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core.closed_loop import simulate
from ...core.controller_design import scenario_design
from ...core.fdi.wheel_reports import report_samples
from ...core.physics.wheel import WheelParams
from ...graph.convert import fdi_sample_of, stamp_ns, telemetry_wheels
from ...core.physics.wheel_set import AXIS_WHEELS
from ...graph.topics import FAULT_EFFECT, FDI_BUS_GRID, FDI_TELEMETRY, PLANT_DONE
from ...runner.scenario_run import short_step_topics
from ...storage.bag import BagError, bag_is_complete, read_bag
from ...core.mission.yaml_text import read_yaml

BATCH = 50   # runs simulated at once: (4001, 50, 3) arrays, far below memory limits


@dataclass
class FdiSamples:
    """One run at the FDI period, (n, wheels) arrays: tcv [V], reaction torque [N m], and for the
    speed-aware observers wheel speed [rad/s], the nominal model's torque [N m] and the ripple phasor;
    ``wheels``: the names of the columns (the run's wheel set's); ``wheel_params``: the wheel type the plant
    modelled them with (the vehicle's datasheet), which the offline observers model them with too."""

    bag: Path | None
    seed: int | None
    time: np.ndarray
    tcv: np.ndarray
    reaction_torque: np.ndarray
    wheel_speed: np.ndarray | None = None
    model_torque: np.ndarray | None = None
    ripple_phasor: np.ndarray | None = None
    # what fault identification fits (core/identification/), when asked for
    motor_torque: np.ndarray | None = None
    friction_torque: np.ndarray | None = None
    free_motor_torque: np.ndarray | None = None
    bus_motor_torque: np.ndarray | None = None    # (n, wheels, bus grid)
    wheels: tuple = AXIS_WHEELS
    wheel_params: WheelParams = WheelParams()

    def rows(self):
        """The samples one by one as telemetry.FdiSample (what the nodes see)."""
        from ...core.fdi.telemetry import FdiSample
        names = ("wheel_speed", "model_torque", "ripple_phasor", "motor_torque", "friction_torque",
                 "free_motor_torque", "bus_motor_torque")
        for k, t in enumerate(self.time):
            extra = {n: None if getattr(self, n) is None else getattr(self, n)[k] for n in names}
            yield FdiSample(int(round(t * 1e9)), self.tcv[k], self.reaction_torque[k], **extra)


def samples_from_series(stamps_ns, tcv, reaction_torque, wheel_speed, period: float = 1.0, bag=None, seed=None,
                        identification: bool = False, wheels=AXIS_WHEELS,
                        wheel_params: WheelParams = WheelParams()) -> FdiSamples:
    """A run reported on the control grid (time first; ``tcv`` the commands sent at each stamp) -> FdiSamples,
    the way the wheel_telemetry node makes them (core/fdi/wheel_reports.report_samples), its nominal model the
    wheel type ``wheel_params`` (``identification``: with the terms fault identification fits)."""
    step = float(np.median(np.diff(stamps_ns))) * 1e-9 if len(stamps_ns) > 1 else 0.1
    rows = report_samples(stamps_ns, tcv, reaction_torque, wheel_speed, wheel_params, period, round(step, 9),
                          identification=identification)
    return samples_from_rows(rows, bag, seed, wheels, wheel_params)


def samples_from_rows(rows, bag=None, seed=None, wheels=AXIS_WHEELS,
                      wheel_params: WheelParams = WheelParams()) -> FdiSamples:
    """A list of telemetry.FdiSample -> FdiSamples (arrays over time)."""
    stamps = np.array([row.stamp_ns for row in rows], np.int64)
    def stack(name):
        return None if not rows or getattr(rows[0], name) is None else np.array([getattr(x, name)
                                                                                             for x in rows])
    empty = np.zeros((0, len(wheels)))
    return FdiSamples(bag=bag, seed=seed, time=stamps // 10**9 + (stamps % 10**9) * 1e-9,
                      tcv=stack("tcv") if rows else empty, reaction_torque=stack("reaction_torque") if rows else empty,
                      wheel_speed=stack("wheel_speed"), model_torque=stack("model_torque"),
                      ripple_phasor=stack("ripple_phasor"), motor_torque=stack("motor_torque"),
                      friction_torque=stack("friction_torque"), free_motor_torque=stack("free_motor_torque"),
                      bus_motor_torque=stack("bus_motor_torque"), wheels=tuple(wheels), wheel_params=wheel_params)


def fdi_samples(data, period: float = 1.0, sampling: str = "mean", speed_aware: bool = True,
                identification: bool = False) -> FdiSamples:
    """The FDI samples the observers of a run saw: the bag's FDI telemetry (what the wheel_telemetry node reported
    once per FDI period), as the observers of FDI sampling ``sampling`` read it; with ``identification``
    also the terms only fault identification reads (the bus-voltage grid)."""
    msgs = data.topic(FDI_TELEMETRY)
    if not msgs:
        raise BagError(f"{data.path}: no {FDI_TELEMETRY} messages")
    wheels = telemetry_wheels(msgs[0][1])   # the wheels reported, in the set's order
    # the identification's bus-voltage grid goes beside each report (in a legacy text report, inside it)
    grids = {stamp_ns(m.header.stamp): m for _, m in data.topic(FDI_BUS_GRID)} if identification else {}
    legacy = hasattr(msgs[0][1], "status")   # a text report carries its grid itself
    lacking = [stamp_ns(m.header.stamp) for _, m in msgs if stamp_ns(m.header.stamp) not in grids]
    if identification and not legacy and lacking:
        raise BagError(f"{data.path}: no {FDI_BUS_GRID} for the report at {lacking[0] * 1e-9:g} s "
                       f"({len(lacking)} reports without their grid)")
    try:
        rows = [fdi_sample_of(m, wheels, identification, grids.get(stamp_ns(m.header.stamp))).sampled(sampling)
                for _, m in msgs]
    except ValueError as exc:
        raise BagError(f"{data.path}: {FDI_TELEMETRY}: {exc}") from None
    rows.sort(key=lambda r: r.stamp_ns)
    steps = np.diff([r.stamp_ns for r in rows])
    period_ns = int(round(period * 1e9))
    if len(steps) and not np.all(steps == period_ns):
        raise BagError(f"{data.path}: FDI telemetry every {np.median(steps) * 1e-9:g} s, not every {period:g} s")
    if not speed_aware:   # the thesis' observers see tcv and reaction torque only
        rows = [type(r)(r.stamp_ns, r.tcv, r.reaction_torque) for r in rows]
    seed, params = None, WheelParams()
    if data.scenario_text:
        seed = (read_yaml(data.scenario_text, "the recorded /scenario") or {}).get("seed")
        params = recorded_wheel(data)
    return samples_from_rows(rows, bag=data.path, seed=seed, wheels=wheels, wheel_params=params)


def recorded_wheel(data) -> WheelParams:
    """The wheel type a bag's run flew, as its datasheet gives it (the FDI's nominal model, whatever the plant's
    emf-limit choice): its /scenario holds the whole vehicle (BagError, one line, for one that does not read)."""
    from ...core.mission.scenario import ScenarioError, parse_scenario
    try:
        return parse_scenario(data.scenario_text, origin=f"{data.path} /scenario").spacecraft.wheel
    except ScenarioError as exc:
        raise BagError(str(exc)) from None


def bag_dirs(root) -> list:
    """Bag directories under ``root`` (itself if it is one), sorted."""
    root = Path(root)
    if not root.exists():
        raise BagError(f"{root}: no such directory")
    if list(root.glob("*.mcap")):
        return [root]
    dirs = sorted(p for p in root.iterdir() if p.is_dir() and list(p.glob("*.mcap")))
    if not dirs:
        raise BagError(f"{root}: no bags in it (expected bag directories with a .mcap file)")
    return dirs


def _refuse_faulty(bag, data):
    """A BagError where a bag is not a fault-free run: its scenario's faults (the ground truth), or a wheel
    whose recorded fault effect is not zero (a fault injected live, fault.<wheel>.<kind>)."""
    from ...core.mission.scenario import ScenarioError, parse_scenario
    text = data.scenario_text
    if text is None:
        raise BagError(f"{bag}: no /scenario recorded: cannot tell it is fault-free")
    try:
        faults = parse_scenario(text, origin=str(bag)).faults
    except ScenarioError as exc:
        raise BagError(f"{bag}: its recorded scenario does not parse ({exc})") from None
    if faults:
        first = faults[0]
        raise BagError(f"{bag}: records {len(faults)} fault(s) ({first.kind} from {first.onset:g} s, ...): thresholds "
                       "are fitted on fault-free runs")
    if data.topic(FAULT_EFFECT):
        _, effect = data.wheel_values(FAULT_EFFECT)
        if effect.size and np.any(effect != 0.0):
            raise BagError(f"{bag}: a fault was injected while it ran (fault effect up to "
                           f"{float(np.abs(effect).max()):.2g} N m): thresholds are fitted on fault-free runs")


def load_samples(root, period: float = 1.0, complete_only: bool = True, on_skip=None, sampling: str = "mean",
                 fault_free: bool = False, executor=None) -> list:
    """FDI samples of every bag under ``root``, in bag order; unreadable, damaged or incomplete bags are reported
    and skipped, and with ``fault_free`` (what thresholds are fitted on) so is a bag whose scenario has a fault or
    whose wheels show a fault's effect (one injected while it ran). ``executor``: read the bags on it (local
    processes, a Dask cluster; default: one after another here), the same samples either way."""
    bags = bag_dirs(root)
    work = [(bag, period, complete_only, sampling, fault_free) for bag in bags]
    read = map(_bag_samples, work) if executor is None else executor.map_unordered(_bag_samples, work, processes=True)
    results = {bag: (samples, why) for bag, samples, why in read}
    out = []
    for bag in bags:
        samples, why = results[bag]
        if why is None:
            out.append(samples)
        elif on_skip is None:
            raise BagError(why)
        else:
            on_skip(why)
    return out


def _bag_samples(work) -> tuple:
    """(bag, its FdiSamples or None, why it was skipped or None): one bag of :func:`load_samples`."""
    bag, period, complete_only, sampling, fault_free = work
    try:
        if complete_only and not bag_is_complete(bag):
            raise BagError(f"{bag}: incomplete bag (no metadata.yaml or MCAP footer)")
        topics = [FDI_TELEMETRY, "/scenario", PLANT_DONE] + ([FAULT_EFFECT] if fault_free else [])
        data = read_bag(bag, topics=topics, intact=True)
        if complete_only and data.last(PLANT_DONE) is None:   # a run cut short teaches a run's start only
            raise BagError(f"{bag}: run interrupted: no {PLANT_DONE} (the plant did not reach the run's end)")
        if complete_only and (short := short_step_topics(bag)):   # runner/scenario_run.not_whole's rule
            raise BagError(f"{bag}: its recorder lost messages on {', '.join(short)}")
        if fault_free:
            _refuse_faulty(bag, data)
        return bag, fdi_samples(data, period, sampling, speed_aware=sampling == "mean"), None
    except BagError as exc:
        return bag, None, str(exc)


def simulated_fault_free_runs(ref, seeds, pool=None, desc: str = "fitting runs (core loop)") -> tuple:
    """FDI samples of fault-free runs of scenario ``ref`` (a name, a path or a Scenario) over ``seeds`` by the
    core loop (rw-fdi screen's: the graph's numbers, no bags) on the executor ``pool`` (default: local
    processes), in seed order, and the plant choices they were made under (what a bag of such a run records)."""
    from tqdm import tqdm
    from ...core.mission.plant_choices import PlantChoices
    from ...core.mission.scenario import Scenario, load_scenario
    from ..campaigns.campaign import LocalExecutor
    scenario = ref if isinstance(ref, Scenario) else load_scenario(ref)
    scenario_design(scenario, None if isinstance(ref, Scenario) else ref)   # one line before any run
    if scenario.faults:
        raise ValueError(f"scenario {scenario.name}: thresholds and networks are fitted on fault-free runs, "
                         "this scenario has faults")
    pool = pool or LocalExecutor()
    seeds = list(seeds)
    runs = [scenario.with_seed(k) for k in seeds]
    by_seed = {}
    with tqdm(total=len(seeds), desc=desc, unit="run", file=sys.stderr) as bar:
        for done in pool.map_unordered(simulated_samples, [runs[i:i + BATCH] for i in range(0, len(runs), BATCH)],
                                       processes=True):
            by_seed.update(done)
            bar.update(len(done))
    plant = PlantChoices.of_recording(scenario.plant_choices().scenario_dict()).as_dict()
    return [by_seed[k] for k in seeds], plant


def simulated_runs(scenarios, identification: bool = False, check=None, progress=None, on_run=None, fdir=None):
    """(scenario, FdiSamples, fault effect peak per wheel) of every scenario, by the core closed loop in
    batches of BATCH (equal durations and plant choices within a batch): the FDI samples the wheel_telemetry
    node would report. ``check(plant_choices)`` runs before each batch is simulated; ``on_run(scenario,
    trajectory, index)`` sees each run's whole trajectory (what else a bench counts of it); ``fdir``
    (flight.Fdir): reconfigure on the FDI's verdict in the loop."""
    for start in range(0, len(scenarios), BATCH):
        batch = scenarios[start:start + BATCH]
        choices = batch[0].plant_choices()
        if check:
            check(choices)
        traj = simulate(batch, wheel=batch[0].datasheet(choices), control_period=choices.control_period,
                        wheel_momentum_coupling=choices.wheel_momentum_coupling, fdir=fdir)
        stamps = np.round(traj.time * 1e9).astype(np.int64)
        for b, scenario in enumerate(batch):
            if on_run is not None:
                on_run(scenario, traj, b)
            samples = samples_from_series(stamps, traj.wheel_command[:, b], traj.reaction_torque[:, b],
                                          traj.wheel_speed[:, b], seed=scenario.seed, identification=identification,
                                          wheels=traj.wheel_names, wheel_params=scenario.spacecraft.wheel)
            onset = min((f.onset for f in scenario.faults), default=None)
            after = traj.time >= onset if onset is not None else np.zeros(len(traj.time), bool)
            yield scenario, samples, (np.abs(traj.fault_effect[after, b]).max(axis=0) if after.any()
                                      else np.zeros(len(traj.wheel_names)))
        if progress:
            progress(len(batch))


def simulated_samples(scenarios) -> dict:
    """seed -> the FdiSamples of each scenario's run by the core loop (:func:`simulated_runs`): an executor's
    unit of work."""
    return {scenario.seed: samples for scenario, samples, _ in simulated_runs(scenarios)}
