"""package.xml declares every run dependency the code imports, under its rosdep key."""
import ast
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# import name -> rosdep key (rosdistro's rosdep/python.yaml); None: no key, pip via requirements.txt
KEYS = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml", "torch": "python3-torch",
        "rosbags": "python3-rosbags-pip", "mcap": "mcap-ros2-support", "mcap_ros2": "mcap-ros2-support",
        "matplotlib": "python3-matplotlib", "tqdm": "python3-tqdm", "jsonschema": "python3-jsonschema",
        "rclpy": "rclpy", "ament_index_python": "ament_index_python", "dask": None, "distributed": None,
        "sgp4": None, "ppigrf": None}


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
