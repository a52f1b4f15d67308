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


def documented_methods(paths) -> dict:
    """Class name -> (its bases' names, the names of its methods with a docstring), of every class in ``paths``."""
    classes = {}
    for path in paths:
        for n in ast.walk(ast.parse(path.read_text())):
            if isinstance(n, ast.ClassDef):
                bases = [b.id if isinstance(b, ast.Name) else getattr(b, "attr", "") for b in n.bases]
                methods = [f for f in n.body if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))]
                classes[n.name] = (bases, {f.name for f in methods if ast.get_docstring(f)})
    return classes


def inherits_doc(classes: dict, cls: str, method: str) -> bool:
    """Whether a base class of ``cls`` (among ``classes``, by name) documents ``method``: its docstring is
    inherited, as Sphinx's autodoc_inherit_docstrings has it."""
    bases = list(classes.get(cls, ((), ()))[0])
    while bases:
        base = bases.pop()
        if base in classes:
            if method in classes[base][1]:
                return True
            bases += classes[base][0]
    return False


def undocumented(path: Path, classes: dict | None = None) -> list:
    """The public functions and methods of ``path`` (properties, and methods overriding one a base class of
    ``classes`` documents, exempt) whose docstring lacks a numpydoc Parameters section (when they take
    arguments besides self/cls) or Returns section (when annotated with a non-None return)."""
    out, classes = [], classes or {}

    def visit(body, prefix=""):
        for n in body:
            if isinstance(n, ast.ClassDef) and not n.name.startswith("_"):
                visit(n.body, f"{prefix}{n.name}.")
            elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and not n.name.startswith("_") and not any(
                    isinstance(d, ast.Name) and d.id in ("property", "cached_property") for d in n.decorator_list) \
                    and not (prefix and inherits_doc(classes, prefix.split(".")[-2], n.name)):
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
    files = [f for room in ("core", "graph", "nodes") for f in sorted((ROOT / "rw_fdi_ros" / room).rglob("*.py"))]
    classes = documented_methods(files)
    missing = [m for f in files for m in undocumented(f, classes)]
    assert not missing, "\n".join(missing)
