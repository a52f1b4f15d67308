"""A bench's journal (tools/benches/journal.py): what it keeps reads back as it was, an interrupted map resumes
with only the rest run, other work starts over, and a journal can name only this package's classes."""
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from rw_fdi_ros.core.physics.faults import Fault
from rw_fdi_ros.scoring.metrics import RunEval, Series
from rw_fdi_ros.tools.benches import journal as J
from rw_fdi_ros.tools.campaigns.campaign import LocalExecutor


def test_a_judged_run_reads_back_as_it_was():
    series = Series(time=np.arange(3.0), residual=np.array([[1.0, np.nan]] * 3), threshold=np.ones((3, 2)),
                    alarm=np.array([[True, False]] * 3))
    run = RunEval(bag="b", scenario="s", seed=7, faults=[Fault("bus_voltage", 1, 30.0, 5.5, 10.0)],
                  series={"model": series}, fault_effect_peak=np.array([0.0, 2e-4]),
                  identification={"y": {"kind": "bus drop"}}, wheels=("x", "y"),
                  reconfiguration=[(31.0, "y", "give_up", "confirmed")])
    arrays = []
    seen = SimpleNamespace(seed=7, dumps=2, onset_in_dump=None)
    data = json.loads(json.dumps(J.encode({3: [run], (1, 2): range(4, 9), "f": math.inf, "seen": seen}, arrays)))
    back = J.decode(data, {f"arr_{i}": a for i, a in enumerate(arrays)})
    got = back[3][0]
    assert isinstance(got, RunEval) and isinstance(got.series["model"], Series)
    assert got.faults == run.faults and got.wheels == ("x", "y") and got.reconfiguration == run.reconfiguration
    np.testing.assert_array_equal(got.series["model"].residual, series.residual)   # NaN where it was
    assert got.series["model"].alarm.dtype == bool and got.faulty_wheels == ["y"]
    assert back[(1, 2)] == range(4, 9) and back["f"] == math.inf and back["seen"] == seen


def test_a_journal_names_only_this_packages_dataclasses():
    with pytest.raises(ValueError, match="not a class of this package"):
        J.decode({"__dataclass__": "subprocess:Popen", "fields": {"args": "true"}}, {})
    import sys
    assert "rw_fdi_ros.cli.__main__" not in sys.modules
    with pytest.raises(ValueError, match="not a class of this package"):   # never imported: its code never runs
        J.decode({"__dataclass__": "rw_fdi_ros.cli.__main__:main", "fields": {}}, {})
    assert "rw_fdi_ros.cli.__main__" not in sys.modules
    with pytest.raises(TypeError, match="cannot keep a set"):
        J.encode({1, 2}, [])


def _square(x):
    calls.append(x)
    return {"x": x, "square": np.array([x * x])}


calls = []


def test_an_interrupted_map_resumes_with_only_the_rest_and_other_work_starts_over(tmp_path, capsys):
    work, executor = list(range(6)), LocalExecutor(jobs=1)
    calls.clear()
    first = J.resumable_map(executor, _square, work, tmp_path, "toy", processes=False)
    got = [next(first) for _ in range(2)]
    first.close()   # interrupted after two items (Ctrl-C ends the generator the same way)
    assert len(list((tmp_path / ".toy_journal").glob("*.npz"))) >= 2
    calls.clear()
    again = list(J.resumable_map(executor, _square, work, tmp_path, "toy", processes=False))
    assert "resuming" in capsys.readouterr().err
    assert sorted(r["x"] for r in again) == work and all(r["square"][0] == r["x"] ** 2 for r in again)
    assert not set(calls) & {r["x"] for r in got} and len(calls) <= 4   # what was kept did not run again
    assert (tmp_path / ".toy_journal").exists()   # until the report is written (a later stage may stop)
    J.finish(tmp_path, "toy")
    assert not (tmp_path / ".toy_journal").exists()

    left = J.resumable_map(executor, _square, work, tmp_path, "toy", processes=False)
    next(left)
    left.close()   # a journal of this work left behind
    calls.clear()
    other = list(J.resumable_map(executor, _square, [10, 11], tmp_path, "toy", processes=False))
    assert "starting over" in capsys.readouterr().err
    assert sorted(calls) == [10, 11] and sorted(r["x"] for r in other) == [10, 11]

    calls.clear()   # the same work by another function (another command's options live there): over again
    again = list(J.resumable_map(executor, _cube, [10, 11], tmp_path, "toy", processes=False))
    assert "starting over" in capsys.readouterr().err and sorted(calls) == [10, 11]
    assert sorted(r["square"][0] for r in again) == [1000, 1331]


def _cube(x):
    calls.append(x)
    return {"x": x, "square": np.array([x ** 3])}
