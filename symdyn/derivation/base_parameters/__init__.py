"""Base parameters at any size: Khalil's rules, a numeric rank analysis, exact checks.

Three steps, none of which does linear algebra on exact numbers whose digits
grow with the arm:

1. `rules.transfer`: each link hands what its joint cannot move to its parent
   (exact, local, the same choice an exact rank analysis makes);
2. the columns left are sampled in doubles (`sampled`) and taken in order:
   a column in the span of the earlier ones is dependent, its coefficients
   found by least squares, then made exact by a small rational solve on just
   the columns it involves (these are the special cases near the base: a first
   link's rotor inertia with its ZZ, columns that vanish);
3. everything is checked exactly: the independent columns have full rank
   modulo the prime 2³¹ − 1 (so they are independent over ℚ), and the whole
   regrouping Y·π = Y_b·β holds at fresh random points modulo that prime
   (a polynomial identity test: a false one passes with probability below
   10⁻⁶ per point, and several points are used).

The result is the same as Gautier's exact method (the independent set and β
are unique once the column order is fixed), at a cost that grows like n³ in
doubles instead of minutes of rational elimination for generically turned
links.

A floating base: the base body's ten parameters come first; the links on it
hand it what their joints cannot move (step 1), and which of its own the base
joint moves — all on a free base, the in-plane ones on a planar base — is left
to steps 2 and 3, which decide it like any other column.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import sympy as sp

from ...model import Robot
from .rules import transfer
from .sampled import PRIME, Floats, Modular, Rationals, frames, regressor_columns

__all__ = ["analyse", "Analysis"]

_INERTIAL = 11

#: A column whose part outside the span of the earlier ones is below this fraction of its size is taken as
#: dependent; the exact checks decide, and a refused analysis is redone at the next, tighter tolerance
#: (nearly parallel axes, off a quarter turn by 4e-6 rad in a real file, leave a rotor column 1e-11 from its
#: link's ZZ).
TOLERANCES = (1e-8, 1e-10, 1e-12, 1e-13)


class Analysis:
    """The outcome: for each independent slot, β as a combination of standard parameter slots."""

    def __init__(self, independent: list[int], combos: dict) -> None:
        self.independent = independent
        self.combos = combos


#: A floating base's body: its ten parameters (XX … M, no rotor) take π's first slots.
_BODY = 10


def _slots(n: int, per: int, body: int = 0) -> list[int]:
    """The inertial slots of π in the sampled columns' order: the base body's `body` first."""
    return list(range(body)) + [body + j * per + i for j in range(n) for i in range(_INERTIAL)]


def _body(robot: Robot) -> int:
    return _BODY if robot.base_joint is not None else 0


def _link_of(k: int, per: int, body: int) -> int:
    """The link whose parameter slot k is (−1: the base body)."""
    return -1 if k < body else (k - body) // per


def _flat(columns: np.ndarray) -> np.ndarray:
    """(columns, n, K) → (n·K, columns): one row per joint and state."""
    return columns.reshape(columns.shape[0], -1).T


def _rank_mod_p(A: np.ndarray) -> int:
    """Rank of an integer matrix modulo PRIME (Gaussian elimination, rows vectorised)."""
    A = A.copy() % PRIME
    rank, rows, cols = 0, *A.shape
    for c in range(cols):
        pivot = next((r for r in range(rank, rows) if A[r, c]), None)
        if pivot is None:
            continue
        A[[rank, pivot]] = A[[pivot, rank]]
        inv = pow(int(A[rank, c]), -1, PRIME)
        A[rank] = A[rank] * inv % PRIME
        below = A[rank + 1 :, c].copy()
        A[rank + 1 :] = (A[rank + 1 :] - below[:, None] * A[rank] % PRIME) % PRIME
        rank += 1
    return rank


def _exact_coefficients(robot: Robot, support: list[int], dependent: int, per: int, seed: int) -> dict:
    """The exact c with Y_dependent = Σ c_k·Y_k over k in `support` (slots), from enough rational points."""
    body = _body(robot)
    links = sorted({_link_of(k, per, body) for k in support + [dependent]})
    count = len(support) + 2  # a point may give a single useful row: the columns of link j vanish below it
    cols = regressor_columns(robot, Rationals(), count, seed, links)
    slots = [k for j in links for k in (range(body) if j < 0 else range(body + j * per, body + j * per + _INERTIAL))]
    index = {k: s for s, k in enumerate(slots)}
    A = sp.Matrix(_flat(cols[[index[k] for k in support]]).tolist())
    b = sp.Matrix(_flat(cols[[index[dependent]]]).tolist())
    normal = (A.T * A).to_DM().convert_to(sp.QQ)
    solution = normal.lu_solve((A.T * b).to_DM().convert_to(sp.QQ)).to_Matrix()
    return {k: Fraction(int(x.p), int(x.q)) for k, x in zip(support, solution) if x != 0}


def analyse(robot: Robot, per: int, seed: int = 1) -> Analysis:
    """Independent inertial slots of `robot` (numeric geometry) and the exact regrouping.

    Raises:
        RuntimeError: the exact checks refuse the numeric analysis at every tolerance
            (`TOLERANCES`: a rank no double can decide); the message gives each refusal.
    """
    fs = frames(robot)
    body = _body(robot)
    combos, gone = transfer(fs, per, body)
    candidates = [k for k in _slots(robot.n, per, body) if k not in gone]
    position = {k: s for s, k in enumerate(_slots(robot.n, per, body))}
    count = max(4, -(-3 * len(candidates) // robot.nv))
    Y = _flat(regressor_columns(robot, Floats(), count, seed))
    refused = []
    for tolerance in TOLERANCES:
        try:
            independent, beta = _regroup(robot, Y, candidates, combos, position, per, seed, tolerance)
            _check(robot, independent, beta, per, seed, position)
        except (RuntimeError, ArithmeticError, ValueError) as exc:  # a rank misjudged in doubles
            refused.append(f"at {tolerance:g}: {exc}")
            continue
        return Analysis(independent, beta)
    raise RuntimeError("; ".join(refused))


def _regroup(robot, Y, candidates, combos, position, per, seed, tolerance) -> tuple[list, dict]:
    """(independent slots, β of each as a combination of standard slots) from the sampled columns Y,
    a column taken as dependent when its part outside the earlier ones' span is below `tolerance`."""
    basis, independent, dependent = np.zeros((Y.shape[0], 0)), [], {}
    for k in candidates:
        y = Y[:, position[k]]
        size = np.linalg.norm(y)
        residual = y - basis @ (basis.T @ y) if independent else y
        residual = residual - basis @ (basis.T @ residual) if independent else residual
        if size > 0 and np.linalg.norm(residual) > tolerance * size:
            basis = np.column_stack([basis, residual / np.linalg.norm(residual)])
            independent.append(k)
        else:
            dependent[k] = None
    for k in dependent:
        y = Y[:, position[k]]
        earlier = [i for i in independent if i < k]
        if np.linalg.norm(y) == 0 or not earlier:
            dependent[k] = {}
            continue
        A = Y[:, [position[i] for i in earlier]]
        c, *_ = np.linalg.lstsq(A, y, rcond=None)
        scale = np.linalg.norm(A, axis=0)
        support = [i for i, ci, s in zip(earlier, c, scale) if abs(ci) * s > tolerance * np.linalg.norm(y)]
        dependent[k] = _exact_coefficients(robot, support, k, per, seed) if support else {}

    # regroup: β_i = combo_i + Σ_d c_{i,d}·combo_d
    beta = {i: dict(combos[i]) for i in independent}
    for d, coefficients in dependent.items():
        for i, c in coefficients.items():
            for k, v in combos[d].items():
                value = beta[i].get(k, 0) + c * v
                if value:
                    beta[i][k] = value
                else:
                    beta[i].pop(k, None)
    return independent, beta


def _check(robot: Robot, independent: list, beta: dict, per: int, seed: int, position: dict) -> None:
    """Exact (mod p) checks: the independent columns have full rank, and Y = Y_b·P."""
    field = Modular()
    count = max(3, -(-2 * len(independent) // robot.nv))
    Y = _flat(regressor_columns(robot, field, count, seed + 7919))
    Yb = Y[:, [position[i] for i in independent]]
    if _rank_mod_p(Yb) < len(independent):
        raise RuntimeError(
            f"base parameters of {robot.name!r}: columns the numeric analysis took as independent are not "
            "(exact check modulo 2^31 - 1)"
        )
    P = np.zeros((len(independent), Y.shape[1]), dtype=np.int64)
    for r, i in enumerate(independent):
        for k, v in beta[i].items():
            P[r, position[k]] = field.const(v)
    product = np.zeros_like(Y)
    for r in range(len(independent)):  # Y_b·P, one rank-one term at a time (no overflow)
        product = (product + Yb[:, [r]] * P[[r], :] % PRIME) % PRIME
    if not np.array_equal(product, Y % PRIME):
        worst = int(np.argmax((product != Y % PRIME).any(axis=0)))
        raise RuntimeError(
            f"base parameters of {robot.name!r}: the regrouping does not reproduce the regressor's column "
            f"{worst} exactly (exact check modulo 2^31 - 1)"
        )
