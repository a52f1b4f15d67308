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
