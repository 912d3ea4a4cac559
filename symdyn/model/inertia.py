"""Whether a rigid body's inertia is physical: positive semidefinite, its principal moments
obeying the triangle inequality I1 + I2 ≥ I3, to the same tolerances wherever symdyn checks one
(the readers, `Link`, the URDF writer and its repair, the identified parameters)."""

from __future__ import annotations

import numpy as np

__all__ = ["semidefinite", "obeys_triangle", "tolerance"]

#: The triangle test's absolute slack (kg m²), far below any robot's link (a milligram 30 µm
#: across): an exporter's numerical zeros pass (iCub's legs: moments of 5e-20 to 4e-18), a small
#: body's real defect does not (moments 1e-13, 1e-13, 2.5e-13).
TRIANGLE_FLOOR = 1e-15


def tolerance(moments) -> float:
    """The semidefinite test's slack: 1e-12 of the largest moment, and at least 1e-12 kg m²."""
    return 1e-12 * max(1.0, float(np.abs(np.asarray(moments, dtype=float)).max()))


def semidefinite(moments) -> bool:
    """Whether the principal moments are all ≥ 0, within `tolerance`."""
    return float(np.min(moments)) >= -tolerance(moments)


def obeys_triangle(moments) -> bool:
    """Whether the principal moments obey I1 + I2 ≥ I3 for the largest I3: within 1e-9 of I3
    (published data rounded to a few digits) and `TRIANGLE_FLOOR`, a negative moment (which
    `semidefinite` judges) counted as zero."""
    a, b, c = sorted(max(float(x), 0.0) for x in moments)
    return a + b >= c * (1 - 1e-9) - TRIANGLE_FLOOR * max(1.0, c)
