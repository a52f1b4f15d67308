"""The optional dependencies (setup.py's extras): imported where a command needs them, or named in one line."""
from __future__ import annotations

import importlib


def require(module: str, extra: str):
    """``module`` imported, or a RuntimeError that says which extra of the package installs it.

    Parameters
    ----------
    module : str
        The module's dotted name.
    extra : str
        The extra of setup.py that installs it (named in the error).

    Returns
    -------
    module
        The imported module.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise RuntimeError(f"{module} is not installed: pip install 'rw_fdi_ros[{extra}]' "
                           f"(or pip install -r requirements.txt)") from exc
