"""composed: several nodes of the graph in one process, ROS 2 composition as rclpy has it.

    composed plant=plant pid_controller_x=pid_controller ... --ros-args --params-file graph.yaml

Each NAME=EXECUTABLE makes node NAME of the node executable EXECUTABLE (what
`ros2 run rw_fdi_ros EXECUTABLE` starts): its own node object, name,
parameters (the params file's NAME entry) and topics, all spun by one
executor in one thread (runtime.spin_nodes). The process ends when every
node has ended with the run, or at once, with that node's exit code, when
one fails. No node name remapping is given on the command line: it would
rename every node of the process. runner/graph.py chooses the grouping
(GROUPINGS); our launcher and the launch file start the same processes.
"""
from __future__ import annotations

import importlib
import sys

from ..graph.runtime import EXIT_BAD_INPUT, exit_watched, spin_nodes

USAGE = "usage: composed NAME=EXECUTABLE [NAME=EXECUTABLE ...] [--ros-args ...]"


def node_factory(spec: str):
    """The factory of one NAME=EXECUTABLE: makes the executable's node under NAME. ValueError (one line)
    for a malformed spec or an executable that is not one of the package's nodes.

    Parameters
    ----------
    spec : str
        NAME=EXECUTABLE.

    Returns
    -------
    callable
        Makes the node; its ``node_name`` is NAME.
    """
    from ..graph.entry import NODES
    name, sep, executable = spec.partition("=")
    if not sep or not name or not executable:
        raise ValueError(f"{spec!r} is not NAME=EXECUTABLE")
    if executable not in NODES or executable == "composed":
        raise ValueError(f"{executable!r} is not a node executable ({', '.join(n for n in NODES if n != 'composed')})")
    cls = importlib.import_module(f"rw_fdi_ros.nodes.{executable}").main.factory

    def make():
        return cls(name=name)
    make.node_name = name
    return make


def main(args=None):
    """Entry point: spin the nodes given as NAME=EXECUTABLE arguments in one process, exit with their code.

    Parameters
    ----------
    args : list of str, optional
        The command line (default sys.argv).
    """
    from rclpy.utilities import remove_ros_args
    argv = list(sys.argv if args is None else args)
    specs = remove_ros_args(argv)[1:]
    try:
        if not specs:
            raise ValueError("no node given")
        factories = [node_factory(spec) for spec in specs]
        names = [f.node_name for f in factories]
        if len(set(names)) != len(names):
            raise ValueError(f"a node name given twice ({', '.join(names)})")
    except ValueError as exc:
        print(f"composed: error: {exc}\n{USAGE}", file=sys.stderr, flush=True)
        sys.exit(EXIT_BAD_INPUT)
    exit_watched(spin_nodes(factories, args=argv))


if __name__ == "__main__":
    main()
