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

Doubles cannot see what lies within their rounding of a dependency: exactly
perpendicular axes in a file come out of the axis-along-z frames'
rational rotations (`Robot.to_modified`, rounded once where several generic
turns compose) off by 10⁻¹⁶, which leaves a rotor column that far from its
link's ZZ (independent, exactly), a coefficient of 10⁻¹⁶ that least squares
drops (involved, exactly), or a column as small as their rounding, beside
which an exactly dependent one looks independent.  Where the exact checks
refuse step 2, it is redone modulo the prime (`_rank_exactly`): the reduced
row echelon form of the columns sampled there gives which are independent and
which earlier ones each other involves, with no tolerance; the rational solves
and step 3 follow as before.  Both give the same result where the checks pass
(the independent set and β are unique).

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
#: dependent by the rank in doubles (one try: where the exact checks refuse it, the rank is decided modulo
#: the prime, which needs no tolerance; tighter ones only told apart what lay above a double's rounding).
TOLERANCES = (1e-8,)


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


def _reduce_mod_p(A: np.ndarray, above: bool = False) -> tuple[list[int], np.ndarray]:
    """(pivot columns, the reduced matrix) of an integer matrix modulo PRIME, by Gaussian elimination
    (rows vectorised).  The pivot columns are those that are no combination of the columns before
    them; `above`: reduced row echelon form (Gauss–Jordan), where a column that is no pivot holds, in
    row r, its coefficient on the r-th pivot column."""
    A = A.copy() % PRIME
    pivots, rows, cols = [], *A.shape
    for c in range(cols):
        rank = len(pivots)
        pivot = next((r for r in range(rank, rows) if A[r, c]), None)
        if pivot is None:
            continue
        A[[rank, pivot]] = A[[pivot, rank]]
        A[rank, c:] = A[rank, c:] * pow(int(A[rank, c]), -1, PRIME) % PRIME
        factor = A[:, c].copy()
        factor[: 0 if above else rank] = 0  # echelon form: the rows above keep their entries
        factor[rank] = 0
        A[:, c:] = (A[:, c:] - factor[:, None] * A[rank, c:] % PRIME) % PRIME
        pivots.append(c)
    return pivots, A


def _rank_mod_p(A: np.ndarray) -> int:
    """Rank of an integer matrix modulo PRIME."""
    return len(_reduce_mod_p(A)[0])


def _rank_exactly(robot: Robot, candidates: list, position: dict, seed: int) -> tuple[list, dict]:
    """(independent, support): the candidates that are no combination of the earlier ones, and for each
    other one the earlier independent slots it involves, decided exactly: the reduced row echelon form
    of the regressor sampled modulo PRIME.

    A set independent there is independent over ℚ (a rational dependency, cleared of denominators,
    holds modulo p too), and a dependent column's coefficients there are its rational ones modulo p;
    a column or a coefficient is taken for 0 wrongly only where the random points hit a root of a
    minor or p divides a numerator (probability of the order of 10⁻⁹; the exact checks would refuse
    it).  No tolerance: what doubles cannot tell apart (a rotor column 10⁻¹⁶ from its link's ZZ, a
    coefficient of 10⁻¹⁶, where exactly perpendicular axes in a file come out of `Robot.to_modified`'s
    rounded rational rotations a last digit off) is told apart here."""
    count = max(4, -(-3 * len(candidates) // robot.nv))
    Y = _flat(regressor_columns(robot, Modular(), count, seed + 104729))
    pivots, R = _reduce_mod_p(Y[:, [position[k] for k in candidates]], above=True)
    independent = [candidates[c] for c in pivots]
    kept = set(pivots)
    support = {
        k: [independent[r] for r in np.flatnonzero(R[: len(pivots), c])]
        for c, k in enumerate(candidates)
        if c not in kept
    }
    return independent, support


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
        RuntimeError: the exact checks refuse both the analysis in doubles and the one modulo p
            (which only unlucky random points can make fail); the message gives each refusal.
    """
    fs = frames(robot)
    body = _body(robot)
    combos, gone = transfer(fs, per, body)
    candidates = [k for k in _slots(robot.n, per, body) if k not in gone]
    position = {k: s for s, k in enumerate(_slots(robot.n, per, body))}
    count = max(4, -(-3 * len(candidates) // robot.nv))
    Y = _flat(regressor_columns(robot, Floats(), count, seed))
    refused = []
    for tolerance in (*TOLERANCES, None):  # None: the rank decided modulo p
        try:
            exact = None if tolerance is not None else _rank_exactly(robot, candidates, position, seed)
            independent, beta = _regroup(robot, Y, candidates, combos, position, per, seed, tolerance, exact)
            _check(robot, independent, beta, per, seed, position)
        except (RuntimeError, ArithmeticError, ValueError) as exc:  # a rank misjudged in doubles
            refused.append(f"{'modulo p' if tolerance is None else f'at {tolerance:g}'}: {exc}")
            continue
        return Analysis(independent, beta)
    raise RuntimeError("; ".join(refused))


def _rank_in_doubles(Y, candidates, position, tolerance) -> tuple[list, dict]:
    """(independent, support) from the sampled columns Y: a column is dependent when its part outside
    the earlier ones' span is below `tolerance` of its size, and involves the earlier independent
    columns whose least-squares coefficients weigh above `tolerance`."""
    basis, independent, dependent = np.zeros((Y.shape[0], 0)), [], []
    for k in candidates:
        y = Y[:, position[k]]
        size = np.linalg.norm(y)
        residual = y - basis @ (basis.T @ y) if independent else y
        residual = residual - basis @ (basis.T @ residual) if independent else residual
        if size > 0 and np.linalg.norm(residual) > tolerance * size:
            basis = np.column_stack([basis, residual / np.linalg.norm(residual)])
            independent.append(k)
        else:
            dependent.append(k)
    support = {}
    for k in dependent:
        y = Y[:, position[k]]
        earlier = [i for i in independent if i < k]
        if np.linalg.norm(y) == 0 or not earlier:
            support[k] = []
            continue
        A = Y[:, [position[i] for i in earlier]]
        c, *_ = np.linalg.lstsq(A, y, rcond=None)
        scale = np.linalg.norm(A, axis=0)
        support[k] = [i for i, ci, s in zip(earlier, c, scale) if abs(ci) * s > tolerance * np.linalg.norm(y)]
    return independent, support


def _regroup(robot, Y, candidates, combos, position, per, seed, tolerance, exact=None) -> tuple[list, dict]:
    """(independent slots, β of each as a combination of standard slots): which columns are independent
    and which earlier ones each other involves from `exact` ((independent, support) of `_rank_exactly`)
    or else from the columns Y sampled in doubles at `tolerance` (`_rank_in_doubles`); the coefficients
    exactly, by a small rational solve on each support."""
    independent, support = exact if exact is not None else _rank_in_doubles(Y, candidates, position, tolerance)
    dependent = {k: _exact_coefficients(robot, s, k, per, seed) if s else {} for k, s in support.items()}

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
