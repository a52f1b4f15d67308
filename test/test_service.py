"""A net under FDIR in service (issue 34): fixed in-service cases on the core loop, every capability at once,
so that a change to one capability cannot silently break another (rw-fdi bench service measures the rates)."""
import numpy as np

from rw_fdi_ros.core.fdi.calibration import UnitCalibration
from rw_fdi_ros.core.mission.vehicle import load_vehicle
from rw_fdi_ros.tools.benches import service_bench as sb
from rw_fdi_ros.tools.campaigns import service_family as family

MANOEUVRES = (100.0, 200.0)


def _runs(draws):
    return sb._simulate(list(draws))


def test_calibrated_observers_leave_the_standby_wheel_alone_and_learn_it_once_it_runs():
    """Wheel units calibrated 150 s, manoeuvres all along, no fault: the standby wheel s (at rest, unpowered:
    residual 0, bound 0 against a band below 0) was given up at 3 s in every run; now nothing is decided.
    A calibration learns nothing from a wheel at rest and unpowered, and its window waits for it to run."""
    runs = _runs([sb.Draw(92_000_001, 600.0, True, False, MANOEUVRES, 5.0, ())])
    assert runs[0]["decisions"] == [] and runs[0]["pointing_kept"]
    c = UnitCalibration(3)
    assert c.update(1e-3, np.zeros(6)) == (0.0, 0.0) and c.n == 0 and not c.frozen
    for _ in range(3):
        c.update(1e-4, [1e-3, 1e-3, 1e-3, 1e-3, 0.0, 0.0])
    assert c.frozen and c.n == 3


def test_a_fault_on_a_datasheet_wheel_then_slews_keeps_the_pointing_and_is_identified():
    """40 % current loss on x at 250 s, 5-deg slews every 100-200 s before and after: x is kept in use beside
    s (giving it up would leave y, z, s unable to slew from these speeds), the pointing is kept at every
    judged sample, no healthy wheel is touched and the fault is named with its size."""
    fault = {"kind": "current_limiter", "wheel": "x", "onset": 250.0, "value": 0.6, "ramp": 0.0}
    run = _runs([sb.Draw(92_000_002, 600.0, False, False, MANOEUVRES, 5.0, (fault,))])[0]
    assert [(w, a) for _, w, a, _ in run["decisions"]] == [("x", "kept_in_use"), ("s", "in_use")]
    assert run["acted_right"] and run["pointing_kept"] and run["worst_deg"] < 0.2
    ident = run["identification"]
    assert ident["kind"] == "current_limiter" and ident["size_right"] and ident["covered"], ident


def test_a_ramping_fault_on_a_calibrated_unit_is_named_once_it_stops_growing():
    """+100 C on z of a wheel unit, ramping over 150 s from 200 s, with slews: z acted on, nothing else; the
    samples since the onset fit no one temperature, the ramps (identification.RAMP_LENGTH) do."""
    fault = {"kind": "temperature", "wheel": "z", "onset": 200.0, "value": 123.0, "ramp": 150.0}
    run = _runs([sb.Draw(92_000_003, 600.0, True, False, MANOEUVRES, 3.0, (fault,))])[0]
    assert run["acted_right"] and run["pointing_kept"], run
    ident = run["identification"]
    assert ident["kind"] == "temperature" and ident["size_right"], ident


def test_a_kept_wheel_whose_bus_goes_on_falling_is_held_and_the_pointing_kept():
    """A bus ramping to 4.15 V over 200 s on x of a datasheet wheel, with slews: x is confirmed while it still
    gives over half its torque and kept beside s; as the bus goes on down it is held (watched once an FDI
    period: fdir.Reconfiguration.review). Kept to the end, such a run lost 34 deg (seed 91,000,164)."""
    fault = {"kind": "bus_voltage", "wheel": "x", "onset": 225.0, "value": 4.15, "ramp": 200.0}
    run = _runs([sb.Draw(92_000_004, 600.0, False, False, (150.0, 450.0), 1.5, (fault,))])[0]
    assert [(w, a) for _, w, a, _ in run["decisions"]] == [("x", "kept_in_use"), ("s", "in_use"), ("x", "held")]
    assert "under the 50 %" in run["decisions"][2][3]
    assert run["acted_right"] and run["pointing_kept"], run


def test_the_in_service_family_draws_every_case_from_its_seed():
    """The draws are data: the same seed the same run, and the family holds what it claims."""
    draws = [sb.draw(s) for s in range(sb.SEED_BASES["net"], sb.SEED_BASES["net"] + 400)]
    assert sb.draw(sb.SEED_BASES["net"]) == draws[0]
    faults = [f for d in draws for f in d.faults]
    ranges = load_vehicle().dispersions.fault_ranges   # the thesis' vehicle's in-service fault sizes
    assert {f["kind"] for f in faults} == set(sb.FAULT_KINDS) and {f["wheel"] for f in faults} >= {"x", "y", "z", "s"}
    assert any(f["ramp"] for f in faults) and any(not f["ramp"] for f in faults)
    assert any(d.units for d in draws) and any(not d.units for d in draws) and any(d.orbit for d in draws)
    assert {d.duration for d in draws} == {dur for dur, _ in family.DURATIONS}
    assert any(len(d.faults) == 2 for d in draws) and any(not d.faults for d in draws)
    for d in draws:
        for f in d.faults:
            low, high = ranges[f["kind"]]
            assert low <= f["value"] <= high and f["onset"] + 240.0 <= d.duration + 1e-9
        s = sb.scenario(d)
        assert s.duration == d.duration and len(s.faults) == len(d.faults)


def test_a_ramp_that_hides_until_it_takes_the_pointing_is_counted_with_its_reason():
    """A bus ramp shows only once the wheel needs the voltage: the run records when its effect first showed, and
    a pointing lost within 60 s of that, before any decision, is counted apart (the grace a step has from its
    onset), not as unexplained; lost later, or after a decision, it stays unexplained."""
    fault = {"kind": "bus_voltage", "wheel": "y", "onset": 295.5, "value": 4.7718, "ramp": 143.4}
    run = _runs([sb.Draw(92_000_005, 600.0, False, False, (299.3, 831.2), 1.91, (fault,))])[0]
    assert run["visible_s"] is not None and fault["onset"] + 60.0 < run["visible_s"] < fault["onset"] + fault["ramp"]
    lost = {"pointing_kept": False, "momentum_said": None, "first_lost_s": 424.0, "visible_s": 411.3,
            "faults": [fault], "decisions": [(424.0, "y", "held", "confirmed faulty"), (424.0, "s", "in_use", "")]}
    assert sb._lost_as_it_showed(lost)
    assert not sb._lost_as_it_showed({**lost, "first_lost_s": 480.0, "decisions": []})     # 60 s of grace only
    assert not sb._lost_as_it_showed({**lost, "decisions": [(400.0, "y", "held", "")]})    # decided in time
    assert not sb._lost_as_it_showed({**lost, "pointing_kept": True, "first_lost_s": None})
    figures = sb.summarize([{**lost, "fault_free_family": False, "duration": 600.0, "units": False,
                             "reconfigured_before_fault": [], "fault_effect_peak": 0.02, "acted_right": True,
                             "healthy_acted": [], "delay_s": 128.5, "action": "held", "at_limit": []}])
    assert figures["pointing_lost_showing"]["k"] == 1 and figures["pointing_lost_unexplained"]["k"] == 0
    assert figures["pointing_kept_allowed"]["n"] == 1 and figures["pointing_kept_allowed"]["k"] == 0   # not said
    said = sb.summarize([{**lost, "fault_free_family": False, "duration": 600.0, "units": False, "momentum_said": "p1",
                          "reconfigured_before_fault": [], "fault_effect_peak": 0.02, "acted_right": True,
                          "healthy_acted": [], "delay_s": 128.5, "action": "held", "at_limit": ["p1"]}])
    assert said["pointing_kept_allowed"]["n"] == 0 and said["pointing_lost_said"]["k"] == 1


def test_a_wheel_given_up_at_its_decision_is_identified_from_the_samples_before():
    """+100 C on z at 170 s, given up (FDIR made to give up every wheel it confirms: the given-up runs of the
    bench): the identification said "not identified: its driver was switched off after 2 samples of the
    fault" in 3 of 4 such runs; it is named, with its size, from the samples before the switch-off. The
    same fault under the flight policy is held or kept, never given up, and the given-up runs are figures
    of their own."""
    fault = {"kind": "temperature", "wheel": "z", "onset": 170.0, "value": 123.0, "ramp": 0.0}
    draw = sb.Draw(92_000_006, 600.0, False, False, (300.0, 600.0), 2.0, (fault,), give_up=True)
    run = _runs([draw])[0]
    assert [(w, a) for _, w, a, _ in run["decisions"]][:2] == [("z", "out_of_use"), ("s", "in_use")], run
    assert run["action"] == "out_of_use" and run["give_up"]
    ident = run["identification"]
    assert ident["kind"] == "temperature" and ident["size_right"] and ident["covered"], ident
    figures = sb.summarize([run])["given_up"]
    assert figures["runs"] == figures["given_up"] == 1 and figures["kind_right"]["k"] == 1
    assert sb.summarize([run])["runs"] == 0   # not among the flight policy's figures
    given = sb.given_up_draws(range(sb.SEED_BASES["net"], sb.SEED_BASES["net"] + 30))
    assert given and all(d.give_up and d.faults and d.duration <= sb.GIVEN_UP_MAX_S for d in given)


def test_the_family_flies_another_vehicle_with_its_wheels_and_its_fdi():
    """Drawn for the shipped microsatellite: its pyramid's wheels fail, its scenario names it, and its FDIR
    judges with the FDI made for it (config/fdi/vehicles/microsat_pyramid); the thesis' draws are unchanged."""
    draws = [sb.draw(s, vehicle="microsat_pyramid") for s in range(sb.SEED_BASES["net"], sb.SEED_BASES["net"] + 60)]
    assert {f["wheel"] for d in draws for f in d.faults} <= {"p1", "p2", "p3", "p4"}
    assert [(d.duration, d.faults and d.faults[0]["kind"]) for d in draws[:20]] == \
        [(d.duration, d.faults and d.faults[0]["kind"]) for d in (sb.draw(d.seed) for d in draws[:20])]
    s = sb.scenario(draws[0])
    assert s.spacecraft.name == "microsat_pyramid" and s.wheel_set().name == "pyramid"
    assert sb.fdir_for(False, vehicle="microsat_pyramid").fdi.curves["model"].plant["vehicle"] == "microsat_pyramid"


def test_a_report_re_identified_keeps_every_act_and_refuses_a_record_that_moved(tmp_path):
    """`bench service --reidentify`: after a change to the identifier the runs with an identification and the
    given-up runs are simulated again and the rest kept; FDIR does not read the identifier, so a re-simulated
    run that acts otherwise than its record means more changed, and is refused, the report left as it was."""
    import json
    import pytest
    report = sb.bench_service(runs=1, seeds="net", out=tmp_path, max_hours=0.15, fault_free_runs=0, given_up_runs=0)
    flight = [r for r in report["runs"] if "identification" in r and not r["give_up"]]
    assert flight and flight[0]["identification"]["kind"] == "current_limiter"
    again = sb.reidentify(tmp_path)
    def text(figures):   # NaN intervals of empty rates compare equal as text
        return json.dumps(figures, sort_keys=True, default=float)
    assert text(again["figures"]) == text(report["figures"])
    assert "--reidentify" in again["rejudged"] and "--reidentify" in (tmp_path / "service.md").read_text()
    record = json.loads((tmp_path / "service.json").read_text())
    moved = next(r for r in record["runs"] if r["seed"] == flight[0]["seed"] and not r["give_up"])
    moved["decisions"] = [[t, w, a, "worded otherwise"] for t, w, a, _ in moved["decisions"]]   # only the words
    moved["worst_deg"] *= 1.0 + 1e-13   # and the last bits, which the runs batched beside it move
    (tmp_path / "service.json").write_text(json.dumps(record))
    assert text(sb.reidentify(tmp_path)["figures"]) == text(again["figures"])
    record = json.loads((tmp_path / "service.json").read_text())
    moved = next(r for r in record["runs"] if r["seed"] == flight[0]["seed"] and not r["give_up"])
    moved["decisions"] = moved["decisions"][1:] + [[1.0, "s", "out_of_use", "moved"]]
    (tmp_path / "service.json").write_text(json.dumps(record))
    with pytest.raises(sb.RecordMismatch, match=f"1 runs act .*seed {flight[0]['seed']}: acts"):
        sb.reidentify(tmp_path)
    assert json.loads((tmp_path / "service.json").read_text()) == record
