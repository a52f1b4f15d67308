"""Fault detection and isolation, one idea a module: what the observer and isolation nodes run.

* telemetry, sampling: control-rate wheel telemetry to FDI samples (the model torque, friction, ripple phasor);
* elman, linear_observer, observer_plugin: the observers (the thesis' Elman network and Luenberger observer,
  and a user's plug-in);
* residuals, calibration: the residual with its ripple bound, learnt on the wheel's own unit;
* detection, threshold_file, threshold_fit: the methods, the alarm rule and the bands;
* verdict: one observer's channel, the decision (an observer or a vote) and the latched verdict;
* pipeline: the FDI wired once, residuals -> channels -> decision -> verdict -> identification;
* identification: which fault an alarmed wheel has and how large;
* input_health: whether an input stream lets a node judge.
"""

__all__ = ["calibration", "detection", "elman", "input_health", "linear_observer", "observer_plugin",
           "pipeline", "residuals", "sampling", "telemetry", "threshold_file", "threshold_fit", "verdict",
           "identification"]
