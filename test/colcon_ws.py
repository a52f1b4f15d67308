"""A colcon workspace holding a clean copy of the tree, built once per test session and shared by the
tests that use the package as a ROS user gets it (test_colcon, test_launch_file)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


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


def build_workspace(ws: Path) -> Path:
    """``ws`` with src/rw_fdi_ros (a clean copy) built by colcon; AssertionError with colcon's output."""
    clean_copy(ws / "src" / "rw_fdi_ros")
    built = subprocess.run([str(BIN / "colcon"), "build"], cwd=ws, env=colcon_env(), capture_output=True,
                           text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]
    return ws
