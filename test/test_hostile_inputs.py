"""Hostile inputs, one probe per class (docs/security.md): each is refused at the door in one line naming what is
wrong, with a non-zero exit, in bounded time and memory, and nothing is written outside its folder.

The classes: a YAML file that expands without bound or nests without end; a name used as a path; a number beyond
what the physics has; a seed beyond numpy's; a plug-in whose output is not one real number per wheel or that ends
the process; a pool larger than the machine; a scheduler that is not Dask; a damaged bag (read past the damage,
and never learnt from)."""
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from rw_fdi_ros.cli import main
from rw_fdi_ros.core.fdi.observer_plugin import ObserverError, WheelObserver, step
from rw_fdi_ros.core.fdi.residuals import SignedResidual
from rw_fdi_ros.core.mission.scenario import SEED_MAX, ScenarioError, load_scenario, parse_scenario
from rw_fdi_ros.core.mission.vehicle import VehicleError, load_vehicle
from rw_fdi_ros.core.mission.yaml_text import MAX_VALUES, YamlError, read_yaml

from conftest import BIN, ROOT

BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 9)}]\n" for i in range(8))   # 9^9 strings
VEHICLE = (ROOT / "config" / "vehicles" / "maksat.yaml").read_text()


def refused(argv, capsys, code=2, within=30.0) -> str:
    """`rw-fdi ARGV` in this process: exit ``code``, one line on stderr, in bounded time; that line."""
    t0 = time.monotonic()
    assert main([str(a) for a in argv]) == code
    assert time.monotonic() - t0 < within
    err = capsys.readouterr().err.strip()
    assert err.startswith("rw-fdi: error:") and "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("text, said", [
    (BOMB, f"more than {MAX_VALUES} values once its aliases are expanded"),
    ("a: &x [1, *x]\n", "an alias inside the value it names"),
    ("[" * 200 + "]" * 200, "nested more than 64 levels deep"),
    ("poles: " + "1" * 5000 + "\n", "a value that cannot be read"),
    ("x: " + "y" * (1 << 21) + "\n", "characters, more than the"),
])
def test_yaml_that_expands_nests_or_grows_without_bound_is_one_line(text, said):
    t0 = time.monotonic()
    with pytest.raises(YamlError, match=said) as info:
        read_yaml(text, "f.yaml")
    assert time.monotonic() - t0 < 2.0 and str(info.value).startswith("f.yaml:") and "\n" not in str(info.value)


def test_an_alias_bomb_in_a_vehicle_or_a_scenario_is_refused_by_the_commands(tmp_path, capsys):
    vehicle = tmp_path / "bomb_vehicle.yaml"   # the bomb under sources: (a field nobody checks the size of)
    head, _, _ = VEHICLE.partition("\nsources:")
    vehicle.write_text(head + "\nsources:\n" + "".join(f"  {line}\n" for line in BOMB.splitlines()))
    assert "aliases are expanded" in refused(["vehicle", vehicle], capsys)
    scenario = tmp_path / "bomb.yaml"
    indented = "".join(f"  {line}\n" for line in BOMB.splitlines())
    scenario.write_text("name: bomb\nduration: 10\ndescription:\n" + indented)
    assert "aliases are expanded" in refused(["run", "--scenario", scenario, "--out", tmp_path / "out"], capsys)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.parametrize("name", ["../../escape", "/abs/escape", ".hidden", "a\\b"])
def test_a_name_that_is_a_path_is_refused_before_anything_is_written(name, tmp_path, capsys):
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"name: {name!r}\nduration: 10\n")
    with pytest.raises(ScenarioError, match="name: .* cannot name a file"):
        load_scenario(str(scenario))
    refused(["run", "--scenario", scenario, "--out", tmp_path / "out"], capsys)
    # flown by another vehicle (--vehicle rewrites the scenario into a file of its own): the same one line
    assert "cannot name a file" in refused(["screen", "--vehicle", "microsat_pyramid", "--scenario", scenario],
                                           capsys)
    assert not (tmp_path / "escape").exists() and not (tmp_path.parent / "escape").exists()
    with pytest.raises(VehicleError, match=r"maksat.yaml.name: .* cannot name a file"):
        load_vehicle(_vehicle_file(tmp_path, {"name: maksat": f"name: {name!r}"}))


def _vehicle_file(tmp_path, replace: dict):
    text = VEHICLE
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new, 1)
    path = tmp_path / "maksat.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("old, new, said", [
    ("torque_constant: 0.029 N m/A", "torque_constant: 1e308 N m/A", "torque_constant: 1e+308 is beyond any"),
    ("torque_constant: 0.029 N m/A", "torque_constant: 50 N m/A", "torque_constant: 50 N m/A is beyond any reaction"),
    ("inertia: 0.0077 kg m^2", "inertia: 1e12 kg m^2", "beyond any spacecraft's"),
])
def test_a_number_beyond_any_wheel_is_refused_where_the_vehicle_is_read(old, new, said, tmp_path, capsys):
    assert said in refused(["vehicle", _vehicle_file(tmp_path, {old: new})], capsys)


def test_a_seed_beyond_numpys_is_refused_before_any_run(tmp_path, capsys):
    with pytest.raises(ScenarioError, match="seed must be a whole number"):
        parse_scenario(f"name: s\nseed: {SEED_MAX + 1}\n", "s.yaml")
    with pytest.raises(ScenarioError, match="seed 9223372036854775808 is not"):
        load_scenario("fault_free").with_seed(SEED_MAX + 1)
    assert "is not a whole number" in refused(["campaign", "--scenario", "fault_free", "--runs", 2, "--seed-start",
                                               SEED_MAX, "--out", tmp_path / "c", "--engine", "core"], capsys)
    assert not list((tmp_path / "c").glob("*/*.mcap"))


def test_limits_of_the_command_line_and_of_a_threshold_file(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["run", "--scenario", "fault_free", "--command-timeout", "1e12"])
    assert "out of range" in capsys.readouterr().err
    import json
    from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves, ThresholdError
    from rw_fdi_ros.fdi_config import FdiConfig
    raw = json.loads(FdiConfig().threshold_path("model").read_text())
    raw["persistence"] = 1_000_000_000
    (tmp_path / "t.json").write_text(json.dumps(raw))
    with pytest.raises(ThresholdError, match=r"t.json: persistence must lie in \[1, 1000\]"):
        ThresholdCurves.load(tmp_path / "t.json")
    raw["persistence"], raw["sample_period"] = 3, -1.0   # a negated number, named with its file
    (tmp_path / "t.json").write_text(json.dumps(raw))
    with pytest.raises(ThresholdError, match=r"t.json: sample_period must lie in \(0, 3600\] s, got -1.0"):
        ThresholdCurves.load(tmp_path / "t.json")
    (tmp_path / "dir.csv").mkdir()
    assert "--table" in refused(["screen", "--scenario", "fault_free", "--seeds", "1..2", "--table",
                                 tmp_path / "dir.csv"], capsys, within=10.0)


class Blind(WheelObserver):
    slot = "blind"
    output = None

    def estimate(self, sample):
        if isinstance(self.output, str) and self.output == "exit":
            sys.exit(0)
        return self.output


@pytest.mark.parametrize("output, said", [
    (np.array([1e-3, 2e-3, 1j, 0.0]), "complex values"),
    ("abc", "must give real numbers"),
    ([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]], "gave 6 values for 4 wheels"),
    ("exit", r"called sys.exit\(0\)"),
])
def test_a_plugin_output_that_is_not_one_real_number_per_wheel_is_one_line_naming_it(output, said):
    observer = Blind(("x", "y", "z", "s"))
    observer.output = output
    with pytest.raises(ObserverError, match=f"^observer blind: .*{said}") as info:
        step(observer, None, False)
    assert "\n" not in str(info.value)


def test_a_blind_sample_is_not_judged_and_leaves_the_window_clean():
    """A plug-in's NaN or inf: that sample's residual is NaN (the channel says 'cannot judge'), and the samples
    after it are those of a run without it."""
    rng = np.random.default_rng(3)
    r, e, p = rng.normal(0, 1e-3, 60), rng.normal(0, 1e-3, 60), rng.normal(0, 1e-4, 60) + 0j
    blind, clean = SignedResidual(), SignedResidual()
    out = []
    for k in range(60):
        estimate = np.inf if k == 20 else np.nan if k == 30 else e[k]
        out.append(blind.update(r[k], estimate, p[k]))
        if k not in (20, 30):
            want = clean.update(r[k], e[k], p[k])
            assert out[-1] == pytest.approx(want, rel=1e-12)
    assert all(np.isnan(out[k]).all() for k in (20, 30))


def test_jobs_are_capped_at_the_machine(capsys):
    from rw_fdi_ros.cli.options import executor
    pool = executor(type("Args", (), {"jobs": 10_000, "scheduler": None})())
    assert pool.jobs == (os.cpu_count() or 1)
    assert "--jobs 10000: this machine has" in capsys.readouterr().err


def test_a_scheduler_that_is_not_dask_is_one_line_in_bounded_time(tmp_path):
    from rw_fdi_ros.tools.campaigns.campaign import DaskExecutor
    server = subprocess.Popen([sys.executable, "-m", "http.server", "0", "--bind", "127.0.0.1"], cwd=tmp_path,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        line = server.stdout.readline()   # "Serving HTTP on 127.0.0.1 port N ..."
        port = int(line.split(" port ")[1].split()[0])
        import distributed   # noqa: F401 -- its import is not the wait measured
        t0 = time.monotonic()
        with pytest.raises(RuntimeError, match=f"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered"):
            DaskExecutor(f"tcp://127.0.0.1:{port}")
        assert time.monotonic() - t0 < DaskExecutor.CONNECT_S + 10.0
    finally:
        server.kill()
        server.wait(10)


@pytest.mark.graph
def test_an_early_sigterm_of_a_run_ends_it_in_one_line(tmp_path):
    """SIGTERM while the graph starts (2.5 s in) gave a KeyError traceback (summary of a bag without a step)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen([str(BIN / "rw-fdi"), "run", "--scenario", "fault_free", "--out",
                             str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        time.sleep(2.5)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode != 0 and "Traceback" not in err and "KeyError" not in err, err[-2000:]


@pytest.mark.graph
def test_two_graphs_in_one_domain_and_namespace_are_told_apart(tmp_path):
    """Both runs failed with a misleading reason, and one bag held the other run's /scenario: the run that
    joins the occupied domain says so, and a run that completes holds its own scenario alone."""
    from concurrent.futures import ThreadPoolExecutor
    from rw_fdi_ros.runner.launcher import DomainLease
    from rw_fdi_ros.runner.scenario_run import run_scenario
    from rw_fdi_ros.storage.bag import read_bag
    for k in (1, 2):
        (tmp_path / f"twin{k}.yaml").write_text(f"name: twin{k}\nduration: 300.0\nseed: {24_000_100 + k}\n")
    with DomainLease() as lease, ThreadPoolExecutor(2) as pool:
        runs = [pool.submit(run_scenario, str(tmp_path / f"twin{k}.yaml"), out_dir=tmp_path / "bags",
                            domain_id=lease.domain_id) for k in (1, 2)]
        outcomes = [r.result() for r in runs]
    said = [o for o in outcomes if not o.ok and "another graph runs in this ROS domain" in o.reason]
    assert said and "give each run its own domain or namespace" in said[0].reason, [o.reason for o in outcomes]
    for k, o in zip((1, 2), outcomes):
        if o.ok:
            scenarios = [m.data for _, m in read_bag(o.bag, ["/scenario"]).topic("/scenario")]
            assert len(scenarios) == 1 and f"name: twin{k}" in scenarios[0]
