"""Khalil's regrouping rules, for any joint placement: what a link hands to its parent.

The part of link j's inertia that its own joint cannot move is carried by the
parent just as well.  About a revolute joint's axis z that part is the mass M,
the first moment along the axis MZ and the inertia YY·(1 − zzᵀ) (the kinetic
energy ½·YY(|ω|² − ω_z²) does not see q̇ⱼ); along a prismatic joint it is the
whole inertia tensor (the body does not turn).  Moved into the parent link's
frame (rotation R₀, origin p₀ of frame j there; on a chain link j − 1, on a
tree the link j hangs on) by the parallel-axis terms of the composite-link
recursion, they add to the parent's parameters exactly; from a link on the
base they go to the fixed base, which does not move them at all, or to a
floating base's body, which moves them (it is parent like any link, its ten
parameters in π's first slots; the rules empty none of its own: the rank
analysis decides which of them a planar base cannot move).  So XX −
YY, and YY, MZ, M vanish (revolute), or the six inertia entries (prismatic):
Khalil's rules with his choice of which parameter gives way, which is the
choice of an exact rank analysis in the column order XX1 … IA1, XX2 ….
"""

from __future__ import annotations

from fractions import Fraction

from .sampled import Frame

__all__ = ["transfer"]

_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M", "IA")
_IO = (("XX", "XY", "XZ"), ("XY", "YY", "YZ"), ("XZ", "YZ", "ZZ"))
_H = ("MX", "MY", "MZ")


def _add(target: dict, combo: dict, scale: Fraction) -> None:
    """target += scale·combo (linear combinations: parameter index → coefficient)."""
    if scale == 0:
        return
    for k, c in combo.items():
        value = target.get(k, 0) + scale * c
        if value:
            target[k] = value
        else:
            target.pop(k, None)


def _combine(*terms: tuple) -> dict:
    out: dict = {}
    for scale, combo in terms:
        _add(out, combo, scale)
    return out


def transfer(frames: list[Frame], per: int, body: int = 0) -> tuple[list[dict], set]:
    """Apply the rules from the tips to the base (a parent comes before its children, so every
    child has handed its part over when its parent's turn comes).

    `body` = 10: a floating base's body, its parameters XX … M in slots 0 … 9 and link j's
    from body + j·per; the links on the base hand their part to it.

    Returns (combos, gone): for every inertial parameter slot (body + j·per + idx, idx in
    XX … IA, and the body's), the linear combination of standard parameters it carries
    after the rules, and the slots the rules emptied (their columns are combinations of
    earlier ones).
    """
    n = len(frames)
    acc = [{name: {body + j * per + i: Fraction(1)} for i, name in enumerate(_NAMES)} for j in range(n)]
    base = {name: {i: Fraction(1)} for i, name in enumerate(_NAMES[:body])}
    gone: set = set()
    for j in range(n - 1, -1, -1):
        a, f = acc[j], frames[j]
        slot = {name: body + j * per + i for i, name in enumerate(_NAMES)}
        if f.revolute:
            YY, MZ, M = a["YY"], a["MZ"], a["M"]
            a["XX"] = _combine((1, a["XX"]), (-1, YY))
            a["YY"], a["MZ"], a["M"] = {}, {}, {}
            gone |= {slot["YY"], slot["MZ"], slot["M"]}
            if f.parent < 0 and not body:
                continue
            R0, p = f.R0, f.p0
            z = [R0[r][2] for r in range(3)]
            S = [(z[r], MZ) for r in range(3)]  # S′ = R0·(0, 0, MZ)
            parent = acc[f.parent] if f.parent >= 0 else base
            parent["M"] = _combine((1, parent["M"]), (1, M))
            for r in range(3):  # h′ += S′ + M·p
                parent[_H[r]] = _combine((1, parent[_H[r]]), S[r], (p[r], M))
            pp = sum(x * x for x in p)
            for r in range(3):
                for c in range(r, 3):
                    # R0·YY(1 − zzᵀ)·R0ᵀ = YY(1 − z′z′ᵀ) with z′ = R0·z; the shift of M and S′
                    eye = 1 if r == c else 0
                    terms = [(eye - z[r] * z[c], YY), (eye * pp - p[r] * p[c], M)]
                    terms += [(2 * eye * p[k] * z[k], MZ) for k in range(3)]
                    terms += [(-z[r] * p[c] - p[r] * z[c], MZ)]
                    parent[_IO[r][c]] = _combine((1, parent[_IO[r][c]]), *terms)
        else:
            Io = [[a[_IO[r][c]] for c in range(3)] for r in range(3)]
            for r in range(3):
                for c in range(r, 3):
                    a[_IO[r][c]] = {}
                    gone.add(slot[_IO[r][c]])
            if f.parent < 0 and not body:
                continue
            R0, parent = f.R0, acc[f.parent] if f.parent >= 0 else base
            for r in range(3):
                for c in range(r, 3):  # R0·Io·R0ᵀ
                    terms = [(R0[r][k] * R0[c][m], Io[k][m]) for k in range(3) for m in range(3)]
                    parent[_IO[r][c]] = _combine((1, parent[_IO[r][c]]), *terms)
    combos = {i: base[name] for i, name in enumerate(_NAMES[:body])}
    for j in range(n):
        for i, name in enumerate(_NAMES):
            combos[body + j * per + i] = acc[j][name]
    return combos, gone
