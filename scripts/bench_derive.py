"""Derivation speed and operation counts for the Puma 560 (issue 3's benchmark).

Run: .venv/bin/python scripts/bench_derive.py
Cold cache (a fresh temporary cache directory), numeric parameters,
symbolic q, q̇, q̈; op counts are mul + add after one joint CSE.
"""

import os
import sys
import tempfile
import time

import sympy as sp


def main() -> int:
    os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-bench-")
    from symdyn import models
    from symdyn.derivation.entry import derive
    from symdyn.derivation.lagrange import trig_dynamics
    from symdyn.derivation.program import make_program
    from symdyn.derivation.regressor import base_parameters, regressor

    robot = models.load("puma560")
    rows = []

    def timed(label, fn):
        start = time.perf_counter()
        value = fn()
        rows.append((label, time.perf_counter() - start))
        return value

    def ne_and_cse():
        dyn = derive(robot, "newton-euler", cache=False)
        make_program("tau", dyn.inputs("tau"), [("tau", dyn.named["tau"] - dyn.F)], dyn.definitions)
        return dyn

    timed("Newton–Euler: tau, M, C, G derived + tau CSE'd", ne_and_cse)
    timed("Lagrange: M, all Christoffel symbols, G (trig polynomials)", lambda: trig_dynamics(robot))
    timed("Lagrange: the same as sympy matrices (derive)", lambda: derive(robot, "lagrange", cache=False))
    timed("regressor Y (symbolic inertial parameters, named columns)", lambda: regressor(robot))
    timed("base parameters (Khalil's rules, rank in doubles, exact checks mod p)", lambda: base_parameters(robot))
    dyn = timed(
        "Newton–Euler on regrouped base parameters (first run, fills cache)",
        lambda: derive(robot, "newton-euler", regroup=True),
    )
    timed("the same, from the cache", lambda: derive(robot, "newton-euler", regroup=True))
    print(f"{'step':68s} {'seconds':>8s}")
    for label, seconds in rows:
        print(f"{label:68s} {seconds:8.2f}")

    plain = derive(robot, "newton-euler")
    print(f"\n{'operations after CSE (mul + add)':40s} {'plain NE':>10s} {'regrouped NE':>13s}")
    for term in ("tau", "M", "G", "Cqd"):
        counts = []
        for d in (plain, dyn):
            expr = d.named[term] - d.F if term == "tau" else d.named[term]
            c = make_program(term, d.inputs(term), [(term, sp.Matrix(expr))], d.definitions).op_count()
            counts.append(c["mul"] + c["add"])
        label = "tau (without friction)" if term == "tau" else term
        print(f"{label:40s} {counts[0]:10d} {counts[1]:13d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
