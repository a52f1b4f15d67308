"""What a person wants to know after a run, read back from its bag."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.scenario import AXES, parse_scenario, setpoint_at
from ..nodes.topics import ATTITUDE, FAULT_EFFECT, SCENARIO

SUMMARY_TOPICS = [SCENARIO, ATTITUDE, FAULT_EFFECT]   # what run_summary reads of a bag


def run_summary(path) -> dict:
    """Pointing error per axis at the end, peak error after the first fault, faults, bag state.

    One pass over the bag folding each sample into the figures (the last error, running maxima):
    memory does not grow with the run's length."""
    from ..storage.bag import BagInfo, iter_messages, typestore
    from ..storage.cdr import read_joint_state_cdr, read_vector_cdr
    info = BagInfo(path=Path(path))
    scenario, waiting = None, []   # attitude rows that came before the scenario (latched, at the start)
    last, peak, effect = None, None, None
    onset = None

    def fold(stamp, attitude):
        nonlocal last, peak
        t = stamp // 10**9 + (stamp % 10**9) * 1e-9
        err = np.abs(np.rad2deg(attitude - setpoint_at(times, values, t)))
        if last is None or t >= last[0]:
            last = (t, err)
        if onset is not None and t >= onset:
            peak = err if peak is None else np.maximum(peak, err)

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
        elif topic == FAULT_EFFECT:
            stamp, value = read_vector_cdr(raw)
            effect = np.abs(value) if effect is None else np.maximum(effect, np.abs(value))
    if scenario is None:
        raise ValueError(f"{info.path}: no /scenario message, cannot tell the set-points")
    if last is None:
        raise ValueError(f"{info.path}: no {ATTITUDE} messages")
    out = {"scenario": scenario.name, "seed": scenario.seed, "end_time": float(last[0]),
           "final_error_deg": dict(zip(AXES, last[1].round(4).tolist())),
           "faults": [f.as_dict() for f in scenario.faults], "bag": str(info.path),
           "complete": info.complete}
    if peak is not None:
        out["peak_error_after_fault_deg"] = dict(zip(AXES, peak.round(4).tolist()))
        if effect is not None:
            out["peak_fault_effect_Nm"] = dict(zip(AXES, effect.tolist()))
    return out


def format_summary(s: dict) -> str:
    lines = [f"run {s['scenario']} seed {s['seed']}: {s['end_time']:.1f} s simulated"]
    lines.append("  final pointing error [deg]: " + "  ".join(f"{a}={v:.3f}" for a, v in s["final_error_deg"].items()))
    for f in s["faults"]:
        lines.append(f"  fault: {f['kind']}={f['value']:g} on wheel {f['wheel']} from {f['onset']:g} s")
    if "peak_error_after_fault_deg" in s:
        lines.append("  peak error after fault [deg]: " +
                     "  ".join(f"{a}={v:.3f}" for a, v in s["peak_error_after_fault_deg"].items()))
    lines.append(f"  bag: {s['bag']}" + ("" if s["complete"] else " (incomplete)"))
    return "\n".join(lines)
