"""Torque allocation: the controllers' body-axis commands over the wheels in use (minimum norm).

The per-axis PID controllers (pid.py) command a torque command voltage v_a
for a wheel along their axis: a body torque demand tau = -G_d k_t v_a
(eq. 2.21; every wheel of the set has the same type, so volts and torque
differ by one factor for all). The wheel commands u (N,) that give it with
the wheels in use are the minimum-norm solution of G_u u = v,

    u = G_u^T (G_u G_u^T)^-1 v                        (G_u: G with out-of-use columns zeroed)

as Basilisk's ``rwMotorTorque`` computes it over the available wheels and
NASA 42's wheel distribution matrix does; a wheel out of use gets 0. For
three orthogonal wheels in use the distribution is the identity and u = v
exactly, so the thesis' loop is unchanged until a reconfiguration.

Voltage limit: where the largest |u_i| exceeds the +-5 V command range
the whole vector is scaled down to it. A per-wheel clip (Basilisk's
``rwMotorVoltage``) would turn the body torque away from the demand and
couple the axes; scaling keeps its direction and loses only magnitude.
"""
from __future__ import annotations

import numpy as np

from .wheel_set import WheelSet


def distribution(spin_axes, in_use) -> np.ndarray:
    """D (N, 3) with u = D v the minimum-norm wheel commands for axis commands v; zero rows for the
    wheels not ``in_use`` ((N,) bool). ValueError when the wheels in use do not span the body."""
    g = np.asarray(spin_axes, float) * np.asarray(in_use, bool)   # (3, N), columns out of use zeroed
    gram = g @ g.T
    if np.linalg.matrix_rank(gram) < 3:
        raise ValueError("the wheels in use do not span the three body axes")
    return g.T @ np.linalg.inv(gram)


def limited(wheel_commands, limit: float):
    """``wheel_commands`` (..., N) scaled down, per run, so that none exceeds ``limit`` [V] in magnitude."""
    u = np.asarray(wheel_commands, float)
    peak = np.abs(u).max(axis=-1, keepdims=True)
    return np.where(peak > limit, u * (limit / np.maximum(peak, 1e-300)), u)


class TorqueAllocator:
    """Wheel commands of a batch of runs, each with its own wheels in use (``in_use``: (B, N) bool)."""

    def __init__(self, wheels: WheelSet, batch: int = 1, limit: float = 5.0):
        self.wheels = wheels
        self.limit = float(limit)
        self.in_use = np.tile(wheels.mask(wheels.active), (batch, 1))
        self._matrix = {}
        self._dist = np.stack([self._distribution(row) for row in self.in_use])

    def _distribution(self, row) -> np.ndarray:
        key = tuple(bool(x) for x in row)
        if key not in self._matrix:
            self._matrix[key] = distribution(self.wheels.matrix, row)
        return self._matrix[key]

    def use(self, names, b: int = 0):
        """Run ``b`` uses the wheels ``names`` from the next command on (ValueError: they do not span)."""
        row = self.wheels.mask(names)
        self._dist[b] = self._distribution(row)
        self.in_use[b] = row

    def wheel_commands(self, axis_commands) -> np.ndarray:
        """u (B, N) [V] for the controllers' axis commands v (B, 3) [V], within the voltage limit."""
        v = np.asarray(axis_commands, float).reshape(len(self.in_use), 3)
        return limited(np.einsum("bnk,bk->bn", self._dist, v), self.limit)
