"""SymEngine's CSE and derivatives (`symdyn.derivation.engine`) give sympy's results exactly."""

import random

import pytest
import sympy as sp

from symdyn.codegen.choice import Programs, derivations
from symdyn.derivation import engine
from symdyn.model import arms
from symdyn.model.random_arms import ArmOptions, random_arm
from tests.conftest import tiered

x0, x1, q1, q2, qd1 = sp.symbols("x0 x1 q1 q2 qd1", real=True)
SYMS = [x0, x1, q1, q2, qd1]


KINDS = ("add", "mul", "pow", "sin", "cos", "sign", "abs")


def _random_expr(rng: random.Random, depth: int = 4, kinds=KINDS) -> sp.Expr:
    """Sums and products of the symbols (x0, x1 as a user may name them: SymEngine's CSE
    temporaries are called so), exact rationals, floats, sin, cos, sign, |·| and powers."""
    if depth == 0 or rng.random() < 0.2:
        return rng.choice(
            SYMS
            + [sp.Rational(rng.choice([-1, 1]) * rng.randint(1, 9), rng.randint(1, 7)), sp.Float(rng.uniform(0.1, 2))]
        )
    kind = rng.choice(kinds)
    a, b = _random_expr(rng, depth - 1, kinds), _random_expr(rng, depth - 1, kinds)
    return {
        "add": lambda: a + b,
        "mul": lambda: a * b,
        "pow": lambda: sp.Pow(a, rng.choice([2, 3] + ([] if a.is_number else [-1, sp.Rational(1, 2)]))),
        "sin": lambda: sp.sin(a),
        "cos": lambda: sp.cos(a),
        "sign": lambda: sp.sign(a),
        "abs": lambda: sp.Abs(a),
    }[kind]()


def _same(a: sp.Expr, b: sp.Expr) -> bool:
    """Equal at five random positive points, to 1e-12 relative: the floats' precision (|·| of √·
    and its like defeat simplify)."""
    rng = random.Random(7)
    for _ in range(5):
        point = {s: sp.Rational(rng.randint(1, 97), rng.randint(1, 13)) for s in SYMS}
        va, vb = sp.N(a.xreplace(point), 30), sp.N(b.xreplace(point), 30)
        if abs(va - vb) > 1e-12 * (1 + abs(va)):
            return False
    return True


def _substituted(replacements, reduced):
    values = {}
    for t, e in replacements:
        values[t] = e.xreplace(values)
    return [e.xreplace(values) for e in reduced]


@pytest.mark.parametrize("seed", tiered(range(20), 10))
def test_symengine_cse_gives_back_the_same_expressions(seed, monkeypatch):
    rng = random.Random(seed)
    exprs = [_random_expr(rng) for _ in range(6)]
    exprs += [exprs[0] * exprs[1], exprs[2] + exprs[0]]  # shared subexpressions
    monkeypatch.setattr(sp, "cse", None)  # no fallback to sympy's
    with engine.use("symengine"):
        replacements, reduced = engine.cse(exprs, sp.numbered_symbols("_t", real=True))
    assert all(not (e.free_symbols - set(SYMS) - {t for t, _ in replacements}) for e in reduced)
    for got, want in zip(_substituted(replacements, reduced), exprs):
        assert _same(got, want), (got, want)


@pytest.mark.parametrize("seed", tiered(range(20), 10))
def test_symengine_partials_equal_sympys_with_sign_held(seed):
    """(|·| left out: SymEngine leaves its derivative unevaluated, and sympy takes over.)"""
    rng = random.Random(100 + seed)
    kinds = tuple(k for k in KINDS if k != "abs")
    expr = _random_expr(rng, kinds=kinds) * sp.sign(qd1) + _random_expr(rng, kinds=kinds)
    bridge = engine._Bridge(frozen=(sp.sign,))
    with engine.use("symengine"):
        fast = engine.partials(expr, SYMS)
        assert fast == [bridge.back(bridge.to(expr).diff(bridge.to(u))) for u in SYMS]  # SymEngine's own
    slow = engine.partials(expr, SYMS)  # sympy: the default outside code generation
    assert engine.current() == "sympy"
    for a, b in zip(fast, slow):
        assert _same(a, b), (a, b)
    assert not any(e.has(sp.Derivative, sp.DiracDelta) for e in fast)


def test_what_symengine_lacks_is_done_by_sympy():
    expr = sp.exp(q1) * sp.sin(q2) + sp.exp(q1)
    with engine.use("symengine"):
        replacements, reduced = engine.cse([expr], sp.numbered_symbols("_t", real=True))
        assert engine.partials(expr, [q1]) == [expr.diff(q1)]
    assert _substituted(replacements, reduced) == [expr]


def test_unknown_engine_is_refused_by_name():
    with pytest.raises(ValueError, match="'maple'"):
        with engine.use("maple"):
            pass


def test_shipped_models_keep_sympy_and_others_get_symengine():
    """generated/ is pinned byte for byte (test_generated): its models' programs use sympy."""
    assert Programs(*derivations(arms.load("twolink"))).engine == "sympy"
    robot = random_arm(3, ArmOptions(general=1.0, symbolic=0.0), n=3)
    assert Programs(*derivations(robot)).engine == "symengine"


@pytest.mark.parametrize("seed", tiered(range(30), 15))
def test_fast_renaming_builds_what_xreplace_builds(seed):
    """`program._renamer` (sums and products re-sorted, not re-evaluated) gives sympy's own
    canonical expression, term order and all: what emitters print and splices compare."""
    from symdyn.derivation.program import _renamer

    rng = random.Random(300 + seed)
    exprs = [_random_expr(rng, depth=5) for _ in range(4)]
    fresh = [sp.Symbol(name, real=True) for name in ("a9", "zz", "b_1", "x00", "q0")]
    rng.shuffle(fresh)
    mapping = dict(zip(SYMS, fresh))
    renamed = _renamer(mapping)
    for e in exprs:
        want = e.xreplace(mapping)
        got = renamed(e)
        assert got == want and got.args == want.args and hash(got) == hash(want), (got, want)


@pytest.mark.parametrize("seed", tiered(range(20), 10))
def test_sums_and_products_come_back_as_sympy_would_build_them(seed, monkeypatch):
    """`engine.canonical` sorts SymEngine's collected terms instead of re-evaluating them: the
    result is sympy's own expression, argument order and all (or sympy builds it)."""
    built = []
    fast = engine.canonical

    def both(kind, args):
        built.append((fast(kind, args), kind(*args)))
        return built[-1][1]

    monkeypatch.setattr(engine, "canonical", both)
    rng = random.Random(500 + seed)
    exprs = [_random_expr(rng, depth=5) for _ in range(5)]
    exprs += [2 * (exprs[0] + exprs[1]), -(exprs[2] - 1) * exprs[3]]
    with engine.use("symengine"):
        engine.cse(exprs, sp.numbered_symbols("_t", real=True))
        engine.partials(exprs[0] * exprs[1], SYMS)
    assert built
    for got, want in built:
        assert got == want and got.args == want.args, (got, want)
