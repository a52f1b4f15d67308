"""The tree passes the package's linter (ruff.toml: flake8's pycodestyle and pyflakes rules), and the public
functions of core/, graph/ and nodes/ have numpydoc Parameters/Returns sections."""
import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing_in_the_tree():
    ruff = Path(sys.executable).parent / "ruff"
    result = subprocess.run([str(ruff), "check", "--no-cache", "rw_fdi_ros", "test", "launch", "setup.py"],
                            cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout[-3000:]
    assert "All checks passed" in result.stdout


def undocumented(path: Path) -> list:
    """The public functions and methods of ``path`` (properties exempt) whose docstring lacks a numpydoc
    Parameters section (when they take arguments besides self/cls) or Returns section (when annotated with
    a non-None return)."""
    out = []

    def visit(body, prefix=""):
        for n in body:
            if isinstance(n, ast.ClassDef) and not n.name.startswith("_"):
                visit(n.body, f"{prefix}{n.name}.")
            elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and not n.name.startswith("_") and not any(
                    isinstance(d, ast.Name) and d.id in ("property", "cached_property") for d in n.decorator_list):
                doc = ast.get_docstring(n) or ""
                args = [a for a in n.args.args + n.args.kwonlyargs if a.arg not in ("self", "cls")]
                returns = n.returns is not None and not (isinstance(n.returns, ast.Constant)
                                                         and n.returns.value is None)
                lacks = ("Parameters" if args and "Parameters\n" not in doc else "") + (
                    " Returns" if returns and "Returns\n" not in doc and "Yields\n" not in doc else "")
                if lacks:
                    out.append(f"{path.relative_to(ROOT)}:{n.lineno} {prefix}{n.name} lacks {lacks.strip()}")
    visit(ast.parse(path.read_text()).body)
    return out


def test_public_functions_have_numpydoc_parameters_and_returns():
    missing = [m for room in ("core", "graph", "nodes") for f in sorted((ROOT / "rw_fdi_ros" / room).rglob("*.py"))
               for m in undocumented(f)]
    assert not missing, "\n".join(missing)
