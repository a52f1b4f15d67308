"""An FDI input stream's order and finiteness (core/fdi/input_health.py) and the isolation channel's
handling of a sample it cannot judge (core/fdi/verdict.py): closed-form cases."""
import math

from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
from rw_fdi_ros.core.fdi.input_health import NEW_RUN, NEXT, OUT_OF_ORDER, STALE, WARN, InputMonitor, stamp_order
from rw_fdi_ros.core.fdi.verdict import ObserverChannel

S = 10**9


def test_stamp_order():
    assert stamp_order(None, 5 * S, S) == NEXT
    assert stamp_order(4 * S, 5 * S, S) == NEXT
    assert stamp_order(5 * S, 5 * S, S) == OUT_OF_ORDER          # a duplicate
    assert stamp_order(5 * S, 3 * S, S) == OUT_OF_ORDER          # late
    assert stamp_order(300 * S, 0, S) == NEW_RUN                 # back at a run's first sample
    assert stamp_order(300 * S, S, S) == NEW_RUN
    assert STALE == 3 and WARN == 1                               # diagnostic_msgs' levels


def test_monitor_notes_gaps_duplicates_and_late_samples_on_their_stamps():
    m = InputMonitor("FDI telemetry", 1.0)
    assert [m.accept(k * S) for k in (0, 1, 2)] == [NEXT] * 3
    assert m.take_note(2 * S) is None
    assert m.accept(6 * S) == NEXT                                # 3, 4, 5 lost
    assert m.take_note(5 * S) is None                             # said on the sample after the gap
    note = m.take_note(6 * S)
    assert note.level == WARN and "3 samples missing before 6 s" in note.message
    assert m.take_note(6 * S) is None                             # said once
    assert m.accept(6 * S) == OUT_OF_ORDER and m.accept(4 * S) == OUT_OF_ORDER
    assert m.last_ns == 6 * S and m.dropped == 2
    note = m.take_note(7 * S)
    assert "dropped a duplicate sample stamped 6 s" in note.message
    assert "dropped a late sample stamped 4 s (after 6 s)" in note.message
    assert m.accept(7 * S) == NEXT and m.take_note(7 * S) is None
    assert m.accept(0) == NEW_RUN and m.last_ns == 0


def curves(threshold=1.0, persistence=2):
    return ThresholdCurves(observer="elman", sample_period=1.0, seeds=[1], false_alarm_rate=0.01,
                           persistence=persistence, curves={a: [threshold] * 50 for a in "xyz"})


def test_a_non_finite_residual_is_not_judged_and_holds_the_alarm():
    ch = ObserverChannel("elman", curves())
    for k in (1, 2):
        rows = ch.update(k * S, [2.0, 0.0, 0.0])
    assert rows["x"][2] and rows["x"][3] == 2.0 and not ch.unjudged
    rows = ch.update(3 * S, [math.nan, math.nan, 0.0])            # NaN > threshold is False: it would clear x
    assert rows["x"][2] and rows["x"][3] == 2.0 and math.isnan(rows["x"][0])
    assert not rows["y"][2] and ch.unjudged == {"x", "y"}
    rows = ch.update(4 * S, [2.0, 0.0, 0.0], bound=[0.0, math.inf, 0.0])
    assert rows["x"][2] and ch.unjudged == {"y"}                   # judged again; y's bound is not finite
    ch.update(5 * S, [0.0, 0.0, 0.0])
    assert not ch.rules["x"].active and not ch.unjudged
