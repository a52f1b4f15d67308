"""Every observer judged in service beside the decision (core/fdi/pipeline.FdiPipeline's watch, `bench service
--every-observer`): it changes nothing FDIR does, and each observer's alarms in the core loop are
those the offline tools (and so the nodes) give on the same FDI samples, calibrated units included."""
import numpy as np
import pytest

from rw_fdi_ros.core.fdi.calibration import calibration_samples
from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.fdi.pipeline import LoadedFdi, observer_estimators
from rw_fdi_ros.fdi_config import FdiConfig
from rw_fdi_ros.tools.benches import service_bench as sb
from rw_fdi_ros.tools.campaigns import service_family as family
from rw_fdi_ros.tools.design.offline import decisions, observe
from rw_fdi_ros.tools.design.samples import samples_from_series

FAULT = {"kind": "current_limiter", "wheel": "y", "onset": 220.0, "value": 0.75, "ramp": 0.0}


@pytest.mark.parametrize("units", [False, True])
def test_the_watch_changes_nothing_fdir_does_and_gives_the_offline_alarms(units):
    draws = [sb.Draw(92_000_900 + k, 420.0, units, False, (60.0, 120.0), 5.0, (FAULT,) if k else ())
             for k in range(2)]
    scenarios = [sb.scenario(d) for d in draws]
    names = scenarios[0].wheel_set().names
    plain = simulate(scenarios, fdir=sb.fdir_for(units, vehicle=draws[0].vehicle))
    watched = simulate(scenarios, fdir=sb.fdir_for(units, watch=FdiConfig()))
    assert [[(d.time, d.wheel, d.action) for d in r] for r in plain.decisions] == \
           [[(d.time, d.wheel, d.action) for d in r] for r in watched.decisions]
    np.testing.assert_array_equal(plain.attitude, watched.attitude)
    assert any(plain.decisions[1]), "the faulty run reconfigures: the watch is judged through it"
    config = FdiConfig(unit_calibration=family.CALIBRATION_S if units else 0.0)
    models, curves = config.load()
    calibration = calibration_samples(family.CALIBRATION_S) if units else 0
    stamps = np.round(watched.time * 1e9).astype(np.int64)
    for b in range(len(draws)):
        samples = samples_from_series(stamps, watched.wheel_command[:, b], watched.reaction_torque[:, b],
                                      watched.wheel_speed[:, b], wheels=names)
        offline = decisions(observe(samples, models, calibration_samples=calibration), curves)
        for slot, wheels in watched.watched[b].items():
            for wheel, (flags, first) in offline[slot].items():
                edges = np.diff(np.concatenate([[0], flags.astype(int), [0]]))   # +1 up, -1 down (the end: 0)
                ends = [round(samples.time[k], 6) if k < len(flags) else None for k in np.flatnonzero(edges == -1)]
                spans = [[round(t, 6), e] for t, e in zip(samples.time[np.flatnonzero(edges == 1)], ends)]
                assert [[round(t, 6), e if e is None else round(e, 6)] for t, e in wheels[wheel]] == spans, \
                    (slot, wheel)
                assert (wheels[wheel][0][0] if wheels[wheel] else None) == pytest.approx(first)
    model = watched.watched[1]["model"]["y"]
    assert model and model[0][0] >= FAULT["onset"], "the model observer alarms the faulty wheel"


def test_the_bench_reads_every_observer_and_the_plugins_beside():
    """A run's figures per observer: alarms before the fault, the faulty wheel and no other, held, delay."""
    draw = sb.Draw(92_000_910, 420.0, False, False, (60.0, 120.0), 5.0, (FAULT,))
    run = sb._simulate([draw], watch=FdiConfig())[0]
    assert set(run["observers"]) == {"elman", "linear", "model"}
    model = run["observers"]["model"]
    assert model["detected"] and model["right"] and model["alarms_before_fault"] == 0
    assert model["delay_s"] == pytest.approx(next(t for t, w, a, _ in run["decisions"] if w == "y") - 220.0,
                                              abs=2.0)
    figures = sb.summarize([run])["observers"]
    assert figures["model"]["right"]["k"] == 1 and "false_alarm_600s" in figures["elman"]


def test_a_model_alone_gives_the_watch_nothing_more_to_load(tmp_path):
    names = ("x", "y", "z", "s")
    models, curves = FdiConfig().load()
    watched = observer_estimators(names, models, ("model",), 1.0)
    make, gains = watched["model"]
    assert gains == [0.0] * 4 and list(watched) == ["model"]


def test_a_plugin_is_watched_in_service_as_its_node_runs_it():
    """A plug-in equal to the model observer (test_observer_plugin.ModelCopy) alarms in the core loop exactly as
    the model observer, run by run and wheel by wheel."""
    from rw_fdi_ros.core.fdi.observer_plugin import ObserverModels
    from test_observer_plugin import ModelCopy
    draws = [sb.Draw(92_000_920 + k, 420.0, bool(k), False, (60.0, 120.0), 5.0, (FAULT,)) for k in range(2)]
    for d in draws:
        scenario = sb.scenario(d)
        fdir = sb.fdir_for(d.units)
        models, curves = FdiConfig(unit_calibration=family.CALIBRATION_S if d.units else 0.0).load()
        watch = LoadedFdi({"model": curves["model"], "model_copy": curves["model"]},
                          ObserverModels(models, [(ModelCopy, {})]), calibration_samples=fdir.fdi.calibration_samples)
        from dataclasses import replace
        traj = simulate([scenario], fdir=replace(fdir, watch=watch))
        assert traj.watched[0]["model_copy"] == traj.watched[0]["model"] and traj.watched[0]["model"]["y"]


def test_an_alarm_up_before_the_onset_and_held_through_it_counts_from_the_onset():
    draw = sb.Draw(1, 600.0, False, False, (60.0, 120.0), 5.0, (FAULT,))
    watched = {"elman": {"x": [], "y": [[200.0, None]], "z": [], "s": []}}
    row = sb.observer_figures(watched, draw, [])["elman"]
    assert row["detected"] and row["held"] and row["right"] and row["delay_s"] == 0.0
    assert row["alarms_before_fault"] == 1   # and it was raised before the fault: a false alarm too
