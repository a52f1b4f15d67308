"""The real `launch` and `launch_ros` for the tests: the user's own where they are importable (a ROS 2
install), else the sources in ../shared/ros2-launch (launch 3.7.1, launch_ros 0.28.0; their PyPI
dependencies osrf-pycommon and lark come from requirements.txt)."""
import importlib.util
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "ros2-launch"


def _installed(name: str) -> bool:
    """A real package ``name``, not a namespace package of a folder that happens to be called so (this
    repository's own launch/ folder is one, seen from its root)."""
    spec = importlib.util.find_spec(name)
    # the shared sources on sys.path (use_launch, an earlier test) are not an install: a subprocess needs them too
    return spec is not None and spec.origin not in (None, "namespace") and SHARED not in Path(spec.origin).parents


def launch_path() -> list:
    """Folders to put on sys.path for ``import launch, launch_ros``: none when they import already."""
    if _installed("launch") and _installed("launch_ros"):
        return []
    folders = [SHARED / sub for sub in ("launch", "launch_ros", "stub")]
    missing = [str(f) for f in folders if not f.is_dir()]
    assert not missing, f"launch and launch_ros are neither importable nor in {SHARED} ({missing})"
    return [str(f) for f in folders]


def use_launch():
    """Make ``import launch, launch_ros`` work in this process."""
    for folder in reversed(launch_path()):
        if folder not in sys.path:
            sys.path.insert(0, folder)
    for name in ("launch", "launch_ros"):
        module = sys.modules.get(name)
        if module is not None and getattr(module, "__file__", None) is None:   # a namespace stand-in
            del sys.modules[name]


# `ros2 launch FILE name:=value ...`: FILE through LaunchService, the process exits with its return code
ROS2_LAUNCH = """
import sys
from launch import LaunchService
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
service = LaunchService(argv=sys.argv[2:])
service.include_launch_description(IncludeLaunchDescription(
    PythonLaunchDescriptionSource(sys.argv[1]),
    launch_arguments=[tuple(a.split(":=", 1)) for a in sys.argv[2:] if ":=" in a]))
sys.exit(service.run())
"""


def ros2_launch_command(python: str, launch_file, *arguments) -> list:
    """The command line of ``ros2 launch launch_file arguments...`` with the real launch machinery."""
    return [python, "-c", ROS2_LAUNCH, str(launch_file), *arguments]


def launch_env(env: dict) -> dict:
    """``env`` with the launch sources on PYTHONPATH when they are not installed."""
    extra = launch_path()
    if extra:
        env = dict(env, PYTHONPATH=os.pathsep.join(extra + [p for p in [env.get("PYTHONPATH")] if p]))
    return env
