"""The FDI configuration across the process boundary: one structured parameter set ``fdi.*`` under FdiConfig's
own field names (``fdi.method``, ``fdi.models``, ``fdi.thresholds``, ``fdi.persistence``,
``fdi.unit_calibration``, ``fdi.fdir``, ``fdi.vehicle``, ``fdi.decision``, ``fdi.plugins``), the way rosbag2_py's
StorageOptions crosses every boundary as itself. The launcher writes it (:func:`fdi_parameters`); every FDI node
reads it back into the same FdiConfig (:func:`declare_fdi`), which resolves its files and checks itself by one rule.
An unset field is FdiConfig's default."""
from __future__ import annotations

from dataclasses import fields
from pathlib import Path

from ..fdi_config import FdiConfig

PREFIX = "fdi"


def fdi_parameters(fdi: FdiConfig) -> dict:
    """The ``fdi.*`` parameter set of ``fdi``, nested as a params file holds it (unset fields left out).

    Parameters
    ----------
    fdi : FdiConfig
        The run's FDI.

    Returns
    -------
    dict
        ``{"fdi": {field: value}}``, plug-ins as a list of strings.
    """
    values = {k: list(v) if isinstance(v, tuple) else v for k, v in fdi.as_dict().items()
              if v is not None and v != ()}
    for k in ("models", "thresholds"):   # a node may run in another working directory
        if k in values:
            values[k] = str(Path(values[k]).resolve())
    return {PREFIX: values}


def declare_fdi(node) -> FdiConfig:
    """Declare the ``fdi.*`` parameters on ``node`` and return their FdiConfig.

    Parameters
    ----------
    node : GraphNode
        The FDI node.

    Returns
    -------
    FdiConfig
        The configuration (NodeError, one line naming the parameter, for one FdiConfig refuses).
    """
    from rclpy.parameter import Parameter
    from .runtime import EXIT_BAD_INPUT, NodeError   # the launcher side imports no rclpy
    defaults = FdiConfig()
    typed = {"models": Parameter.Type.STRING, "thresholds": Parameter.Type.STRING, "vehicle": Parameter.Type.STRING,
             "decision": Parameter.Type.STRING, "persistence": Parameter.Type.INTEGER,
             "plugins": Parameter.Type.STRING_ARRAY}
    values = {}
    for f in fields(FdiConfig):
        name = f"{PREFIX}.{f.name}"
        node.declare_parameter(name, typed.get(f.name, getattr(defaults, f.name)))
        value = node.param(name)
        if value is not None:
            values[f.name] = tuple(value) if f.name == "plugins" else value
    try:
        return FdiConfig(**{**values, "unit_calibration": float(values.get("unit_calibration", 0.0))})
    except (TypeError, ValueError) as exc:   # said as the command line says it: named here as the parameter
        text = str(exc).replace("fdi_method", "method", 1)
        if text.startswith("--"):
            name, _, rest = text[2:].partition(" ")
            text = f"{name.replace('-', '_')} {rest}"
        raise NodeError(f"parameter fdi.{text}", EXIT_BAD_INPUT) from None
