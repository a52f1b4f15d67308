"""What a person wants to know after a run, read back from its bag."""
from __future__ import annotations

import numpy as np

from ..core.scenario import AXES, parse_scenario, setpoint_at
from ..nodes.topics import ATTITUDE, FAULT_EFFECT, SCENARIO

SUMMARY_TOPICS = [SCENARIO, ATTITUDE, FAULT_EFFECT]   # what run_summary reads of a bag


def run_summary(bag) -> dict:
    """Pointing error per axis at the end, peak error after the first fault, faults, bag state.

    ``bag``: a storage.bag BagSeries (or BagData) holding at least SUMMARY_TOPICS."""
    text = bag.scenario_text
    if text is None:
        raise ValueError(f"{bag.path}: no /scenario message, cannot tell the set-points")
    scenario = parse_scenario(text, origin=f"{bag.path}:/scenario")
    t, att, _, _ = bag.joint_states(ATTITUDE)
    if len(t) == 0:
        raise ValueError(f"{bag.path}: no {ATTITUDE} messages")
    times, values = scenario.setpoint_schedule()
    sp = np.array([setpoint_at(times, values, ti) for ti in t])
    err = np.rad2deg(att - sp)
    out = {"scenario": scenario.name, "seed": scenario.seed, "end_time": float(t[-1]),
           "final_error_deg": dict(zip(AXES, np.abs(err[-1]).round(4).tolist())),
           "faults": [f.as_dict() for f in scenario.faults], "bag": str(bag.path),
           "complete": bag.complete}
    if scenario.faults:
        onset = min(f.onset for f in scenario.faults)
        after = t >= onset
        if after.any():
            out["peak_error_after_fault_deg"] = dict(zip(AXES, np.abs(err[after]).max(axis=0).round(4).tolist()))
            _, eff = bag.vectors(FAULT_EFFECT)
            if len(eff):
                out["peak_fault_effect_Nm"] = dict(zip(AXES, np.abs(eff).max(axis=0).tolist()))
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
