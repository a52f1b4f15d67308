"""The spacecraft without ROS: plain numpy over the thesis' equations, used by the nodes and the offline tools.

Layered bottom up, each a package with a public face: physics (wheel, body, plant, orbit), control (PID,
allocation, the controllers' design), fdi (observers, residuals, bands, the FDI pipeline, identification),
fdir (what the spacecraft does with a wheel the FDI confirms), mission (the vehicle and the scenario as data);
flight flies a batch through all of them given the gains, closed_loop under the vehicle's design.
"""

__all__ = ["closed_loop", "control", "fdi", "fdir", "flight", "mission", "physics"]
