"""The decision (core/fdi/verdict.DecisionRule): what makes /diagnostics is one observer's alarm or a vote of them,
set in configuration and on the command line,
the same in the isolation node and the offline tools (core/fdi/pipeline.Verdict)."""
import subprocess
import sys

import numpy as np
import pytest

from rw_fdi_ros.core.fdi.verdict import DecisionRule, decision_of
from rw_fdi_ros.fdi_config import FdiConfig

from conftest import verdict_of_flags


def _rows(alarms: dict, firsts: dict) -> dict:
    """observer -> wheel x -> (residual, threshold, alarm, first alarm)."""
    return {o: {"x": (0.1 * (i + 1), 1.0, alarms[o], firsts[o])} for i, o in enumerate(alarms)}


def test_a_vote_alarms_a_wheel_where_enough_observers_do():
    vote = decision_of("2of3", "speed_aware")
    assert vote == DecisionRule(("model", "elman", "linear"), 2) and vote.lead == "model"
    assert vote.label == "2of3" and vote.phrase == "2 of 3 observers"
    one = _rows({"model": True, "elman": False, "linear": False}, {"model": 10.0, "elman": None, "linear": None})
    assert vote.combine(one)["x"] == (0.1, 1.0, False, None)   # one observer is not two
    two = _rows({"model": True, "elman": False, "linear": True}, {"model": 10.0, "elman": None, "linear": 14.0})
    assert vote.combine(two)["x"] == (0.1, 1.0, True, 14.0)    # up when the second alarms; the lead's residual
    every = decision_of("3of3", "speed_aware")
    assert every.combine(two)["x"][2] is False
    three = _rows({"model": True, "elman": True, "linear": True}, {"model": 10.0, "elman": 12.0, "linear": 14.0})
    assert every.combine(three)["x"][2:] == (True, 14.0) and decision_of("1of3", "speed_aware").combine(three)[
        "x"][2:] == (True, 10.0)
    single = decision_of("linear", "speed_aware")
    assert single.combine(two) is two["linear"] and single.phrase == "linear observer"


@pytest.mark.parametrize("text, method, message", [
    ("4of3", "speed_aware", "a vote KofN of the 3 observers"),
    ("0of3", "speed_aware", "e.g. 2of3"),
    ("2of3", "thesis", "of the 2 observers"),       # the thesis method has two
    ("model", "thesis", "must be one of elman, linear"),
    ("majority", "speed_aware", "got 'majority'"),
])
def test_a_decision_the_method_cannot_take_is_refused_in_one_line(text, method, message):
    with pytest.raises(ValueError, match=message):
        decision_of(text, method)
    with pytest.raises(ValueError, match="--decision must be one of"):
        FdiConfig(method, decision=text)


def test_the_default_decision_is_the_methods():
    assert decision_of("", "speed_aware") == DecisionRule(("model",)) and FdiConfig().decision_rule.lead == "model"
    assert decision_of("", "thesis") == DecisionRule(("elman",))


def test_the_offline_verdict_of_a_vote_is_the_nodes():
    """Flags of three observers through the pipeline's Verdict: the vote's alarm, latched, up at the second alarm."""
    flags = {o: np.zeros((8, 3), bool) for o in ("model", "elman", "linear")}
    flags["model"][2:, 0] = True
    flags["elman"][5:7, 0] = True   # the second vote on x at 5 s, gone at 7 s: the verdict stays (latched)
    flags["linear"][1:, 1] = True   # y: one observer only
    v = verdict_of_flags(flags, decision_of("2of3", "speed_aware"))
    assert v[:, 0].tolist() == [False] * 5 + [True] * 3 and not v[:, 1:].any()
    assert verdict_of_flags(flags, decision_of("linear", "speed_aware"))[:, 1].sum() == 7


def test_the_command_line_takes_a_decision_and_refuses_a_wrong_one(tmp_path):
    (tmp_path / "cl.yaml").write_text("name: cl\nduration: 200\nfaults: "
                                      "[{kind: current_limiter, wheel: y, onset: 100, value: 0.6}]\n")
    cli = [sys.executable, "-m", "rw_fdi_ros.cli", "screen", "--scenario", "cl.yaml", "--seeds", "8000..8001",
           "--jobs", "1"]
    ok = subprocess.run(cli + ["--decision", "2of3"], cwd=tmp_path, capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    words = next(line for line in ok.stdout.splitlines() if " verdict " in line).split()
    assert int(words[words.index("correct") + 1]) == 2
    bad = subprocess.run(cli + ["--decision", "3of4"], cwd=tmp_path, capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0 and "--decision must be one of" in bad.stderr


def test_bands_given_alone_run_with_the_networks_they_were_fitted_with(tmp_path):
    """--thresholds of a directory `rw-fdi defaults` wrote: its networks beside them, not the thesis' (the
    elman bands were fitted with those); bands of your own alone, for a vehicle without a shipped FDI: the
    method's networks, which fit-thresholds fits with by default."""
    from rw_fdi_ros.paths import fdi_dir
    micro = fdi_dir("speed_aware", "microsat_pyramid")
    assert FdiConfig(thresholds=str(micro)).for_vehicle("microsat_pyramid").models_dir == micro
    assert FdiConfig(thresholds=str(micro)).models_dir == micro
    assert FdiConfig(thresholds=str(tmp_path)).for_vehicle("coupled").models_dir == fdi_dir("speed_aware")
    assert FdiConfig().for_vehicle("microsat_pyramid").models_dir == micro
    assert FdiConfig().for_vehicle("maksat") == FdiConfig()
