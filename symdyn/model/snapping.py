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
reader reports each snap and its size, and what the snaps do to the dynamics
(`SnapEffect`: the largest relative change of τ, M and q̈ over random states,
measured by the numeric reference on the robot as read and on the robot as
written); `snap=False` keeps the file's numbers.

The reference is a later stage than the model (model ← … ← numeric), so this
module only declares the measurement: `Snapping` keeps the two robots and
measures them, when first asked, through `set_effect_measure`'s function,
which the `symdyn` package installs (`symdyn.numeric.snap_effect`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, Callable

__all__ = [
    "ANGLE_TOLERANCE",
    "DENOMINATORS",
    "Snapped",
    "snap_angle",
    "snap_axis",
    "SnapEffect",
    "Snapping",
    "set_effect_measure",
]

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


# --------------------------------------------------------------------------- what the snaps do


#: Relative changes below this are written "< 1e-13": the reference's own rounding, not the snaps.
ROUNDING = 1e-13


def _size(x: float) -> str:
    return "0" if x == 0 else f"< {ROUNDING:.0e}" if x < ROUNDING else f"{x:.1e}"


@dataclass(frozen=True)
class SnapEffect:
    """How far the snaps move the dynamics: over `states` random states (a fixed seed, so a
    generated header is the same on every run), the largest relative change of τ (‖Δτ‖∞/‖τ‖∞
    at each state), of M (max |ΔM_ij| / max |M_ij|) and of forward dynamics q̈ under the same
    torques (‖Δq̈‖∞/‖q̈‖∞), the file's numbers the yardstick.  qdd is None where M is singular."""

    tau: float
    M: float
    qdd: float | None
    states: int

    def line(self) -> str:
        """One line a person reads (ASCII: generated headers print it)."""
        keep = "--no-snap or snap=False keeps the file's numbers"
        if self.tau == self.M == self.qdd == 0:
            return f"snaps leave tau, M and qdd unchanged, bit for bit ({self.states} random states; {keep})"
        qdd = "qdd not defined (M is singular)" if self.qdd is None else f"qdd by {_size(self.qdd)}"
        return (
            f"snaps change tau by at most {_size(self.tau)}, M by {_size(self.M)}, {qdd} "
            f"(relative, {self.states} random states; {keep})"
        )


_measure: Callable[[Any, Any], SnapEffect] | None = None


def set_effect_measure(measure: Callable[[Any, Any], SnapEffect]) -> None:
    """Install `measure(snapped, literal) -> SnapEffect`, the function `Snapping.effect` calls.
    The `symdyn` package installs `symdyn.numeric.snap_effect.snap_effect` (lazily imported):
    the model states the effect, a later stage measures it, and no import climbs."""
    global _measure
    _measure = measure


@dataclass(frozen=True)
class Snapping:
    """The two readings of one file: `snapped` (the robot as read, snaps applied) and `literal`
    (`snap=False`, the file's numbers), both without their record; `effect` measures how far
    the snaps move the dynamics, once, when first asked (`print(robot)`, a generated header)."""

    snapped: Any
    literal: Any

    @functools.cached_property
    def effect(self) -> SnapEffect:
        """The `SnapEffect` of the snaps (measured on first use, then kept).

        Raises:
            RuntimeError: no measure is installed (the `symdyn` package installs it on import).
        """
        if _measure is None:
            raise RuntimeError("no snap-effect measure is installed: import symdyn (it installs the reference's)")
        return _measure(self.snapped, self.literal)
