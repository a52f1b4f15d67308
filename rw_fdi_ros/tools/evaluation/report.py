"""report.md and plots of an evaluation, beside the thesis' own numbers."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...core.physics.wheel_set import AXIS_WHEELS

THESIS = {
    "reliability": {"linear": (99, 99, 100), "elman": (97, 100, 96)},
    # Table 4.2, keyed by (kind, severity in the thesis' units: % off, % loss, degrees C)
    "correctness": {"elman": {("bus_voltage", 31.25): 95, ("current_limiter", 40.0): 98, ("temperature", 150.0): 98}},
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


TABLE42_CELLS = (("VBus 2.5 V off", "bus_voltage", 31.25), ("40 % current loss", "current_limiter", 40.0),
                 ("temperature 150 C off", "temperature", 150.0))
GRID_KINDS = (("VBus {:.0f} %", "bus_voltage"), ("current {:.0f} %", "current_limiter"), ("+{:.0f} C", "temperature"))
NONE_LABEL = {"bus_voltage": "VBus", "current_limiter": "current", "temperature": "temperature"}


def _cell(cells, kind, sev):
    return next((c for c in cells if c["kind"] == kind and c.get("severity") is not None
                 and abs(c["severity"] - sev) < 0.5), None)


def smallest_detected(cells, kind, share: float = 0.5):
    """The cell of the smallest size of ``kind`` detected in at least ``share`` of its runs (None: none)."""
    sized = sorted((c for c in cells if c["kind"] == kind and c.get("severity") is not None
                    and c["detected"]["rate"] is not None), key=lambda c: c["severity"])
    return next((c for c in sized if c["detected"]["rate"] >= share), None)


def headline(figures: dict) -> list:
    """Rows (figure, {observer: (thesis, ours)}) of evaluation.md's 'thesis figures to meet and beat'."""
    rows = []

    def row(name, fn, thesis):
        rows.append((name, {obs: (thesis.get(obs, "not given" if obs in THESIS["reliability"] else NOT_IN_THESIS),
                                  fn(f)) for obs, f in figures.items()}))

    row("threshold reliability x/y/z",
        lambda f: "/".join("-" if a not in f["reliability"] else f"{f['reliability'][a] * 100:.0f}"
                           for a in AXIS_WHEELS)
        + f" % (n={f['reliability'].get('runs', 0)})",
        {o: "/".join(map(str, v)) + " %" for o, v in THESIS["reliability"].items()})
    for label, kind, sev in TABLE42_CELLS:
        th = {o: f"{v[(kind, sev)]} %" for o, v in THESIS["correctness"].items()}
        row(f"correctness, {label}", lambda f, kind=kind, sev=sev: _pct((_cell(f["faults"], kind, sev) or {})
                                                                        .get("correctness")), th)

    def smallest(f):
        parts = []
        for fmt, kind in GRID_KINDS:
            c = smallest_detected(f["faults"], kind)
            parts.append(f"{NONE_LABEL[kind]} none" if c is None else fmt.format(c["severity"]))
        return " / ".join(parts)
    row("smallest fault detected in >= 50 % of its runs", smallest, THESIS["smallest"])

    def delays(f):
        values = [v for _, kind in GRID_KINDS for c in [smallest_detected(f["faults"], kind)]
                  if c and c["delay_s"] for v in c["delay_s"]["values"]]
        return "-" if not values else (f"median {np.median(values):.0f} s, 90 % within "
                                       f"{np.percentile(values, 90):.0f} s ({min(values):.0f}-{max(values):.0f} s)")
    row("detection delay at those sizes", delays, THESIS["delay"])
    row("ripple +40 %", lambda f: f"false alarm in {_pct(f['false_alarm_disturbance'])}", THESIS["ripple"])
    row("false alarms, held-out fault-free runs", lambda f: _pct(f["false_alarm_heldout"]), {})
    row("false alarms before onset in faulty runs (their fault-free part)",
        lambda f: _pct(f.get("false_alarm_before_onset")), {})

    def held(f):
        cells = [c for c in f["faults"] if c["held_to_end"]["rate"] is not None]
        n = sum(c["held_to_end"]["n"] for c in cells)
        kept = sum(c["held_to_end"]["rate"] * c["held_to_end"]["n"] for c in cells)
        return "-" if not n else f"held to end in {kept / n * 100:.0f} % of {n} detections"
    row("alarm held after detection", held, THESIS["held"])
    return rows


NOT_IN_THESIS = "not in the thesis"   # the model observer is ours, not the thesis'


def _thesis_reliability(obs: str) -> str:
    values = THESIS["reliability"].get(obs)
    return NOT_IN_THESIS if values is None else "/".join(map(str, values)) + " %"


def _intro(report: dict) -> list:
    """The title, what was evaluated with what, and who produced it (a resumed study: each session)."""
    lines = ["# rw_fdi_ros evaluation report", "",
             f"{report['runs']} runs evaluated by bag replay through the observer and isolation nodes; "
             f"persistence P = {report['persistence']}; models `{report['models']}`, thresholds "
             f"`{report['thresholds']}`. Definitions: `shared/spec/evaluation.md` and `rw_fdi_ros/scoring/metrics.py`. "
             "Ranges are median [min, max].", ""]
    prov = report.get("provenance")
    if prov:
        lines += [f"Produced by `{prov.get('command', '')}` at commit `{prov.get('commit', '')}`.", ""]
        sessions = prov.get("sessions", [])
        if len(sessions) > 1:   # a resumed study: each session did the part its stage times show
            lines += ["Sessions (a resumed study keeps what earlier sessions recorded, trained and replayed):", ""]
            lines += [f"{i}. commit `{x.get('commit', '')}`, {x.get('seconds', 0) / 60:.1f} min"
                      for i, x in enumerate(sessions, 1)] + [""]
    return lines


def _headline_section(obs_figs: dict) -> list:
    observers = list(obs_figs)
    lines = ["## The thesis' figures and ours", "",
             "| figure | " + " | ".join(f"thesis, {o} | ours, {o}" for o in observers) + " |",
             "|---|" + "---|---|" * len(observers)]
    for name, cols in headline(obs_figs):
        lines.append(f"| {name} | " + " | ".join(f"{cols[o][0]} | {cols[o][1]}" for o in observers) + " |")
    return lines + ["", "Smallest detected: per fault kind, the smallest size of the Table 5.1/5.2 grid (and Table "
                    "4.2) that alarmed on the faulty wheel in at least half of its runs.", ""]


def _reliability_section(obs_figs: dict) -> list:
    wheels = [a for a in next(iter(obs_figs.values()), {}).get("reliability", {}) if a not in ("runs", "seeds")]
    wheels = wheels or list(AXIS_WHEELS)
    lines = ["## Threshold reliability (Tables 3.1 / 4.1)", "",
             f"| observer | {' | '.join(wheels)} | fitting runs | thesis x/y/z |",
             "|---|" + "---|" * len(wheels) + "---|---|"]
    for obs, f in obs_figs.items():
        rel = f["reliability"]
        cells = " | ".join("-" if a not in rel else f"{rel[a] * 100:.0f} %" for a in wheels)
        lines.append(f"| {obs} | {cells} | {rel.get('runs', 0)} | {_thesis_reliability(obs)} |")
    return lines


def _false_alarm_section(obs_figs: dict) -> list:
    return ["", "## False alarms", "", "| observer | held-out fault-free | faulty runs, before onset | "
            "ripple +40 % (must not alarm) | thesis, ripple |", "|---|---|---|---|---|"] + [
        f"| {obs} | {_pct(f['false_alarm_heldout'])} | {_pct(f.get('false_alarm_before_onset'))} | "
        f"{_pct(f['false_alarm_disturbance'])} | {THESIS['ripple'].get(obs, NOT_IN_THESIS)} |"
        for obs, f in obs_figs.items()]


def _correctness_section(obs_figs: dict) -> list:
    """Per observer, a row per fault kind and size beside the thesis' Table 4.2 correctness where it has one."""
    lines = ["", "## Correctness per fault kind and size (Table 4.2) and detection figures (Tables 5.1 / 5.2)", "",
             "Correct = every faulty axis alarms after onset and no other axis alarms at any time. "
             "'observable' counts only runs whose fault effect (faulty minus healthy wheel torque) rose above "
             "the fault-free residual level, so the observer is not blamed for physics that hides the fault.", ""]
    for obs, f in obs_figs.items():
        lines += [f"### {obs} observer", "",
                  "| fault | size | axes | runs | correct | correct (observable) | detected | delay [s] | "
                  "time above [s] | held to end | gap detected [1e-3 N m] | gap missed [1e-3 N m] | thesis |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for c in f["faults"]:
            thesis = next((v for (kind, sev), v in THESIS["correctness"].get(obs, {}).items() if _cell([c], kind, sev)),
                          None)
            lines.append(f"| {c['kind']} | {c['size']} | {','.join(c['axes'])} | {c['runs']} | "
                         f"{_pct(c['correctness'])} | {_pct(c['correctness_observable'])} | {_pct(c['detected'])} | "
                         f"{_med(c['delay_s'])} | {_med(c['time_above_s'])} | {_pct(c['held_to_end'])} | "
                         f"{_med(c['gap_detected_mNm'])} | {_med(c['gap_missed_mNm'])} | "
                         f"{'' if thesis is None else f'{thesis} % correct'} |")
        lines += ["", f"Thesis: smallest detected {THESIS['smallest'][obs]}, delays {THESIS['delay'][obs]}, "
                  f"alarm {THESIS['held'][obs]}." if obs in THESIS["smallest"] else
                  "The thesis has no model observer: the nominal wheel model needs the measured wheel speed.", ""]
    return lines


def _identification_section(rows: list) -> list:
    if not rows:
        return []
    return ["## Fault identification (the isolation node, from the first alarm on)", "",
            "Kind right: the last identification of the faulty wheel names the injected kind; size right: "
            "within 10 % of the true value (temperature: 10 C). `rw-fdi bench identification` has the "
            "figures on large samples.", "",
            "| fault | size | wheels | identified | kind right | size right | abs size error | identified as |",
            "|---|---|---|---|---|---|---|---|"] + [
        f"| {c['kind']} | {c['size']} | {c['wheels']} | {_pct(c['identified'])} | {_pct(c['kind_right'])} | "
        f"{_pct(c['size_right'])} | {_med(c['abs_size_error'])} | "
        + ", ".join(f"{k} {n}" for k, n in c["identified_as"].items()) + " |" for c in rows] + [""]


def _health_section(report: dict) -> list:
    """How many runs the FDI could not judge or had input trouble in, and the first 50 such rows."""
    health = report.get("health", [])

    def runs_with(kind):
        return len({h["bag"] for h in health if h["kind"] == kind})
    lines = ["## The FDI's own health", "",
             f"Runs with samples the FDI could not judge (STALE): {runs_with('cannot_judge')}; with input trouble "
             f"(WARN: gaps, dropped duplicates or late samples): {runs_with('input_trouble')}"
             f"; of {report['runs']}.", ""]
    if health:
        lines += ["| bag | status | wheel | what | samples | first [s] | message |", "|---|---|---|---|---|---|---|"]
        lines += [f"| {h['bag']} | {h['topic']} | {h['wheel']} | {h['kind'].replace('_', ' ')} | {h['samples']} | "
                  f"{h['first_s']:g} | {h['message']} |" for h in health[:50]]
        lines += (["", f"({len(health) - 50} more rows in report.json)"] if len(health) > 50 else []) + [""]
    return lines


def _engines_section(engines: dict | None) -> list:
    """The engine that recorded and judged, and how far the graph, as reference, agreed on its sample."""
    if not engines:
        return []
    lines = ["## Engines", "", f"Recorded and judged by the **{engines['recorded_and_judged_by']}** engine "
             "(docs/evaluation.md \"Engines\")."]
    check = engines.get("graph_sample")
    if check:
        lines += ["", f"The graph as reference: {check['runs']} runs recorded through the graph as well; "
                  f"**{check['identical_bags']} of {check['runs']}** bags the same as the core engine's, topic "
                  f"by topic and message by message; {check['evaluated']} replayed through the FDI graph: "
                  f"evaluation {'**the same**' if check['evaluation_agrees'] else '**differs**'} (figures, "
                  "identification, health)" + (f" (differs in {', '.join(check['disagreeing'])})"
                                               if check["disagreeing"] else "") + "."]
        lines += [f"- `{d['bag']}`: {'; '.join(d['differences'])}" for d in check["differing"]]
    return lines + [""]


def _time_section(stages: dict | None) -> list:
    if not stages:
        return []
    lines = ["## Time", "", "| stage | seconds | runs | runs per minute |", "|---|---|---|---|"]
    for name, st in stages.items():
        rpm = f"{st['runs'] / st['seconds'] * 60:.1f}" if st.get("runs") and st["seconds"] > 0 else "-"
        lines.append(f"| {name} | {st['seconds']:.0f} | {st.get('runs', '-')} | {rpm} |")
    return lines + [""]


def write_markdown(report: dict, path: Path):
    obs_figs = report["observers"]
    lines = (_intro(report) + _headline_section(obs_figs) + _reliability_section(obs_figs)
             + _false_alarm_section(obs_figs) + _correctness_section(obs_figs)
             + _identification_section(report.get("identification")) + _health_section(report))
    if report.get("skipped"):
        lines += ["## Skipped bags", ""] + [f"- `{s['bag']}`: {s['reason']}" for s in report["skipped"]] + [""]
    if report.get("plots"):
        lines += ["## Plots", ""] + [f"![{Path(p).stem}]({Path(p).name})" for p in report["plots"]] + [""]
    lines += _engines_section(report.get("engines")) + _time_section(report.get("stages"))
    path.write_text("\n".join(lines))


def _save(fig, path: Path) -> str:
    import matplotlib.pyplot as plt
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)


def _residual_plot(r, out: Path) -> str:
    """Residual vs threshold of one run, an observer a row and a wheel a column (shaded: alarm, line: onset)."""
    import matplotlib.pyplot as plt
    observers = list(r.series)
    fig, axes = plt.subplots(len(observers), len(r.wheels), figsize=(4.4 * len(r.wheels), 3 * len(observers)),
                             sharex=True, squeeze=False)
    for row, obs in enumerate(observers):
        s = r.series[obs]
        for i, a in enumerate(r.wheels):   # the run's wheels, a standby one included
            ax = axes[row, i]
            ax.plot(s.time, s.residual[:, i] * 1e3, lw=1.1, label="residual")
            ax.plot(s.time, s.threshold[:, i] * 1e3, "--", color="tab:red", lw=1.1, label="threshold")
            if s.alarm[:, i].any():
                ax.fill_between(s.time, 0, 1, where=s.alarm[:, i], transform=ax.get_xaxis_transform(),
                                color="tab:orange", alpha=0.15)
            for f in r.faults:
                if r.wheels[f.wheel] == a:
                    ax.axvline(f.onset, color="k", lw=0.8)
            ax.set_title(f"{obs}, wheel {a}", fontsize=9)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{r.scenario} seed {r.seed}: residual vs threshold [1e-3 N m] (shaded: alarm)")
    return _save(fig, out / f"residuals_{r.scenario}_s{r.seed}.png")


def _delay_plot(figures: dict, out: Path) -> str:
    """The detection delay distributions, a box per fault cell."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(figures), figsize=(6 * len(figures), 4), sharey=True, squeeze=False)
    for ax, (obs, f) in zip(axes[0], figures.items()):
        cells = [c for c in f["faults"] if c["delay_s"]]
        if cells:
            ax.boxplot([c["delay_s"]["values"] for c in cells], orientation="horizontal")
            ax.set_yticks(range(1, len(cells) + 1), [f"{c['kind']}\n{c['size']}" for c in cells], fontsize=7)
        ax.set_title(f"{obs}: detection delay [s]")
        ax.grid(alpha=0.3)
    return _save(fig, out / "detection_delay.png")


def _grid_plot(figures: dict, out: Path) -> str:
    """The share detected over fault kind and size (Tables 5.1 / 5.2)."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(figures), figsize=(6 * len(figures), 4.5), squeeze=False)
    for ax, (obs, f) in zip(axes[0], figures.items()):
        cells = [c for c in f["faults"] if c["kind"] != "multiple"]
        kinds = sorted({c["kind"] for c in cells})
        if not kinds:   # fault-free runs only: nothing to grid (an empty image would warn)
            ax.text(0.5, 0.5, "no single-fault runs", ha="center", va="center", transform=ax.transAxes)
            ax.set_axis_off()
            continue
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
    return _save(fig, out / "detection_grid.png")


def write_plots(runs, figures: dict, out: Path) -> list:
    import matplotlib
    matplotlib.use("Agg")
    # residual vs threshold for one run of each kind (thesis Figs. 4.19-4.23, 5.2/5.3)
    chosen = {}
    for r in runs:
        chosen.setdefault((r.category, tuple(sorted({f.kind for f in r.faults}))), r)
    return ([_residual_plot(r, out) for r in list(chosen.values())[:8]]
            + [_delay_plot(figures, out), _grid_plot(figures, out)])


def validate_report(report: dict):
    """Check a report.json against rw_fdi_ros/tools/evaluation/report_schema.json (raises on mismatch)."""
    import json
    import jsonschema
    schema = json.loads((Path(__file__).with_name("report_schema.json")).read_text())
    jsonschema.validate(report, schema)
