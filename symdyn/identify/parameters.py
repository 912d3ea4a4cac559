"""Standard and base parameters as numbers: the bridge between a `Robot` and identification.

Identification works on the vectors of `symdyn.derivation.regressor`: the
standard parameters π (14 per link, XX…M about the link-frame origin in the
recursion's link frames, IA, FV, FS, FO) and the base parameters β = P·π that
the exact regrouping makes identifiable.  This module turns a robot into π
(`standard_vector`), π back into a robot in the robot's own link frames
(`with_standard`), and the exact base parameters into a float map P
(`base_map`, cached like a derivation).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .. import __version__
from ..model import Link, Robot, exact_cos_sin, inertia

__all__ = ["BaseMap", "base_map", "robot_names", "standard_names", "standard_vector", "with_standard", "PER_LINK"]

#: Standard parameters per link: XX XY XZ YY YZ ZZ MX MY MZ M IA FV FS FO.
PER_LINK = 14
#: A floating base's body's: the first ten (no rotor, no friction), before the links'.
BODY = 10


def standard_names(n: int, floating: bool = False) -> tuple[str, ...]:
    """XX1, XY1, …, FO1, XX2, …: the regressor's parameter names (14 per link); `floating`: the
    base body's XX0 … M0 first."""
    from ..derivation.regressor import parameter_symbols

    return tuple(str(s) for s in parameter_symbols(n, floating))


def robot_names(robot: Robot) -> tuple[str, ...]:
    """`standard_names` of this robot (its base body's first on a floating base)."""
    return standard_names(robot.n, robot.base_joint is not None)


def standard_vector(robot: Robot) -> np.ndarray:
    """The robot's standard parameters π (14n,; a floating base's body's ten first) as floats, in the
    order of the regressor's columns."""
    from ..derivation.regressor import parameter_values

    robot.require_numeric("identification")
    return np.array([float(v) for v in parameter_values(robot)])


@dataclass(frozen=True)
class BaseMap:
    """The base parameters of a robot's geometry: β = P·π, and Y·π = Y[:, columns]·β.

    names: the base parameters' names (each the standard parameter of its
    independent column, e.g. "ZZ1" stands for ZZ1 + YY2 + …); columns: those
    columns of the full regressor (indices into π); P: (len(names), 14n) the
    exact regrouping as floats; expressions: each β in the standard symbols,
    as text; exact: the `BaseParameters` behind it all.
    """

    names: tuple
    columns: tuple
    P: np.ndarray
    expressions: tuple
    exact: object = None

    def values(self, robot_or_pi) -> np.ndarray:
        """β of a robot (or of a standard vector π)."""
        pi = standard_vector(robot_or_pi) if isinstance(robot_or_pi, Robot) else np.asarray(robot_or_pi, float)
        return self.P @ pi


def base_map(robot: Robot) -> BaseMap:
    """The exact base parameters of `robot` (`regressor.base_parameters`) as a float map,
    computed once per model and kept in the derivation cache (a Panda's takes ~1.5 s)."""
    import sympy as sp

    from ..derivation.cache import cached, key
    from ..derivation.entry import code_fingerprint
    from ..derivation.regressor import base_parameters

    robot.require_numeric("identification")

    def build() -> BaseMap:
        base = base_parameters(robot)
        P = np.zeros((len(base.expressions), len(base.params)))
        index = {s: k for k, s in enumerate(base.params)}
        for b, expr in enumerate(base.expressions):
            for term in sp.Add.make_args(sp.expand(expr)):
                coeff, syms = term.as_coeff_mul()
                if len(syms) != 1 or syms[0] not in index:
                    coeff, sym = term.as_independent(*base.params, as_Add=False)
                    syms = (sym,)
                P[b, index[syms[0]]] += float(coeff)
        return BaseMap(
            names=tuple(str(base.params[k]) for k in base.independent),
            columns=tuple(base.independent),
            P=P,
            expressions=tuple(str(e) for e in base.expressions),
            exact=base,
        )

    entry = key(robot.fingerprint(), __version__, code_fingerprint())
    if entry not in _MAPS:
        _MAPS[entry] = cached("identify-base-map", entry, build)[0]
    return _MAPS[entry]


_MAPS: dict = {}  # this process's maps, by cache key: a fit in a loop reads the cache file once


def _recursion_rotation(robot: Robot, j: int) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) with x_recursion = R·x_own + p for link j's frames (`Robot.to_modified`)."""
    link = robot.links[j]
    if robot.convention == "modified":
        return np.eye(3), np.zeros(3)
    if robot.convention == "standard":
        c, s = (float(x) for x in exact_cos_sin(link.alpha))
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), np.array([float(link.a), 0, 0])
    from ..model.placement import axis_rotation

    Ra = np.array(axis_rotation(link.axis), dtype=float)
    return Ra.T, np.zeros(3)


def with_standard(robot: Robot, pi, *, name: str | None = None) -> Robot:
    """`robot` with the standard parameters π (14n,), read in the recursion's frames and written back
    into the robot's own link frames: mass, COM and inertia about the COM per link, the rotor inertia
    Jm = IA/G², viscous B = FV/G² and Coulomb Tc± = (FO ± FS)/|G| (a link without gear, G = 0, gets
    G = 1 where the motor terms are not zero).  Geometry, limits and the URDF record are kept.

    A ValueError where π is no physical body (a mass ≤ 0 with first moments, an inertia that is
    not positive semidefinite, negative friction): `Robot` checks each link as it always does.
    """
    pi = np.asarray(pi, dtype=float)
    body = BODY if robot.base_joint is not None else 0
    if pi.shape != (body + PER_LINK * robot.n,):
        raise ValueError(
            f"expected {body + PER_LINK * robot.n} standard parameters for {robot.name!r}, got shape {pi.shape}"
        )
    base_body = None
    if body:  # the base body's ten, in its own frame (the recursion's frame {0})
        m, r, Ic = _body(pi[:BODY], f"the base body of {robot.name!r}", "0")
        eig = np.linalg.eigvalsh(Ic)
        base_body = dataclasses.replace(
            robot.base_body or Link(),
            m=float(m),
            r=tuple(float(x) for x in r),
            I=tuple(tuple(float(x) for x in row) for row in Ic),
            physical=inertia.obeys_triangle(eig),
        )
        pi = pi[BODY:]
    links = []
    for j, link in enumerate(robot.links):
        block = pi[PER_LINK * j : PER_LINK * (j + 1)]
        M, r, Ic = _body(block[:BODY], f"link {j + 1} of {robot.name!r}", str(j + 1))
        IA, FV, FS, FO = block[BODY:]
        R, p = _recursion_rotation(robot, j)
        r_own = R.T @ (r - p) if M > 0 else np.zeros(3)
        I_own = R.T @ Ic @ R
        I_own = (I_own + I_own.T) / 2
        G = float(link.G)
        if G == 0 and any(x != 0 for x in (IA, FV, FS, FO)):
            G = 1.0
        motor = dict(Jm=IA / G**2, B=FV / G**2, Tc=((FO + FS) / abs(G), (FO - FS) / abs(G))) if G else {}
        eig = np.linalg.eigvalsh(I_own)
        links.append(
            dataclasses.replace(
                link,
                m=float(M),
                r=tuple(float(x) for x in r_own),
                I=tuple(tuple(float(x) for x in row) for row in I_own),
                G=link.G if G == float(link.G) else G,
                physical=inertia.obeys_triangle(eig),
                **motor,
            )
        )
    out = dataclasses.replace(robot, links=tuple(links), name=name or robot.name)
    return dataclasses.replace(out, base_body=base_body) if body else out


def _body(ten, what: str, index: str) -> tuple:
    """(m, COM r, inertia about the COM) of a body's ten inertial parameters XX … MZ, M about its
    origin; a ValueError where a mass ≤ 0 carries first moments."""
    XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M = ten
    Io = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    h = np.array([MX, MY, MZ])
    if M > 0:
        r = h / M
        return M, r, Io - M * (r @ r * np.eye(3) - np.outer(r, r))
    if M == 0 and not h.any():
        return M, np.zeros(3), Io
    raise ValueError(
        f"{what}: mass M{index} = {M:.6g} with first moments (MX, MY, MZ) = {tuple(np.round(h, 12))} is no physical body"
    )
