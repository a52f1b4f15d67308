"""`rw-fdi bench figures` reads what it claims: every figure finds its README row and its record, every row
of the README's table is re-measured, and a small sample is flagged exactly where it disagrees beyond chance."""
import json
from pathlib import Path

from rw_fdi_ros.tools.benches import figures_check as fc
from rw_fdi_ros.scoring.metrics import rate

ROOT = Path(__file__).resolve().parents[1]


def test_every_row_of_the_readme_table_is_re_measured_and_every_figure_reads_its_record():
    rows = fc.readme_rows(ROOT / "README.md")
    table = [k for k in rows if k != "what"]
    assert len(table) >= 10
    for key in table:
        assert any(key.startswith(f.row) for f in fc.FIGURES), f"README row not re-measured: {key}"
    assert set(fc.BENCH_FUNCTIONS) == set(fc.SMALL) == {f.bench for f in fc.FIGURES}
    for f in fc.FIGURES:
        if f.bench in fc.RECORDS:
            value = f.extract(json.loads((ROOT / fc.RECORDS[f.bench]).read_text()))
            assert ("k" in value and "n" in value) if isinstance(value, dict) else value == value, f.label


def test_a_small_sample_is_flagged_where_its_interval_misses_the_records():
    figure = fc.Figure("x", "a rate", "service", lambda r: r)
    record = rate([True] * 985 + [False] * 15)          # 98.5 % [97.5, 99.1]
    assert not fc._compare(figure, rate([True] * 19 + [False]), record)[2]      # 95 % of 20: could be
    assert fc._compare(figure, rate([True] * 12 + [False] * 8), record)[2]      # 60 % of 20: cannot
    value = fc.Figure("x", "a value", "dumping", lambda r: r, 1.0, "h")
    assert not fc._compare(value, 13.9, 13.7)[2] and fc._compare(value, 15.0, 13.7)[2]
    sample = fc.Figure("x", "bags", "reproduce", lambda r: r)
    assert fc._compare(sample, {"identical_bags": 5, "runs": 6}, None)[2]
    assert not fc._compare(sample, {"identical_bags": 6, "runs": 6}, None)[2]


def test_a_report_with_runs_writes_them_as_a_table_one_row_a_run(tmp_path):
    """Per-run results go elsewhere (issue 38): pandas or polars read <name>_runs.csv."""
    import csv

    from rw_fdi_ros.tools.benches.kit import write_report
    runs = [{"seed": 1, "pointing_kept": True, "faults": [{"kind": "bus_voltage"}],
             "identification": {"kind": "bus_voltage", "covered": True}},
            {"seed": 2, "pointing_kept": False, "faults": [], "delay_s": 3.5}]
    write_report({"runs": runs}, tmp_path, "demo", lambda r: "demo\n")
    with open(tmp_path / "demo_runs.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["seed"] for r in rows] == ["1", "2"]
    assert rows[0]["identification.kind"] == "bus_voltage" and rows[1]["identification.kind"] == ""
    assert rows[1]["delay_s"] == "3.5" and rows[0]["faults"] == '[{"kind": "bus_voltage"}]'


def test_the_day_in_orbit_runs_beside_the_other_benches(monkeypatch, tmp_path):
    """The check's longest single piece of work (the day in orbit, one process) starts at once in its own
    process; the dumping bench takes its report instead of simulating it again."""
    monkeypatch.setitem(fc.SMALL, "dumping", {**fc.SMALL["dumping"], "hours": 0.25})
    with fc._day_beside(True, tmp_path) as day:
        report = day.result(timeout=300)
    assert report["hours"] == 0.25 and report["scenario"] == "dumping_day" and (tmp_path / "day.png").is_file()
    with fc._day_beside(False, tmp_path) as none:
        assert none is None


def test_every_bench_the_figures_check_runs_is_found():
    """Each bench of `rw-fdi bench figures` names a module and a function that exist (a renamed module is found
    here, not an hour into the check)."""
    import importlib
    from rw_fdi_ros.tools.benches.figures_check import BENCH_FUNCTIONS
    for name, (module, function, _) in BENCH_FUNCTIONS.items():
        assert callable(getattr(importlib.import_module(module, "rw_fdi_ros.tools.benches"), function)), name
