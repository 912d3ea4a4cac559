"""Jacobians of straight-line programs (`symdyn.codegen.derivatives`): forward mode and
reverse accumulation give the same Jacobian exactly, sign(·) held constant in both, and
`jacobian` takes the elimination order with fewer products (on the shipped Newton–Euler
τ, the order that gives the leaner program)."""

import sympy as sp

from symdyn import models
from symdyn.codegen.derivatives import forward, jacobian, reverse
from symdyn.codegen.functions import FunctionSpec, candidates
from symdyn.derivation.entry import derive

x, y, z = sp.symbols("x y z", real=True)
a, b, c, d = sp.symbols("a b c d", real=True)
#: A small program with sharing, a transcendental, a sign(·) term and an inactive definition.
DEFINITIONS = [(a, x * y), (b, sp.sin(a) + x * sp.sign(y)), (c, b * b * y + a), (d, sp.cos(z) * 3)]
OUTPUTS = [c * d, a + b, d]
WRT = [x, y]


def _inline(expr, definitions):
    for s, e in reversed(definitions):
        expr = expr.xreplace({s: e})
    return expr


def _exact(rows, new):
    everything = DEFINITIONS + list(new)
    return [[sp.expand(_inline(sp.sympify(e), everything)) for e in row] for row in rows]


def test_reverse_accumulation_equals_forward_mode_and_the_hand_derivative():
    fwd, rev = forward(DEFINITIONS, OUTPUTS, WRT), reverse(DEFINITIONS, OUTPUTS, WRT)
    assert _exact(fwd[1], fwd[0]) == _exact(rev[1], rev[0])
    full = [_inline(o, DEFINITIONS).xreplace({sp.sign(y): sp.Symbol("s_y")}) for o in OUTPUTS]
    by_hand = [[sp.expand(sp.diff(o, v).xreplace({sp.Symbol("s_y"): sp.sign(y)})) for v in WRT] for o in full]
    assert _exact(rev[1], rev[0]) == by_hand  # sign(y) held constant, the inactive d a constant
    assert rev[1][2] == [0, 0]


def test_jacobian_takes_reverse_for_many_inputs_and_forward_for_many_outputs():
    inputs = sp.symbols("u1:9", real=True)
    chain = [(sp.Symbol("p1", real=True), inputs[0])]
    for k, u in enumerate(inputs[1:], 2):
        chain.append((sp.Symbol(f"p{k}", real=True), sp.sin(chain[-1][0]) * u))
    many_in = jacobian(chain, [chain[-1][0]], list(inputs))
    assert all(s.name.startswith("dD") for s, _ in many_in[0])  # reverse accumulation
    fan = [(sp.Symbol(f"r{k}", real=True), sp.sin(x) * k) for k in range(1, 9)]
    many_out = jacobian(fan, [s * s for s, _ in fan], [x])
    assert all(s.name.startswith("D") and not s.name.startswith("dD") for s, _ in many_out[0])


def test_the_chosen_order_gives_the_leaner_tau_derivatives_program():
    tau = candidates(derive(models.load("rrp"), "newton-euler", regroup=True))["tau"]
    q, qd = tau.inputs[0][1], tau.inputs[1][1]
    ops = {}
    for name, method in (("forward", forward), ("reverse", reverse), ("chosen", jacobian)):
        new, rows = method(tau.definitions, list(tau.outputs[0][1]), list(q) + list(qd))
        J = sp.ImmutableMatrix(rows)
        spec = FunctionSpec(
            "tau_derivatives", tau.inputs, (("tau", tau.outputs[0][1]), ("J", J)), tuple(tau.definitions) + tuple(new)
        )
        ops[name] = spec.program().op_count()["total"]
    assert ops["chosen"] == min(ops["forward"], ops["reverse"]) < max(ops["forward"], ops["reverse"])
