"""Many telemetry tables judged as one campaign (`rw-fdi telemetry DIR`): each run's verdict scored against its
ground truth, and the rates with their sample sizes and 95 % intervals, by fault kind.

A run is a table (docs/telemetry.md). Its ground truth is the table's ``<joint>.fault [1]`` columns; a JSON file
beside it (``run.csv`` -> ``run.json``) may describe the fault further: ``{"fault": {"kind": ..., "effect_nm":
...}}``, the kind to group by and the fault's largest 1-s torque on its wheel. A fault whose torque never
reaches the wheel's band cannot be seen by any observer at that band: it is reported as invisible, not as a
miss.
"""
from __future__ import annotations

import json
from functools import partial
from pathlib import Path

import numpy as np

from ...scoring.metrics import rate
from .telemetry_file import TelemetryError, judge, read_table

SUFFIXES = (".csv", ".parquet")


def table_paths(paths) -> list:
    """The tables named: files as given, a directory's CSV and Parquet files in name order (TelemetryError when
    a path is neither, or a directory holds none)."""
    out = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.suffix.lower() in SUFFIXES)
            if not found:
                raise TelemetryError(f"{p}: no .csv or .parquet table in it")
            out += found
        elif p.is_file():
            out.append(p)
        else:
            raise TelemetryError(f"{p}: no such file or directory")
    return out


def described_fault(path) -> dict | None:
    """The fault the JSON beside the table describes (its ``fault`` mapping), or None."""
    side = Path(path).with_suffix(".json")
    if not side.is_file():
        return None
    try:
        fault = json.loads(side.read_text())
    except ValueError:
        raise TelemetryError(f"{side}: not JSON") from None
    fault = fault.get("fault") if isinstance(fault, dict) else fault
    if fault is None:
        return None
    effect = fault.get("effect_nm") if isinstance(fault, dict) else None
    if (not isinstance(fault, dict) or not isinstance(fault.get("kind", ""), str)
            or not (effect is None or (isinstance(effect, (int, float)) and np.isfinite(effect) and effect >= 0))):
        raise TelemetryError(f"{side}: 'fault' must be a mapping with a 'kind' name and an 'effect_nm' >= 0 [N m]")
    return fault


def score_run(verdict: dict, fault: dict | None = None) -> dict:
    """One run's verdict against its ground truth.

    Parameters
    ----------
    verdict : dict
        :func:`telemetry_file.judge`'s verdict on a table with fault columns.
    fault : dict, optional
        The described fault (:func:`described_fault`): its ``kind`` and ``effect_nm``.

    Returns
    -------
    dict
        ``kind`` ('fault_free' without a faulty wheel, 'unscored' without fault columns), ``false_alarm``
        (an alarm on a healthy run, or before the onset), and for a faulty run ``detected`` (its wheel's first
        alarm at or after the onset: one before it is a false alarm and a miss), ``right_wheel`` (that wheel
        and no other), ``latency_s``, ``identified`` (the kind the identification named) and ``visible`` (the
        fault's largest 1-s torque above the wheel's median band after the onset, as scoring/metrics'
        observability; None undescribed).
    """
    wheels = verdict["wheels"]
    alarms = {a: w["first_alarm_s"] for a, w in wheels.items() if w["first_alarm_s"] is not None}
    faulty = [a for a, w in wheels.items() if w["truth_onset_s"] is not None]
    row = {"kind": "fault_free", "alarmed": ",".join(alarms), "not_judged_s": len(verdict["not_judged_s"])}
    if not verdict.get("scored", True):   # no fault columns: what it saw, not scored
        return {**row, "kind": "unscored", "false_alarm": None}
    if not faulty:
        return {**row, "false_alarm": bool(alarms)}
    wheel = faulty[0]
    onset = wheels[wheel]["truth_onset_s"]
    first = alarms.get(wheel)
    detected = first is not None and first >= onset
    band = [s["threshold"] for s in verdict["samples"] if s["wheel"] == wheel and s["time_s"] >= onset]
    effect = (fault or {}).get("effect_nm")
    return {**row, "kind": (fault or {}).get("kind", "fault"), "size": (fault or {}).get("size"), "wheel": wheel,
            "onset_s": onset,
            "false_alarm": any(t < onset for t in alarms.values()), "detected": detected,
            "right_wheel": detected and set(alarms) == {wheel}, "latency_s": first - onset if detected else None,
            "identified": wheels[wheel]["kind"], "band_nm": float(np.median(band)) if band else None,
            "effect_nm": effect, "visible": None if effect is None or not band else effect > float(np.median(band))}


def _judged(path, joints, vehicle, fdi, max_gap):
    """(path, score) of one table: a worker's call; a table that cannot be judged is a row saying why."""
    try:
        table = read_table(path, joints)
        return path, score_run(judge(table, vehicle, fdi, max_gap=max_gap), described_fault(path))
    except TelemetryError as exc:
        return path, {"kind": "not_judged", "error": str(exc)}


def judge_campaign(paths, joints, vehicle, fdi, max_gap: float = 2.5, executor=None, progress=None) -> list:
    """Every table judged (on ``executor``'s worker processes): one scored row per run, in the paths' order."""
    work = partial(_judged, joints=joints, vehicle=vehicle, fdi=fdi, max_gap=max_gap)
    done = {}
    results = (executor.map_unordered(work, paths, processes=True) if executor else map(work, paths))
    for path, row in results:
        done[path] = {"table": str(path), **row}
        if progress:
            progress()
    return [done[p] for p in paths]


def summary(rows: list) -> dict:
    """The campaign's rates, each with its count, sample size and 95 % interval: false alarms on fault-free
    runs; per fault kind, detection and the right wheel among the visible faults, how the invisible ones went,
    the identification named and the median latency."""
    def share(flags):   # metrics.rate, with no interval (not NaN, which JSON has not) for no runs
        r = rate(flags)
        return {**r, "ci95": r["ci95"] if r["n"] else None}
    apart = ("fault_free", "unscored", "not_judged")
    healthy = [r for r in rows if r["kind"] == "fault_free"]
    faulty = [r for r in rows if r["kind"] not in apart]
    out = {"runs": len(rows), "unscored": sum(r["kind"] == "unscored" for r in rows),
           "unscored_alarmed": sum(bool(r["alarmed"]) for r in rows if r["kind"] == "unscored"),
           "not_judged": {r["table"]: r["error"] for r in rows if r["kind"] == "not_judged"},
           "false_alarms_fault_free": share(r["false_alarm"] for r in healthy),
           "false_alarms_before_onset": share(r["false_alarm"] for r in faulty), "kinds": {}}
    for kind in sorted({r["kind"] for r in faulty}):
        runs = [r for r in faulty if r["kind"] == kind]
        seen = [r for r in runs if r["visible"] is not False]
        hidden = [r for r in runs if r["visible"] is False]
        latency = [r["latency_s"] for r in seen if r["detected"]]
        named = {}
        for r in seen:
            if r["detected"]:
                named[str(r["identified"])] = named.get(str(r["identified"]), 0) + 1
        out["kinds"][kind] = {"runs": len(runs), "visible": len(seen), "invisible": len(hidden),
                              "detected": share(r["detected"] for r in seen),
                              "right_wheel": share(r["right_wheel"] for r in seen),
                              "invisible_alarmed": share(r["detected"] for r in hidden),
                              "median_latency_s": float(np.median(latency)) if latency else None,
                              "identified_as": named}
    return out


def format_summary(s: dict) -> str:
    """The summary on one screen."""
    def pct(r):
        return "n/a" if not r["n"] else (f"{r['k']}/{r['n']} = {100 * r['rate']:.1f} % "
                                         f"[{100 * r['ci95'][0]:.1f}, {100 * r['ci95'][1]:.1f}]")
    lines = [f"{s['runs']} runs judged" + (f", {s['unscored']} without fault columns (not scored)"
                                            if s.get("unscored") else "")]
    lines += [f"  not judged: {table}: {why}" for table, why in s.get("not_judged", {}).items()]
    lines += [
             f"  false alarms, fault-free runs:       {pct(s['false_alarms_fault_free'])}",
             f"  alarms before the onset, faulty runs: {pct(s['false_alarms_before_onset'])}"]
    if s.get("unscored"):
        lines.append(f"  alarmed, unscored runs: {s['unscored_alarmed']}")
    for kind, k in s["kinds"].items():
        lines.append(f"  {kind}: {k['runs']} runs, {k['visible']} visible at the band, {k['invisible']} invisible")
        lines.append(f"    detected {pct(k['detected'])}; that wheel and no other {pct(k['right_wheel'])}"
                     + (f"; median {k['median_latency_s']:g} s after the onset" if k["median_latency_s"] is not None
                        else ""))
        if k["invisible"]:
            lines.append(f"    invisible, alarmed anyway: {pct(k['invisible_alarmed'])}")
        if k["identified_as"]:
            lines.append("    identified as: " + ", ".join(f"{name} {n}" for name, n in
                                                             sorted(k["identified_as"].items(), key=lambda x: -x[1])))
    return "\n".join(lines)


def write_campaign(rows: list, s: dict, out) -> list:
    """telemetry_summary.json, telemetry_runs.csv (one row per run, for pandas) and, with described faults,
    telemetry_campaign.png (each fault's latency against its size over the band) in ``out``."""
    import csv
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "telemetry_summary.json", out / "telemetry_runs.csv"]
    if any(r.get("effect_nm") and r.get("band_nm") for r in rows):
        paths.append(out / "telemetry_campaign.png")
        _plot_latency(rows, paths[-1])
    paths[0].write_text(json.dumps(s, indent=1))
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(paths[1], "w", newline="") as fh:
        writer = csv.DictWriter(fh, keys)
        writer.writeheader()
        writer.writerows(rows)
    return paths


def _plot_latency(rows: list, path) -> None:
    """Per fault kind, each run's latency against its fault's size over the band (log); misses at the top,
    invisible faults (size under the band) left of the dashed line."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    faulty = [r for r in rows if r.get("effect_nm") and r.get("band_nm")]
    kinds = sorted({r["kind"] for r in faulty})
    fig, axes = plt.subplots(1, len(kinds), figsize=(3.2 * len(kinds), 3.0), sharey=True, squeeze=False)
    top = max([r["latency_s"] for r in faulty if r["detected"]] + [10.0]) * 1.3
    for ax, kind in zip(axes[0], kinds):
        runs = [r for r in faulty if r["kind"] == kind]
        ratio = np.array([r["effect_nm"] / r["band_nm"] for r in runs])
        hit = np.array([r["right_wheel"] for r in runs], bool)
        found = np.array([r["detected"] for r in runs], bool)
        late = np.array([r["latency_s"] if r["detected"] else top for r in runs], float)
        ax.semilogx(ratio[hit], late[hit], "o", ms=3, label="that wheel, no other")
        ax.semilogx(ratio[found & ~hit], late[found & ~hit], "s", ms=4, color="tab:orange", label="also another")
        ax.semilogx(ratio[~found], late[~found], "x", color="tab:red", label="missed")
        ax.axvline(1.0, color="k", ls="--", lw=0.8)
        ax.set_title(f"{kind} ({len(runs)} runs)", fontsize=9)
        ax.set_xlabel("fault torque / band")
    axes[0, 0].set_ylabel("first alarm after the onset [s]")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
