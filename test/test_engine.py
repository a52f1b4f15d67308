"""The core engine (node code on the batched core loop) records the graph's bags, and judges them as the
FDI graph does.

Same scenario files and seeds through both engines: a three-fault-kind mix with manoeuvres on the
default four-wheel set (the standby wheel s at rest), varied wheel units, and the thesis' three
orthogonal wheels. The bags hold the same topics and types, and per topic the same messages with
the same stamps and contents (storage/compare.py); each says which engine recorded it. Then the
core engine's evaluation (the observer and isolation nodes' code on the recorded telemetry) gives
the report the replay through the FDI graph gives: the same figures, identification and health.
"""
from pathlib import Path

import pytest

from rw_fdi_ros.storage.bag import bag_engine, message_counts
from rw_fdi_ros.storage.compare import bag_differences
from rw_fdi_ros.tools.campaigns.campaign import run_campaign
from rw_fdi_ros.tools.evaluation.evaluate import evaluate

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

SEED0 = 21_000_000   # disjoint from every other seed range (docs/fdi.md "Seeds")
SCENARIOS = {
    # two manoeuvres on top of the thesis' set-point step, a current loss on y, a hotter z later
    "mix": "duration: 70.0\nmanoeuvres: {interval_s: [20.0, 30.0], size_deg: [-5.0, 5.0]}\n"
           "faults:\n  - {kind: current_limiter, wheel: y, onset: 25.0, value: 0.6}\n"
           "  - {kind: temperature, wheel: z, onset: 45.0, value: 173.0}\n",
    # a bus drop on a wheel of drawn units
    "units": "duration: 60.0\nwheels: {variation: true}\n"
             "faults:\n  - {kind: bus_voltage, wheel: x, onset: 20.0, value: 5.5}\n",
    # the thesis' three wheels, a ripple increase
    "three": "duration: 50.0\nplant: {wheel_set: orthogonal}\n"
             "faults:\n  - {kind: ripple_gain, wheel: z, onset: 10.0, value: 1.4}\n",
    # in orbit, wheels above the dump start: the magnetorquers dump from the first magnetometer sample
    "orbit": "duration: 30.0\ninitial: {wheel_speed: [38.0, -36.0, 40.0]}\n"
             "environment: {epoch: 2026-03-01T00:00:00}\nmagnetorquers: {dumping: {start_speed: 35.0}}\n"
             "faults:\n  - {kind: current_limiter, wheel: z, onset: 12.0, value: 0.6}\n",
}
GROUPS = {"three": "three", "orbit": "orbit"}   # evaluation takes one wheel set (and kind of run) at a time


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    root = tmp_path_factory.mktemp("engines")
    out = {}
    for name, body in SCENARIOS.items():
        path = root / f"engine_{name}.yaml"
        path.write_text(f"name: engine_{name}\nseed: 0\n{body}")
        both = {}
        for engine in ("graph", "core"):
            group = GROUPS.get(name, "four")
            res = run_campaign(str(path), 2, SEED0, root / engine / group, engine=engine, desc=f"{name} {engine}")
            assert not res.failed, res.failed
            both[engine] = sorted(res.done)
        out[name] = both
    return root, out


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_the_engines_record_the_same_bags(recorded, name):
    _, out = recorded
    graph, core = out[name]["graph"], out[name]["core"]
    assert [b.name for b in graph] == [b.name for b in core] and len(core) == 2
    for g, c in zip(graph, core):
        assert bag_engine(g) == "graph" and bag_engine(c) == "core"
        assert message_counts(g) == message_counts(c)
        assert bag_differences(g, c) == []


def test_in_orbit_the_bags_hold_the_magnetometer_and_the_rods(recorded):
    """Once a second the plant's magnetometer reading and the momentum-dumping node's dipole for the same
    stamp, the rods on (the wheels start above the dump start)."""
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.storage.bag import read_bag
    _, out = recorded
    bag = out["orbit"]["graph"][0]
    counts = message_counts(bag)
    assert counts[T.MAGNETOMETER] == counts[T.DIPOLE_COMMAND] == 31
    data = read_bag(bag, [T.MAGNETOMETER, T.DIPOLE_COMMAND])
    fields = [m for _, m in data.topic(T.MAGNETOMETER)]
    dipoles = [m for _, m in data.topic(T.DIPOLE_COMMAND)]
    assert all(15e-6 < (m.magnetic_field.x ** 2 + m.magnetic_field.y ** 2 + m.magnetic_field.z ** 2) ** 0.5 < 60e-6
               for m in fields)
    assert all(max(abs(d.vector.x), abs(d.vector.y), abs(d.vector.z)) > 1.0 for d in dipoles)
    from rw_fdi_ros.runner.summary import format_summary, run_summary
    summary = run_summary(bag)   # what a person reads after the run: one dump, on the whole run
    assert summary["momentum_dumps"] == [[0.0, 30.0]]
    assert "momentum dumping: 1 dump (rods on 0-30 s)" in format_summary(summary)


def test_a_different_run_is_told_apart(recorded):
    """The comparison is not blind: the two seeds of one scenario differ, and it says where."""
    _, out = recorded
    a, b = out["mix"]["core"]
    found = bag_differences(a, b)
    assert found and any("/attitude" in line for line in found)


def test_the_core_evaluation_is_the_fdi_graphs(recorded, tmp_path):
    root, _ = recorded
    reports = {engine: evaluate(root / "core" / "four", tmp_path / engine, engine=engine, plots=False)
               for engine in ("graph", "core")}
    assert reports["core"]["runs"] == reports["graph"]["runs"] == 4
    assert reports["core"]["engine"] == "core" and not (tmp_path / "core" / "replays").exists()
    for key in ("observers", "identification", "health"):
        assert reports["core"][key] == reports["graph"][key], key
    # the runs are not all quiet: there is something to agree on
    assert reports["core"]["identification"] and Path(tmp_path / "graph" / "replays").is_dir()


def test_the_core_engine_refuses_what_it_does_not_record(tmp_path):
    with pytest.raises(ValueError, match="core engine records the closed loop without the FDI"):
        run_campaign("fault_free", 1, 1, tmp_path, engine="core", fdi=True)
    with pytest.raises(ValueError, match="unknown engine"):
        run_campaign("fault_free", 1, 1, tmp_path, engine="fast")


def test_a_replay_waits_for_every_reports_grid_when_its_bags_hold_them(recorded, tmp_path):
    """The isolation node is told that every report comes with its grid (not left to discovery, which may
    bring the report's publisher first on a loaded machine: the report judged without its grid); a bag
    without grids (an older recorder) leaves it to what it sees."""
    from rw_fdi_ros.core.mission.plant_choices import PlantChoices
    from rw_fdi_ros.tools.campaigns.replay import replay_nodes
    _, out = recorded
    bags = out["mix"]["core"]
    plant = PlantChoices.of_recording({}).as_dict()

    def awaits(bag_list):
        nodes = replay_nodes(bag_list, [tmp_path / f"o{i}" for i in range(len(bag_list))], None, plant)
        return next(n for n in nodes if n.executable == "isolation").parameters["await_bus_grid"]
    assert awaits(bags) is True
    assert awaits([*bags, tmp_path / "no_metadata"]) is False
