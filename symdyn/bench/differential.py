"""Differential checks of one arm, stage by stage, for the random-arm tests.

`check_arm(robot)` runs the correctness ladder on any numeric arm and
returns one `Finding` per comparison (its worst relative error and time):
the reference against Pinocchio (τ, M, G, C·q̇, the Christoffel C, forward
dynamics; friction against its own law), the three derivations (plain and
regrouped Newton–Euler, Lagrange) against the reference, plain against
regrouped Newton–Euler exactly at rational points, every generated target
and function against the reference, and the identities (M symmetric
positive definite, Ṁ − 2C skew, τ(q, 0, 0) = G + F(0), fdyn∘τ = id,
Y·π = τ).  A stage that raises is a finding with an infinite error and the
exception, never an abort.  Needs Pinocchio (the `test` extra).
"""

from __future__ import annotations

import random
import time
import traceback
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable, Iterable

import numpy as np
import sympy as sp

from ..numeric import reference as ref
from ..model import Robot

__all__ = [
    "Finding",
    "STAGES",
    "check_arm",
    "disagreements",
    "evaluate",
    "friction_law",
    "pinocchio_at",
    "pinocchio_derivatives",
    "relative_error",
    "states",
]

STAGES = ("pinocchio", "derive", "exact", "targets", "identities")
TARGETS = ("numpy", "c", "casadi")
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "F", "fdyn", "Y")


@dataclass(frozen=True)
class Finding:
    """One comparison: `stage`, what was compared, its worst relative error
    (inf when the stage raised; `detail` then holds the exception) and seconds."""

    stage: str
    what: str
    error: float
    seconds: float
    detail: str = ""


def disagreements(findings: Iterable[Finding], tol: float = 1e-10) -> list[Finding]:
    """The findings that fail: over `tol` relative, a crash, or any nonzero
    difference in the exact stage (rational arithmetic has no rounding)."""
    return [f for f in findings if not f.error <= (0.0 if f.stage == "exact" else tol)]


def relative_error(got, expected, floor: float = 1e-6) -> float:
    """max|got − expected| / max(max|expected|, floor); inf on a shape mismatch or NaN.
    `floor` is the scale below which a difference counts as absolute (the arm's torque scale)."""
    got, expected = np.asarray(got, dtype=float), np.asarray(expected, dtype=float)
    if got.shape != expected.shape:
        return float("inf")
    err = float(np.max(np.abs(got - expected), initial=0.0)) / max(float(np.max(np.abs(expected), initial=0.0)), floor)
    return err if np.isfinite(err) else float("inf")


def states(robot: Robot, count: int, seed: int = 0):
    """(q, qd, qdd, tau) each (count, n): q within the joint limits, a few q̇ = 0
    and a few single joints at rest (Coulomb friction at rest is 0)."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = rng.uniform(lo, hi, (count, robot.n))
    qd = rng.uniform(-2, 2, (count, robot.n))
    qd[:2] = 0.0
    qd[2:4, rng.integers(robot.n)] = 0.0
    qdd = rng.uniform(-5, 5, (count, robot.n))
    tau = rng.uniform(-20, 20, (count, robot.n))
    return q, qd, qdd, tau


def friction_law(robot: Robot, qd) -> np.ndarray:
    """F = G²·B·q̇ + |G|·Tc⁺ (q̇ > 0) or |G|·Tc⁻ (q̇ < 0), 0 at rest, from the link parameters."""
    G = np.array([float(link.G) for link in robot.links])
    B = np.array([float(link.B) for link in robot.links])
    tp, tn = np.array([[float(x) for x in link.Tc] for link in robot.links]).T
    return G**2 * B * qd + np.abs(G) * np.where(qd > 0, tp, np.where(qd < 0, tn, 0.0))


def pinocchio_at(model, q, qd, qdd, tau, *, christoffel: bool = True) -> dict:
    """Pinocchio's τ, M, G, C·q̇, Christoffel symbols (`christoffel`: n Coriolis matrices per
    state; a floating base has none) and forward dynamics at each state."""
    import pinocchio as pin

    data = model.createData()
    n = model.nv
    out = {k: [] for k in ("tau", "M", "G", "Cqd", "ddq") + (("Gamma",) if christoffel else ())}
    for x, v, a, t in zip(q, qd, qdd, tau):
        out["tau"].append(pin.rnea(model, data, x, v, a).copy())
        M = pin.crba(model, data, x)
        out["M"].append(np.triu(M) + np.triu(M, 1).T)
        g = pin.computeGeneralizedGravity(model, data, x).copy()
        out["G"].append(g)
        out["Cqd"].append(pin.nonLinearEffects(model, data, x, v) - g)
        if christoffel:  # Pinocchio's C satisfies Ṁ = C + Cᵀ and is linear in q̇: q̇ = e_i gives ∂M/∂q_i
            dM = np.stack([(lambda C: C + C.T)(pin.computeCoriolisMatrix(model, data, x, e).copy()) for e in np.eye(n)])
            out["Gamma"].append(0.5 * (np.einsum("ikj->kij", dM) + np.einsum("jki->kij", dM) - dM))
        out["ddq"].append(pin.aba(model, data, x, v, t).copy())
    return {k: np.array(v) for k, v in out.items()}


def pinocchio_derivatives(model, robot: Robot, q, qd, qdd, tau) -> dict:
    """Pinocchio's ∂τ/∂(q, q̇) at (q, q̇, q̈) and ∂q̈/∂(q, q̇), q̈ and M⁻¹ at (q, q̇, τ), each
    state; Pinocchio has no friction, so its law is added: ∂F/∂q̇ = G²·B (Coulomb's
    derivative taken as 0, also at rest) and q̈ is solved at τ − F(q̇)."""
    import pinocchio as pin

    data = model.createData()
    B = np.diag([float(link.G) ** 2 * float(link.B) for link in robot.links])
    out = {k: [] for k in ("dtau_dq", "dtau_dqd", "qdd", "dqdd_dq", "dqdd_dqd", "Minv")}
    for x, v, a, t in zip(q, qd, qdd, tau):
        pin.computeRNEADerivatives(model, data, x, v, a)
        out["dtau_dq"].append(data.dtau_dq.copy())
        out["dtau_dqd"].append(data.dtau_dv.copy() + B)
        pin.computeABADerivatives(model, data, x, v, t - friction_law(robot, v))
        out["qdd"].append(data.ddq.copy())
        out["dqdd_dq"].append(data.ddq_dq.copy())
        Minv = pin.computeMinverse(model, data, x)
        Minv = np.triu(Minv) + np.triu(Minv, 1).T
        out["dqdd_dqd"].append(data.ddq_dv.copy() - Minv @ B)
        out["Minv"].append(Minv)
    return {k: np.array(v) for k, v in out.items()}


# --------------------------------------------------------------------------- stages


def _pinocchio(robot: Robot, q, qd, qdd, tau, floor: float) -> Iterable[tuple[str, float]]:
    from .peers import pinocchio_model

    bare = robot.nofriction(all=True)
    peer = pinocchio_at(pinocchio_model(robot), q, qd, qdd, tau)
    yield "tau (frictionless)", relative_error(ref.rne(bare, q, qd, qdd), peer["tau"], floor)
    yield (
        "tau (friction by its law)",
        relative_error(ref.rne(robot, q, qd, qdd), peer["tau"] + friction_law(robot, qd), floor),
    )
    yield "M", relative_error(ref.inertia(robot, q), peer["M"], floor)
    yield "G", relative_error(ref.gravload(robot, q), peer["G"], floor)
    yield "C qd", relative_error(np.einsum("skj,sj->sk", ref.coriolis(robot, q, qd), qd), peer["Cqd"], floor)
    yield "Christoffel", relative_error(ref.christoffel(robot, q), peer["Gamma"], floor)
    yield "fdyn (aba)", relative_error(ref.accel(bare, q, qd, tau), peer["ddq"])


def _expected(robot: Robot, q, qd, qdd) -> dict:
    """The reference value of every term at the states."""
    C = ref.coriolis(robot, q, qd)
    tau = ref.rne(robot, q, qd, qdd)
    return {
        "tau": tau,
        "M": ref.inertia(robot, q),
        "C": C,
        "Cqd": np.einsum("skj,sj->sk", C, qd),
        "G": ref.gravload(robot, q),
        "F": ref.friction(robot, qd),
    }


def _derivations(robot: Robot) -> dict:
    from ..derivation.entry import derive

    return {
        "newton-euler": derive(robot, "newton-euler"),
        "newton-euler regrouped": derive(robot, "newton-euler", regroup=True),
        "lagrange": derive(robot, "lagrange"),
    }


_FUNCTIONS = {sp.cos: np.cos, sp.sin: np.sin, sp.sign: np.sign, sp.Abs: np.abs}


def evaluate(exprs, definitions, values: dict) -> list:
    """Float values of sympy expressions over a batch: `values` maps input
    symbols to arrays, `definitions` [(Symbol, expr)] are named
    intermediates.  Each distinct node is computed once, without recursion,
    so trees of 10⁵ nodes (a 7-joint arm's Lagrange M) cost well under a second."""
    defs = dict(definitions)
    memo = {k: np.asarray(v, dtype=float) for k, v in values.items()}
    for root in exprs:
        stack = [sp.sympify(root)]
        while stack:
            e = stack[-1]
            if e in memo:
                stack.pop()
                continue
            if e.is_Symbol and e not in defs:
                raise ValueError(f"no value for the symbol {e}")
            deps = (defs[e],) if e.is_Symbol else e.args
            pending = [a for a in deps if a not in memo]
            if pending:
                stack.extend(pending)
                continue
            stack.pop()
            args = [memo[a] for a in deps]
            if e.is_Symbol:
                memo[e] = args[0]
            elif e.is_Number or e.is_NumberSymbol:  # 3, 1/2, pi
                memo[e] = float(e)
            elif e.is_Add:
                memo[e] = sum(args[1:], args[0])
            elif e.is_Mul:
                memo[e] = np.prod(np.broadcast_arrays(*args), axis=0)
            elif e.is_Pow:
                memo[e] = np.power(args[0], args[1])
            else:
                memo[e] = _FUNCTIONS[e.func](args[0])
    return [memo[sp.sympify(e)] for e in exprs]


def _derive(robot: Robot, q, qd, qdd, floor: float) -> Iterable[tuple[str, float]]:
    expected = _expected(robot, q, qd, qdd)
    count = q.shape[0]
    for label, dyn in _derivations(robot).items():
        values = dict(zip(dyn.q + dyn.qd + dyn.qdd, np.concatenate([q, qd, qdd], 1).T))
        # a recursion without its Christoffel passes (regrouped, for code generation) names C·q̇, not
        # C: its C is ½ ∂(C q̇)/∂q̇, which the targets stage checks as generated
        terms = ("tau", "M", "C", "G", "F") if "C" in dyn.named or not dyn.named else ("tau", "M", "Cqd", "G", "F")
        for term in terms:
            expr = dyn.named[term] if term in dyn.named else dyn.term(term)
            flat = evaluate(list(expr), dyn.definitions, values)
            got = np.stack([np.broadcast_to(v, (count,)) for v in flat], -1).reshape(expected[term].shape)
            yield f"{label} {term}", relative_error(got, expected[term], floor)


def _in_joint_angles(dyn, q) -> bool:
    """Whether a derivation's trigonometric atoms are cos q_i, sin q_i alone
    (the expanded Lagrange folds an offset π/3 into cos(q + π/3))."""
    exprs = [e for _, e in dyn.definitions] + [x for t in ("tau", "M", "G") for x in dyn.named.get(t, dyn.term(t))]
    return all(a.args[0] in q for e in exprs for a in sp.sympify(e).atoms(sp.cos, sp.sin))


def _exact(robot: Robot, points: int = 2, seed: int = 3) -> Iterable[tuple[str, float]]:
    """Newton–Euler regrouped and Lagrange against plain Newton–Euler at exact
    rational points (τ, M, G, C·q̇, F): every difference must be 0."""
    from ..derivation.exact import compile_exact, random_rational_point

    dyns = _derivations(robot)
    plain = dyns["newton-euler"]
    q, qd, qdd = plain.q, plain.qd, plain.qdd
    if not _in_joint_angles(dyns["lagrange"], q):
        del dyns["lagrange"]  # cos(q + π/3) has no rational value: compared in floats only
    inputs = [f(x) for x in q for f in (sp.cos, sp.sin)] + list(q) + list(qd) + list(qdd)
    terms = ("tau", "M", "G", "Cqd", "F")
    flat = lambda dyn: [x for t in terms for x in dyn.named.get(t, dyn.term(t))]  # noqa: E731
    signs = {sp.sign(v): sp.Dummy() for v in qd}
    evaluators = {
        label: compile_exact(
            [(s, e.xreplace(signs)) for s, e in dyn.definitions],
            [x.xreplace(signs) for x in flat(dyn)],
            inputs + list(signs.values()),
        )
        for label, dyn in dyns.items()
    }
    rng = random.Random(seed)
    worst = dict.fromkeys((label for label in dyns if label != "newton-euler"), 0.0)
    for _ in range(points):
        point = random_rational_point(robot.n, rng)
        args = [Fraction(int(point[x].p), int(point[x].q)) for x in inputs]
        args += [Fraction((v > 0) - (v < 0)) for v in args[3 * robot.n : 4 * robot.n]]  # sgn q̇
        expected = evaluators["newton-euler"](*args)
        for label in worst:
            got = evaluators[label](*args)
            worst[label] = max(worst[label], *(float(abs(x - y)) for x, y in zip(got, expected)))
    for label, error in worst.items():
        yield f"{label} == newton-euler (tau, M, G, C qd, F)", error


def _call(f: Callable, target: str, shape: tuple, *args) -> np.ndarray:
    """A generated function over a batch of states (CasADi: one state at a time,
    its column vectors and 1×1 matrices read as the per-state `shape`)."""
    if target != "casadi":
        return np.asarray(f(*args))
    return np.array([np.array(f(*row)).reshape(shape) for row in zip(*args)])


def _targets(robot: Robot, q, qd, qdd, tau, floor: float) -> Iterable[tuple[str, float]]:
    from ..codegen.entry import load
    from ..derivation.regressor import parameter_values

    expected = _expected(robot, q, qd, qdd)
    expected["fdyn"] = ref.accel(robot, q, qd, tau)
    pi = np.array([float(v) for v in parameter_values(robot)])
    args = {"tau": (q, qd, qdd), "M": (q,), "C": (q, qd), "Cqd": (q, qd), "G": (q,), "F": (qd,), "fdyn": (q, qd, tau)}
    for target in TARGETS:
        model = load(robot, target)
        for name in FUNCTIONS[:-1]:
            got = _call(getattr(model, name), target, expected[name].shape[1:], *args[name])
            yield f"{target} {name}", relative_error(got, expected[name], 1e-6 if name == "fdyn" else floor)
        Y = _call(model.Y, target, (robot.n, pi.size), q, qd, qdd)
        yield f"{target} Y·π", relative_error(Y @ pi, expected["tau"], floor)


def _mass_matrix_rate(robot: Robot, q, qd) -> np.ndarray:
    """Ṁ(q, q̇) from Pinocchio, independently of symdyn: its C satisfies Ṁ = C + Cᵀ."""
    import pinocchio as pin

    from .peers import pinocchio_model

    model = pinocchio_model(robot)
    data = model.createData()
    C = np.array([pin.computeCoriolisMatrix(model, data, x, v).copy() for x, v in zip(q, qd)])
    return C + np.swapaxes(C, -1, -2)


def _identities(robot: Robot, q, qd, qdd, floor: float) -> Iterable[tuple[str, float]]:
    from ..codegen.entry import load
    from ..derivation.regressor import parameter_values

    f = load(robot, "c")
    M, C = f.M(q), f.C(q, qd)
    eig = np.linalg.eigvalsh(M)
    yield "M symmetric", relative_error(M, np.swapaxes(M, -1, -2), floor)
    yield "M positive definite (1 if not)", float(eig.min() <= 0)
    dM = _mass_matrix_rate(robot, q, qd)
    N = dM - 2 * C
    yield (
        "Mdot - 2C skew",
        relative_error(N + np.swapaxes(N, -1, -2), np.zeros_like(N), floor=max(np.abs(dM).max(), np.abs(M).max())),
    )
    zero = np.zeros_like(q)
    yield "tau(q, 0, 0) = G + F(0)", relative_error(f.tau(q, zero, zero), f.G(q) + f.F(zero), floor)
    yield "fdyn(q, qd, tau(q, qd, qdd)) = qdd", relative_error(f.fdyn(q, qd, f.tau(q, qd, qdd)), qdd)
    pi = np.array([float(v) for v in parameter_values(robot)])
    yield "Y·π = tau", relative_error(f.Y(q, qd, qdd) @ pi, f.tau(q, qd, qdd), floor)


def check_arm(robot: Robot, *, count: int = 12, seed: int = 0, stages: Iterable[str] = STAGES) -> list[Finding]:
    """Every comparison of `stages` for `robot` at `count` random states."""
    q, qd, qdd, tau = states(robot, count, seed)
    # torque-like quantities are compared relative to the arm's own scale, so a term that is
    # exactly zero (G with vertical axes) is not judged by its rounding noise alone
    floor = max(float(np.abs(ref.inertia(robot, q)).max()), float(np.abs(ref.rne(robot, q, qd, qdd)).max()), 1e-6)
    runs = {
        "pinocchio": lambda: _pinocchio(robot, q, qd, qdd, tau, floor),
        "derive": lambda: _derive(robot, q, qd, qdd, floor),
        "exact": lambda: _exact(robot),
        "targets": lambda: _targets(robot, q, qd, qdd, tau, floor),
        "identities": lambda: _identities(robot, q, qd, qdd, floor),
    }
    findings = []
    for stage in stages:
        start = time.perf_counter()
        try:
            for what, error in runs[stage]():
                findings.append(Finding(stage, what, error, time.perf_counter() - start))
                start = time.perf_counter()
        except Exception as exc:  # noqa: BLE001 (a crash is a finding, reported with the arm)
            detail = "".join(traceback.format_exception_only(exc)).strip()
            findings.append(
                Finding(
                    stage,
                    "crashed",
                    float("inf"),
                    time.perf_counter() - start,
                    f"{detail}\n{traceback.format_exc(limit=-3)}",
                )
            )
    return findings
