"""Whether a rigid body's inertia is physical: positive semidefinite, its principal moments
obeying the triangle inequality I1 + I2 ≥ I3, to one tolerance wherever symdyn checks one."""

from __future__ import annotations

import numpy as np

__all__ = ["semidefinite", "obeys_triangle", "tolerance"]


def tolerance(moments) -> float:
    """The absolute slack of both tests: 1e-12 of the largest moment, and at least 1e-12 (kg m²):
    an exporter's numerical zeros (iCub's 1e-20) are zeros."""
    return 1e-12 * max(1.0, float(np.abs(np.asarray(moments, dtype=float)).max()))


def semidefinite(moments) -> bool:
    """Whether the principal moments are all ≥ 0, within `tolerance`."""
    return float(np.min(moments)) >= -tolerance(moments)


def obeys_triangle(moments) -> bool:
    """Whether the principal moments (ascending, as eigvalsh gives them) obey I1 + I2 ≥ I3, within
    1e-9 of I3 (published data rounded to a few digits) and `tolerance`."""
    a, b, c = (float(x) for x in moments)
    return a + b >= c * (1 - 1e-9) - tolerance(moments)
