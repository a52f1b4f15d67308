"""The options several `rw-fdi` commands share are defined once (argparse parents): same action, same default."""
import argparse

import pytest

from rw_fdi_ros.cli import build_parser
from rw_fdi_ros.core.detection import FALSE_ALARM_RATE

SHARED = {"--persistence": ["run", "evaluate", "screen", "fit-thresholds", "reproduce"],
          "--models": ["run", "evaluate", "screen", "fit-thresholds"],
          "--jobs": ["campaign", "evaluate", "reproduce", "defaults"],   # bench's --jobs is its study's own
          "--false-alarm-rate": ["fit-thresholds", "defaults"]}


def commands() -> dict:
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


@pytest.mark.parametrize("option", sorted(SHARED))
def test_a_shared_option_is_one_definition(option):
    subs = commands()
    actions = {id(a) for c in SHARED[option] for a in subs[c]._actions if option in a.option_strings}
    assert len(actions) == 1
    given = [c for c, p in subs.items() if c != "bench" and any(option in a.option_strings for a in p._actions)]
    assert sorted(given) == sorted(SHARED[option])


def test_the_shared_defaults_are_what_they_were():
    parse = build_parser().parse_args
    assert parse(["fit-thresholds", "--out", "x"]).false_alarm_rate == FALSE_ALARM_RATE
    assert parse(["defaults"]).false_alarm_rate == FALSE_ALARM_RATE and parse(["defaults"]).jobs is None
    assert parse(["reproduce", "--out", "x", "--persistence", "4"]).persistence == 4
    assert parse(["fit-thresholds", "--out", "x"]).persistence is None
    assert parse(["bench", "study", "--jobs", "3"]).jobs == 3


BAD = {"--persistence": ["-2", "0", "x", "1001"], "--jobs": ["0", "-1"], "--seed": ["-1", "1.5"],
       "--unit-calibration": ["-1", "nan", "inf"], "--false-alarm-rate": ["0", "1.5", "nan"],
       "--runs": ["0"], "--epochs": ["0"], "--command-timeout": ["0", "-3"], "--duration": ["0", "-inf"],
       "--fault-free-runs": ["0"], "--seed-start": ["-5"]}


def numeric_options():
    """(command, option, action) of every option that takes a number (int or float type)."""
    for name, parser in commands().items():
        for action in parser._actions:
            kind = getattr(action.type, "__name__", "")
            if action.option_strings and kind in ("int", "float"):
                yield name, action.option_strings[0], action


def test_every_numeric_option_is_range_checked_before_anything_starts(capsys):
    """`--persistence -2` made every wheel alarm from t = 0 with nothing said (issue 26): every numeric
    option now goes through cli.number, and a value out of its range is one line and exit 2."""
    options = list(numeric_options())
    assert len(options) >= 20
    plain = [(c, o) for c, o, a in options if a.type in (int, float)]
    assert not plain, f"numeric options without a range: {plain}"
    for command, option, _ in options:
        for bad in BAD.get(option, []):
            with pytest.raises(SystemExit) as exc:
                build_parser().parse_args([command, option, bad])
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
    from rw_fdi_ros.cli import parse_seeds
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
