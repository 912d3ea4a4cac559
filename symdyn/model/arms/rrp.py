"""A small spherical RRP arm (the first three joints of a Stanford-type arm).

Illustrative parameters, not a real robot: it exists so that prismatic
joints, joint offsets, products of inertia, off-axis centres of mass and
motor parameters are all exercised.  Standard DH.
"""

from __future__ import annotations

import math

from ..robot import Link, Robot


def build(symbolic: bool = False) -> Robot:
    """The RRP arm: revolute waist, revolute shoulder, prismatic boom."""
    if symbolic:
        raise ValueError("the RRP arm ships with numeric parameters only")
    links = (
        Link(
            d=0.4,
            a=0.0,
            alpha=-math.pi / 2,
            qlim=(-math.pi, math.pi),
            m=6.0,
            r=(0.0, 0.05, -0.1),
            I=((0.12, 0.0, 0.0), (0.0, 0.10, 0.01), (0.0, 0.01, 0.05)),
            Jm=2e-4,
            B=1.5e-3,
            Tc=(0.4, -0.4),
            G=-50.0,
        ),
        Link(
            d=0.15,
            a=0.05,
            alpha=math.pi / 2,
            offset=math.pi / 6,
            qlim=(-2.0, 2.0),
            m=4.0,
            r=(-0.02, -0.1, 0.03),
            I=((0.05, 0.002, 0.0), (0.002, 0.04, 0.0), (0.0, 0.0, 0.03)),
            Jm=2e-4,
            B=1.0e-3,
            Tc=(0.2, -0.25),
            G=80.0,
        ),
        Link(
            joint="prismatic",
            theta=-math.pi / 2,
            a=0.02,
            qlim=(0.2, 0.9),
            m=2.5,
            r=(0.0, 0.01, -0.25),
            I=((0.08, 0.0, 0.001), (0.0, 0.08, 0.0), (0.001, 0.0, 0.004)),
            Jm=1e-4,
            B=5e-4,
            Tc=(0.05, -0.05),
            G=200.0,
        ),
    )
    return Robot(
        "rrp",
        links,
        gravity=(0, 0, 9.81),
        poses={"qz": (0.0, 0.0, 0.5), "qn": (0.3, 0.8, 0.6)},
        source="illustrative (symdyn)",
    )
