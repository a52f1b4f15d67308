"""The core-loop engine: a campaign's bags recorded by the node code on the batched core loop, no ROS graph.

The core closed loop (core/closed_loop.simulate: the plant, PID and
allocation code the nodes run) simulates a batch of runs at once; for each
run the messages the graph's nodes would publish are made by the nodes' own
code (nodes/plant_report.PlantReport for the plant, the controllers' and the
allocation's CDR, convert.wheel_states_msg, and the wheel_telemetry node's
core/fdi/wheel_reports.ReportSampler for the FDI telemetry) and written through the
project's bag writer with the stamps the graph's recorder gives them. A bag
says which engine recorded it (custom_data ``engine``). The bags equal the
graph's topic for topic, message for message (test/test_engine.py); the
graph stays the reference, and a study records a sample through it as well
(tools/evaluation/reproduce.py).

It records what `rw-fdi run` and `rw-fdi campaign` record without the FDI
nodes: the FDI itself is run by `rw-fdi evaluate` (by replay through the FDI
graph, or by the same node code on the recorded telemetry).
"""
from __future__ import annotations

import shutil
import time
from pathlib import Path

ENGINES = ("graph", "core")
BATCH = 25   # runs simulated at once per worker: (4001, 25, N) arrays


def _serialized(message) -> bytes:
    if isinstance(message, (bytes, bytearray)):
        return bytes(message)
    from rclpy.serialization import serialize_message
    return serialize_message(message)


def write_run_bag(bag: Path, scenario, choices, traj, run: int, units) -> int:
    """Write run ``run`` of the core-loop trajectory ``traj`` as the graph's recorder would have recorded
    it into ``bag`` (created); the number of messages."""
    from ...core.physics.environment import magnetometer_steps
    from ...core.fdir import Reconfiguration
    from ...core.physics.wheel_set import joint_name, wheel_set
    from ...graph import topics as T
    from ...core.physics.spacecraft import BODY_AXES
    from ...core.fdi.wheel_reports import ReportSampler
    from ...graph.convert import fdi_messages, offered_qos, step_stamp_ns, wheel_states_msg
    from ...graph.plant_report import PlantReport, run_units
    from ...storage.cdr import joint_state_cdr, vector_cdr
    from ...storage.writer import BagWriter
    wheels = wheel_set(choices.wheel_set)
    names, joints = wheels.names, tuple(joint_name(n) for n in wheels.names)
    report = PlantReport(scenario.effective_text(choices.scenario_dict()), names, run_units(units, run, wheels.count))
    # the FDI's nominal wheel model is the vehicle's datasheet, whatever the plant's emf-limit choice
    datasheet = scenario.spacecraft.wheel
    reports = ReportSampler(datasheet, choices.fdi_period, choices.control_period, identification=True)
    orbit, rods = scenario.environment is not None, scenario.magnetorquers is not None
    reading_every = magnetometer_steps(choices.control_period) if orbit else None
    writer = BagWriter(bag)
    for topic, type_name, qos in T.recorded_rows(True, False, (), "speed_aware", choices.wheel_set, orbit, rods):
        writer.add_topic(topic, type_name, offered_qos(getattr(T, qos)))   # the recorder's: the same bag
    writer.set_custom_data("engine", "core")

    def write(messages, stamp):
        # the log time the graph's recorder gives: the message's stamp (header or clock), which is the step's
        for topic, message in messages:
            writer.write(topic, stamp, _serialized(message))

    try:
        write(report.start(), 0)   # the latched /scenario: logged at 0, as the recorder logs it
        faults = tuple(scenario.faults)
        ops = {k: v[:, run] for k, v in traj.operating_point.items()}
        last = len(traj.time) - 1
        for k in range(last + 1):
            stamp = step_stamp_ns(k, choices.control_period)
            magnetometer = orbit and k % reading_every == 0
            write(report.step(stamp, traj.time[k], traj.attitude[k, run], traj.body_rate[k, run],
                              traj.wheel_angle[k, run], traj.wheel_speed[k, run], traj.reaction_torque[k, run],
                              traj.fault_effect[k, run], {kind: v[k] for kind, v in ops.items()},
                              faults, traj.magnetic_field[k, run] if magnetometer else None), stamp)
            samples = reports.add_speed(stamp, traj.wheel_speed[k, run], traj.reaction_torque[k, run])
            if magnetometer and rods:
                write([(T.DIPOLE_COMMAND, vector_cdr(stamp, traj.dipole[k, run]))], stamp)
            command = traj.axis_command[k, run]
            for i, axis in enumerate(BODY_AXES):   # each controller's vector holds its own axis only
                write([(T.tcv_command(axis), vector_cdr(stamp, [command[i] if j == i else 0.0 for j in range(3)]))],
                      stamp)
            if k == 0:   # the allocation says its wheels' states with its first command (no FDIR: never again)
                write([(T.FDIR_WHEELS, wheel_states_msg(stamp, Reconfiguration(wheels), names))], stamp)
            write([(T.WHEEL_COMMAND, joint_state_cdr(stamp, joints, effort=traj.wheel_command[k, run]))], stamp)
            for sample in samples + reports.add_command(stamp, traj.wheel_command[k, run]):   # wheel_telemetry's
                write(fdi_messages(sample, names, datasheet.bus_voltage), sample.stamp_ns)
            if k == last:
                write(report.done(stamp), stamp)
    finally:
        writer.close()
    return writer.count


def batch_key(scenario, emf_limit) -> tuple:
    """What runs simulated in one batch share: duration and plant choices (their faults, seeds, manoeuvres
    and wheel units may differ)."""
    return (scenario.duration, scenario.plant_choices(emf_limit=emf_limit))


def record_batch(items) -> list:
    """Record one batch: ``items`` = [(scenario ref, seed, bag path, emf_limit)] of equal batch_key;
    [(seed, bag, wall seconds, error or None)]. Module level, so process pools and Dask workers can run it."""
    from ...core.closed_loop import simulate
    from ...core.physics.plant import units_of
    from ...core.mission.scenario import load_scenario
    from ...core.physics.wheel_set import wheel_set
    t0 = time.monotonic()
    loaded = {}
    scenarios = [loaded.setdefault(ref, load_scenario(ref)).with_seed(seed) for ref, seed, _, _ in items]
    keys = {batch_key(s, emf) for s, (_, _, _, emf) in zip(scenarios, items)}
    if len(keys) != 1:
        raise ValueError(f"one batch, several durations or plant choices: {sorted(map(str, keys))}")
    choices = scenarios[0].plant_choices(emf_limit=items[0][3])
    wheel = scenarios[0].datasheet(choices)
    traj = simulate(scenarios, wheel=wheel, control_period=choices.control_period,
                    wheel_momentum_coupling=choices.wheel_momentum_coupling, wheels=choices.wheel_set,
                    magnetic_field=choices.magnetic_field)
    units = units_of(scenarios, wheel, wheel_set(choices.wheel_set).count)
    out = []
    for run, (scenario, (_, seed, bag, _)) in enumerate(zip(scenarios, items)):
        bag = Path(bag)
        if bag.exists():
            shutil.rmtree(bag)
        bag.parent.mkdir(parents=True, exist_ok=True)
        try:
            write_run_bag(bag, scenario, choices, traj, run, units)
            error = None
        except Exception as exc:  # noqa: BLE001 -- one bad run is reported, the batch goes on
            shutil.rmtree(bag, ignore_errors=True)
            error = f"{type(exc).__name__}: {exc}"
        out.append((seed, str(bag), (time.monotonic() - t0) / len(items), error))
    return out


def batches(items: list, jobs: int) -> list:
    """``items`` dealt into batches of at most BATCH, at least one per job while there are items."""
    if not items:
        return []
    n = max(min(len(items), jobs), -(-len(items) // BATCH))
    size = -(-len(items) // n)
    return [items[i:i + size] for i in range(0, len(items), size)]


def check_engine(engine: str, fdi: bool = False):
    """ValueError (one line) for an engine that cannot record this campaign."""
    if engine not in ENGINES:
        raise ValueError(f"unknown engine {engine!r}: {' or '.join(ENGINES)}")
    if engine == "core" and fdi:
        raise ValueError("the core engine records the closed loop without the FDI nodes: record with --engine "
                         "graph to have the FDI in the loop (FDIR), or evaluate the core engine's bags")
