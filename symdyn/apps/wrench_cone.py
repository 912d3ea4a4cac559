"""The contact wrench cone of a rectangular sole: what a surface contact can push with.

A sole of half-length X (along its frame's x) and half-width Y (along y), flat on the ground,
with Coulomb friction μ linearised as a pyramid at each corner, transmits exactly the wrenches
(f, τ) — in the sole's frame, about its centre — that satisfy (Caron, Pham and Nakamura,
"Stability of surface contacts for humanoid robots: closed-form formulae of the contact wrench
cone for rectangular support areas", ICRA 2015):

    f_z ≥ 0,  |f_x| ≤ μ f_z,  |f_y| ≤ μ f_z                  (friction on the resultant)
    |τ_x| ≤ Y f_z,  |τ_y| ≤ X f_z                             (the centre of pressure in the sole)
    τ_min ≤ τ_z ≤ τ_max                                       (the yaw torque)
    τ_min = −μ(X + Y) f_z + |Y f_x − μ τ_x| + |X f_y − μ τ_y|
    τ_max =  μ(X + Y) f_z − |Y f_x + μ τ_x| − |X f_y + μ τ_y|

`rows` writes them as g ≤ 0, each absolute value as its two signs (linear rows an optimiser
takes smoothly); `tests/test_wrench_cone.py` checks them against the cone the sixteen corner
rays span.
"""

from __future__ import annotations

import itertools

__all__ = ["rows"]


def rows(force, moment, half_length: float, half_width: float, mu: float) -> list:
    """The cone's rows g ≤ 0 (26 of them) for the wrench `force` (f_x, f_y, f_z) and `moment`
    (τ_x, τ_y, τ_z) in the sole's frame about its centre: numbers, arrays or CasADi expressions.

    Raises:
        ValueError: a half-length, half-width or μ that is not positive and finite.
    """
    for name, value in (("half_length", half_length), ("half_width", half_width), ("mu", mu)):
        if not 0 < float(value) < float("inf"):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    X, Y = float(half_length), float(half_width)
    fx, fy, fz = (force[k] for k in range(3))
    tx, ty, tz = (moment[k] for k in range(3))
    out = [-fz, fx - mu * fz, -fx - mu * fz, fy - mu * fz, -fy - mu * fz]
    out += [tx - Y * fz, -tx - Y * fz, ty - X * fz, -ty - X * fz]
    for s1, s2 in itertools.product((1, -1), repeat=2):
        # τ_z ≥ τ_min: −μ(X+Y) f_z + s1 (Y f_x − μ τ_x) + s2 (X f_y − μ τ_y) − τ_z ≤ 0 for every sign
        out.append(-mu * (X + Y) * fz + s1 * (Y * fx - mu * tx) + s2 * (X * fy - mu * ty) - tz)
        # τ_z ≤ τ_max: τ_z − μ(X+Y) f_z + s1 (Y f_x + μ τ_x) + s2 (X f_y + μ τ_y) ≤ 0 for every sign
        out.append(tz - mu * (X + Y) * fz + s1 * (Y * fx + mu * tx) + s2 * (X * fy + mu * ty))
    return out
