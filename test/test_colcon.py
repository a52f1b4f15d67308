"""The package as ROS users get it: `colcon build` of a clean copy, the install sourced, everything run
from a directory outside the source tree through the installed executables.

colcon comes from PyPI (requirements.txt); the build takes a few seconds.
"""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
NODES = ["elman_observer", "isolation", "linear_observer", "model_observer", "pid_controller", "plant", "player",
         "recorder"]
# the fast subset `colcon test` runs here (README: the whole suite is plain `colcon test`)
FAST_TESTS = ["test/test_convert.py", "test/test_wheel.py", "test/test_plant_choices.py", "test/test_detection.py"]
SHORT_FAULT = """name: short_loss
duration: 90
seed: 3
faults:
  - {kind: current_limiter, wheel: x, onset: 40, value: 0.6}
"""


def clean_copy(dest: Path):
    """The tracked files of the tree (what a checkout holds), else the package's own folders."""
    listed = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    files = listed.stdout.split() if listed.returncode == 0 and listed.stdout else []
    if not files:
        files = [str(p.relative_to(ROOT)) for folder in ("rw_fdi_ros", "launch", "config", "resource", "test")
                 for p in (ROOT / folder).rglob("*") if p.is_file() and "__pycache__" not in p.parts]
        files += ["setup.py", "setup.cfg", "package.xml", "README.md"]
    for name in files:
        target = dest / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target)


def colcon_env():
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}",
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    for key in ("PYTHONPATH", "AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH"):
        env.pop(key, None)
    return env


def sourced(ws: Path, command: str, cwd: Path, timeout=300):
    """``command`` in bash after sourcing the workspace's install/setup.bash, in ``cwd``."""
    return subprocess.run(["bash", "-c", f"source {ws / 'install' / 'setup.bash'} && {command}"], cwd=cwd,
                          env=colcon_env(), capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    ws = tmp_path_factory.mktemp("ws")
    clean_copy(ws / "src" / "rw_fdi_ros")
    built = subprocess.run([str(BIN / "colcon"), "build"], cwd=ws, env=colcon_env(), capture_output=True,
                           text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]
    return ws


def test_the_install_holds_every_executable_and_every_file_the_nodes_read(workspace):
    prefix = workspace / "install" / "rw_fdi_ros"
    lib = prefix / "lib" / "rw_fdi_ros"
    assert sorted(p.name for p in lib.iterdir()) == sorted(NODES + ["rw-fdi"])
    share = prefix / "share" / "rw_fdi_ros"
    copy = workspace / "src" / "rw_fdi_ros"
    shipped = [p for p in (copy / "config").rglob("*") if p.is_file()]
    assert {"elman_x.npz", "thresholds_elman.json", "fastdds.xml", "rw_fdi.json"} <= {p.name for p in shipped}
    for source in shipped:   # models, thresholds of both methods, scenarios, DDS profile, viewer layout
        assert (share / source.relative_to(copy)).is_file(), source
    assert (share / "launch" / "rw_fdi.launch.py").is_file() and (share / "package.xml").is_file()
    # from outside the tree the installed package finds its data in share/ and starts lib/'s files
    where = sourced(workspace, f"{sys.executable} -c 'import rw_fdi_ros.paths as p; "
                               "print(p.config_dir()); print(p.installed_executable(\"plant\"))'", cwd=workspace)
    assert where.returncode == 0, where.stderr
    assert where.stdout.split() == [str(share / "config"), str(lib / "plant")]


def _verdict(text: str) -> list:
    """The FDI lines of `rw-fdi run`'s summary: per wheel the truth and each observer's verdict."""
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("fault detection and isolation"))
    return [ln.strip() for ln in lines[start:] if ln.strip().startswith(("x ", "y ", "z ", "identified"))]


def test_installed_run_from_outside_the_tree_gives_the_source_tree_verdict(workspace, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "short.yaml").write_text(SHORT_FAULT)
    exe = workspace / "install" / "rw_fdi_ros" / "lib" / "rw_fdi_ros" / "rw-fdi"
    installed = sourced(workspace, f"{exe} run --scenario short.yaml --out installed_bags", cwd=elsewhere)
    assert installed.returncode == 0, installed.stdout[-1500:] + installed.stderr[-1500:]
    source = subprocess.run([str(BIN / "rw-fdi"), "run", "--scenario", str(elsewhere / "short.yaml"), "--out",
                             str(tmp_path / "source_bags")], cwd=ROOT, env=colcon_env(), capture_output=True,
                            text=True, timeout=300)
    assert source.returncode == 0, source.stderr[-1500:]
    verdict = _verdict(installed.stdout)
    assert verdict == _verdict(source.stdout)
    assert verdict[0].startswith("x") and "faulty from" in verdict[0] and "identified on wheel x: current loss" in \
        verdict[-1]
    assert (elsewhere / "installed_bags" / "short_loss_s0003" / "metadata.yaml").is_file()


def test_colcon_test_runs_the_fast_subset_and_passes(workspace):
    tested = subprocess.run([str(BIN / "colcon"), "test", "--pytest-args", *FAST_TESTS], cwd=workspace,
                            env=colcon_env(), capture_output=True, text=True, timeout=300)
    assert tested.returncode == 0, tested.stdout[-2000:]
    result = subprocess.run([str(BIN / "colcon"), "test-result", "--verbose"], cwd=workspace, env=colcon_env(),
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout[-2000:]
    summary = result.stdout.strip().splitlines()[-1]
    assert summary.startswith("Summary:") and " 0 errors, 0 failures" in summary
    assert int(summary.split()[1]) > 50, summary
