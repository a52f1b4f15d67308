"""`rw-fdi bench service`: FDIR in service, every capability at once.

Each run is drawn from its seed as a spacecraft in service meets it, all at once:

* the four-wheel set (orthogonal_skew: x, y, z and the standby s);
* wheel units (varied, the observers calibrated for 150 s) or datasheet wheels, half each;
* manoeuvres from the start to the end, before and after any fault: intervals drawn per run within
  60-900 s, sizes up to Table 2.3's 5 deg per axis;
* a fault (two runs in three) of any kind, its size drawn over the kind's range (off every grid), on
  any active wheel, its onset anywhere (a share right after the calibration), a step or a ramp of
  50-300 s; a second fault (one faulty run in five) on another wheel, s included once it came in;
* a share in orbit (one in five), the magnetorquers dumping momentum;
* 600 s to 6 h.

The core loop runs the node code: the onboard verdict, the isolation node's fault identification and
the reconfiguration (core.closed_loop.simulate with Fdir). Figures, each with its 95 % Wilson interval:

* reconfigurations without a fault, per 600-s fault-free run and per 100 h of fault-free service (the
  fault-free runs and the time before the first onset of the others);
* the faulty wheel, and no other, acted on (given up, held or kept with its reason) among the runs whose
  fault is physically visible; a fault the physics hides is counted as such;
* pointing kept: within 0.2 deg on every axis at every sample from 60 s after the first onset (60 s
  from the start without a fault) that is not within 60 s of a set-point change; a run whose FDIR said
  the momentum could not allow it, when it happened, is counted apart with that reason;
* identification of the wheel acted on: kind right, size within tolerance, interval covering the truth.

In service FDIR keeps or holds nearly every wheel it acts on (a wheel given up would leave the momentum
to the others); a wheel given up is identified from the samples before its driver goes off. That case
gets runs of its own (``given_up_runs``): faulty draws of the family, up to 30 min long, with FDIR made
to give up every wheel it confirms (``Fdir.holdable`` infinite, no slew margin, the policy before holding
and keeping), measured for identification only.

With ``watch`` (``--every-observer``) every observer of an FDI configuration (ours, and a user's plug-ins) is
judged beside the decision on the same runs, acted on by nothing (core/fdi/pipeline.FdiPipeline watch): its false alarms
on fault-free 600-s runs and per 100 h, the faulty wheel and no other alarmed, no healthy wheel alarmed while or
after the spacecraft reconfigured, the alarm held to the end, the delay (docs/fdi.md "Learned observers in
service").

Seeds: tuning from 90,000,000, evaluation (figures of record) from 91,000,000, the suite's net
from 92,000,000; within each, the fault-free 600-s runs from +500,000 and the given-up runs from +700,000.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ...fdi_config import FdiConfig
from ...core.closed_loop import simulate
from ...core.fdir import SATURATED_S
from ...core.fdi.identification.identifiability import TOLD_APART, other_family_misfit, told_apart
from ...core.fdi.identification import DRIVE, UNKNOWN
from ...core.mission.plant_choices import FDI_PERIOD
from ...core.mission.scenario import SETTLE_S, Scenario, in_transient
from ...core.mission.vehicle import DEFAULT_VEHICLE
from ...core.physics.faults import nominal_values
from ...core.physics.wheel import torque_scale
from ..campaigns.campaign import LocalExecutor
from .journal import resumable_map
from ..campaigns.service_family import FAULT_FREE_S, FAULT_KINDS, Draw, batches, draw, fdir_for, scenario
from ...scoring.metrics import judge_size
from ...scoring.metrics import rate
from .kit import format_rate, write_report, vehicle_words

SEED_BASES = {"tuning": 90_000_000, "evaluation": 91_000_000, "net": 92_000_000}
FAULT_FREE_SEEDS = 500_000   # the fault-free runs' seeds: the set's base plus this
GIVEN_UP_SEEDS = 700_000     # the given-up runs' seeds: the set's base plus this
GIVEN_UP_MAX_S = 1800.0      # [s] the given-up runs' longest
POINTING_DEG = 0.2
EVERY = 10               # record every 10th control sample (1 s): hours of four wheels in memory
ACTED = ("out_of_use", "held", "kept_in_use")
# what FDIR says when the momentum (or the wheels left) cannot keep the pointing (core/fdir.py)
MOMENTUM_REASONS = ("pointing is lost", "no wheel left")
# [N m] a fault effect well above every residual bound: certainly visible (the Type A's; another wheel type's
# scaled by its torque, wheel.torque_scale: run_figures' visible_torque)
VISIBLE_TORQUE = 2e-4


def judged_mask(time, scenario_: Scenario, start: float) -> np.ndarray:
    """The samples the pointing is judged at: from ``start`` on, not within SETTLE_S after a set-point change
    nor after a fault's onset (a second fault has the 60 s the first has)."""
    times, _ = scenario_.setpoint_schedule()
    return (time >= start) & ~in_transient(time, [*times, *(f.onset for f in scenario_.faults)])


def _identification(traj, b: int, d: Draw, scenario_: Scenario, i: int, out: dict) -> dict:
    """The identification of run ``b``'s first fault (on wheel index ``i``, acted on) against the truth."""
    f0 = d.faults[0]
    found = (traj.identified[b] or {}).get(f0["wheel"]) if traj.identified else None
    truth = f0["kind"]   # the identifier names a kind as the scenario does
    row = {"true_kind": truth, "kind": found.kind if found else "none",
           "message": found.message() if found else "never alarmed"}
    row["kind_right"] = row["kind"] == truth
    # or the drive named, its current and bus not told apart (Identification.between)
    row["kind_narrowed"] = row["kind_right"] or (found is not None and truth in found.between)
    if row["kind_right"]:
        row.update(judge_size(scenario_.faults[0], found.size, found.low, found.high, found.at_s,
                              nominal=nominal_values(scenario_.spacecraft.wheel)),
                   low=float(found.low), high=float(found.high), growing=found.growing)
    if d.give_up and out["action"] == "out_of_use" and truth in DRIVE:
        row["drive_misfit"] = _drive_misfit(traj, b, i, scenario_, truth, f0["onset"], f0["onset"] + out["delay_s"])
        row["drive_told_apart"] = told_apart(row["drive_misfit"])
    return row


def run_figures(traj, b: int, d: Draw, scenario_: Scenario) -> dict:
    """What one run did: decisions, pointing, identification, against the truth."""
    names = traj.wheel_names
    decisions = [(round(x.time, 1), x.wheel, x.action, x.reason) for x in traj.decisions[b]]
    first = min((f["onset"] for f in d.faults), default=None)
    start = (first if first is not None else 0.0) + SETTLE_S
    judged = judged_mask(traj.time, scenario_, start)
    error = np.degrees(np.abs(traj.error[:, b])).max(axis=1)
    bad = judged & (error > POINTING_DEG)
    out = {"seed": d.seed, "fault_free_family": d.fault_free, "give_up": d.give_up, "duration": d.duration,
           "units": d.units,
           "orbit": d.orbit, "faults": list(d.faults),
           "decisions": decisions, "pointing_kept": not bool(bad.any()),
           "worst_deg": float(error[judged].max(initial=0.0)),
           "first_lost_s": float(traj.time[np.argmax(bad)]) if bad.any() else None,
           "peak_wheel_speed": float(np.abs(traj.wheel_speed[:, b]).max())}
    said = [x for x in decisions if any(m in x[3] for m in MOMENTUM_REASONS)]
    lost = out["first_lost_s"]
    # said when it happens: before the first judged sample it is lost at, or within the settling time of it
    # (a loss that begins inside a slew is first judged up to SETTLE_S later)
    in_time = [x for x in said if lost is None or x[0] <= lost + SETTLE_S]
    out["momentum_said"] = in_time[0][3] if in_time else None
    out["momentum_said_s"] = in_time[0][0] if in_time else None
    out["at_limit"] = [x[1] for x in decisions if x[2] == "at_limit"]
    out["reconfigured_before_fault"] = [x for x in decisions if first is None or x[0] < first]
    acted = {w for _, w, a, _ in decisions if a in ACTED}
    faulty = {f["wheel"] for f in d.faults}
    if d.faults:
        f0 = d.faults[0]
        after = traj.time >= f0["onset"]
        i = names.index(f0["wheel"])
        effect = np.abs(traj.fault_effect[:, b, i])
        out["fault_effect_peak"] = float(effect[after].max(initial=0.0))
        out["visible_torque"] = visible = VISIBLE_TORQUE * torque_scale(scenario_.spacecraft.wheel)
        shown = after & (effect > visible)
        # a ramp may hide for minutes (a bus drop shows once the wheel needs the voltage): when it showed
        out["visible_s"] = float(traj.time[np.argmax(shown)]) if shown.any() else None
        out["acted_right"] = bool(f0["wheel"] in acted and not (acted - faulty))
        out["healthy_acted"] = sorted(acted - faulty)
        out["delay_s"] = next((t - f0["onset"] for t, w, a, _ in decisions if w == f0["wheel"] and a in ACTED), None)
        out["action"] = next((a for _, w, a, _ in decisions if w == f0["wheel"] and a in ACTED), None)
        if sum(f["wheel"] == f0["wheel"] for f in d.faults) == 1 and f0["wheel"] in acted:
            out["identification"] = _identification(traj, b, d, scenario_, i, out)
    if traj.watched:
        out["observers"] = observer_figures(traj.watched[b], d, decisions)
    return out


def _drive_misfit(traj, b: int, i: int, scenario_, kind: str, onset: float, given_up_at: float) -> float:
    """How far the other drive family stays from the run's drive fault on the FDI samples its wheel was driven
    with the fault, from the onset to its give-up, each the mean of its control steps (D,
    core/identification/identifiability.py)."""
    driven = (traj.time >= onset) & (traj.time < given_up_at)
    fault, nominal = scenario_.faults[0], nominal_values(scenario_.spacecraft.wheel)
    return other_family_misfit(kind, traj.tcv[driven, b, i], traj.wheel_speed[driven, b, i], traj.time[driven],
                               [fault.value_at(t, nominal) for t in traj.time[driven]], scenario_.spacecraft.wheel,
                               period=FDI_PERIOD)


def observer_figures(watched: dict, d: Draw, decisions: list) -> dict:
    """slot -> what each observer judged beside the decision said of one run: its alarms against the truth and
    against FDIR's acts (a healthy wheel alarmed while or after the spacecraft reconfigured)."""
    first = min((f["onset"] for f in d.faults), default=None)
    faulty = {f["wheel"] for f in d.faults}
    acted_at = min((t for t, _, a, _ in decisions if a in ACTED), default=None)
    out = {}
    for slot, wheels in watched.items():
        starts = {a: [s for s, _ in spans] for a, spans in wheels.items()}
        before = first if first is not None else d.duration
        row = {"alarms_before_fault": sum(s < before for ss in starts.values() for s in ss),
               "alarmed": sorted(a for a, ss in starts.items() if ss)}
        if d.faults:
            f0 = d.faults[0]
            # an alarm of the faulty wheel up at the onset or after it (one raised before and still up: from the onset)
            on_fault = [max(s, f0["onset"]) for s, e in wheels[f0["wheel"]] if e is None or e >= f0["onset"]]
            healthy = sorted(a for a, ss in starts.items() if ss and a not in faulty)
            row.update(detected=bool(on_fault), healthy_alarmed=healthy, right=bool(on_fault) and not healthy,
                       delay_s=on_fault[0] - f0["onset"] if on_fault else None,
                       held=bool(on_fault) and wheels[f0["wheel"]][-1][1] is None)
            if acted_at is not None:
                row["healthy_after_reconfiguration"] = sorted(
                    a for a, spans in wheels.items() if a not in faulty and any(e is None or e >= acted_at
                                                                               for _, e in spans))
        out[slot] = row
    return out


def _simulate(draws: list, watch: FdiConfig | None = None) -> list:
    """One batch (equal duration, wheels and orbit): the runs' figures; ``watch``: every observer's too."""
    scenarios = [scenario(d) for d in draws]
    fdir = fdir_for(draws[0].units, draws[0].give_up, draws[0].vehicle, watch)
    # a given-up run (at most 30 min) keeps every control step: what its driven FDI samples averaged
    traj = simulate(scenarios, fdir=fdir, every=1 if draws[0].give_up else EVERY)
    return [run_figures(traj, b, d, s) for b, (d, s) in enumerate(zip(draws, scenarios))]


def given_up_draws(seeds, vehicle: str = DEFAULT_VEHICLE) -> list:
    """The faulty draws among ``seeds``, at most GIVEN_UP_MAX_S long, to run with FDIR giving every wheel up."""
    from dataclasses import replace
    return [replace(d, give_up=True) for d in (draw(s, GIVEN_UP_MAX_S, vehicle=vehicle) for s in seeds) if d.faults]


def run_service(seeds, executor=None, progress=None, max_duration: float | None = None, fault_free_seeds=(),
                given_up_seeds=(), vehicle: str = DEFAULT_VEHICLE, watch: FdiConfig | None = None,
                out=None) -> list:
    """Figures of the in-service runs of ``seeds``, of the fault-free 600-s runs of ``fault_free_seeds`` and of
    the faulty draws of ``given_up_seeds`` with FDIR giving up (:func:`given_up_draws`), in seed order, on
    ``executor`` (local processes by default, or a Dask cluster), all flying ``vehicle``; with ``watch`` (an
    FdiConfig) every observer of it judged beside the decision on each flight run; with ``out``, the finished
    batches kept there and an interrupted bench resumed (journal.resumable_map)."""
    from functools import partial
    work = batches([draw(s, max_duration, vehicle=vehicle) for s in seeds]
                   + [draw(s, fault_free=True, vehicle=vehicle) for s in fault_free_seeds]
                   + given_up_draws(given_up_seeds, vehicle))
    runs = []
    executor, simulate_batch = executor or LocalExecutor(), partial(_simulate, watch=watch)
    # the campaigns' executor: SIGTERM or Ctrl-C drops the queued batches and ends the workers at once
    done = (resumable_map(executor, simulate_batch, work, out, "service") if out is not None
            else executor.map_unordered(simulate_batch, work, processes=True))
    for batch in done:
        runs += batch
        if progress:
            progress(len(batch))
    return sorted(runs, key=lambda r: r["seed"])


GROWTHS = ("step", "temperature ramp", "current or bus ramp")


def _growth(fault: dict) -> str:
    """How a fault grew, as the identification figures are split: a step, or a ramp of the friction law or of
    the motor current (current loss, bus drop: alike at one speed)."""
    if not fault["ramp"]:
        return "step"
    return "temperature ramp" if fault["kind"] == "temperature" else "current or bus ramp"


def _lost_as_it_showed(run: dict) -> bool:
    """Lost, not said, within SETTLE_S of the fault's effect first showing (the grace a step has from its onset)
    and before any decision on it: a ramp that hid until then took the pointing out faster than an alarm can be
    confirmed (a window mean of WINDOW samples and the persistence)."""
    lost, shown = run["first_lost_s"], run.get("visible_s")
    if run["pointing_kept"] or run["momentum_said"] is not None or lost is None or shown is None:
        return False
    wheel = run["faults"][0]["wheel"]
    decided = min((t for t, w, a, _ in run["decisions"] if w == wheel and a in ACTED), default=np.inf)
    return lost < shown + SETTLE_S and lost <= decided + 1.0


def summarize(all_runs: list) -> dict:
    """The figures (module docstring): the fault-free ones on the family's runs and the fault-free 600-s runs
    together, the others on the family's runs."""
    given_up = [r for r in all_runs if r.get("give_up")]
    all_runs = [r for r in all_runs if not r.get("give_up")]   # the flight policy's runs
    runs = [r for r in all_runs if not r.get("fault_free_family")]
    free = [r for r in all_runs if not r["faults"]]
    free_600 = [r for r in free if r["duration"] == FAULT_FREE_S]
    hours = sum(r["duration"] if not r["faults"] else r["faults"][0]["onset"] for r in all_runs) / 3600.0
    before = sum(len(r["reconfigured_before_fault"]) > 0 for r in all_runs)
    faulty = [r for r in runs if r["faults"]]
    visible = [r for r in faulty if r["fault_effect_peak"] > r.get("visible_torque", VISIBLE_TORQUE)]
    hidden = [r for r in faulty if r["fault_effect_peak"] <= r.get("visible_torque", VISIBLE_TORQUE)]
    ident = [r["identification"] for r in faulty if "identification" in r]
    right = [i for i in ident if i["kind_right"]]
    delays = np.array([r["delay_s"] for r in faulty if r["delay_s"] is not None])
    said = [r for r in runs if r["at_limit"]]
    return {
        "runs": len(runs), "hours": sum(r["duration"] for r in runs) / 3600.0,
        "fault_free_runs": len(all_runs) - len(runs),
        "at_limit_said": {"runs": len(said), "pointing_kept": sum(r["pointing_kept"] for r in said)},
        "reconfigured_fault_free_600s": rate(bool(r["decisions"]) for r in free_600),
        "reconfigured_fault_free_any": rate(bool(r["decisions"]) for r in free),
        "fault_free_hours": hours, "runs_reconfigured_before_fault": before,
        "reconfigurations_per_100h": 100.0 * before / hours if hours else None,
        "acted_right": rate(r["acted_right"] for r in visible),
        "physically_hidden": {"runs": len(hidden), "acted": sum(r["action"] is not None for r in hidden),
                              "healthy_acted": sum(bool(r["healthy_acted"]) for r in hidden)},
        "healthy_acted": rate(bool(r["healthy_acted"]) for r in runs if r["faults"]),
        "pointing_kept": rate(r["pointing_kept"] for r in runs),
        "pointing_kept_faulty": rate(r["pointing_kept"] for r in faulty),
        "pointing_lost_said": rate(not r["pointing_kept"] and r["momentum_said"] is not None for r in runs),
        # the goal's "where the wheels allow it": every run but those lost where FDIR said they could not
        "pointing_kept_allowed": rate(r["pointing_kept"] for r in runs
                                      if r["pointing_kept"] or r["momentum_said"] is None),
        "pointing_lost_showing": rate(_lost_as_it_showed(r) for r in runs),
        "pointing_lost_unexplained": rate(not r["pointing_kept"] and r["momentum_said"] is None
                                          and not _lost_as_it_showed(r) for r in runs),
        "kind_right": rate(i["kind_right"] for i in ident),
        "kind_right_by_action": {a: rate(r["identification"]["kind_right"] for r in faulty
                                         if "identification" in r and r["action"] == a) for a in ACTED},
        "kind_right_by_growth": {g: rate(r["identification"]["kind_right"] for r in faulty
                                         if "identification" in r and _growth(r["faults"][0]) == g) for g in GROWTHS},
        "covered_by_growth": {g: rate(r["identification"]["covered"] for r in faulty if "identification" in r
                                      and r["identification"]["kind_right"] and _growth(r["faults"][0]) == g)
                              for g in GROWTHS},
        "size_right": rate(i["size_right"] for i in right),
        "covered": rate(i["covered"] for i in right),
        "delay_s": ({"median": float(np.median(delays)), "p90": float(np.percentile(delays, 90)),
                     "max": float(delays.max())} if delays.size else None),
        "unknown": sum(i["kind"] == UNKNOWN for i in ident),
        "given_up": _given_up_figures(given_up),
        **({"observers": _observer_figures(all_runs, free_600, visible, hours)} if any("observers" in r
                                                                                     for r in all_runs) else {}),
    }


def _observer_figures(all_runs: list, free_600: list, visible: list, hours: float) -> dict:
    """Every observer judged beside the decision (run_figures' ``observers``), slot by slot: false alarms on the
    fault-free 600-s runs and per 100 h of fault-free service, the faulty wheel and no other alarmed (visible
    faults), no healthy wheel alarmed while or after the spacecraft reconfigured, the alarm held to the end,
    the delay."""
    slots = next(r["observers"] for r in all_runs if "observers" in r)
    out = {}
    for slot in slots:
        def of(r):
            return r["observers"][slot]
        detected = [of(r) for r in visible if of(r)["detected"]]
        delays = np.array([o["delay_s"] for o in detected])
        reconfigured = [of(r) for r in visible if "healthy_after_reconfiguration" in of(r)]
        alarms = sum(of(r)["alarms_before_fault"] for r in all_runs)
        out[slot] = {
            "false_alarm_600s": rate(bool(of(r)["alarmed"]) for r in free_600),
            "false_alarms_per_100h": 100.0 * alarms / hours if hours else None, "false_alarms": alarms,
            "right": rate(of(r)["right"] for r in visible),
            "detected": rate(of(r)["detected"] for r in visible),
            "no_healthy_after_reconfiguration": rate(not o["healthy_after_reconfiguration"] for o in reconfigured),
            "held": rate(o["held"] for o in detected),
            "delay_s": ({"median": float(np.median(delays)), "p90": float(np.percentile(delays, 90))}
                        if delays.size else None)}
    return out


def _given_up_figures(runs: list) -> dict:
    """Identification of the wheel given up at its decision, on the runs with FDIR giving up; those whose
    fault was never acted on (hidden by the physics, or after the run's end) are counted apart."""
    out = [r for r in runs if r["action"] == "out_of_use" and "identification" in r]
    ident = [r["identification"] for r in out]
    right = [i for i in ident if i["kind_right"]]
    drive = [i for i in ident if "drive_told_apart" in i]
    told = [i for i in drive if i["drive_told_apart"]]
    # what the physics allows: a temperature always (its spin-down shows it), a drive fault where its driven
    # samples tell a current loss from a bus drop
    allowed = [i for i in ident if i["true_kind"] not in DRIVE] + told
    return {"runs": len(runs), "given_up": len(out), "kind_right": rate(i["kind_right"] for i in ident),
            "drive": len(drive), "drive_told_apart": len(told),
            "kind_right_told_apart": rate(i["kind_right"] for i in allowed),
            "drive_right_told_apart": rate(i["kind_right"] for i in told),
            "drive_said_not_told_apart": rate(i.get("kind_narrowed", i["kind_right"]) for i in drive
                                              if not i["drive_told_apart"]),
            "kind_narrowed": rate(i.get("kind_narrowed", i["kind_right"]) for i in ident),
            "kind_wrong": sum(i["kind"] not in (i["true_kind"], "unknown", "none") for i in ident),
            "size_right": rate(i["size_right"] for i in right), "covered": rate(i["covered"] for i in right),
            "kind_right_by_kind": {k: rate(r["identification"]["kind_right"] for r in out
                                           if r["faults"][0]["kind"] == k) for k in FAULT_KINDS},
            "kind_right_by_growth": {g: rate(r["identification"]["kind_right"] for r in out
                                             if _growth(r["faults"][0]) == g) for g in GROWTHS}}



def bench_service(runs: int = 1000, seeds: str = "evaluation", out: str | Path = "reports/service", executor=None,
                  progress=None, max_hours: float | None = None, fault_free_runs: int = 1000,
                  given_up_runs: int = 300, vehicle: str = DEFAULT_VEHICLE, watch: FdiConfig | None = None) -> dict:
    """``runs`` of the in-service family, ``fault_free_runs`` fault-free 600-s runs of it and the faulty draws
    among ``given_up_runs`` seeds run with FDIR giving up, on the seeds of ``seeds`` (SEED_BASES; the fault-free
    ones from FAULT_FREE_SEEDS above, the given-up ones from GIVEN_UP_SEEDS); the report in ``out``."""
    seed_base = SEED_BASES[seeds]
    t0 = time.monotonic()
    max_duration = None if max_hours is None else 3600.0 * max_hours
    free_base = seed_base + FAULT_FREE_SEEDS
    given_base = seed_base + GIVEN_UP_SEEDS
    results = run_service(range(seed_base, seed_base + runs), executor, progress, max_duration,
                          range(free_base, free_base + fault_free_runs), range(given_base, given_base + given_up_runs),
                          vehicle, watch, out)
    report = {"schema": "rw_fdi_ros/service_bench/2", "seconds": time.monotonic() - t0, "max_hours": max_hours,
              "vehicle": vehicle,
              "date": time.strftime("%Y-%m-%d"), "seed_set": seeds, "seed_base": seed_base,
              "seeds": [seed_base, seed_base + runs - 1],
              "fault_free_seeds": [free_base, free_base + fault_free_runs - 1] if fault_free_runs else None,
              "given_up_seeds": [given_base, given_base + given_up_runs - 1] if given_up_runs else None,
              "figures": summarize(results), "runs": results}
    return write_report(report, out, "service", format_service)


class RecordMismatch(RuntimeError):
    """A run re-simulated for its identification acted or pointed otherwise than its record: more changed than
    the identifier, and the whole bench must be run again."""


# what a re-simulated run must repeat of its record: FDIR does not read the identifier, so its acts (when, which
# wheel, what; their reasons' wording may have changed) and pointing are the same wheel for wheel
_UNMOVED = ("acts", "pointing_kept", "worst_deg", "action", "acted_right", "delay_s")


def _same(a, b) -> bool:
    """Equal, floats to 1e-9 relative: a batch of other runs beside it moves a run's numbers in the last bits."""
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1e-12)
    return a == b


def _unmoved(run: dict) -> dict:
    """What of ``run`` a change to the identifier cannot move (_UNMOVED), as the report's JSON holds it."""
    return json.loads(json.dumps({"acts": [x[:3] for x in run["decisions"]],
                                  **{k: run.get(k) for k in _UNMOVED[1:]}}))


def reidentify(out: str | Path = "reports/service", executor=None, progress=None) -> dict:
    """Re-measure the identification of the service report in ``out`` after a change to the identifier: its runs
    that carry an identification (a single fault acted on) and its given-up runs simulated again, every other
    run kept as measured (the fault-free ones, the faults never acted on). Each flight run re-simulated must
    repeat its record's decisions and pointing (_UNMOVED), else RecordMismatch: then more than the identifier
    changed. Minutes instead of the bench's hour and a half, as the long fault-free runs are not flown again."""
    out = Path(out)
    path = out / "service.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no service report to re-identify (run `rw-fdi bench service` first)")
    report = json.loads(path.read_text())
    report.pop("text", None)
    report.pop("ok", None)
    if any("observers" in r for r in report["runs"]):
        raise ValueError(f"{path}: a report of every observer (--every-observer); re-identify the decision's "
                         "report, or run that bench again")
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    max_duration = None if report.get("max_hours") is None else 3600.0 * report["max_hours"]
    flight = [r["seed"] for r in report["runs"] if "identification" in r and not r.get("give_up")]
    given = range(report["given_up_seeds"][0], report["given_up_seeds"][1] + 1) if report.get("given_up_seeds") \
        else ()
    t0 = time.monotonic()
    new = run_service(flight, executor, progress, max_duration, (), given, vehicle)
    old = {r["seed"]: r for r in report["runs"] if not r.get("give_up") and not r.get("fault_free_family")}
    moved = {}
    for r in new:
        if not r.get("give_up"):
            now, then = _unmoved(r), _unmoved(old[r["seed"]])
            what = [k for k in _UNMOVED if not _same(now[k], then[k])]
            moved.update({r["seed"]: what} if what else {})
    if moved:
        # kept for a look: the runs took minutes to an hour
        (out / "service_reidentify_refused.json").write_text(json.dumps(new, indent=1))
        seed, what = next(iter(moved.items()))
        raise RecordMismatch(f"{len(moved)} runs act or point otherwise than recorded (seed {seed}: "
                             f"{', '.join(what)}; the runs in {out / 'service_reidentify_refused.json'}): more than "
                             "the identifier changed; run `rw-fdi bench service` again")
    again = {(r["seed"], bool(r.get("give_up"))) for r in new}
    report["runs"] = sorted([r for r in report["runs"] if (r["seed"], bool(r.get("give_up"))) not in again] + new,
                            key=lambda r: r["seed"])
    report["figures"] = summarize(report["runs"])
    report["rejudged"] = (report.get("rejudged", "") + f" Identification re-measured {time.strftime('%Y-%m-%d')} "
                          f"({(time.monotonic() - t0) / 60:.0f} min, `rw-fdi bench service --reidentify`): "
                          f"the {len(flight)} flight runs with an identification and the given-up runs simulated "
                          "again, each flight run's decisions and pointing as recorded; every other run as "
                          "measured.").strip()
    return write_report(report, out, "service", format_service)


def _format_observers(figures: dict | None) -> list:
    """The table of every observer judged beside the decision (``--every-observer``), one column each."""
    if not figures:
        return []
    slots = list(figures)

    def row(name, cell):
        return f"| {name} | " + " | ".join(cell(figures[s]) for s in slots) + " |"
    return ["", "## Every observer in service", "",
            "Each observer judged beside the decision on the same runs (the model observer's verdict flies FDIR; "
            "the others are acted on by nothing): its alarms against the truth and against FDIR's acts.", "",
            "| figure | " + " | ".join(slots) + " |", "|---|" + "---|" * len(slots),
            row("false alarms, fault-free 600-s runs", lambda o: format_rate(o["false_alarm_600s"])),
            row("false alarms per 100 h of fault-free service",
                lambda o: "-" if o["false_alarms_per_100h"] is None else
                f"{o['false_alarms_per_100h']:.1f} ({o['false_alarms']})"),
            row("the faulty wheel and no other alarmed (visible faults)", lambda o: format_rate(o["right"])),
            row("detected (visible faults)", lambda o: format_rate(o["detected"])),
            row("no healthy wheel alarmed while or after the spacecraft reconfigured",
                lambda o: format_rate(o["no_healthy_after_reconfiguration"])),
            row("alarm held to the end (detected)", lambda o: format_rate(o["held"])),
            row("delay median / p90 [s]", lambda o: "-" if not o["delay_s"] else
                f"{o['delay_s']['median']:.0f} / {o['delay_s']['p90']:.0f}")]


def _service_intro(report: dict) -> list:
    """The title (the vehicle where not the thesis'), and what was measured: seeds, hours, time, shortening."""
    f = report["figures"]
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    return ["# FDIR in service (`rw-fdi bench service`)"
            + (f", vehicle {vehicle_words(vehicle)}" if vehicle != DEFAULT_VEHICLE else ""), "",
            f"Measured {report['date']}, {report['seed_set']} seeds {report['seeds'][0]:,}-{report['seeds'][1]:,} "
            f"({f['runs']} runs, {f['hours']:.0f} h of service)"
            + (f" and fault-free 600-s runs {report['fault_free_seeds'][0]:,}-{report['fault_free_seeds'][1]:,}"
               if report.get("fault_free_seeds") else "")
            + f"; {report['seconds'] / 60:.0f} min on this machine. "
            "95 % Wilson intervals. The envelope: tools/benches/service_bench.py"
            + (f"; runs longer than {report['max_hours']:g} h shortened to it (--max-hours)."
               if report.get("max_hours") else ".")
            + (f" {report['rejudged']}" if report.get("rejudged") else ""), ""]


def _service_table(f: dict) -> list:
    """The figures of FDIR in service against their goals."""
    lines = ["| figure | measured | goal |", "|---|---|---|",
             f"| reconfigurations without a fault, 600-s runs | {format_rate(f['reconfigured_fault_free_600s'])} | "
             "<= 0.5 % |",
             "| reconfigurations without a fault, per 100 h | "
             + ("-" if f["reconfigurations_per_100h"] is None else f"{f['reconfigurations_per_100h']:.2f} ")
             + f"({f['runs_reconfigured_before_fault']} in {f['fault_free_hours']:.0f} h) | <= 1 |",
             f"| the faulty wheel and no other acted on (visible faults) | {format_rate(f['acted_right'])} | >= 99 % |",
             f"| pointing kept, every run | {format_rate(f['pointing_kept'])} | >= 99 % |",
             f"| pointing lost where FDIR said the momentum could not allow it | "
             f"{format_rate(f['pointing_lost_said'])} | said |",
             *([f"| pointing kept where the wheels allowed it (every run but those) | "
                f"{format_rate(f['pointing_kept_allowed'])} | >= 99 % |"] if "pointing_kept_allowed" in f else []),
             f"| pointing lost within {SETTLE_S:.0f} s of a ramp's effect first showing, before the FDI could "
             f"confirm it | {format_rate(f['pointing_lost_showing'])} | said |",
             f"| pointing lost, unexplained | {format_rate(f['pointing_lost_unexplained'])} | 0 |",
             f"| identification: kind right | {format_rate(f['kind_right'])} | >= 95 % |",
             f"| identification: size within tolerance | {format_rate(f['size_right'])} | >= 90 % |",
             f"| identification: 95 % interval covers the truth | {format_rate(f['covered'])} | >= 90 % |"]
    lines += [f"| kind right, wheel {a.replace('_', ' ')} | {format_rate(r)} | >= 95 % |"
              for a, r in f["kind_right_by_action"].items()]
    return lines + [f"| kind right / interval covers, {g}s | {format_rate(r)} / "
                    f"{format_rate(f['covered_by_growth'][g])} | >= 95 % / >= 90 % |"
                    for g, r in f.get("kind_right_by_growth", {}).items()]


def _service_notes(f: dict) -> list:
    """The delay to a decision, the wheels said at their limit, the faults the physics hides."""
    d, a, h = f["delay_s"], f["at_limit_said"], f["physically_hidden"]
    lines = ["", f"Onset to decision: median {d['median']:.0f} s, p90 {d['p90']:.0f} s, max {d['max']:.0f} s "
             "(ramps included)."] if d else []
    return lines + [
        f"A wheel in use said at its limit after a reconfiguration (past the holdable speed, at the voltage "
        f"limit for {SATURATED_S:.0f} s, or short of torque with no wheel left): {a['runs']} runs, the pointing "
        f"kept in {a['pointing_kept']} of them (the warning came; the slews then allowed it).",
        f"Faults the physics hides (no visible torque effect, never acted on): {h['runs']} runs."]


def _given_up_drive_rows(g: dict) -> list:
    """The drive faults (current loss, bus drop) the physics tells apart or not, on a wheel given up."""
    if "drive" not in g:
        return []
    return [f"| current losses and bus drops the physics tells apart on their driven samples (the other "
            f"family at least D = {TOLD_APART:.0f} noise floors^2 away, "
            "core/identification/identifiability.py) | "
            f"{g['drive_told_apart']} of {g['drive']} | |",
            f"| kind right where the physics tells it (temperature, and drive faults told apart) | "
            f"{format_rate(g['kind_right_told_apart'])} | >= 95 % |",
            f"| kind right, drive faults told apart | {format_rate(g['drive_right_told_apart'])} | |",
            f"| 'current loss or bus drop' said (or the kind named right), drive faults the physics does "
            f"not tell apart | "
            f"{format_rate(g['drive_said_not_told_apart'])} | said |"]


def _given_up_section(g: dict | None, seeds) -> list:
    """The identification of a wheel FDIR gives up, on runs of its own (none: nothing)."""
    if not (g and g["runs"]):
        return []
    return (["", "## A wheel given up at its decision", "",
             f"FDIR in service keeps or holds nearly every wheel it acts on, so the wheel given up gets runs of "
             f"its own: the faulty draws of seeds {seeds[0]:,}-{seeds[1]:,} ({g['runs']} runs, at most "
             f"{GIVEN_UP_MAX_S / 60:.0f} min) with FDIR made to give up every wheel it confirms; its "
             "identification comes from the samples while it was driven and as it spun down on its friction "
             f"(at rest it shows nothing). {g['given_up']} wheels given up (the rest: faults the physics hid, "
             "or confirmed after the run's end).", "",
             "| figure | measured | goal |", "|---|---|---|",
             f"| kind right, wheel given up | {format_rate(g['kind_right'])} | >= 95 % |",
             f"| kind right, or the drive named (current or bus not told apart) | "
             f"{format_rate(g['kind_narrowed']) if 'kind_narrowed' in g else '-'} | |"]
            + _given_up_drive_rows(g)
            + [f"| a wrong kind named | {g.get('kind_wrong', '-')} of {g['given_up']} | 0 |",
               f"| size within tolerance | {format_rate(g['size_right'])} | >= 90 % |",
               f"| 95 % interval covers the truth | {format_rate(g['covered'])} | >= 90 % |"]
            + [f"| kind right, {k.replace('_', ' ')} | {format_rate(r)} | >= 95 % |"
               for k, r in g.get("kind_right_by_kind", {}).items()]
            + [f"| kind right, {k}s | {format_rate(r)} | >= 95 % |" for k, r in g["kind_right_by_growth"].items()])


def format_service(report: dict) -> str:
    f = report["figures"]
    lines = (_service_intro(report) + _service_table(f) + _service_notes(f) + _format_observers(f.get("observers"))
             + _given_up_section(f.get("given_up"), report.get("given_up_seeds")))
    return "\n".join(lines) + "\n"
