"""The physics of the spacecraft, one idea a module: what the plant node and the core loop integrate.

* wheel: the Bialke reaction wheel (thesis 2.2.2, Fig. 2.2), its datasheet and a unit's variation;
* wheel_set: N wheels of one type, each with a spin axis in the body frame;
* spacecraft: the rigid body (eq. 2.27) and its external disturbance (2.2.4);
* faults: the fault vocabulary (kinds, nominal values, operating points) the plant injects;
* plant: the rigid body driven by a wheel set, with faults, stepped for a batch of runs;
* environment, orbit, geomagnetic: the orbit, the field the magnetometer reads and the torques it brings;
* magnetorquers: three rods along the body axes and the momentum-dumping law that commands them.
"""

__all__ = ["environment", "faults", "geomagnetic", "magnetorquers", "orbit", "plant", "spacecraft", "wheel",
           "wheel_set"]
