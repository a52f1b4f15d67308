"""The run as data, one idea a module: the spacecraft and the scenario a run flies.

* vehicle: the spacecraft as a vehicle file (YAML) read into one typed value;
* scenario: a seed, a duration, initial conditions, set-point changes and a fault schedule;
* plant_choices: the choices a run is made under, as one object;
* yaml_text: YAML as the package reads a user's file, one line for what is wrong.
"""

__all__ = ["plant_choices", "scenario", "vehicle", "yaml_text"]
