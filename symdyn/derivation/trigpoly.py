"""Exact trigonometric polynomials in joint angles: the algebra of the fast Lagrange route.

A `TrigPoly` is Σ_k [c_k cos(k·θ) + s_k sin(k·θ)] over integer frequency
vectors k, with coefficients in the sympy `PolyRing` QQ[gens] whose
generators are the other symbols (robot parameters, joint rates, prismatic
joint variables).  Products become sums of angles (product-to-sum),
derivatives are exact, equality is a dict compare, so M, C and G of a
six-joint arm are built with integer dict arithmetic and no sympy
expression in the inner loops.  `from_expr` folds a sympy expression (e.g.
a Newton–Euler result, a DAG of shared subtrees) into this canonical form
and `to_expr` prints it back, so this module serves derive (lagrange.py)
and simplify (folding, comparing forms).

Angles: θ_i = q_i + offset_i (a constant offset per angle, kept inside the
cos/sin so that it stays exact).  Constants that are not rational (a Float,
π, √2, cos of an angle that is not a multiple of π/2) become the exact
rational of their double value, as `symdyn.derivation.symbols.exact` does for float
model parameters; multiples of π/2 are exact (`symdyn.model.exact_cos_sin`).

Representation (internal; `items()` gives QQ[gens] coefficients):
a frequency vector k is one Python int with balanced base-2²¹ digits, k_1
most significant, so adding angles is an integer addition and the sign of
the int is the sign of the first non-zero k_i (canonical form: that entry
positive; k = 0 carries only a cosine); |k_i| must stay below 2²⁰.  A
term's key is 2·code + (0 for cos, 1 for sin).  A monomial is one int with
16 bits per generator exponent (generator 0 lowest), so multiplying
monomials is an addition.  Coefficients are integer numerators over one
positive denominator per polynomial, kept in lowest terms, which makes the
form unique.
"""

from __future__ import annotations

import functools
import math
from typing import Iterable, Mapping, Sequence

import sympy as sp
from sympy.polys.domains import QQ
from sympy.polys.rings import PolyElement, PolyRing

from .symbols import exact, exact_cos_sin_of

__all__ = [
    "TrigSpace",
    "TrigPoly",
    "from_expr",
    "to_expr",
    "fold",
    "equal",
    "space_for",
    "summation",
    "lincomb",
    "constant_cos_sin",
    "to_qq",
]

_BITS = 21
_BASE = 1 << _BITS
_HALF = _BASE >> 1
_EBITS = 16  # bits per generator exponent in a packed monomial
_EMASK = (1 << _EBITS) - 1


def _encode(k: Sequence[int]) -> int:
    """Pack a frequency vector into one int (k[0] most significant, balanced digits)."""
    code = 0
    for ki in k:
        if not -_HALF < ki < _HALF:
            raise ValueError(f"frequency {ki} is out of range: |k_i| must stay below {_HALF}")
        code = code * _BASE + ki
    return code


@functools.lru_cache(maxsize=1 << 16)
def _decode(code: int, n: int) -> tuple[int, ...]:
    """The frequency vector of length n packed in `code`."""
    digits = []
    for _ in range(n):
        r = code % _BASE
        if r >= _HALF:
            r -= _BASE
        digits.append(r)
        code = (code - r) // _BASE
    return tuple(reversed(digits))


def _ratio(value) -> tuple[int, int]:
    """A constant (int, float, QQ, sympy number) as (numerator, denominator > 0);
    floats and irrational numbers become the rational of their shortest decimal
    (`placement.exact`, as everywhere in the derivations: 0.4318 → 2159/5000)."""
    if isinstance(value, int):
        return value, 1
    if isinstance(value, sp.Basic):
        if value.is_Rational:
            return int(value.p), int(value.q)
    elif hasattr(value, "numerator") and hasattr(value, "denominator") and not isinstance(value, float):
        return int(value.numerator), int(value.denominator)
    value = exact(float(value))
    return int(value.p), int(value.q)


def to_qq(value):
    """A constant as an element of QQ (see `_ratio`)."""
    return QQ(*_ratio(value))


def constant_cos_sin(angle) -> tuple:
    """cos and sin of a constant angle in QQ, exactly on the unit circle (`symbols.exact_cos_sin_of`)."""
    c, s = exact_cos_sin_of(angle)
    return to_qq(c), to_qq(s)


def _make(space: "TrigSpace", acc: dict, den: int) -> "TrigPoly":
    """A TrigPoly from accumulated numerators over `den`: drop zeros, reduce to lowest terms."""
    out = {}
    for key, t in acc.items():
        d = {m: x for m, x in t.items() if x}
        if d:
            out[key] = d
    if not out:
        return TrigPoly(space, {}, 1)
    if den != 1:
        g = den
        for d in out.values():
            g = math.gcd(g, *d.values())
            if g == 1:
                break
        if g != 1:
            den //= g
            out = {key: {m: x // g for m, x in d.items()} for key, d in out.items()}
    return TrigPoly(space, out, den)


# --------------------------------------------------------------------------- the space


class TrigSpace:
    """Where trig polynomials live: the angles θ_i = angles[i] + offsets[i] and
    the coefficient ring QQ[gens].  Two spaces are equal when their angles,
    offsets and generators are."""

    def __init__(self, angles: Sequence[sp.Symbol], gens: Sequence[sp.Symbol] = (), offsets: Sequence | None = None):
        self.angles = tuple(angles)
        self.gens = tuple(gens)
        for s in self.angles + self.gens:
            if not isinstance(s, sp.Symbol):
                raise ValueError(f"angles and generators must be sympy Symbols, got {s!r}")
        clash = set(self.angles) & set(self.gens)
        if clash or len(set(self.angles)) != len(self.angles) or len(set(self.gens)) != len(self.gens):
            raise ValueError(f"angles {self.angles} and generators {self.gens} must be distinct symbols")
        offsets = [0] * len(self.angles) if offsets is None else list(offsets)
        if len(offsets) != len(self.angles):
            raise ValueError(f"{len(offsets)} offsets given for {len(self.angles)} angles")
        self.offsets = tuple(sp.sympify(o) for o in offsets)
        for a, o in zip(self.angles, self.offsets):
            if o.free_symbols or not o.is_real:
                raise ValueError(f"the offset of angle {a} must be a real constant, got {o}")
        self.ring = PolyRing(self.gens, QQ)
        self.n = len(self.angles)
        self._angle_index = {a: i for i, a in enumerate(self.angles)}
        self._gen_index = {g: i for i, g in enumerate(self.gens)}
        self._key = (self.angles, self.gens, self.offsets)
        self._args: dict = {}

    def __eq__(self, other) -> bool:
        return isinstance(other, TrigSpace) and self._key == other._key

    def __hash__(self) -> int:
        return hash(self._key)

    def __repr__(self) -> str:
        return f"TrigSpace(angles={self.angles}, gens={self.gens}, offsets={self.offsets})"

    # ---- monomials
    def _pack(self, exps: Sequence[int]) -> int:
        return sum(e << (_EBITS * j) for j, e in enumerate(exps))

    def _unpack(self, m: int) -> tuple[int, ...]:
        return tuple((m >> (_EBITS * j)) & _EMASK for j in range(len(self.gens)))

    # ---- constructors
    @property
    def zero(self) -> "TrigPoly":
        return TrigPoly(self, {}, 1)

    @property
    def one(self) -> "TrigPoly":
        return self.const(1)

    def const(self, value) -> "TrigPoly":
        """A constant: int, float (its exact rational), QQ element, ring element or angle-free sympy expression."""
        if isinstance(value, TrigPoly):
            return value
        if isinstance(value, PolyElement):
            if value.ring != self.ring:
                raise ValueError(f"coefficient {value} is from ring {value.ring}, expected {self.ring}")
            den = math.lcm(1, *(int(c.denominator) for c in value.values()))
            return _make(
                self,
                {0: {self._pack(m): int(c.numerator) * (den // int(c.denominator)) for m, c in value.items()}},
                den,
            )
        if isinstance(value, sp.Basic) and not value.is_Number:
            return from_expr(value, self)
        p, q = _ratio(value)
        return _make(self, {0: {0: p}}, q)

    def gen(self, symbol: sp.Symbol) -> "TrigPoly":
        """A ring generator (a parameter, joint rate, prismatic variable) as a trig polynomial."""
        i = self._gen_index.get(symbol)
        if i is None:
            raise KeyError(f"{symbol} is not a generator of this space; generators are {self.gens}")
        return TrigPoly(self, {0: {1 << (_EBITS * i): 1}}, 1)

    def term(self, k: Sequence[int], kind: str = "cos", coeff=1) -> "TrigPoly":
        """coeff·cos(k·θ) or coeff·sin(k·θ) for an integer frequency vector k."""
        if len(k) != self.n:
            raise ValueError(f"frequency vector {tuple(k)} has {len(k)} entries, the space has {self.n} angles")
        if kind not in ("cos", "sin"):
            raise ValueError(f"kind must be 'cos' or 'sin', got {kind!r}")
        code = _encode([int(x) for x in k])
        sign = 1
        if code < 0:
            code, sign = -code, (-1 if kind == "sin" else 1)
        if kind == "sin" and code == 0:
            return self.zero
        c = self.const(coeff)
        d = c.terms.get(0)
        if d is None:
            return self.zero
        return TrigPoly(self, {code << 1 | (kind == "sin"): d if sign > 0 else {m: -x for m, x in d.items()}}, c.den)

    def cos(self, i: int) -> "TrigPoly":
        """cos θ_i (i counts from 0)."""
        return self.term([int(j == i) for j in range(self.n)], "cos")

    def sin(self, i: int) -> "TrigPoly":
        """sin θ_i (i counts from 0)."""
        return self.term([int(j == i) for j in range(self.n)], "sin")

    def _arg(self, code: int) -> sp.Expr:
        """k·θ as sympy, written with the angle symbols and offsets (cached per space)."""
        arg = self._args.get(code)
        if arg is None:
            k = _decode(code, self.n)
            arg = self._args[code] = sp.Add(*[ki * (a + o) for ki, a, o in zip(k, self.angles, self.offsets) if ki])
        return arg

    def from_expr(self, expr, memo: dict | None = None) -> "TrigPoly":
        return from_expr(expr, self, memo)


# --------------------------------------------------------------------------- the polynomials


class TrigPoly:
    """Σ_k c_k cos(k·θ) + s_k sin(k·θ) with coefficients in space.ring; immutable.

    Supports +, −, * (with TrigPolys, ints, floats, QQ, ring elements),
    ** (non-negative int), ==, `diff`, `to_expr`, `items`.  Built by a
    `TrigSpace` (const, gen, term, cos, sin, from_expr), not directly.
    """

    __slots__ = ("space", "terms", "den")

    def __init__(self, space: TrigSpace, terms: dict, den: int):
        self.space = space
        self.terms = terms  # {key: {packed monomial: numerator ≠ 0}}, never mutated after construction
        self.den = den  # common positive denominator, lowest terms with the numerators

    # ---- inspection
    def items(self) -> Iterable[tuple[tuple[int, ...], str, PolyElement]]:
        """(frequency vector k, 'cos' or 'sin', coefficient in space.ring) for every term, in key order."""
        S = self.space
        for key in sorted(self.terms):
            coeff = PolyElement(S.ring, {S._unpack(m): QQ(x, self.den) for m, x in self.terms[key].items()})
            yield _decode(key >> 1, S.n), ("sin" if key & 1 else "cos"), coeff

    def __len__(self) -> int:
        """Number of (frequency, kind) terms."""
        return len(self.terms)

    @property
    def nterms(self) -> int:
        """Number of monomial terms over all coefficients."""
        return sum(len(d) for d in self.terms.values())

    def is_zero(self) -> bool:
        return not self.terms

    def __bool__(self) -> bool:
        return bool(self.terms)

    def is_constant(self) -> bool:
        """True when no angle appears (the polynomial is a single k = 0 coefficient or zero)."""
        return not self.terms or (len(self.terms) == 1 and 0 in self.terms)

    def __repr__(self) -> str:
        return f"TrigPoly({self.to_expr()})"

    def __eq__(self, other) -> bool:
        if not isinstance(other, TrigPoly):
            try:
                other = self.space.const(other)
            except (ValueError, TypeError, KeyError):
                return NotImplemented
        return self.space == other.space and self.den == other.den and self.terms == other.terms

    __hash__ = None

    # ---- arithmetic
    def _coerce(self, other) -> "TrigPoly":
        if isinstance(other, TrigPoly):
            if other.space is not self.space and other.space != self.space:
                raise ValueError(f"trig polynomials from different spaces: {self.space} and {other.space}")
            return other
        return self.space.const(other)

    def __add__(self, other) -> "TrigPoly":
        return summation([self, self._coerce(other)], self.space)

    __radd__ = __add__

    def __neg__(self) -> "TrigPoly":
        return TrigPoly(self.space, {k: {m: -x for m, x in d.items()} for k, d in self.terms.items()}, self.den)

    def __sub__(self, other) -> "TrigPoly":
        return summation([self, -self._coerce(other)], self.space)

    def __rsub__(self, other) -> "TrigPoly":
        return self._coerce(other) - self

    def __mul__(self, other) -> "TrigPoly":
        other = self._coerce(other)
        if not self.terms or not other.terms:
            return self.space.zero
        if other.is_constant():
            return self._scale(other)
        if self.is_constant():
            return other._scale(self)
        return _mul(self, other)

    __rmul__ = __mul__

    def __pow__(self, e: int) -> "TrigPoly":
        if not isinstance(e, int) or e < 0:
            raise ValueError(f"a trig polynomial can be raised to a non-negative int power only, got {e!r}")
        result, base = self.space.one, self
        while e:
            if e & 1:
                result = result * base
            e >>= 1
            if e:
                base = base * base
        return result

    def _scale(self, c: "TrigPoly") -> "TrigPoly":
        """Multiply every coefficient by the constant (angle-free) polynomial c."""
        cd = c.terms[0]
        if len(cd) == 1 and 0 in cd:
            x = cd[0]
            if x == 1 and c.den == 1:
                return self
            return _make(
                self.space, {k: {m: v * x for m, v in d.items()} for k, d in self.terms.items()}, self.den * c.den
            )
        cl = list(cd.items())
        acc = {}
        for k, d in self.terms.items():
            t = acc[k] = {}
            for m, v in d.items():
                for mc, xc in cl:
                    mm = m + mc
                    t[mm] = t.get(mm, 0) + v * xc
        return _make(self.space, acc, self.den * c.den)

    # ---- calculus
    def diff(self, symbol: sp.Symbol) -> "TrigPoly":
        """∂/∂symbol, exact: an angle (cos ↔ sin times k_i), a ring generator, else 0."""
        i = self.space._angle_index.get(symbol)
        if i is not None:
            return self.diff_angle(i)
        j = self.space._gen_index.get(symbol)
        if j is not None:
            return self.diff_gen(j)
        return self.space.zero

    def diff_angle(self, i: int) -> "TrigPoly":
        """∂/∂θ_i: c cos(kθ) → −k_i c sin(kθ), s sin(kθ) → k_i s cos(kθ)."""
        n = self.space.n
        acc = {}
        for key, d in self.terms.items():
            code = key >> 1
            ki = _decode(code, n)[i]
            if ki:
                if key & 1:
                    acc[code << 1] = {m: ki * x for m, x in d.items()}
                else:
                    acc[code << 1 | 1] = {m: -ki * x for m, x in d.items()}
        return _make(self.space, acc, self.den)

    def diff_gen(self, j: int) -> "TrigPoly":
        """∂/∂(generator number j) of every coefficient."""
        shift = _EBITS * j
        unit = 1 << shift
        acc = {}
        for key, d in self.terms.items():
            t = {}
            for m, x in d.items():
                e = (m >> shift) & _EMASK
                if e:
                    t[m - unit] = x * e
            acc[key] = t
        return _make(self.space, acc, self.den)

    def subs_gen(self, values: Mapping[sp.Symbol, object]) -> "TrigPoly":
        """Substitute constants (ints, floats → exact, QQ, sympy rationals) for some ring generators."""
        S = self.space
        subs = [(_EBITS * S._gen_index[s], *_ratio(v)) for s, v in values.items()]
        top = {
            shift: max(((m >> shift) & _EMASK for d in self.terms.values() for m in d), default=0)
            for shift, _, _ in subs
        }
        den = self.den * math.prod(q ** top[shift] for shift, _, q in subs)
        acc: dict = {}
        for key, d in self.terms.items():
            t = acc[key] = {}
            for m, x in d.items():
                for shift, p, q in subs:
                    e = (m >> shift) & _EMASK
                    x *= p**e * q ** (top[shift] - e)
                    m -= e << shift
                t[m] = t.get(m, 0) + x
        return _make(S, acc, den)

    def embed(self, space: TrigSpace) -> "TrigPoly":
        """The same polynomial in a larger space whose generators extend this one's."""
        mine = self.space
        if space == mine:
            return self
        if (space.angles, space.offsets) != (mine.angles, mine.offsets) or space.gens[: len(mine.gens)] != mine.gens:
            raise ValueError(
                f"cannot embed a polynomial of {mine} into {space}: angles and offsets must "
                f"agree and the generators must extend {mine.gens}"
            )
        return TrigPoly(space, self.terms, self.den)  # packed monomials: new generators are higher bits

    # ---- output
    def to_expr(self) -> sp.Expr:
        """The sympy expression Σ coeff·cos(k·θ) + coeff·sin(k·θ), θ_i written q_i + offset_i."""
        S = self.space
        out = []
        for key in sorted(self.terms):
            coeff = sp.Add(
                *[
                    sp.Rational(x, self.den) * sp.Mul(*[g**e for g, e in zip(S.gens, S._unpack(m)) if e])
                    for m, x in self.terms[key].items()
                ]
            )
            code = key >> 1
            if code == 0:
                out.append(coeff)
            else:
                arg = S._arg(code)
                out.append(coeff * (sp.sin(arg) if key & 1 else sp.cos(arg)))
        return sp.Add(*out)


def _mul(A: TrigPoly, B: TrigPoly) -> TrigPoly:
    """Product by product-to-sum; every product carries ½, put into the denominator once.

    cos a cos b = ½[cos(a−b) + cos(a+b)]   sin a sin b = ½[cos(a−b) − cos(a+b)]
    sin a cos b = ½[sin(a+b) + sin(a−b)]   cos a sin b = ½[sin(a+b) − sin(a−b)]
    """
    acc: dict = {}
    Bitems = [(kb >> 1, kb & 1, list(db.items())) for kb, db in B.terms.items()]
    for ka, da in A.terms.items():
        ca, sa = ka >> 1, ka & 1
        ia = list(da.items())
        for cb, sb, ib in Bitems:
            s, d = ca + cb, ca - cb
            if sa == sb:
                k1 = (d if d >= 0 else -d) << 1
                k2, g2 = s << 1, not sa
            else:
                k1 = s << 1 | 1  # s > 0: one factor is a sine, so its code is > 0
                if d == 0:
                    k2 = None
                else:
                    g2 = bool(sa)  # sin a cos b: +sin d; cos a sin b: −sin d
                    if d < 0:
                        d, g2 = -d, not g2
                    k2 = d << 1 | 1
            if len(ia) == 1 and len(ib) == 1:
                (ma, xa), (mb, xb) = ia[0], ib[0]
                m, x = ma + mb, xa * xb
                t = acc.get(k1)
                if t is None:
                    acc[k1] = {m: x}
                else:
                    t[m] = t.get(m, 0) + x
                if k2 is not None:
                    if not g2:
                        x = -x
                    t = acc.get(k2)
                    if t is None:
                        acc[k2] = {m: x}
                    else:
                        t[m] = t.get(m, 0) + x
                continue
            prods = [(ma + mb, xa * xb) for ma, xa in ia for mb, xb in ib]
            t = acc.get(k1)
            if t is None:
                t = acc[k1] = {}
            for m, x in prods:
                t[m] = t.get(m, 0) + x
            if k2 is not None:
                t = acc.get(k2)
                if t is None:
                    t = acc[k2] = {}
                if g2:
                    for m, x in prods:
                        t[m] = t.get(m, 0) + x
                else:
                    for m, x in prods:
                        t[m] = t.get(m, 0) - x
    return _make(A.space, acc, 2 * A.den * B.den)


def summation(polys: Iterable[TrigPoly], space: TrigSpace) -> TrigPoly:
    """Σ polys over a common denominator, accumulated in place (linear in the number of terms)."""
    polys = [p for p in polys if p.terms]
    if not polys:
        return space.zero
    if len(polys) == 1:
        return polys[0]
    den = math.lcm(*(p.den for p in polys))
    acc: dict = {}
    for p in polys:
        f = den // p.den
        for key, d in p.terms.items():
            t = acc.get(key)
            if t is None:
                acc[key] = dict(d) if f == 1 else {m: f * x for m, x in d.items()}
            elif f == 1:
                for m, x in d.items():
                    t[m] = t.get(m, 0) + x
            else:
                for m, x in d.items():
                    t[m] = t.get(m, 0) + f * x
    return _make(space, acc, den)


def lincomb(pairs: Iterable[tuple[object, TrigPoly]], space: TrigSpace) -> TrigPoly:
    """Σ c·p over (c, p) pairs with constant scalars c (int, QQ, sympy rational)."""
    scaled = []
    for c, p in pairs:
        if not c or not p.terms:
            continue
        num, den = _ratio(c)
        if num == 1 and den == 1:
            scaled.append(p)
        elif num == -1 and den == 1:
            scaled.append(-p)
        else:
            scaled.append(
                _make(space, {k: {m: num * x for m, x in d.items()} for k, d in p.terms.items()}, den * p.den)
            )
    return summation(scaled, space)


# --------------------------------------------------------------------------- sympy → TrigPoly


def _linear_arg(arg: sp.Expr, space: TrigSpace, where: sp.Expr) -> tuple[int, sp.Expr]:
    """Split the argument of sin/cos into an integer frequency code over the
    angles θ and a constant: arg = k·θ + c (offsets moved into c)."""
    k = [0] * space.n
    const = sp.S.Zero
    for term in sp.Add.make_args(arg):
        coeff, rest = term.as_coeff_Mul()
        if rest is sp.S.One:
            const += coeff
            continue
        i = space._angle_index.get(rest)
        if i is None:
            if not rest.free_symbols:
                const += term
                continue
            raise ValueError(
                f"{where}: the argument must be an integer combination of the angles "
                f"{space.angles} plus a constant; the term {term} is not"
            )
        if not (coeff.is_Integer or (coeff.is_Float and float(coeff).is_integer())):
            raise ValueError(f"{where}: angle {rest} has the non-integer multiple {coeff}")
        k[i] += int(coeff)
    const -= sum((ki * o for ki, o in zip(k, space.offsets) if ki), sp.S.Zero)
    return _encode(k), const


def _trig(func, arg: sp.Expr, space: TrigSpace, where: sp.Expr) -> TrigPoly:
    """cos or sin of k·θ + c as a trig polynomial (c folded in exactly where it can be)."""
    code, c = _linear_arg(arg, space, where)
    is_sin = func is sp.sin
    sign = 1
    if code < 0:  # cos(−x + c) = cos(x − c); sin(−x + c) = −sin(x − c)
        code, c = -code, -c
        sign = -1 if is_sin else 1
    cc, sc = constant_cos_sin(c) if c != 0 else (QQ(1), QQ(0))
    if code == 0:
        return space.const(sign * (sc if is_sin else cc))
    # cos(x + c) = cos c cos x − sin c sin x;  sin(x + c) = cos c sin x + sin c cos x
    cos_coeff, sin_coeff = (sc, cc) if is_sin else (cc, -sc)
    return space.term(_decode(code, space.n), "cos", sign * cos_coeff) + space.term(
        _decode(code, space.n), "sin", sign * sin_coeff
    )


def _not_poly(e: sp.Expr, space: TrigSpace, why: str) -> ValueError:
    return ValueError(
        f"cannot write {e} as a trigonometric polynomial in the angles {space.angles} "
        f"with coefficients polynomial in {space.gens}: {why}"
    )


def _constant_value(p: TrigPoly):
    """The QQ value of a numeric constant polynomial, or None."""
    if not p.terms:
        return QQ(0)
    if p.is_constant():
        d = p.terms[0]
        if len(d) == 1 and 0 in d:
            return QQ(d[0], p.den)
    return None


def _atom(e: sp.Expr, space: TrigSpace) -> TrigPoly:
    if e.is_Symbol:
        if e in space._gen_index:
            return space.gen(e)
        if e in space._angle_index:
            raise _not_poly(e, space, f"the angle {e} appears outside sin/cos")
        raise _not_poly(e, space, f"unknown symbol {e} (neither an angle nor a generator)")
    if e.is_Rational:
        return space.const(e)
    if e.is_number and e.is_real:
        return space.const(float(e))  # Float, π, E: the exact rational of the double
    raise _not_poly(e, space, f"unsupported atom {e!r}")


def _node(e: sp.Expr, space: TrigSpace, memo: dict) -> TrigPoly:
    """The trig polynomial of an Add, Mul or Pow from its (already converted) arguments."""
    if e.is_Pow:
        base, ex = e.args
        b = memo[base]
        if ex.is_Integer and ex >= 0:
            return b ** int(ex)
        value = _constant_value(b)
        if value is None:
            raise _not_poly(e, space, f"the power {ex} of a non-constant")
        if ex.is_Integer:
            if not value:
                raise _not_poly(e, space, "division by zero")
            return space.const(value ** int(ex))
        return space.const(float(value) ** float(ex))
    return summation([memo[a] for a in e.args], space) if e.is_Add else _product([memo[a] for a in e.args])


def _product(polys: list) -> TrigPoly:
    """Product of trig polynomials, smallest first (constants scale, they do not multiply out)."""
    polys = sorted(polys, key=len)
    acc = polys[0]
    for p in polys[1:]:
        acc = acc * p
    return acc


def from_expr(expr, space: TrigSpace, memo: dict | None = None) -> TrigPoly:
    """Fold a sympy expression into its canonical trig polynomial.

    expr must be polynomial in sin/cos of integer combinations of the angles
    (plus constants), the ring generators and constants.  Subexpressions are
    memoised (pass one `memo` dict to several calls that share subtrees), and
    the walk is iterative, so deep DAG-shaped trees from Newton–Euler cost
    one visit per distinct node.  Named intermediates: seed the memo with
    {symbol: TrigPoly} (convert the definitions in order with the same memo)
    and expressions written in those names fold without expanding them.
    """
    if memo is None:
        memo = {}
    expr = sp.sympify(expr)
    stack = [expr]
    while stack:
        e = stack[-1]
        if e in memo:
            stack.pop()
            continue
        if e.func in (sp.sin, sp.cos):
            memo[e] = _trig(e.func, e.args[0], space, e)
        elif not e.args or e.is_Atom:
            memo[e] = _atom(e, space)
        elif not (e.is_Add or e.is_Mul or e.is_Pow):
            raise _not_poly(e, space, f"unsupported function {type(e).__name__}")
        else:
            pending = [a for a in e.args if a not in memo]
            if pending:
                stack.extend(pending)
                continue
            memo[e] = _node(e, space, memo)
        stack.pop()
    return memo[expr]


def to_expr(p: TrigPoly) -> sp.Expr:
    """The sympy expression of a trig polynomial (see `TrigPoly.to_expr`)."""
    return p.to_expr()


# --------------------------------------------------------------------------- conveniences


def space_for(exprs: Iterable, angles: Sequence[sp.Symbol], offsets: Sequence | None = None) -> TrigSpace:
    """A space whose generators are the free symbols of `exprs` other than the angles (sorted by name)."""
    return TrigSpace(angles, sorted(_symbols(exprs) - set(angles), key=str), offsets)


def _symbols(exprs: Iterable) -> set:
    """Free symbols of expressions, one visit per distinct node (sympy's `free_symbols`
    re-walks shared subtrees, which is exponential on a DAG)."""
    seen: set = set()
    syms: set = set()
    stack = [sp.sympify(e) for e in exprs]
    while stack:
        e = stack.pop()
        if e in seen:
            continue
        seen.add(e)
        if e.is_Symbol:
            syms.add(e)
        else:
            stack.extend(e.args)
    return syms


def fold(expr, angles: Sequence[sp.Symbol], offsets: Sequence | None = None) -> sp.Expr:
    """Rewrite expr in canonical trig-polynomial form (products of sin/cos become sums of angles)."""
    return from_expr(expr, space_for([expr], angles, offsets)).to_expr()


def equal(a, b, angles: Sequence[sp.Symbol], offsets: Sequence | None = None) -> bool:
    """Exact equality of two sympy expressions as trig polynomials in `angles`."""
    space = space_for([a, b], angles, offsets)
    memo: dict = {}
    return from_expr(a, space, memo) == from_expr(b, space, memo)
