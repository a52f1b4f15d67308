"""package.xml declares every run dependency the code imports, under its rosdep key."""
import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# import name -> rosdep key (rosdistro's rosdep/python.yaml); None: no key, pip via requirements.txt
KEYS = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml", "torch": "python3-torch",
        "rosbags": "python3-rosbags-pip", "mcap": "mcap-ros2-support", "mcap_ros2": "mcap-ros2-support",
        "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "jsonschema": "python3-jsonschema",
        "rclpy": "rclpy", "ament_index_python": "ament_index_python", "launch": "launch", "launch_ros": "launch_ros",
        "dask": None, "distributed": None,
        "sgp4": None, "ppigrf": None, "foxglove": None, "websockets": "python3-websockets",
        "pyarrow": None}


def imported_modules() -> set:
    names = set()
    for path in (ROOT / "rw_fdi_ros").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - {"rw_fdi_ros", "__future__"}


def test_every_imported_package_is_a_declared_run_dependency():
    declared = {e.text for e in ET.parse(ROOT / "package.xml").getroot() if e.tag in ("exec_depend", "depend")}
    for name in sorted(imported_modules()):
        if name.endswith(("_msgs", "_srvs", "_interfaces")):
            assert name in declared, f"package.xml: add <exec_depend>{name}</exec_depend>"
        else:
            assert name in KEYS, f"{name}: imported but not mapped to a rosdep key in this test"
            assert KEYS[name] is None or KEYS[name] in declared, f"package.xml: add {KEYS[name]} for {name}"


def test_an_optional_dependency_missing_is_named_with_its_extra():
    """A command that needs an extra the install lacks says in one line how to get it (cli prints it)."""
    from rw_fdi_ros.extras import require
    assert require("json", "train").dumps([1]) == "[1]"
    with pytest.raises(RuntimeError, match=r"no_such_module_rw is not installed: pip install 'rw_fdi_ros\[train\]'"):
        require("no_such_module_rw", "train")


def test_setup_py_declares_what_the_code_imports_and_the_extras_the_rest():
    """Every third-party package imported outside the extras is in install_requires; torch, dask and distributed
    (imported only through extras.require) are in the extras."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "setup")
    kw = {k.arg: ast.literal_eval(k.value) for k in call.keywords if k.arg in ("install_requires", "extras_require")}
    installed = {r.split("=")[0].split("[")[0].lower() for r in kw["install_requires"]}
    extras = {r.split("=")[0].lower() for group in kw["extras_require"].values() for r in group}
    pip_name = {"yaml": "pyyaml", "mcap_ros2": "mcap-ros2-support", "foxglove": "foxglove-sdk"}
    for name in sorted(imported_modules()):
        if name.endswith(("_msgs", "_srvs", "_interfaces")) or name in ("rclpy", "ament_index_python", "launch",
                                                                          "launch_ros"):
            continue   # the ROS install's (requirements.txt: the ros-kilted-* wheels; launch: the launch files')
        assert pip_name.get(name, name) in installed | extras, f"setup.py: declare {name}"
    assert {"torch", "dask", "distributed"} <= extras
