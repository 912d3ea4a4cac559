"""The Puma 560 with the consensus parameters of Corke & Armstrong-Hélouvy.

Source: P. Corke and B. Armstrong-Hélouvy, "A search for consensus among
model parameters reported for the PUMA 560 robot", ICRA 1994, as in the
Robotics Toolbox for MATLAB `mdl_puma560` ("params of 8/95"): standard DH,
d1 = 0, base = tool = identity, gravity (0, 0, 9.81).  Motor parameters are
motor-referenced; gear ratios of joints 1 and 3 are negative.  Poses: qz
(zero), qr (ready), qs (stretch), qn (nominal, MATLAB's q3 = π).
`build(modified=True)` gives the same arm in modified (Craig) DH.
"""

from __future__ import annotations

from ..robot import Link, Robot
from ._data import read

#: Links whose published inertia violates the triangle inequality, kept as published:
#: link 1 is a lumped inertia about its axis (0, 0.35, 0) and link 3 has Ixx + Izz < Iyy.
UNPHYSICAL = (1, 3)


def build(symbolic: bool = False, modified: bool = False) -> Robot:
    """The Puma 560 (numeric parameters; symbolic inertial parameters come from
    `symdyn.derivation.regressor`, not from this model)."""
    if symbolic:
        raise ValueError(
            "the Puma 560 ships with numeric parameters only; for symbolic "
            "inertial parameters use symdyn.derivation.regressor on this model"
        )
    data = read("puma560_params")
    links = tuple(
        Link(
            d=p["d"],
            a=p["a"],
            alpha=p["alpha"],
            offset=p["offset"],
            qlim=p["qlim"],
            m=p["m"],
            r=p["r"],
            I=p["I"],
            Jm=p["Jm"],
            B=p["B"],
            Tc=(p["Tc_plus"], p["Tc_minus"]),
            G=p["G"],
            physical=j not in UNPHYSICAL,
        )
        for j, p in enumerate(data["links"], start=1)
    )
    cfg = data["configurations"]
    poses = {"qz": cfg["qz"], "qr": cfg["qr"], "qs": cfg["qs"], "qn": cfg["qn_matlab"]}
    robot = Robot("puma560", links, gravity=tuple(data["gravity_matlab"]), poses=poses, source=data["source"])
    return robot.to_modified() if modified else robot
