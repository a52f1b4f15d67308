"""Which room imports which: the product path (`rw-fdi run`, the launch file) imports no tools module, and the
design tools import no bench. Each probe runs in a fresh interpreter, so what an earlier test imported does not
count."""
import subprocess
import sys

PRODUCT_PATH = ("rw_fdi_ros.cli", "rw_fdi_ros.cli.verbs.run", "rw_fdi_ros.cli.verbs.bag", "rw_fdi_ros.runner.graph",
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


def import_graph() -> dict:
    """module -> the package's modules it imports (at the top or inside a function), from the source."""
    import ast
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    files = {".".join(p.relative_to(root).with_suffix("").parts).removesuffix(".__init__"): p
             for p in (root / "rw_fdi_ros").rglob("*.py")}
    graph = {}
    for module, path in files.items():
        here = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
        graph[module] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = ".".join(here.split(".")[:len(here.split(".")) - node.level + 1]) if node.level else ""
                source = ".".join(filter(None, (base, node.module)))
                names = [f"{source}.{a.name}" for a in node.names] + [source]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            hit = next((n for n in names if n in files and n != module), None)
            graph[module] |= {n for n in names if n in files and n != module and not (n == source and hit != n)} \
                if isinstance(node, ast.ImportFrom) else {n for n in names if n in files}
    return graph


def test_no_module_imports_one_that_imports_it_back():
    """No circle anywhere in the package's import graph, imports inside functions included (a lazy import is an
    arrow all the same)."""
    graph = import_graph()
    done, stack = set(), []

    def visit(module):
        stack.append(module)
        for other in graph[module]:
            assert other not in stack, " -> ".join(stack[stack.index(other):] + [other])
            if other not in done:
                visit(other)
        stack.pop()
        done.add(module)
    for module in graph:
        if module not in done:
            visit(module)
    assert len(graph) > 100 and sum(map(len, graph.values())) > 300   # the graph was read


def test_a_script_importing_the_flat_core_of_before_still_runs():
    """A user's in-service screen imported rw_fdi_ros.core.scenario, gone in the move to packages: every old name is
    the new module itself, and the new module keeps its own name."""
    code = ("import sys, rw_fdi_ros.core.scenario as old, rw_fdi_ros.core.mission.scenario as new\n"
            "from rw_fdi_ros.core import MOVED\n"
            "import importlib\n"
            "for name, where in MOVED.items():\n"
            "    assert importlib.import_module('rw_fdi_ros.core.' + name) is importlib.import_module("
            "'rw_fdi_ros.core.' + where), name\n"
            "assert old is new and new.__spec__.name == 'rw_fdi_ros.core.mission.scenario'\n"
            "from rw_fdi_ros.core.closed_loop import Fdir, simulate\n"
            "print(old.load_scenario('fault_free').name)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "fault_free", out.stderr[-2000:]
