"""report.md and plots of an evaluation, beside the thesis' own numbers."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.scenario import AXES

THESIS = {
    "reliability": {"linear": (99, 99, 100), "elman": (97, 100, 96)},
    "correctness": {"elman": {("bus_voltage", "31% off (5.5 V)"): 95, ("current_limiter", "40% loss"): 98,
                              ("temperature", "+150 C"): 98}},
    "smallest": {"linear": "VBus 40 % / current 50 % / +90 C", "elman": "VBus 20 % / current 20 % / +60 C"},
    "delay": {"linear": "5 - 20 s", "elman": "15 - 65 s"},
    "ripple": {"linear": "false alarm", "elman": "no alarm"},
    "held": {"linear": "lost within 40 s", "elman": "held to end of run"},
}


def _pct(rate):
    return "-" if rate is None or rate.get("rate") is None else f"{rate['rate'] * 100:.0f} % (n={rate['n']})"


def _med(stats, unit=""):
    if not stats:
        return "-"
    return f"{stats['median']:.1f}{unit} [{stats['min']:.1f}, {stats['max']:.1f}]"


def write_markdown(report: dict, path: Path):
    obs_figs = report["observers"]
    lines = ["# rw_fdi_ros evaluation report", "",
             f"{report['runs']} runs evaluated by bag replay through the observer and isolation nodes; "
             f"persistence P = {report['persistence']}; models `{report['models']}`, thresholds "
             f"`{report['thresholds']}`. Definitions: `shared/spec/evaluation.md` and `rw_fdi_ros/tools/metrics.py`. "
             "Ranges are median [min, max].", ""]
    if report.get("provenance"):
        lines += [f"Produced by `{report['provenance'].get('command', '')}` at commit "
                  f"`{report['provenance'].get('commit', '')}`.", ""]
    lines += ["## Threshold reliability (Tables 3.1 / 4.1)", "",
              "| observer | x | y | z | fitting runs | thesis x/y/z |", "|---|---|---|---|---|---|"]
    for obs, f in obs_figs.items():
        rel = f["reliability"]
        cells = " | ".join("-" if a not in rel else f"{rel[a] * 100:.0f} %" for a in AXES)
        lines.append(f"| {obs} | {cells} | {rel.get('runs', 0)} | {'/'.join(map(str, THESIS['reliability'][obs]))} % |")
    lines += ["", "## False alarms", "", "| observer | held-out fault-free | ripple +40 % (must not alarm) | thesis, ripple |",
              "|---|---|---|---|"]
    for obs, f in obs_figs.items():
        lines.append(f"| {obs} | {_pct(f['false_alarm_heldout'])} | {_pct(f['false_alarm_disturbance'])} | "
                     f"{THESIS['ripple'][obs]} |")
    lines += ["", "## Correctness per fault kind and size (Table 4.2) and detection figures (Tables 5.1 / 5.2)", "",
              "Correct = every faulty axis alarms after onset and no other axis alarms at any time. "
              "'observable' counts only runs whose fault effect (faulty minus healthy wheel torque) rose above "
              "the fault-free residual level, so the observer is not blamed for physics that hides the fault.", ""]
    for obs, f in obs_figs.items():
        lines += [f"### {obs} observer", "",
                  "| fault | size | axes | runs | correct | correct (observable) | detected | delay [s] | "
                  "time above [s] | held to end | gap detected [1e-3 N m] | gap missed [1e-3 N m] | thesis |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for c in f["faults"]:
            thesis = THESIS["correctness"].get(obs, {}).get((c["kind"], c["size"]))
            lines.append(f"| {c['kind']} | {c['size']} | {','.join(c['axes'])} | {c['runs']} | "
                         f"{_pct(c['correctness'])} | {_pct(c['correctness_observable'])} | {_pct(c['detected'])} | "
                         f"{_med(c['delay_s'])} | {_med(c['time_above_s'])} | {_pct(c['held_to_end'])} | "
                         f"{_med(c['gap_detected_mNm'])} | {_med(c['gap_missed_mNm'])} | "
                         f"{'' if thesis is None else f'{thesis} % correct'} |")
        lines += ["", f"Thesis: smallest detected {THESIS['smallest'][obs]}, delays {THESIS['delay'][obs]}, "
                  f"alarm {THESIS['held'][obs]}.", ""]
    if report.get("skipped"):
        lines += ["## Skipped bags", ""] + [f"- `{s['bag']}`: {s['reason']}" for s in report["skipped"]] + [""]
    if report.get("plots"):
        lines += ["## Plots", ""] + [f"![{Path(p).stem}]({Path(p).name})" for p in report["plots"]] + [""]
    if report.get("stages"):
        lines += ["## Time", "", "| stage | seconds | runs | runs per minute |", "|---|---|---|---|"]
        for name, st in report["stages"].items():
            rpm = f"{st['runs'] / st['seconds'] * 60:.1f}" if st.get("runs") and st["seconds"] > 0 else "-"
            lines.append(f"| {name} | {st['seconds']:.0f} | {st.get('runs', '-')} | {rpm} |")
        lines.append("")
    path.write_text("\n".join(lines))


def write_plots(runs, figures: dict, out: Path) -> list:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    # residual vs threshold for one run of each kind (thesis Figs. 4.19-4.23, 5.2/5.3)
    chosen = {}
    for r in runs:
        key = (r.category, tuple(sorted({f.kind for f in r.faults})))
        chosen.setdefault(key, r)
    for (cat, kinds), r in list(chosen.items())[:8]:
        fig, axes = plt.subplots(2, 3, figsize=(13, 6), sharex=True)
        for row, obs in enumerate(("elman", "linear")):
            s = r.series[obs]
            for i, a in enumerate(AXES):
                ax = axes[row, i]
                ax.plot(s.time, s.residual[:, i] * 1e3, lw=1.1, label="residual")
                ax.plot(s.time, s.threshold[:, i] * 1e3, "--", color="tab:red", lw=1.1, label="threshold")
                if s.alarm[:, i].any():
                    ax.fill_between(s.time, 0, 1, where=s.alarm[:, i], transform=ax.get_xaxis_transform(),
                                    color="tab:orange", alpha=0.15)
                for f in r.faults:
                    if AXES[f.wheel] == a:
                        ax.axvline(f.onset, color="k", lw=0.8)
                ax.set_title(f"{obs}, wheel {a}", fontsize=9)
                ax.grid(alpha=0.3)
        axes[0, 0].legend(fontsize=7)
        fig.suptitle(f"{r.scenario} seed {r.seed}: residual vs threshold [1e-3 N m] (shaded: alarm)")
        fig.tight_layout()
        p = out / f"residuals_{r.scenario}_s{r.seed}.png"
        fig.savefig(p, dpi=90)
        plt.close(fig)
        paths.append(str(p))
    # detection delay distributions
    fig, axes = plt.subplots(1, 2, figsize=(12, 4), sharey=True)
    for ax, (obs, f) in zip(axes, figures.items()):
        labels, data = [], []
        for c in f["faults"]:
            if c["delay_s"]:
                labels.append(f"{c['kind']}\n{c['size']}")
                data.append(c["delay_s"]["values"])
        if data:
            ax.boxplot(data, orientation="horizontal")
            ax.set_yticks(range(1, len(labels) + 1), labels, fontsize=7)
        ax.set_title(f"{obs}: detection delay [s]")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    p = out / "detection_delay.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    paths.append(str(p))
    # detected / missed grid over fault size (Tables 5.1 / 5.2)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, (obs, f) in zip(axes, figures.items()):
        cells = [c for c in f["faults"] if c["kind"] != "multiple"]
        kinds = sorted({c["kind"] for c in cells})
        sizes = {k: [c for c in cells if c["kind"] == k] for k in kinds}
        width = max((len(v) for v in sizes.values()), default=1)
        grid = np.full((len(kinds), width), np.nan)
        for i, k in enumerate(kinds):
            for j, c in enumerate(sizes[k]):
                grid[i, j] = c["detected"]["rate"] if c["detected"]["rate"] is not None else np.nan
                ax.text(j, i, f"{c['size']}\n{grid[i, j] * 100:.0f}%", ha="center", va="center", fontsize=7)
        ax.imshow(grid, cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
        ax.set_yticks(range(len(kinds)), kinds, fontsize=8)
        ax.set_xticks([])
        ax.set_title(f"{obs}: share detected per fault size")
    fig.tight_layout()
    p = out / "detection_grid.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    paths.append(str(p))
    return paths


def validate_report(report: dict):
    """Check a report.json against rw_fdi_ros/tools/report_schema.json (raises on mismatch)."""
    import json
    import jsonschema
    schema = json.loads((Path(__file__).with_name("report_schema.json")).read_text())
    jsonschema.validate(report, schema)
