"""Which room imports which: the product path (`rw-fdi run`, the launch file) imports no tools module, and the
design tools import no bench. Each probe runs in a fresh interpreter, so what an earlier test imported does not
count."""
import subprocess
import sys

PRODUCT_PATH = ("rw_fdi_ros.cli.verbs.run", "rw_fdi_ros.cli.verbs.bag", "rw_fdi_ros.runner.graph",
                "rw_fdi_ros.runner.launcher", "rw_fdi_ros.runner.shm", "rw_fdi_ros.runner.scenario_run",
                "rw_fdi_ros.runner.summary", "rw_fdi_ros.runner.verdict", "rw_fdi_ros.runner.residual_figure",
                "rw_fdi_ros.runner.fdi_run")


def loaded_after(modules, prefix: str) -> list:
    code = (f"import sys, importlib\nfor m in {list(modules)!r}: importlib.import_module(m)\n"
            f"print(sorted(m for m in sys.modules if m.startswith({prefix!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return eval(out.stdout)


def test_the_product_path_imports_no_tools_module():
    assert loaded_after(PRODUCT_PATH, "rw_fdi_ros.tools") == []


def test_the_design_tools_import_no_bench():
    design = ("rw_fdi_ros.tools.design.service_training", "rw_fdi_ros.tools.design.vehicle_defaults",
              "rw_fdi_ros.tools.design.defaults", "rw_fdi_ros.tools.design.offline", "rw_fdi_ros.tools.design.samples")
    assert loaded_after(design, "rw_fdi_ros.tools.benches") == []
