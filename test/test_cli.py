"""The options several `rw-fdi` commands share are defined once (argparse parents): same action, same default;
each bench takes only the options it reads."""
import argparse

import pytest

from rw_fdi_ros.cli import VERBS, build_parser
from rw_fdi_ros.core.fdi.detection import FALSE_ALARM_RATE

SHARED = {"--persistence": ["run", "evaluate", "screen", "fit-thresholds", "reproduce", "telemetry"],
          "--models": ["run", "evaluate", "screen", "fit-thresholds", "telemetry"],
          # the benches take a --jobs of their own
          "--jobs": ["campaign", "evaluate", "reproduce", "defaults", "screen", "fit-thresholds", "train", "telemetry"],
          "--observer": ["run", "evaluate", "screen", "fit-thresholds", "train"],
          "--false-alarm-rate": ["fit-thresholds", "defaults", "telemetry"]}


# the options several benches share, and the benches that read each
BENCH_SHARED = {"--out": ["detection", "identification", "units", "memory", "operations", "recovery", "dumping",
                          "service"],
                "--seed-set": ["operations", "recovery", "service"],
                "--fault-free-runs": ["detection", "units", "operations", "recovery", "service"],
                "--runs-per-cell": ["detection", "identification", "units", "operations", "recovery", "dumping"],
                "--seed": ["graph", "fdi", "study", "memory", "dumping"],
                "--duration": ["graph", "fdi", "study"],
                "--jobs": ["study", "detection", "identification", "units", "operations", "recovery", "dumping",
                           "service"],
                "--scheduler": ["detection", "identification", "units", "operations", "recovery", "dumping", "service",
                                "scaling"],
                "--max-hours": ["service", "scaling"],
                "--vehicle": ["detection", "identification", "units", "operations", "recovery", "dumping", "service"],
                "--observer": ["detection", "units", "operations", "service"],
                "--thresholds": ["detection", "units", "operations", "service"]}


def subcommands(parser) -> dict:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def commands() -> dict:
    """Every command's parser by its words: the verbs ("run") and the benches ("bench detection")."""
    out = {}
    for name, parser in subcommands(build_parser()).items():
        out[name] = parser
        if name == "bench":
            out.update({f"bench {b}": p for b, p in subcommands(parser).items()})
    return out


def takes(parser, option) -> bool:
    return any(option in a.option_strings for a in parser._actions)


@pytest.mark.parametrize("option", sorted(SHARED))
def test_a_shared_option_is_one_definition(option):
    subs = commands()
    actions = {id(a) for c in SHARED[option] for a in subs[c]._actions if option in a.option_strings}
    assert len(actions) == 1
    given = [c for c, p in subs.items() if not c.startswith("bench") and takes(p, option)]
    assert sorted(given) == sorted(SHARED[option])


@pytest.mark.parametrize("option", sorted(BENCH_SHARED))
def test_a_bench_option_is_one_definition_given_to_the_benches_that_read_it(option):
    subs = commands()
    actions = {id(a) for b in BENCH_SHARED[option] for a in subs[f"bench {b}"]._actions if option in a.option_strings}
    assert len(actions) == 1
    given = [c.split()[1] for c, p in subs.items() if c.startswith("bench ") and takes(p, option)]
    assert sorted(given) == sorted(BENCH_SHARED[option])


@pytest.mark.parametrize("argv, flag", [(["bench", "detection", "--hours", "3"], "--hours 3"),
                                        (["bench", "memory", "--units"], "--units"),
                                        (["bench", "graph", "--out", "x"], "--out x")])
def test_a_flag_a_bench_does_not_take_is_an_error(argv, flag, capsys):
    """`bench detection --hours 3` ran the detection bench and ignored --hours: now argparse refuses it."""
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == f"rw-fdi: error: unrecognized arguments: {flag}"
    assert sum("error" in line for line in err) == 1


def test_every_verb_module_has_add_arguments_and_main():
    names = [verb.NAME for verb in VERBS]
    assert len(set(names)) == len(names) == len(subcommands(build_parser()))
    for verb in VERBS:
        assert isinstance(verb.HELP, str) and verb.HELP and isinstance(verb.PARENTS, tuple), verb.__name__
        assert callable(verb.add_arguments) and callable(verb.main), verb.__name__
        assert verb.__doc__ and verb.__doc__.strip(), verb.__name__


def test_the_shared_defaults_are_what_they_were():
    parse = build_parser().parse_args
    assert parse(["fit-thresholds", "--out", "x"]).false_alarm_rate == FALSE_ALARM_RATE
    assert parse(["defaults"]).false_alarm_rate == FALSE_ALARM_RATE and parse(["defaults"]).jobs is None
    assert parse(["reproduce", "--out", "x", "--persistence", "4"]).persistence == 4
    assert parse(["fit-thresholds", "--out", "x"]).persistence is None
    assert parse(["bench", "study", "--jobs", "3"]).jobs == 3
    assert parse(["bench", "dumping"]).seed == 1 and parse(["bench", "service"]).fault_free_runs == 1000
    assert parse(["bench", "detection"]).runs_per_cell is None and parse(["bench", "detection"]).out is None


BAD = {"--persistence": ["-2", "0", "x", "1001"], "--jobs": ["0", "-1"], "--seed": ["-1", "1.5"],
       "--unit-calibration": ["-1", "nan", "inf"], "--false-alarm-rate": ["0", "1.5", "nan"],
       "--runs": ["0"], "--epochs": ["0"], "--command-timeout": ["0", "-3"], "--duration": ["0", "-inf"],
       "--fault-free-runs": ["0"], "--seed-start": ["-5"], "--runs-per-cell": ["0"], "--service-runs": ["0"],
       "--max-hours": ["0", "6.5"], "--day-hours": ["0", "241"], "--graph-sample": ["-1"]}


def numeric_options():
    """(command, option, action) of every option that takes a number (int or float type), the benches' too."""
    for name, parser in commands().items():
        for action in parser._actions:
            kind = getattr(action.type, "__name__", "")
            if action.option_strings and kind in ("int", "float"):
                yield name, action.option_strings[0], action


def test_every_numeric_option_is_range_checked_before_anything_starts(capsys):
    """`--persistence -2` made every wheel alarm from t = 0 with nothing said (issue 26): every numeric
    option now goes through cli.options.number, and a value out of its range is one line and exit 2."""
    options = list(numeric_options())
    assert len(options) >= 20
    plain = [(c, o) for c, o, a in options if a.type in (int, float)]
    assert not plain, f"numeric options without a range: {plain}"
    for command, option, _ in options:
        for bad in BAD.get(option, []):
            with pytest.raises(SystemExit) as exc:
                build_parser().parse_args([*command.split(), option, bad])
            assert exc.value.code == 2
            err = capsys.readouterr().err.strip().splitlines()[-1]
            assert err.startswith(f"rw-fdi {command}: error: argument {option}"), err
    assert build_parser().parse_args(["run", "--scenario", "s", "--persistence", "3", "--seed", "0"]).persistence == 3


@pytest.mark.parametrize("text, said", [
    ("1..100000000000", "100,000,000,000 runs; one command takes at most 1,000,000"),
    ("-5..3", "seeds are whole numbers in [0, "), ("9..3", "the last seed is below the first"),
    ("a..b", "must be A..B or A with whole numbers")])
def test_a_seed_range_is_bounded_before_anything_starts(text, said):
    """`screen --seeds 1..100000000000` started without a word (issue 39): the same bounds for every command."""
    from rw_fdi_ros.cli.options import parse_seeds
    with pytest.raises(ValueError, match=".*") as err:
        parse_seeds(text, "--seeds")
    assert said in str(err.value) and "\n" not in str(err.value)
    assert parse_seeds("3..5", "--seeds") == range(3, 6)


def test_a_scheduler_that_does_not_answer_is_one_line(monkeypatch):
    """`campaign --scheduler tcp://127.0.0.1:1` ended in a 58-line traceback after 30 s (issue 39)."""
    from rw_fdi_ros.tools.campaigns.campaign import DaskExecutor
    monkeypatch.setattr(DaskExecutor, "CONNECT_S", 1.0)
    with pytest.raises(RuntimeError) as err:
        DaskExecutor("tcp://127.0.0.1:1")
    said = str(err.value)
    assert said.startswith("--scheduler tcp://127.0.0.1:1: no Dask scheduler answered within 1 s") and "\n" not in said


@pytest.mark.parametrize("argv", [["defaults", "--hidden", "10"], ["defaults", "--vehicle", "cubesat_6u",
                                                                    "--loss", "huber", "--window", "150"]])
def test_the_networks_design_options_are_only_for_the_set_trained_for_service(argv, capsys):
    from rw_fdi_ros.cli import main
    assert main(argv) == 2
    said = capsys.readouterr().err.strip()
    assert said.startswith("rw-fdi: error: --") and "only with --service" in said and "\n" not in said


def test_a_service_bench_shorter_than_its_shortest_runs_is_one_line_before_anything_runs(tmp_path, capsys):
    from rw_fdi_ros.cli import main
    assert main(["bench", "service", "--max-hours", "0.05", "--out", str(tmp_path)]) == 2
    said = capsys.readouterr().err.strip()
    assert said == "rw-fdi: error: --max-hours: at least 0.167 h, the family's shortest runs (600 s); got 0.05"
    assert not any(tmp_path.iterdir())


def test_screen_json_and_table_give_the_counts_and_one_row_a_run(tmp_path, capsys):
    """`screen --json` prints the counts per scenario and observer; `--table` writes one CSV row per run with
    each observer's verdict and the identification (issue 38: every run is a row)."""
    import csv
    import json

    from rw_fdi_ros.cli import main
    table = tmp_path / "runs.csv"
    assert main(["screen", "--scenario", "current_0p6_x", "--seeds", "1..2", "--json", "--table", str(table)]) == 0
    counts = json.loads(capsys.readouterr().out)
    assert counts["current_0p6_x"]["verdict"]["runs"] == 2 and counts["current_0p6_x"]["verdict"]["correct"] == 2
    rows = list(csv.DictReader(table.open()))
    assert [r["seed"] for r in rows] == ["1", "2"]
    assert all(r["verdict.correct"] == "True" and r["identification.x.kind"] == "current_limiter" for r in rows)


def test_the_scaling_bench_times_the_same_runs_on_each_worker_count(monkeypatch):
    """`bench scaling` (issue 38): the same in-service runs on 1 and 2 local workers, runs per second and the
    projection for 100,000 runs from the simulated hours per wall second (run_service replaced: no simulation)."""
    from rw_fdi_ros.tools.benches import scaling_bench
    seen = []

    def fake(seeds, executor, progress, max_duration):
        seen.append((list(seeds), executor.jobs, max_duration))
        return [{"seed": s} for s in seeds]
    monkeypatch.setattr(scaling_bench, "run_service", fake)
    report = scaling_bench.bench_scaling(runs=3, max_hours=0.25)
    assert [jobs for _, jobs, _ in seen] == [1, 2] and seen[0][0] == seen[1][0] == list(range(93_000_000, 93_000_003))
    assert seen[0][2] == 900.0 and report["ok"] and len(report["rows"]) == 2
    family = report["family_h_per_run"]
    assert abs(family - 2202.0 / 3600.0) < 1e-9   # service_family.DURATIONS: 0.7 x 600 s + ... + 0.03 x 6 h
    for row in report["rows"]:
        assert abs(row["projected_h"] * 3600.0 * row["simulated_h_per_wall_s"] - 100_000 * family) < 1e-6
    assert "100,000 runs in" in report["text"]
