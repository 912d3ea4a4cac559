"""The planar two-link arm of Corke, *Robotics, Vision and Control*, Eq. 9.3.

Source: Robotics Toolbox for MATLAB, `mdl_twolink` (numeric: a1 = a2 = 1 m,
m1 = m2 = 1 kg, COM 0.5 m from each joint, no link inertia, motor or
friction) and `mdl_twolink_sym` (symbolic a1, a2, c1, c2, m1, m2, g, where
c_i is the COM offset along x_i, so the COM is a_i + c_i from joint i).
The arm is mounted with base Rx(π/2): it moves in the world x–z plane and
gravity acts along −y of frame {0}.
"""

from __future__ import annotations

import sympy as sp

from ..robot import Link, Robot, rotx
from ._data import read


def build(symbolic: bool = False) -> Robot:
    """The numeric arm, or with `symbolic=True` the arm in a1, a2, c1, c2, m1, m2, g."""
    data = read("twolink_params")
    if symbolic:
        a1, a2, c1, c2, m1, m2, g = sp.symbols("a1 a2 c1 c2 m1 m2 g", real=True)
        links = (Link(a=a1, m=m1, r=(c1, 0, 0)), Link(a=a2, m=m2, r=(c2, 0, 0)))
        return Robot(
            "twolink_sym",
            links,
            gravity=(0, 0, g),
            base=rotx(sp.pi / 2),
            poses=data["configurations"],
            source=data["source"],
        )
    links = tuple(
        Link(
            d=p["d"],
            a=p["a"],
            alpha=p["alpha"],
            offset=p["offset"],
            m=p["m"],
            r=p["r"],
            I=p["I"],
            Jm=p["Jm"],
            B=p["B"],
            Tc=(p["Tc_plus"], p["Tc_minus"]),
            G=p["G"],
        )
        for p in data["links"]
    )
    return Robot(
        "twolink",
        links,
        gravity=(0, 0, data["g"]),
        base=rotx(sp.pi / 2),
        poses=data["configurations"],
        source=data["source"],
    )
