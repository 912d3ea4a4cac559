"""The one rule for exact constants read from files: angles and axes near exact values are snapped.

A file writes π/2 as 1.5707963267948966, 1.57079632679 or 1.570796327;
derivations compare exactly, and only an exact quarter turn gives the zeros
that keep the code lean (base-parameter regrouping needs them).  The rule:
an angle within `ANGLE_TOLERANCE` radians of k·π/d (d = 1, 2, 3, 4, 6, 8, 12)
becomes the double nearest k·π/d — exact 0 and ±1 for multiples of π/2 —
and a unit axis whose components are within the same tolerance of ±x, ±y or
±z becomes that axis exactly.  1e-9 rad admits every exporter that writes 9
or more decimals (rounding error ≤ 5e-10) and nothing written to 6 decimals
(1.570796 is 3.3e-7 from π/2: snapping it would move the model by more than
any agreement we check, and a file may mean exactly what it says).  The
reader reports each snap and its size; `snap=False` keeps the file's numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ANGLE_TOLERANCE", "DENOMINATORS", "Snapped", "snap_angle", "snap_axis"]

#: Largest change a snap makes, in radians (angles) or per component (unit axes).
ANGLE_TOLERANCE = 1e-9
#: The multiples of π recognised: k·π/d for these d, the smallest d first.
DENOMINATORS = (1, 2, 3, 4, 6, 8, 12)


@dataclass(frozen=True)
class Snapped:
    """A value replaced by its exact neighbour: what it became, its label and the change."""

    value: object  # the new float angle or axis tuple
    label: str  # "pi/2", "-3pi/4", "0", "axis -y"
    change: float  # largest absolute change


def _pi_label(k: int, d: int) -> str:
    if k == 0:
        return "0"
    sign, k = ("-" if k < 0 else ""), abs(k)
    return f"{sign}{'' if k == 1 else k}pi" + ("" if d == 1 else f"/{d}")


def snap_angle(angle: float) -> Snapped | None:
    """The exact neighbour k·π/d of `angle` within ANGLE_TOLERANCE, or None
    (also None when the angle already is that double: nothing changes)."""
    for d in DENOMINATORS:
        k = round(angle * d / math.pi)
        g = math.gcd(k, d)
        if g > 1:  # k·π/d in lowest terms was seen with a smaller denominator
            continue
        target = k * math.pi / d
        change = abs(angle - target)
        if change <= ANGLE_TOLERANCE:
            return None if change == 0 else Snapped(target, _pi_label(k, d), change)
    return None


def snap_axis(axis) -> Snapped | None:
    """±x, ±y or ±z exactly when the unit `axis` is within ANGLE_TOLERANCE of it
    (per component), else None (also None when it is exactly that axis)."""
    for k, name in enumerate("xyz"):
        for sign in (1, -1):
            target = tuple(sign if i == k else 0 for i in range(3))
            change = max(abs(float(a) - t) for a, t in zip(axis, target))
            if change <= ANGLE_TOLERANCE:
                return None if change == 0 else Snapped(target, f"axis {'+' if sign > 0 else '-'}{name}", change)
    return None
