"""Fault identification: which fault a wheel has and how large (thesis 1.2.1, the step it leaves out).

Once a wheel is alarmed, each fault kind is a one-parameter family of the nominal Bialke wheel
(core/physics/wheel.py) driven by the measured command u and wheel speed Omega, every term the mean over one FDI
period of its control-rate values (telemetry.TelemetrySampler):

    current_limiter  a [-]:   r^ = -a tau_m(u, Omega; 8 V) + tau_f(Omega; 23 C)           (limiter)
    temperature      T [C]:   r^ = -tau_m(u, Omega; 8 V) + tau_v(T) Omega + tau_c tanh(.)  (eq. 2.15)
    bus_voltage      V [V]:   r^ = -tau_m(u, Omega; V)   + tau_f(Omega; 23 C)             (eqs. 2.9-2.14)

The aliased commutation ripple enters as two nuisance regressors (p: the ripple phasor):

    r_k = r^_k(theta) + alpha Im p_k + beta Re p_k + e_k,   RSS_h(theta) = || P_perp (r - r^(theta)) ||^2

over a grid of theta per family, alpha and beta eliminated by projection, and over a grid of ramps
(RAMP_SHARE, RAMP_LENGTH: theta moving linearly from the healthy value; the step is one of them).

* kind: the family with the lowest RSS, if it explains at least ``EXPLAINED`` of what the nominal wheel
  leaves unexplained and beats every other family by (RSS_other - RSS_h) / s^2 >= ``DECISIVE``; else
  ``unknown``;
* size: theta at the last sample of the best fit; interval {theta : RSS_h(theta) - RSS_min <=
  chi2_1(0.95) s^2 c}, s^2 = max(RSS_min / (n - 3), sigma_floor^2), c = ``CORRELATION`` for the serial
  correlation of 1 s samples; where it reaches the grid's end only a bound is observable.

On a calibrated unit (core/fdi/calibration.py) every family is the unit's (its shares b^ scale k_t, G_d, the
viscous and coulomb friction), and what the calibration does not know enters as four more regressors
dr^/db with its posterior N(0, Sigma) as prior: RSS_h(theta) = min || r - r^(theta; b^) - X_r (alpha,
beta) - X_u(theta) db ||^2 + c s^2 db' Sigma^-1 db.

Samples count from the fault's onset on (FaultIdentifier finds it in the samples kept before the alarm)
and are never forgotten. A wheel given up (its driver off) goes on through its spin-down, which shows only
a temperature; its ripple is then one regressor of the phase its healthy samples before the onset give,
and under MIN_DRIVEN driven samples a current loss and a bus drop are named together (``between``). A wheel
that reports its bus voltage or temperature holds those families to the report (decision.held_to_reports):
then the report, not the samples, tells a current loss from a bus drop.
The derivation, the choices and their measurements: docs/fdi.md, "Fault
identification".

The package, one idea a module:

* families: the three kinds (the scenario's names), their grids and predicted torques (SIGMA_FLOOR);
* ramps: the ramps a fault may grow by (RAMP_SHARE, RAMP_LENGTH, ramp_fractions);
* sums: ProfileSums, a wheel's running sums giving RSS of every grid point and ramp;
* result: the Identification type, its message and /diagnostics values, and their decoder (from_values);
* decision: decide (kind, size, interval; decide_steps: the same a piece at a time) and identify (whole
  arrays);
* onset: onset_index, where a fault's effect begins;
* identifier: FaultIdentifier, the wheels sample by sample;
* identifiability: whether the physics tells a current loss from a bus drop on a wheel's driven samples.
"""
from .decision import (CHI2_95, CORRELATION, DECISIVE, EXPLAINED, FREE_UNIT_SHARE, MIN_DRIVEN, decide,
                       decide_steps, decision_steps, held_to_reports, identify)
from .families import (BUS_VOLTAGE_GRID, CURRENT_LIMITER_GRID, DRIVE, GRIDS, KINDS, REPORTED_TOLERANCE, SIGMA_FLOOR,
                       TEMPERATURE_GRID, UNITS, UNKNOWN, bus_motor_torque, bus_voltage_grid, family_predictions,
                       unit_sensitivities)
from .identifier import IDENTIFICATION_WORK, FaultIdentifier
from .onset import ONSET_HEALTHY, onset_index
from .ramps import (RAMP_LENGTH, RAMP_NOTED_S, RAMP_SECONDS, RAMP_SHARE, RAMP_START_SHARES, SLOW_SECONDS,
                    SLOW_START_SHARES, ramp_fractions)
from .result import FORMER_NAMES, MIN_SAMPLES, NONE, SPOKEN, Identification, kind_name
from .sums import KAPPA_MAX, ProfileSums

__all__ = ["BUS_VOLTAGE_GRID", "CHI2_95", "CORRELATION", "CURRENT_LIMITER_GRID", "DECISIVE", "DRIVE", "EXPLAINED",
           "FORMER_NAMES", "FREE_UNIT_SHARE", "FaultIdentifier", "GRIDS", "IDENTIFICATION_WORK",
           "Identification", "KAPPA_MAX", "KINDS",
           "MIN_DRIVEN", "MIN_SAMPLES", "NONE", "ONSET_HEALTHY", "ProfileSums", "RAMP_LENGTH", "RAMP_NOTED_S",
           "REPORTED_TOLERANCE",
           "RAMP_SECONDS", "RAMP_SHARE", "RAMP_START_SHARES", "SIGMA_FLOOR", "SLOW_SECONDS", "SLOW_START_SHARES",
           "SPOKEN", "TEMPERATURE_GRID", "UNITS", "UNKNOWN", "bus_motor_torque", "bus_voltage_grid", "decide",
           "decide_steps", "decision_steps",
           "family_predictions", "held_to_reports", "identify", "kind_name", "onset_index", "ramp_fractions",
           "unit_sensitivities"]
