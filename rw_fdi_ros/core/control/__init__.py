"""The attitude control, one idea a module: what the controller and allocation nodes run.

* pid: the PID controller per axis (thesis 2.2.5, eq. 2.36);
* allocation: the body-axis commands over the wheels in use (minimum norm), a given-up wheel's hold;
* controller_design: the vehicle's gains, designed to its targets on its own step responses (cached).
"""

__all__ = ["allocation", "controller_design", "pid"]
