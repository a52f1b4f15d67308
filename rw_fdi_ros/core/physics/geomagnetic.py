"""The geomagnetic field along the orbit, in the inertial frame [T].

[choice] ``magnetic_field`` (a plant choice, recorded in every bag):

- ``igrf`` (default): the International Geomagnetic Reference Field, 14th generation, to degree 13,
  evaluated by ``ppigrf`` (IAGA's coefficients, 1900-2030, interpolated to the epoch's date);
- ``tilted_dipole``: the same model's degree-1 terms only, the centred dipole tilted ~10 deg from the
  pole that textbook momentum-dumping analyses use; cheaper and smoother, up to ~20 % off in magnitude.

ppigrf gives the field in geocentric spherical components (B_r, B_theta south, B_phi east, nT); they are
turned into the Earth-fixed frame at the position's colatitude theta and longitude phi,

    B = B_r e_r + B_theta e_theta + B_phi e_phi,
    e_r = (sin th cos ph, sin th sin ph, cos th), e_theta = (cos th cos ph, cos th sin ph, -sin th),
    e_phi = (-sin ph, cos ph, 0),

and into the inertial frame by the sidereal angle (orbit.sidereal_angle).
"""
from __future__ import annotations

from datetime import datetime

import numpy as np

FIELD_MODELS = ("igrf", "tilted_dipole")
IGRF_YEARS = (1900, 2030)   # what IGRF-14 covers (its secular variation is extrapolated past 2025)


def _rotate_z(vectors, angle):
    """Components in a frame turned by ``angle`` about z: (x cos a + y sin a, -x sin a + y cos a, z)."""
    c, s = np.cos(angle), np.sin(angle)
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    return np.stack((c * x + s * y, -s * x + c * y, z), axis=-1)


def field_inertial(position, sidereal, epoch: datetime, model: str = "igrf") -> np.ndarray:
    """The field [T] at inertial positions ``position`` (n, 3) [m] whose sidereal angles are ``sidereal``
    (n,) [rad], for ``model`` (FIELD_MODELS) at ``epoch``'s date; shape (n, 3).

    Parameters
    ----------
    position : array_like, shape (n, 3)
        Inertial (ECI) positions [m].
    sidereal : array_like, shape (n,)
        Greenwich mean sidereal angle at each position's time [rad] (orbit.sidereal_angle).
    epoch : datetime
        Date whose IGRF coefficients are used.
    model : str, optional
        ``igrf`` or ``tilted_dipole``; ValueError otherwise.

    Returns
    -------
    ndarray, shape (n, 3)
        The field b [T], inertial frame.
    """
    if model not in FIELD_MODELS:
        raise ValueError(f"magnetic_field must be one of {', '.join(FIELD_MODELS)}, got {model!r}")
    import ppigrf
    fixed = _rotate_z(np.asarray(position, float), sidereal)
    r = np.linalg.norm(fixed, axis=-1)
    # ppigrf divides B_phi by sin(theta): a point exactly over a pole is taken 1e-9 rad (6 mm) off it
    theta = np.clip(np.arccos(np.clip(fixed[:, 2] / r, -1.0, 1.0)), 1e-9, np.pi - 1e-9)
    phi = np.arctan2(fixed[:, 1], fixed[:, 0])
    b_r, b_theta, b_phi = (c[0] for c in ppigrf.igrf_gc(r / 1e3, np.rad2deg(theta), np.rad2deg(phi),
                                                        epoch.replace(tzinfo=None),
                                                        max_degree=13 if model == "igrf" else 1))
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    b_fixed = np.stack((b_r * st * cp + b_theta * ct * cp - b_phi * sp,
                        b_r * st * sp + b_theta * ct * sp + b_phi * cp,
                        b_r * ct - b_theta * st), axis=-1) * 1e-9
    return _rotate_z(b_fixed, -np.asarray(sidereal, float))
