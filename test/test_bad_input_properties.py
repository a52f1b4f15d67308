"""Property-based (hypothesis): every malformed or out-of-range scenario and seed range is either taken or
refused with one line naming the file and field; never a traceback, never a hang.

Bounded in time: a fixed number of examples, each parse well under a second."""
import time

import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from rw_fdi_ros.cli.options import parse_seeds
from rw_fdi_ros.core.mission.scenario import Scenario, ScenarioError, parse_scenario

FIELDS = ["name", "description", "duration", "seed", "faults", "setpoints", "initial", "plant", "wheels"]
FAULT_FIELDS = ["kind", "wheel", "onset", "value", "ramp"]
KINDS = ["current_limiter", "temperature", "bus_voltage", "ripple_gain", "nonsense"]

scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=20),
                    st.sampled_from(["1e12", "nan", "inf", "-0", "x", "y", "z", "random", "", "0x10", "yes"]))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                      st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=12)
faults = st.fixed_dictionaries({}, optional={k: st.one_of(values, st.sampled_from(KINDS)) for k in FAULT_FIELDS})
scenarios = st.fixed_dictionaries({}, optional={**{k: values for k in FIELDS},
                                                "faults": st.one_of(values, st.lists(faults, max_size=3)),
                                                "wheels": st.one_of(values, st.fixed_dictionaries(
                                                    {}, optional={"variation": values, "spread": values,
                                                                  "scale": values}))})
PROPERTY = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def judged(text: str, origin: str = "s.yaml"):
    t0 = time.monotonic()
    try:
        out = parse_scenario(text, origin=origin)
    except ScenarioError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(origin), message
        out = None
    assert time.monotonic() - t0 < 30.0   # a hang guard, not a speed goal (a loaded CI machine took > 1 s)
    return out


@PROPERTY
@given(scenarios)
def test_any_scenario_mapping_is_taken_or_refused_in_one_line(raw):
    out = judged(yaml.safe_dump(raw, allow_unicode=True))
    if out is not None:   # taken: a scenario the plant can run, with the duration asked for
        assert isinstance(out, Scenario) and 1.0 <= out.duration <= 1e6
        assert all(0.0 <= f.onset <= out.duration for f in out.faults)
        out.draws()
        if out.wheels:
            out.unit_scales()


@PROPERTY
@given(st.one_of(st.text(max_size=200), st.binary(max_size=200).map(lambda b: b.decode("latin-1"))))
def test_any_text_is_taken_or_refused_in_one_line(text):
    judged(text)


@PROPERTY
@given(st.sampled_from(FIELDS), values, values)
def test_a_field_given_twice_is_refused_naming_it(field, first, second):
    body = yaml.safe_dump({field: first}) + yaml.safe_dump({field: second})
    try:
        parse_scenario(body, origin="twice.yaml")
    except ScenarioError as exc:
        assert "\n" not in str(exc)
        if "not valid YAML" not in str(exc):
            assert field in str(exc), str(exc)
    else:
        raise AssertionError(f"{field} given twice was accepted")


def test_huge_and_empty_scenarios_are_refused_at_once():
    for text in ("", "   \n", "[]", "faults: [" + "1, " * 33_000 + "1]", "faults: [" + "1, " * 200_000 + "1]",
                 "x" * 5_000_000):
        assert judged(text) is None


@PROPERTY
@given(st.text(max_size=30))
def test_any_seed_range_is_taken_or_refused_naming_the_option(text):
    try:
        seeds = parse_seeds(text, "--seeds")
    except ValueError as exc:
        assert str(exc).startswith("--seeds") and "\n" not in str(exc)
    else:
        assert len(seeds) >= 1 and seeds.start <= seeds.stop - 1
