"""Code generation on floating bases (issue 35): every target against the reference and Pinocchio.

Random trees of 2 joints on a free and on a planar base: the NumPy, C (SIMD batch on the
free base, scalar on the planar one) and CasADi functions tau, M, C, G, Cqd, F, fdyn and Minv equal the numeric reference
(itself Pinocchio's, tests/test_tree_reference.py) at 200 states to 1e-10; the derivatives
equal Pinocchio's computeRNEADerivatives and computeABADerivatives (∂/∂q in the tangent
space) at the same states, friction's viscous term added; q has nq entries, q̇, q̈, τ nv;
C is the reference's (Pinocchio's computeCoriolisMatrix); Y has the base body's ten columns first.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import symdyn
import symdyn.reference as ref
from symdyn.codegen.derivatives import tangent_map
from symdyn.codegen.lazy import signatures
from symdyn.derivation.regressor import parameter_values
from symdyn.model.random_robots import random_tree_robot
from tests.conftest import tiered

STATES = 200
BASES = {"free": (3, 2), "planar": (5, 2)}  # base: (seed, joints)


def _close(a, b, what: str) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, f"{what}: shape {a.shape}, expected {b.shape}"
    err = np.abs(a - b).max() / (1 + np.abs(b).max())
    assert err < 1e-10, f"{what}: {err:.2e}"


# the planar base in the main suite; the free one (its C SIMD batch build, 14 s): make test-all
@pytest.fixture(scope="module", params=tiered(["planar", "free"], 1))
def case(request, tmp_path_factory):
    """(robot, states q, v, a, τ, the reference's answers) of one base, code in a fresh cache."""
    seed, n = BASES[request.param]
    robot = random_tree_robot(seed, n=n, base_joint=request.param)
    rng = np.random.default_rng(seed)
    q = robot.integrate(robot.neutral(), rng.normal(size=(STATES, robot.nv)) * 2)
    v, a = rng.normal(size=(2, STATES, robot.nv))
    qd = v + 0.1 * np.sign(v)  # away from 0: Coulomb friction's sign is defined
    want = {
        "tau": ref.rne(robot, q, qd, a),
        "M": ref.inertia(robot, q),
        "G": ref.gravload(robot, q),
        "Cqd": ref.rne(robot, q, qd, 0 * a, gravity=(0, 0, 0)) - ref.friction(robot, qd),
        "F": ref.friction(robot, qd),
        "C": ref.coriolis(robot, q, qd),
    }
    want["fdyn"] = ref.accel(robot, q, qd, want["tau"])
    want["Minv"] = np.linalg.inv(want["M"])
    return robot, q, qd, a, want


def _check(model, robot, q, qd, a, want, label: str) -> None:
    assert (model.nq, model.nv) == (robot.nq, robot.nv)
    got = {
        "tau": model.tau(q, qd, a),
        "M": model.M(q),
        "C": model.C(q, qd),
        "G": model.G(q),
        "Cqd": model.Cqd(q, qd),
        "F": model.F(qd),
        "fdyn": model.fdyn(q, qd, want["tau"]),
        "Minv": model.Minv(q),
    }
    for term, value in got.items():
        _close(value, want[term], f"{label} {term}")
    tau, dq, dqd = model.tau_derivatives(q, qd, a)
    _close(tau, want["tau"], f"{label} tau_derivatives' tau")
    qdd, ddq, ddqd, minv = model.fdyn_derivatives(q, qd, want["tau"])
    _close(qdd, want["fdyn"], f"{label} fdyn_derivatives' qdd")
    _close(minv, want["Minv"], f"{label} fdyn_derivatives' Minv")
    _close(ddq, -minv @ dq_at(model, q, qd, qdd), f"{label} dqdd_dq = -Minv dtau_dq")
    pi = np.array([float(v) for v in parameter_values(robot)])
    Y = model.Y(q, qd, a)
    assert Y.shape[-2:] == (robot.nv, 10 + 14 * robot.n)
    _close(Y @ pi, want["tau"], f"{label} Y pi (the base body's ten columns first)")


def dq_at(model, q, qd, qdd):
    return model.tau_derivatives(q, qd, qdd)[1]


def _pin_q(robot, q):
    if robot.base_joint != "planar":
        return q
    return np.concatenate([q[..., :2], np.cos(q[..., 2:3]), np.sin(q[..., 2:3]), q[..., 3:]], -1)


def _check_pinocchio(pin, model_, robot, q, qd, a, want, label: str) -> None:
    """∂τ and ∂q̈ of the generated `model_` against Pinocchio's (tangent space), the viscous
    friction's ∂F/∂q̇ added."""
    from symdyn.bench.peers import pinocchio_model

    _, dq, dqd = model_.tau_derivatives(q, qd, a)
    _, ddq, ddqd, _ = model_.fdyn_derivatives(q, qd, want["tau"])

    model = pinocchio_model(robot)
    data = model.createData()
    k = robot.nv - robot.n
    viscous = np.diag([0.0] * k + [float(link.G) ** 2 * float(link.B) for link in robot.links])
    for i in range(STATES):
        qp = _pin_q(robot, q[i])
        Pq, Pv, _ = pin.computeRNEADerivatives(model, data, qp, qd[i], a[i])
        _close(dq[i], Pq, f"{label} dtau_dq vs Pinocchio")
        _close(dqd[i], Pv + viscous, f"{label} dtau_dqd vs Pinocchio")
        tau_pin = want["tau"][i] - ref.friction(robot, qd[i])  # Pinocchio's τ for the same q̈
        Aq, Av, Minv = pin.computeABADerivatives(model, data, qp, qd[i], tau_pin)
        _close(ddq[i], Aq, f"{label} dqdd_dq vs Pinocchio")
        _close(ddqd[i], Av - Minv @ viscous, f"{label} dqdd_dqd vs Pinocchio")


@pytest.mark.parametrize("case", ["planar"], indirect=True)  # the free base's programs: checked through C and CasADi
def test_numpy(case):
    robot, q, qd, a, want = case
    _check(symdyn.load(robot, "numpy"), robot, q, qd, a, want, "numpy")


class _EachState:
    """A model whose functions take batches but call the scalar C function state by state
    (no SIMD kernel to compile)."""

    def __init__(self, model):
        self.model, self.nq, self.nv = model, model.nq, model.nv

    def __getattr__(self, name):
        def each(*args):
            out = [getattr(self.model, name)(*state) for state in zip(*args)]
            return tuple(map(np.array, zip(*out))) if isinstance(out[0], tuple) else np.array(out)

        return each


def test_c_scalar_and_batched(case):
    """The free base through the SIMD batch kernels, the planar one through the scalar functions."""
    robot, q, qd, a, want = case
    model = symdyn.load(robot, "c")
    batched = robot.base_joint == "free"
    _check(model if batched else _EachState(model), robot, q, qd, a, want, "C batch" if batched else "C scalar")
    one = {"tau": model.tau(q[7], qd[7], a[7]), "M": model.M(q[7])}  # one state: the scalar entry point
    _close(one["tau"], want["tau"][7], "C scalar tau")
    _close(one["M"], want["M"][7], "C scalar M")
    _close(model.fdyn(q[7], qd[7], want["tau"][7]), want["fdyn"][7], "C scalar fdyn")
    with pytest.raises(ValueError, match=rf"\(\.\.\., {robot.nq}\)"):
        model.tau(q[7][:-1], qd[7], a[7])


def test_casadi(case):
    robot, q, qd, a, want = case
    model = symdyn.load(robot, "casadi")
    _check(model, robot, q, qd, a, want, "casadi")
    assert model.functions["tau"].size1_in(0) == robot.nq and model.functions["tau"].size1_in(1) == robot.nv


def test_generate_writes_sizes(tmp_path):
    robot = random_tree_robot(1, n=1, base_joint="free")
    paths = symdyn.generate(robot, "c", tmp_path)
    header = next(p for p in paths if p.suffix == ".h").read_text()
    name = robot.name.upper()
    assert f"#define {name}_NQ {robot.nq}" in header and f"#define {name}_NV {robot.nv}" in header
    assert f"function: C(q: {robot.nq}, qd: {robot.nv}) -> C: {robot.nv}x{robot.nv}" in header
    assert f"function: Y(q: {robot.nq}, qd: {robot.nv}, qdd: {robot.nv}) -> Y: {robot.nv}x{10 + 14 * robot.n}" in header
    assert f"function: tau(q: {robot.nq}, qd: {robot.nv}, qdd: {robot.nv}) -> tau: {robot.nv}" in header


def test_signatures_and_tangent_map():
    """Lazy C signatures take q of nq; the free base's map turns v into the quaternion's rate."""
    sigs = {s.name: s for s in signatures(random_tree_robot(2, n=3, base_joint="free"))}
    assert dict(sigs["C"].outputs)["C"] == (9, 9) and dict(sigs["Y"].outputs)["Y"] == (9, 10 + 14 * 3)
    assert sigs["frame_jacobian"].inputs == (("q", 10),) and sigs["frame_drift"].inputs == (("q", 10), ("v", 9))
    assert dict(sigs["centroidal_map"].outputs)["Ag"] == (6, 9)
    assert sigs["tau"].inputs == (("q", 10), ("qd", 9), ("qdd", 9))
    assert dict(sigs["tau_derivatives"].outputs)["dtau_dq"] == (9, 9)
    q = sp.symbols("x y z qx qy qz qw q1", real=True)
    T = tangent_map(q, 7, "free")
    point = dict(zip(q, [1, 2, 3, *np.array([0.1, -0.3, 0.5, 0.8]) / np.linalg.norm([0.1, -0.3, 0.5, 0.8]), 0.4]))
    Tn = np.array(T.subs(point), dtype=float)
    robot = random_tree_robot(1, n=1, base_joint="free")
    qn = np.array([float(point[s]) for s in q])
    v = np.arange(1.0, 8.0)
    from symdyn.model.base_joint import coordinate_rates

    _close(Tn @ v, coordinate_rates(robot, qn, v), "tangent map vs coordinate_rates")
    with pytest.raises(ValueError, match="unknown base joint"):
        tangent_map(q, 7, "spherical")


@pytest.mark.parametrize("target", ["numpy", "c", "casadi"])
def test_derivatives_equal_pinocchios(case, target):
    """∂τ/∂(q, v) and ∂q̈/∂(q, v) of each target against computeRNEADerivatives and
    computeABADerivatives: skipped before any check when Pinocchio is absent."""
    pin = pytest.importorskip("pinocchio", reason="the derivatives are checked against Pinocchio (the test extra)")
    robot, q, qd, a, want = case
    if target == "numpy" and robot.base_joint == "free":
        pytest.skip("the free base's programs are checked through C and CasADi (test_numpy takes the planar one)")
    model = symdyn.load(robot, target)
    model = _EachState(model) if target == "c" and robot.base_joint != "free" else model
    _check_pinocchio(pin, model, robot, q, qd, a, want, target)


@pytest.mark.parametrize("target", ["c-extension", "c-ctypes", "numpy", "casadi"])
def test_a_zero_quaternion_is_refused_by_name_and_any_other_read_by_its_direction(target):
    """A free base's q[3:7] = 0 is no rotation (the generated code would divide by |q|² = 0):
    a ValueError naming it, one state or the state of a batch at fault — as a quaternion so short
    that 2/|q|² overflows; a quaternion of another length gives the unit one's values."""
    from symdyn.codegen.emit.clib import CompileOptions

    robot = random_tree_robot(1, n=2, base_joint="free")
    binding = target.split("-")[1] if target.startswith("c-") else None
    model = symdyn.load(robot, "c", options=CompileOptions(binding=binding)) if binding else symdyn.load(robot, target)
    q = np.tile(robot.integrate(robot.neutral(), np.full(robot.nv, 0.4)), (5, 1))
    v = np.full((5, robot.nv), 0.3)
    for bad in (0.0, 1e-160, 1e-200):  # zero, |q|² subnormal (2/|q|² overflows), |q|² underflowing to 0
        one = q[0].copy()
        one[3:7] *= bad
        with pytest.raises(ValueError, match=r"^tau\(\): the base's quaternion q\[3:7\] is zero \(\|q\|² below"):
            model.tau(one, v[0], v[0])
        many = q.copy()
        many[3, 3:7] *= bad
        with pytest.raises(ValueError, match=r"quaternion q\[3:7\] is zero \(state 3\)"):
            model.tau(many, v, v)
        with pytest.raises(ValueError, match=r"^M\(\): the base's quaternion q\[3:7\] is zero"):
            model.M(one)  # M does not depend on the base's turn, and still refuses no rotation
    scaled = q.copy()
    scaled[:, 3:7] *= 0.5
    _close(model.tau(scaled, v, v), model.tau(q, v, v), "tau with a half-length quaternion")
