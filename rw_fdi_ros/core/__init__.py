"""The spacecraft without ROS: plain numpy over the thesis' equations, used by the nodes and the offline tools.

Layered bottom up, each package with a public face: physics (wheel, body, plant, orbit, faults); mission (the
vehicle and the scenario as data); control (PID, allocation); fdi (observers, residuals, bands, the FDI
pipeline, identification); fdir (what the spacecraft does with a wheel the FDI confirms); flight (a batch flown
through all of them, given the gains); controller_design (the vehicle's gains, designed on its own step
responses, which it flies); closed_loop (a flight under that design).
"""

__all__ = ["closed_loop", "control", "controller_design", "fdi", "fdir", "flight", "mission", "physics"]
