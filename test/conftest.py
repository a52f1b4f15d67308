"""Shared test set-up: every ROS process the tests start stays on loopback in a private domain."""
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="rw_fdi_test_roslog_"))
os.environ.pop("ROS_LOCALHOST_ONLY", None)


# --- the FDI graph runs several test modules judge -------------------------------------------
import json  # noqa: E402
from concurrent.futures import ThreadPoolExecutor  # noqa: E402

import pytest  # noqa: E402

from rw_fdi_ros.core.mission.scenario import load_scenario  # noqa: E402
from rw_fdi_ros.core.physics.wheel import bus_fault_visible_above  # noqa: E402
from rw_fdi_ros.runner.fdi_run import run_with_fdi  # noqa: E402


# The modules that start ROS graphs or process pools (each already keeps both cores busy) are marked
# `graph`: scripts/run_tests.sh runs them one after another in one pytest, and the rest in another beside it.


@pytest.fixture(scope="session")
def colcon_workspace(tmp_path_factory):
    """A colcon workspace with a clean copy of the tree built (test/colcon_ws.py), shared by the session."""
    from colcon_ws import build_workspace
    return build_workspace(tmp_path_factory.mktemp("ws"))


def bus_seed():
    """A seed whose X wheel spins fast enough for a 5.5 V bus to matter (physics.md)."""
    fast = bus_fault_visible_above(5.5) + 2.0
    s = load_scenario("bus_5v5_x")
    return next(seed for seed in range(1, 200) if s.with_seed(seed).draws()[0].wheel_speed[0] > fast)


def case_seed(name: str) -> int:
    return CASES[name][1] if CASES[name][1] is not None else bus_seed()


# The live FDI graph runs shared by test_fdi_graph and test_screen_matches_graph (each run costs
# about a minute of CI): name -> (scenario, seed (None: bus_seed()), fdi method)
CASES = {"fault_free": ("fault_free", 12, "speed_aware"), "bus_5v5_x": ("bus_5v5_x", None, "speed_aware"),
         "current_0p6_x": ("current_0p6_x", 12, "speed_aware"),
         "temperature_150_x": ("temperature_150_x", 13, "speed_aware"),
         "bus_x_current_z": ("bus_x_current_z", None, "speed_aware"),
         "current_0p6_x_thesis": ("current_0p6_x", 12, "thesis")}


CASE_DURATION = 300.0   # the thesis scenarios shortened from 400 s: every fault starts by 250 s


@pytest.fixture(scope="session")
def fdi_runs(tmp_path_factory):
    """name -> RunOutcome of CASES through the live graph (two at a time); each outcome carries
    the Scenario it ran (``.scenario``: the shipped one, CASE_DURATION long, at its seed)."""
    root = tmp_path_factory.mktemp("fdi")
    seeds = {k: case_seed(k) for k in CASES}
    files = {}
    for k, (name, _, _) in CASES.items():
        text = (ROOT / "config" / "scenarios" / f"{name}.yaml").read_text()
        assert "duration: 400.0" in text, name
        files[k] = root / f"{k}.yaml"
        files[k].write_text(text.replace("duration: 400.0", f"duration: {CASE_DURATION}"))
    with ThreadPoolExecutor(2) as pool:
        # detection alone (fdir off): the thesis' figures; the chain with reconfiguration: test_fdir_graph.py
        futures = {k: pool.submit(run_with_fdi, str(files[k]), seed=s, out_dir=root / k, figure=True,
                                  fdi={"method": CASES[k][2], "fdir": False}) for k, s in seeds.items()}
        results = {k: f.result() for k, f in futures.items()}
    for k, outcome in results.items():
        outcome.scenario = load_scenario(str(files[k])).with_seed(seeds[k])
    report = {k: {"seed": seeds[k], "ok": o.ok, "reason": o.reason, "fdi": o.summary and o.summary.get("fdi")}
              for k, o in results.items()}
    print(json.dumps(report, indent=1, default=str))
    return results


def verdict_of_flags(flags: dict, decision, speed=None):
    """(n, 3) alarms of core/fdi/pipeline.Verdict stepped over observers' alarm flags {observer: (n, 3) bool}, each
    row's first alarm that observer's first flag up (as ObserverChannel gives it), ``speed`` (n, 3) [rad/s]."""
    import numpy as np
    from rw_fdi_ros.core.fdi.pipeline import Verdict
    verdict = Verdict("xyz", decision)
    n = len(next(iter(flags.values())))
    out = np.zeros((n, 3), bool)
    for k in range(n):
        rows_of = {o: {a: (0.0, 1.0, bool(f[k, i]), float(np.argmax(f[:, i])) if f[:k + 1, i].any() else None)
                       for i, a in enumerate("xyz")} for o, f in flags.items()}
        decided = verdict.decide(rows_of, None if speed is None else speed[k])
        out[k] = [decided[a][2] for a in "xyz"]
    return out


BIN = Path(sys.executable).parent   # the venv's rw-fdi
KALMAN = f"{ROOT}/examples/kalman_observer/kalman_observer.py:KalmanObserver"   # the worked plug-in example


def cli(*args, timeout=300):
    import subprocess
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    return subprocess.run([str(BIN / "rw-fdi"), *args], capture_output=True, text=True, timeout=timeout, env=env)


@pytest.fixture(scope="session")
def kalman_fdi(tmp_path_factory):
    """The worked example trained and fitted by the commands a user runs (small: 6 and 12 runs)."""
    out = tmp_path_factory.mktemp("kalman_fdi")
    r = cli("train", "--observer", KALMAN, "--simulate", "fault_free", "--seeds", "61000000..61000005",
            "--out", str(out), "--jobs", "1")
    assert r.returncode == 0, r.stderr
    r2 = cli("fit-thresholds", "--observer", KALMAN, "--simulate", "fault_free", "--seeds", "60000000..60000011",
             "--false-alarm-rate", "0.005", "--out", str(out), "--jobs", "1")
    assert r2.returncode == 0, r2.stderr
    return out, r.stdout + r2.stdout
