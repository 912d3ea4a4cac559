"""Fixed-base trees (issue 35): every derivation and every emitted target reads the parents.

Random trees are random arms (`random_arm`: standard, modified and general convention,
revolute and prismatic joints, motors, friction, tool, payload) whose links are hung on
random earlier links or on the base.  Lagrange (expanded and named) and Newton–Euler
(plain and on base parameters) agree exactly at rational points; M's entries between
branches are literal zeros that cost no operation; the base parameters are exact against
the regressor's rank; the generated NumPy, C and CasADi functions agree with the reference;
and a planar two-arm tree prints the closed form a reader derives by hand.
"""

import dataclasses
import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from symdyn.codegen import entry as codegen
from symdyn.codegen.functions import candidates
from symdyn.derivation import kinematics
from symdyn.derivation.entry import derive
from symdyn.derivation.exact import compile_exact
from symdyn.derivation.symbols import joint_symbols
from symdyn.derivation.lagrange_dag import derive as lagrange_dag
from symdyn.derivation.regressor import base_parameters, parameter_values
from symdyn.model import Link, Robot, rotx
from symdyn.model.placement import placement
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref
from symdyn.presentation.printing import closed_form, elements

from conftest import random_states
from exact_eval import exact_value, random_point
from test_regressor import assert_exact_base_parameters
from tests.conftest import tiered

SMALL = ArmOptions(n_min=3, n_max=5, symbolic=0.0)
GENERAL = ArmOptions(n_min=3, n_max=5, symbolic=0.0, general=1.0)


def random_tree(seed: int, options: ArmOptions = SMALL, *, offsets: bool = True) -> Robot:
    """`random_arm(seed)` (3 joints or more) with each link hung on the link before it (40 %)
    or on a random earlier link or the base, never all on the link before; offsets=False zeroes the joint offsets (exact points need
    cos qᵢ, sin qᵢ alone: cos(q + π/3) has no rational value)."""
    arm = random_arm(seed, options)
    rng = random.Random(seed + 1000)
    links = []
    for i, link in enumerate(arm.links):
        parent = i - 1 if rng.random() < 0.4 else rng.randrange(-1, i)
        links.append(dataclasses.replace(link, parent=parent, offset=link.offset if offsets else 0))
    if all(link.parent == i - 1 for i, link in enumerate(links)):  # drawn a chain: the last link on the base
        links[-1] = dataclasses.replace(links[-1], parent=-1)
    return dataclasses.replace(arm, links=tuple(links), name=f"tree{seed}")


def related(robot: Robot) -> set:
    """Pairs (i, j) of joints one of which hangs from the other (i == j included)."""
    return {(a, b) for b in range(robot.n) for a in kinematics.ancestors(robot.parents, b)} | {
        (b, a) for b in range(robot.n) for a in kinematics.ancestors(robot.parents, b)
    }


def two_arms(symbolic: bool = False) -> Robot:
    """Two planar two-link arms on one base (Corke's two-link arm, Eq. 9.3, twice): the
    second arm's first joint on the base, like the first's; links 1-2 and 3-4."""
    if symbolic:
        a = sp.symbols("a1:5", real=True)
        c = sp.symbols("c1:5", real=True)
        m = sp.symbols("m1:5", real=True)
        g = sp.Symbol("g", real=True)
    else:
        a, c, m, g = (1.0, 0.8, 0.7, 0.9), (-0.5, -0.4, -0.3, -0.45), (2.0, 1.5, 1.2, 1.1), 9.81
    inertia = lambda i: ((0, 0, 0),) * 3 if symbolic else np.diag([0.01 + 0.01 * i, 0.02, 0.025 + 0.01 * i])  # noqa: E731
    links = tuple(Link(a=a[i], m=m[i], r=(c[i], 0, 0), I=inertia(i), parent=p) for i, p in enumerate((-1, 0, -1, 2)))
    return Robot("twoarms", links, gravity=(0, 0, g), base=rotx(sp.pi / 2))


def branch(robot: Robot, joints) -> Robot:
    """The chain of `joints` (each hanging on the one before) cut out of a tree."""
    links = tuple(dataclasses.replace(robot.links[j], parent=None) for j in joints)
    return dataclasses.replace(robot, links=links, name=f"{robot.name}_branch", poses={})


# --------------------------------------------------------------------------- derive


def test_a_tree_is_derived():
    tree = two_arms()
    assert not tree.is_chain and tree.parents == (-1, 0, -1, 2)
    for method in ("newton-euler", "lagrange"):
        assert derive(tree, method).M.shape == (4, 4)


def _exact_evaluators(dyns: dict, terms) -> tuple[dict, list]:
    """{label: a function of the exact inputs}, the inputs: every sin/cos atom of the
    derivations (cos q1, sin(q1 + q2) of the expanded Lagrange, …), q, q̇, q̈ and sgn q̇."""
    plain = next(iter(dyns.values()))
    q, qd, qdd = plain.q, plain.qd, plain.qdd
    signs = {sp.sign(v): sp.Dummy() for v in qd}
    flats = {
        label: (
            [(s, e.xreplace(signs)) for s, e in dyn.definitions],
            [x.xreplace(signs) for t in terms for x in dyn.named.get(t, dyn.term(t))],
        )
        for label, dyn in dyns.items()
    }
    atoms = set()
    for definitions, outputs in flats.values():
        for e in [e for _, e in definitions] + outputs:
            atoms |= sp.sympify(e).atoms(sp.sin, sp.cos)
    inputs = sorted(atoms, key=sp.default_sort_key) + list(q) + list(qd) + list(qdd) + list(signs.values())
    return {label: compile_exact(d, o, inputs) for label, (d, o) in flats.items()}, inputs


def _exact_point(robot: Robot, inputs: list, rng: random.Random) -> list:
    """Exact values of the inputs of `_exact_evaluators` at a random rational point."""
    q, qd, _ = joint_symbols(robot.n)
    angles, values = random_point(robot, rng)
    for i, x in enumerate(q):
        values[x] = Fraction(rng.randint(-30, 30), 10)  # a prismatic joint's q itself
    out = []
    for x in inputs:
        if isinstance(x, (sp.sin, sp.cos)):
            out.append(Fraction(str(exact_value(x, q, angles, {}))))
        elif x in values:
            out.append(values[x])
        else:  # sgn q̇ᵢ
            v = values[qd[len(out) - (len(inputs) - robot.n)]]
            out.append(Fraction((v > 0) - (v < 0)))
    return out


def _exact_differences(dyns: dict, robot: Robot, terms, points: int, seed: int) -> dict:
    """Every derivation's `terms` at exact rational points minus the first derivation's:
    {label: largest |difference|}."""
    evaluators, inputs = _exact_evaluators(dyns, terms)
    rng = random.Random(seed)
    first = next(iter(dyns))
    worst = dict.fromkeys(dyns, Fraction(0))
    for _ in range(points):
        args = _exact_point(robot, inputs, rng)
        expected = evaluators[first](*args)
        assert all(isinstance(x, (Fraction, int)) for x in expected)
        for label, evaluate in evaluators.items():
            worst[label] = max(worst[label], *(abs(x - y) for x, y in zip(evaluate(*args), expected)))
    return worst


@pytest.mark.parametrize("seed", tiered([3, 13, 5, 10, 11, 21], 1))
@pytest.mark.parametrize("options", [SMALL, GENERAL], ids=["dh", "general"])
def test_lagrange_and_newton_euler_agree_exactly_on_random_trees(seed, options):
    """Lagrange's energy route (expanded trigonometric polynomials and named intermediates)
    and the Newton–Euler recursion (plain and on regrouped base parameters) give the same
    τ, M, G, C·q̇ and F at exact rational points: the difference is 0, not small."""
    robot = random_tree(seed, options, offsets=False)
    assert not robot.is_chain
    dyns = {
        "newton-euler": derive(robot, "newton-euler"),
        "newton-euler regrouped": derive(robot, "newton-euler", regroup=True),
        "lagrange": derive(robot, "lagrange"),
        "lagrange named": lagrange_dag(robot),
    }
    terms = ("tau", "M", "G", "Cqd", "F")
    assert _exact_differences(dyns, robot, terms, points=2, seed=seed) == dict.fromkeys(dyns, 0)


def test_christoffel_c_of_both_routes_agree_exactly_on_a_tree():
    """C, not only C·q̇: the Christoffel symbols of joints on different branches are 0
    (the recursion skips their passes) and the rest agree with Lagrange's."""
    robot = random_tree(13, GENERAL, offsets=False)
    dyns = {"newton-euler": derive(robot, "newton-euler"), "lagrange": derive(robot, "lagrange")}
    assert _exact_differences(dyns, robot, ("C",), points=2, seed=4) == dict.fromkeys(dyns, 0)


# --------------------------------------------------------------------------- M's zeros


@pytest.mark.parametrize("seed", tiered([13, 5, 21], 1))
def test_m_between_branches_is_a_literal_zero_in_every_derivation(seed):
    robot = random_tree(seed, GENERAL)
    apart = [(i, j) for i in range(robot.n) for j in range(robot.n) if (i, j) not in related(robot)]
    assert apart, robot.parents
    dyns = [
        derive(robot, "newton-euler"),
        derive(robot, "newton-euler", regroup=True),
        derive(robot, "lagrange"),
        lagrange_dag(robot),
    ]
    for dyn in dyns:
        named = dyn.named.get("M", dyn.M)
        assert all(named[i, j] is sp.S.Zero for i, j in apart), dyn.method
        assert all(dyn.M[i, j] is sp.S.Zero for i, j in apart), dyn.method
    C = dyns[0].named["C"]  # the Christoffel C of the full recursion: C_ij = Σ_k Γ_ijk q̇_k
    assert all(C[i, j] is sp.S.Zero for i, j in apart)


def _ops(robot: Robot, term: str, method: str = "newton-euler") -> int:
    dyn = derive(robot, method, regroup=method == "newton-euler")
    return candidates(dyn)[term].program().op_count()["total"]


@pytest.mark.parametrize("method", ["newton-euler", "lagrange"])
def test_two_arms_on_one_base_cost_what_the_two_arms_cost(method):
    """M's cross-branch block costs nothing: the tree's M (and τ, G) program has exactly the
    operations of the two arms' programs as separate chains, and its cross entries are 0."""
    tree = two_arms()
    arms = [branch(tree, (0, 1)), branch(tree, (2, 3))]
    for term in ("M", "tau", "G"):
        assert _ops(tree, term, method) == sum(_ops(arm, term, method) for arm in arms), term
    dyn = derive(tree, method, regroup=method == "newton-euler")
    program = candidates(dyn)["M"].program()
    M = dict(program.outputs)["M"]
    assert all(M[i, j] == 0 for i in (0, 1) for j in (2, 3)) and all(M[j, i] == 0 for i in (0, 1) for j in (2, 3))


def torso() -> Robot:
    """Two 2-joint arms on a shared torso joint (general convention): links 1, then 2-3 and 4-5."""

    def shoulder(side):
        return Link(
            origin=placement((0, side * 0.2, 0.4), (side * np.pi / 2, 0, 0)),
            m=2.0,
            r=(0.15, 0, 0),
            I=np.diag([0.01, 0.03, 0.03]),
            parent=0,
        )

    elbow = Link(
        origin=placement((0.3, 0, 0), (0, 0, 0)), axis=(0, 1, 0), m=1.0, r=(0.1, 0, 0), I=np.diag([0.005, 0.01, 0.01])
    )
    trunk = Link(origin=placement((0, 0, 0.3), (0, 0, 0)), m=5.0, r=(0, 0, 0.1), I=np.diag([0.1, 0.1, 0.05]))
    return Robot("torso", (trunk, shoulder(1), elbow, shoulder(-1), elbow), convention="general")


def _programs(robot: Robot) -> dict:
    """Operations of each generated function's program, as `load(robot, target)` makes them."""
    from symdyn.codegen.choice import Programs, derivations

    programs = Programs(*derivations(robot))
    return {name: programs.program(name).op_count()["total"] for name in ("tau", "M", "G", "fdyn", "Minv")}


def test_a_torso_tree_costs_less_than_its_branches_as_chains():
    """The torso is computed once and the cross block never: the tree's τ, fdyn and M⁻¹ cost
    less than the two torso-plus-arm chains together, and M and G no more.  M's LDLᵀ takes
    the leaves first (Featherstone's LTDL): no fill-in between the arms."""
    tree = torso()
    assert tree.parents == (-1, 0, 1, 0, 3)
    ops = _programs(tree)
    chains = [_programs(branch(tree, (0, 1, 2))), _programs(branch(tree, (0, 3, 4)))]
    for name in ("tau", "fdyn", "Minv"):
        assert ops[name] < sum(chain[name] for chain in chains), name
    for name in ("M", "G"):
        assert ops[name] <= sum(chain[name] for chain in chains), name


# --------------------------------------------------------------------------- base parameters


@pytest.mark.parametrize("seed", tiered([3, 13, 21], 2))
def test_base_parameters_of_trees_are_exact(seed):
    """Khalil's rules hand what a joint cannot move to the parent link (the fixed base for
    links on it) and the rank analysis does the rest: as many independent columns as the
    symbolic regressor's rank at fresh rational points, and Y·β_regrouped = Y·π exactly."""
    robot = random_tree(seed, GENERAL)
    assert not robot.is_chain
    assert_exact_base_parameters(robot, base_parameters(robot), 40 // robot.n + 2, seed=100 + seed)


def test_two_arms_have_the_base_parameters_of_the_two_arms():
    tree = two_arms()
    counts = [len(base_parameters(arm).independent) for arm in (branch(tree, (0, 1)), branch(tree, (2, 3)))]
    assert len(base_parameters(tree).independent) == sum(counts)


# --------------------------------------------------------------------------- kinematics


def test_the_tool_jacobian_of_a_tree_is_that_of_the_last_links_branch():
    tree = random_tree(13, SMALL)
    path = sorted(kinematics.ancestors(tree.parents, tree.n - 1))
    chain = branch(tree, path)
    q = sp.symbols(f"q1:{tree.n + 1}", real=True)
    J = kinematics.jacob0(tree, q)
    Jc = kinematics.jacob0(chain, [q[j] for j in path])
    for col in range(tree.n):
        expected = Jc[:, path.index(col)] if col in path else sp.zeros(6, 1)
        assert (J[:, col] - expected).applyfunc(sp.expand) == sp.zeros(6, 1)
    assert (kinematics.fkine(tree, q) - kinematics.fkine(chain, [q[j] for j in path])).applyfunc(sp.expand) == sp.zeros(
        4, 4
    )


# --------------------------------------------------------------------------- generated code

STATES = 200
RTOL = 1e-10


def _close(got, expected, what):
    got = np.asarray(got, dtype=float).reshape(expected.shape)
    scale = max(1.0, float(np.abs(expected).max()))
    err = float(np.abs(got - expected).max()) / scale
    assert err <= RTOL, f"{what}: relative error {err:.2e} > {RTOL:.0e}"


TREES = {
    "two-arms": two_arms,
    "random-13": lambda: random_tree(13, GENERAL),
    "torso": torso,
    "random-11-dh": lambda: random_tree(11, SMALL),  # standard DH
    "random-5-mdh": lambda: random_tree(5, SMALL),  # modified DH, prismatic joints
}


# the two arms and the torso in the main suite; random-5-mdh, random-13 and random-11-dh: make test-all
@pytest.fixture(scope="module", params=tiered(["two-arms", "torso", "random-5-mdh", "random-13", "random-11-dh"], 2))
def tree(request):
    robot = TREES[request.param]()
    q, qd, qdd = random_states(robot, STATES, seed=7)
    tau = ref.rne(robot, q, qd, qdd)
    return robot, (q, qd, qdd, tau)


#: Trees whose C is compiled too (the C target prints the NumPy target's programs; a compile of
#: every function costs seconds per tree, so the others check NumPy and CasADi only).
C_TREES = ("torso", "random-5-mdh")


@pytest.mark.parametrize("target", ["numpy", "casadi"])
def test_generated_functions_of_a_tree_agree_with_the_reference(tree, target):
    _check_generated(*tree, target)


# make test-all: the C of a tree is in the main suite on a smaller one, two joints on a planar base
# (tests/test_floating_codegen.py::test_c_scalar_and_batched), and the torso's C derivatives here
@pytest.mark.slow
@pytest.mark.parametrize("name", C_TREES)
def test_generated_c_of_a_tree_agrees_with_the_reference(name):
    robot = TREES[name]()
    q, qd, qdd = random_states(robot, STATES, seed=7)
    _check_generated(robot, (q, qd, qdd, ref.rne(robot, q, qd, qdd)), "c")


def _check_generated(robot, states, target):
    q, qd, qdd, tau = states
    f = codegen.load(robot, target)
    C = ref.coriolis(robot, q, qd)
    M = ref.inertia(robot, q)
    expected = {
        "tau": ((q, qd, qdd), tau),
        "M": ((q,), M),
        "C": ((q, qd), C),
        "Cqd": ((q, qd), np.einsum("skj,sj->sk", C, qd)),
        "G": ((q,), ref.gravload(robot, q)),
        "F": ((qd,), ref.friction(robot, qd)),
        "fdyn": ((q, qd, tau), ref.accel(robot, q, qd, tau)),
        "Minv": ((q,), np.linalg.inv(M)),
    }
    for name, (args, value) in expected.items():
        _close(getattr(f, name)(*args), value, f"{robot.name} {target} {name}")
    pi = np.array([float(v) for v in parameter_values(robot)])
    Y = np.asarray(f.Y(q, qd, qdd)).reshape(STATES, robot.n, pi.size)
    _close(Y @ pi, tau, f"{robot.name} {target} Y·π")


def _central(f, x, h=1e-6):
    """∂f/∂x by central differences, (states, outputs, inputs)."""
    cols = []
    for k in range(x.shape[1]):
        e = np.zeros_like(x)
        e[:, k] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.stack(cols, -1)


def test_generated_derivatives_of_a_tree_agree_with_differences_of_the_reference(tree, request):
    robot, (q, qd, qdd, tau) = tree
    f = codegen.load(robot, "c" if request.node.callspec.params["tree"] in C_TREES else "numpy")
    value, dq, dqd = f.tau_derivatives(q, qd, qdd)
    _close(value, tau, "tau")
    for got, expected in (
        (dq, _central(lambda x: ref.rne(robot, x, qd, qdd), q)),
        (dqd, _central(lambda x: ref.rne(robot, q, x, qdd), qd)),
    ):
        err = np.abs(got - expected).max() / max(1.0, np.abs(expected).max())
        assert err < 1e-6, err
    qdd_, dq, dqd, Minv = f.fdyn_derivatives(q, qd, tau)
    _close(qdd_, qdd, "qdd")
    _close(Minv, np.linalg.inv(ref.inertia(robot, q)), "Minv")
    for got, expected in (
        (dq, _central(lambda x: ref.accel(robot, x, qd, tau), q)),
        (dqd, _central(lambda x: ref.accel(robot, q, x, tau), qd)),
    ):
        err = np.abs(got - expected).max() / max(1.0, np.abs(expected).max())
        assert err < 1e-5, err


# --------------------------------------------------------------------------- printing


def test_two_arms_print_the_closed_form_of_eq_9_3_twice():
    """The two arms' M is block diagonal (M13 = M14 = M23 = M24 = 0) and each block is
    Eq. 9.3's: M11 = m1(a1 + c1)² + m2(a1² + (a2 + c2)² + 2a1(a2 + c2)cos q2), by hand."""
    dyn = derive(two_arms(symbolic=True), "newton-euler")
    M = dict(elements(dyn, "M"))
    assert {M[k] for k in ("M13", "M14", "M23", "M24")} == {0}
    a1, a2, a3, a4, c1, c2, c3, c4, m1, m2, m3, m4 = sp.symbols("a1 a2 a3 a4 c1 c2 c3 c4 m1 m2 m3 m4", real=True)
    q2, q4 = dyn.q[1], dyn.q[3]
    hand = {
        "M11": m1 * (a1 + c1) ** 2 + m2 * (a1**2 + (a2 + c2) ** 2 + 2 * a1 * (a2 + c2) * sp.cos(q2)),
        "M33": m3 * (a3 + c3) ** 2 + m4 * (a3**2 + (a4 + c4) ** 2 + 2 * a3 * (a4 + c4) * sp.cos(q4)),
        "M34": m4 * ((a4 + c4) ** 2 + a3 * (a4 + c4) * sp.cos(q4)),
    }
    for name, expr in hand.items():
        assert sp.expand(M[name] - expr) == 0, name
    text = closed_form(dyn, ("M", "G"), "text")
    assert "M13 = 0" in text and "M24 = 0" in text
    assert "cos(q3 + q4)" in text and "cos(q1 + q2)" in text  # each arm's natural angle


def test_the_plain_casadi_rnea_reads_trees_and_refuses_floating_bases(tree):
    """The baseline CasADi RNEA (symdyn.numeric.casadi_rnea) follows the parents as well."""
    from symdyn.numeric import casadi_rnea

    robot, (q, qd, qdd, tau) = tree
    f = casadi_rnea.functions(robot)
    got = np.array([np.array(f.tau(*row)).ravel() for row in zip(q[:20], qd[:20], qdd[:20])])
    _close(got, tau[:20], f"{robot.name} casadi_rnea tau")
    M = np.array([np.array(f.M(x)) for x in q[:20]])
    _close(M, ref.inertia(robot, q[:20]), f"{robot.name} casadi_rnea M")
    with pytest.raises(NotImplementedError, match="fixed base"):
        casadi_rnea.functions(dataclasses.replace(robot, base_joint="planar"))
