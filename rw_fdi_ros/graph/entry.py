"""Console-script entry points of the nodes (what `ros2 run rw_fdi_ros <exe>` starts).

A launch that ends early (`ros2 launch` shutting down on a failed node) sends SIGINT to nodes that
may still be importing numpy, scipy or torch. Python would print a KeyboardInterrupt traceback from
inside those imports; here the node ends quietly with 128 + the signal instead. Once imported, the
node's own handling (rclpy's, runtime.spin_node: close the bag, exit 0) takes over.
"""
from __future__ import annotations

import importlib
import signal


def _quiet_exit(signum, frame):
    raise SystemExit(128 + signum)


def _run(executable: str):
    previous = {s: signal.signal(s, _quiet_exit) for s in (signal.SIGINT, signal.SIGTERM)}
    module = importlib.import_module(f"rw_fdi_ros.nodes.{executable}")
    for s, handler in previous.items():
        signal.signal(s, handler)
    module.main()


def _entry(executable: str):
    def main():
        _run(executable)
    main.__name__ = executable
    return main


NODES = ("plant", "pid_controller", "recorder", "elman_observer", "linear_observer", "model_observer", "isolation",
         "wheel_allocation", "player", "composed", "momentum_dumping", "live_view", "plugin_observer",
         "wheel_telemetry")
globals().update({name: _entry(name) for name in NODES})
