"""The attitude control, one idea a module: what the controller and allocation nodes run.

* pid: the PID controller per axis (thesis 2.2.5, eq. 2.36);
* allocation: the body-axis commands over the wheels in use (minimum norm), a given-up wheel's hold.

The vehicle's gains are designed above the loop (core/controller_design.py): the design flies it.
"""

__all__ = ["allocation", "pid"]
