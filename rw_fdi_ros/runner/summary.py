"""What a person wants to know after a run, read back from its bag."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.physics.spacecraft import BODY_AXES, nearest_setpoint
from ..core.mission.scenario import in_transient, parse_scenario, setpoint_at
from ..core.physics.environment import MAGNETOMETER_PERIOD
from ..core.physics.magnetorquers import DumpLog
from ..graph.topics import ATTITUDE, DIPOLE_COMMAND, FAULT_EFFECT, FDIR_WHEELS, SCENARIO

# what run_summary reads of a bag
SUMMARY_TOPICS = [SCENARIO, ATTITUDE, FAULT_EFFECT, FDIR_WHEELS, DIPOLE_COMMAND]
POINTING_DEG = 0.2   # the pointing requirement [deg] (thesis Table 2.3)


def run_summary(path) -> dict:
    """Pointing error per axis at the end, peak error after the first fault and when the pointing was back
    within 0.2 deg (both outside set-point transients: a commanded slew is not the fault's), the reconfiguration
    decisions (/fdir/wheels), in orbit the momentum dumps, faults,
    bag state.

    One pass over the bag folding each sample into the figures (the last error, running maxima):
    memory does not grow with the run's length."""
    from ..storage.bag import BagInfo, iter_messages, typestore
    from ..storage.cdr import read_joint_state_cdr, read_vector_cdr
    info = BagInfo(path=Path(path))
    scenario, waiting = None, []   # attitude rows that came before the scenario (latched, at the start)
    last, peak, effect = None, None, None
    onset, outside, decisions = None, None, {}   # outside: the last time after onset beyond POINTING_DEG
    dumps = DumpLog()

    def fold(stamp, attitude):
        nonlocal last, peak, outside
        t = stamp // 10**9 + (stamp % 10**9) * 1e-9
        err = np.abs(np.rad2deg(attitude - nearest_setpoint(setpoint_at(times, values, t), attitude)))
        if last is None or t >= last[0]:
            last = (t, err)
        # the fault's error, not a commanded slew's: set-point transients left out, as the service bench does
        if onset is not None and t >= onset and not in_transient(t, times):
            peak = err if peak is None else np.maximum(peak, err)
            if err.max() >= POINTING_DEG and (outside is None or t > outside):
                outside = t

    for topic, _, raw in iter_messages(path, SUMMARY_TOPICS, info):
        if topic == SCENARIO and scenario is None:
            text = typestore().deserialize_cdr(raw, info.types[topic]).data
            scenario = parse_scenario(text, origin=f"{info.path}:/scenario")
            times, values = scenario.setpoint_schedule()
            onset = min((f.onset for f in scenario.faults), default=None)
            for row in waiting:
                fold(*row)
            waiting = []
        elif topic == ATTITUDE:
            stamp, attitude, _, _ = read_joint_state_cdr(raw)
            if scenario is None:
                waiting.append((stamp, attitude))
            else:
                fold(stamp, attitude)
        elif topic == FAULT_EFFECT:   # per wheel: a JointState's efforts (a Vector3Stamped before the 4th wheel)
            value = (read_vector_cdr(raw)[1] if info.types[topic].endswith("Vector3Stamped")
                     else read_joint_state_cdr(raw)[3])
            effect = np.abs(value) if effect is None else np.maximum(effect, np.abs(value))
        elif topic == DIPOLE_COMMAND:
            stamp, dipole = read_vector_cdr(raw)
            dumps.add(stamp * 1e-9, dipole)
        elif topic == FDIR_WHEELS:
            _fold_decisions(typestore().deserialize_cdr(raw, info.types[topic]), decisions)
    return _summary(info, scenario, last, decisions, dumps, peak, (onset, outside, effect))


def _summary(info, scenario, last, decisions: dict, dumps, peak, fault: tuple) -> dict:
    """:func:`run_summary`'s figures from what its pass folded (``fault``: onset, last time outside, effect)."""
    if scenario is None:
        raise ValueError(f"{info.path}: no /scenario message, cannot tell the set-points")
    if last is None:
        raise ValueError(f"{info.path}: no {ATTITUDE} messages")
    wheels = scenario.wheel_set(recorded=True).names
    out = {"scenario": scenario.name, "seed": scenario.seed, "end_time": float(last[0]),
           "final_error_deg": dict(zip(BODY_AXES, last[1].round(4).tolist())),
           "faults": [f.as_dict(wheels) for f in scenario.faults], "bag": str(info.path),
           "complete": info.complete,
           "reconfiguration": _reconfiguration(decisions)}
    if DIPOLE_COMMAND in info.counts:   # a dipole holds until the next reading's
        out["momentum_dumps"] = [[a, min(b + MAGNETOMETER_PERIOD, out["end_time"])] for a, b in dumps.done()]
    if peak is not None:
        onset, outside, effect = fault
        out.update(_after_fault(peak, onset, outside, last[0], effect, wheels))
    return out


def _fold_decisions(msg, decisions: dict):
    """Each wheel's decision of a /fdir/wheels message into ``decisions``: (since, joint) -> (state, reason)."""
    for status in msg.status:
        v = {kv.key: kv.value for kv in status.values}
        if "since" in v:
            decisions[(float(v["since"]), status.hardware_id)] = (v["state"], v["reason"])


def _reconfiguration(decisions: dict) -> list:
    """The decisions in time order; at one time, the wheel given up (held) before the one brought in."""
    return [{"time": t, "wheel": joint.removeprefix("reaction_wheel_"), "state": state, "reason": reason}
            for (t, joint), (state, reason) in sorted(
                decisions.items(), key=lambda d: (d[0][0], d[1][0] not in ("given_up", "held")))]


def _after_fault(peak, onset: float, outside, end: float, effect, wheels) -> dict:
    """The peak error after the first fault, when the pointing was back within POINTING_DEG for good (None:
    not by the run's ``end``) and, where recorded, the peak fault effect per wheel."""
    out = {"peak_error_after_fault_deg": dict(zip(BODY_AXES, peak.round(4).tolist()))}
    # pointing within the requirement from this time on (never out after the onset: the onset)
    back = onset if outside is None else outside + 0.1
    out["pointing_back_s"] = None if outside is not None and outside >= end else float(back)
    if effect is not None:
        out["peak_fault_effect_Nm"] = dict(zip(wheels, effect.tolist()))
    return out


def format_summary(s: dict) -> str:
    lines = [f"run {s['scenario']} seed {s['seed']}: {s['end_time']:.1f} s simulated"]
    lines.append("  final pointing error [deg]: " + "  ".join(f"{a}={v:.3f}" for a, v in s["final_error_deg"].items()))
    for f in s["faults"]:
        lines.append(f"  fault: {f['kind']}={f['value']:g} on wheel {f['wheel']} from {f['onset']:g} s")
    for d in s.get("reconfiguration", []):
        lines.append(f"  reconfiguration at {d['time']:g} s: wheel {d['wheel']} {d['state'].replace('_', ' ')} "
                     f"({d['reason']})")
    if "momentum_dumps" in s:
        dumps = s["momentum_dumps"]
        lines.append(f"  momentum dumping: {len(dumps)} dump{'s' if len(dumps) != 1 else ''}" + (
            " (rods on " + ", ".join(f"{a:g}-{b:g} s" for a, b in dumps[:6]) + (", ..." if len(dumps) > 6 else "")
            + ")" if dumps else ""))
    if "peak_error_after_fault_deg" in s:
        lines.append("  peak error after fault, set-point slews left out [deg]: " +
                     "  ".join(f"{a}={v:.3f}" for a, v in s["peak_error_after_fault_deg"].items()))
        back, onset = s.get("pointing_back_s"), min((f["onset"] for f in s["faults"]), default=0.0)
        lines.append(f"  pointing within {POINTING_DEG:g} deg on every axis " +
                     ("never again after the fault" if back is None else "throughout" if back <= onset
                      else f"again from {back:.1f} s ({back - onset:.1f} s after the onset)"))
    lines.append(f"  bag: {s['bag']}" + ("" if s["complete"] else " (incomplete)"))
    return "\n".join(lines)
