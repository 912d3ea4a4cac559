"""The straight-line program: one joint CSE, readable names, honest op counts."""

import math
import os
import subprocess
import sys

import pytest
import sympy as sp

from symdyn.codegen.emit import Infix
from symdyn.derivation.program import lower, make_program, make_programs
from symdyn.derivation.symbols import joint_symbols

q, qd, qdd = joint_symbols(3)
a, b, c = sp.symbols("a b c", real=True)


class _Float:
    """Evaluate a program with Python floats, one primitive at a time."""

    def __init__(self, env):
        self.env = env

    number = staticmethod(float)

    def symbol(self, name):
        return self.env[name]

    neg = staticmethod(lambda x: -x)
    add = staticmethod(lambda x, y: x + y)
    sub = staticmethod(lambda x, y: x - y)
    mul = staticmethod(lambda x, y: x * y)
    div = staticmethod(lambda x, y: x / y)
    pow = staticmethod(lambda x, e: x**e)

    def call(self, name, x):
        return {
            "sin": math.sin,
            "cos": math.cos,
            "sqrt": math.sqrt,
            "abs": abs,
            "sign": lambda v: float((v > 0) - (v < 0)),
        }[name](x)


def run(program, values: dict) -> list:
    """All output entries of the program at the given input values."""
    env = {s.name: v for s, v in values.items()}
    alg = _Float(env)
    for s, e in program.assignments:
        env[s.name] = lower(e, alg)
    return [lower(e, alg) for _, m in program.outputs for e in m]


def ops(expr, **inputs):
    syms = sorted(expr.free_symbols, key=str)
    return make_program("f", [("x", syms)], [("y", sp.Matrix([expr]))]).op_count()


VALUES = {q[0]: 0.3, q[1]: -1.1, q[2]: 2.2, qd[0]: 0.7, qd[1]: -0.4, qd[2]: 0.0, a: 1.5, b: -0.25, c: 3.0}


def _exact(expr):
    return float(expr.subs(VALUES).evalf(30))


@pytest.mark.parametrize(
    "expr, expected",
    [
        (a - b, {"add": 1}),
        (a + b + c, {"add": 2}),
        (-a, {"neg": 1, "total": 0}),
        (a * b * c, {"mul": 2}),
        (3 * a, {"mul": 1}),
        (sp.Rational(1, 3) * a, {"mul": 1}),
        (a**2, {"mul": 1}),
        (a**3, {"mul": 2}),
        (a / b, {"div": 1}),
        (1 / (a * b), {"div": 1, "mul": 1}),
        (a / b**2, {"div": 1, "mul": 1}),
        (sp.sin(a), {"fun": 1}),
        (sp.sign(a) * b, {"fun": 1, "mul": 1}),
        (sp.sqrt(a), {"fun": 1}),
        (a - 2 * b, {"add": 1, "mul": 1}),
    ],
)
def test_op_count_rules(expr, expected):
    got = ops(expr)
    for kind, count in expected.items():
        assert got[kind] == count, f"{expr}: {got}"
    assert got["total"] == got["add"] + got["mul"] + got["div"] + got["fun"]


def test_program_computes_its_outputs():
    shared = sp.sin(q[0]) * qd[1] + sp.cos(q[1] + q[2]) ** 2
    outs = sp.Matrix(
        [
            [shared * qd[0] - sp.Rational(2, 7) * shared, qd[1] ** 2 / (1 + shared**2)],
            [sp.sign(qd[2]) * sp.Abs(q[0]) + shared, sp.cos(2 * q[1] - q[2]) * qd[0]],
        ]
    )
    p = make_program("f", [("q", q), ("qd", qd)], [("y", outs)])
    got = run(p, VALUES)
    assert got == pytest.approx([_exact(e) for e in outs], rel=1e-14, abs=1e-15)


def test_joint_cse_computes_a_shared_subexpression_once():
    shared = (q[0] + qd[0]) * (q[1] - qd[1])
    alone = make_program("f", [("q", q), ("qd", qd)], [("y", sp.Matrix([sp.sin(shared)]))]).op_count()["total"]
    joint = make_program("f", [("q", q), ("qd", qd)], [("y", sp.Matrix([sp.sin(shared), sp.cos(shared)]))]).op_count()[
        "total"
    ]
    assert joint == alone + 1  # the product is computed once; one more call


def test_trig_of_sums_becomes_products_of_single_angles():
    outs = sp.Matrix([sp.cos(2 * q[1] + 2 * q[2]), sp.sin(q[1] - q[2]), sp.cos(q[0] + q[1] + q[2])])
    p = make_program("f", [("q", q)], [("y", outs)])
    calls = {e for _, x in p.assignments for e in x.atoms(sp.sin, sp.cos)}
    assert all(call.args[0] in q for call in calls)
    assert run(p, VALUES) == pytest.approx([_exact(e) for e in outs], rel=1e-14)
    names = {s.name for s, _ in p.assignments}
    assert {"c2", "s2", "c3", "s3", "c23", "s23"} <= names


def test_intermediates_have_readable_names():
    s1, sq, sgn = sp.sin(q[0]), qd[0] ** 2, sp.sign(qd[1])
    outs = sp.Matrix([s1 * qd[1] + sgn * q[2], s1 * qd[2] + sq * q[1], sq * q[2] + sgn * q[0]])
    p = make_program("f", [("q", q), ("qd", qd)], [("y", outs)])
    names = [s.name for s, _ in p.assignments]
    assert sorted(names) == ["qd1_sq", "s1", "sgn_qd2"]


def test_definitions_keep_their_names_and_unused_ones_are_dropped():
    w, v, unused, alias = sp.symbols("w2_z v3_x unused alias", real=True)
    defs = [(w, qd[0] + qd[1]), (v, w * sp.cos(q[1])), (unused, q[0] ** 5), (alias, -qd[2])]
    p = make_program("f", [("q", q), ("qd", qd)], [("y", sp.Matrix([v * w + alias, v]))], defs)
    names = [s.name for s, _ in p.assignments]
    assert "w2_z" in names and "v3_x" in names
    assert "unused" not in names and "alias" not in names  # trivial definitions are inlined
    assert names.index("w2_z") < names.index("v3_x")
    assert run(p, VALUES) == pytest.approx([(0.7 - 0.4) ** 2 * math.cos(-1.1) - 0.0, 0.3 * math.cos(-1.1)])


def test_functions_cse_d_together_each_compute_their_own_outputs_from_what_they_need():
    w = sp.Symbol("w2_z", real=True)
    defs = [(w, sp.sin(q[0]) * qd[1] + sp.cos(q[1] + q[2]))]
    f = sp.Matrix([w * q[2] + sp.cos(q[1] + q[2]) * q[0], (q[0] * q[1] + q[2]) ** 2])
    g = sp.Matrix([(q[0] * q[1] + q[2]) * sp.sin(q[2]), sp.cos(q[1] + q[2])])
    together = make_programs(
        [
            dict(name="f", inputs=[("q", q), ("qd", qd)], outputs=[("y", f)]),
            dict(name="g", inputs=[("q", q)], outputs=[("y", g)]),
        ],
        defs,
    )
    alone = [
        make_program("f", [("q", q), ("qd", qd)], [("y", f)], defs),
        make_program("g", [("q", q)], [("y", g)], defs),
    ]
    full = [f.xreplace(dict(defs)), g]
    for made, single, outs in zip(together, alone, full):
        assert run(made, VALUES) == pytest.approx([_exact(e) for e in outs], rel=1e-14)
        assert made.op_count()["total"] <= single.op_count()["total"]
        # q1·q2 + q3, once in each: the group's CSE names it, each function computes it in place
        assert [s.name for s, _ in made.assignments] == [s.name for s, _ in single.assignments]
    # g reads only q: nothing of f's (its definition w2_z, qd) is among its assignments
    assert not together[1].used_inputs() & set(qd) and "w2_z" not in {s.name for s, _ in together[1].assignments}
    with pytest.raises(ValueError, match="'g' uses symbols that are neither inputs nor definitions: qd1"):
        make_programs([dict(name="g", inputs=[("q", q)], outputs=[("y", g + sp.Matrix([qd[0], 0]))])])


def test_unknown_symbol_is_a_clear_error():
    with pytest.raises(ValueError, match="neither inputs nor definitions: a"):
        make_program("f", [("q", q)], [("y", sp.Matrix([a * q[0]]))])


def test_numbers_are_printed_exactly():
    alg = Infix({}, power="pow")
    text = lower(sp.Rational(1, 3) * a + sp.Rational(2159, 5000), alg)[0]
    assert sorted(text.split(" + ")) == sorted(["0.4318", f"{1 / 3!r}*a"])


def test_infix_text_never_merges_minus_signs():
    alg = Infix({}, power="pow")
    text = lower(-(-a - b) * c - (-a), alg)[0]
    assert "--" not in text.replace(" ", "")
    assert eval(text, {"a": 1.5, "b": -0.25, "c": 3.0}) == pytest.approx(_exact(-(-a - b) * c + a))


def test_program_is_the_same_under_any_hash_seed():
    code = (
        "import sympy as sp; from symdyn.derivation.program import make_program; from symdyn.derivation.symbols import joint_symbols;"
        "q, qd, _ = joint_symbols(3);"
        "e = [sp.cos(q[0] + q[1]) * qd[k] ** 2 + sp.sin(q[2] - q[0]) * qd[(k + 1) % 3] * sp.cos(q[1])"
        "     + sp.Rational(3, 7) * qd[k] * sp.sin(q[0]) for k in range(3)];"
        "p = make_program('f', [('q', q), ('qd', qd)], [('y', sp.Matrix(e))]);"
        "print(p.assignments, p.outputs)"
    )
    outs = {
        subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=True,
            env={**os.environ, "PYTHONHASHSEED": seed},
        ).stdout
        for seed in ("1", "2")
    }
    assert len(outs) == 1
