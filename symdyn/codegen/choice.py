"""Which derivation each function of a model's code comes from, and the list of its programs.

Each term (τ, M, C, C·q̇, G, F, the bias) takes the derivation whose program
has the fewest operations (Lagrange's trigonometric polynomials give a
compact M, Newton–Euler's recursion a compact τ); forward dynamics, the
derivatives and M⁻¹ are built from the chosen M, bias and τ.
"""

from __future__ import annotations

from typing import Sequence

from ..derivation import engine, progress
from ..derivation.dynamics import Dynamics
from ..model import Robot
from ..derivation.program import Program, dag_size
from .derivatives import (
    christoffel_spec,
    fdyn_derivatives_program,
    minv_factors_spec,
    minv_spec,
    tau_derivatives_spec,
)
from .shipped import is_shipped
from .functions import NAMES, FunctionSpec, SingularMass, candidates, fdyn_spec, regressor_spec
from .contact_functions import ContactSpecs, contact_names, derivatives_program, parts_program
from .task_functions import TaskPrograms

__all__ = ["programs", "Programs", "derivations", "DERIVED"]

#: The functions built from the chosen terms, after them (and Y) in every model's list.
DERIVED = ("tau_derivatives", "fdyn_derivatives", "Minv")


def _cheapest(specs: Sequence[FunctionSpec]) -> tuple[FunctionSpec, Program]:
    """The spec whose program has the fewest operations (the first on ties).

    Specs are built smallest first, by the nodes of their expression DAG; one
    with more than twice as many nodes as the best program so far has
    operations is not built (CSE leaves 0.9–1.7 operations per node here):
    a generic 7-joint arm's expanded Lagrange C would take minutes to CSE
    only to lose to the Newton–Euler recursion.
    """
    sizes = [dag_size(s.outputs, s.definitions) for s in specs]
    best = None
    for k in sorted(range(len(specs)), key=lambda k: (sizes[k], k)):
        if best is not None and sizes[k] > 2 * best[0]:
            continue
        program = specs[k].program()
        candidate = (program.op_count()["total"], k, specs[k], program)
        best = candidate if best is None else min(best, candidate, key=lambda c: c[:2])
    return best[2], best[3]


def _engine(robot: Robot) -> str:
    """The engine a model's programs are built with (`symdyn.derivation.engine`): sympy for the
    shipped models, whose code in generated/ is pinned byte for byte, SymEngine for any other."""
    return "sympy" if is_shipped(robot) else "symengine"


def derivations(robot: Robot) -> tuple[list, list[str]]:
    """(derivations, their labels) that code generation chooses from: Newton–Euler on the
    regrouped base parameters when the robot is numeric (a floating base: on the full
    parameters where derive refuses to regroup it), and Lagrange where its expanded form
    may be leaner (up to six joints on a fixed base; a floating base's Lagrange is named: 3–6× Newton–Euler's τ on random trees).

    Raises:
        NotImplementedError: what derive refuses besides regrouping a floating base.
    """
    from ..derivation.entry import EXPANDED_MAX_JOINTS, derive

    regroup = not robot.is_symbolic
    try:
        dyns = [derive(robot, "newton-euler", regroup=regroup)]
    except NotImplementedError:  # a floating base without base parameters (yet): the full parameters
        if robot.base_joint is None or not regroup:
            raise
        regroup = False
        dyns = [derive(robot, "newton-euler")]
    origins = ["newton-euler, base parameters" if regroup else "newton-euler"]
    if (
        robot.base_joint is None and robot.n <= EXPANDED_MAX_JOINTS
    ):  # Lagrange's expanded M can be the leanest; named, it never is
        dyns.append(derive(robot, "lagrange"))
        origins.append("lagrange")
    return dyns, origins


class Programs:
    """Every function's program, each built when first asked for (with what it needs), then kept.

    The task-space functions (`symdyn.derivation.task_space.functions`: frames, centre of
    mass, centroidal momentum) come last, from the task-space derivation of the robot's frames.
    The terms tau, M, C, Cqd, G, F and the bias take the derivation whose program has
    the fewest operations (the first on ties); fdyn, the derivatives and M⁻¹ are built
    from the chosen M, bias and τ; Y from `regressor` (a `Regressor`, or a callable
    returning one: it is only built when Y is asked for).  `origins`: a label per
    derivation for the generated files (default: their methods).  A floating base
    (`Robot.base_joint`) adds its velocities' brackets to C (`christoffel_spec`), its Y has the base
    body's ten columns first, and its ∂τ/∂q is taken in the tangent space
    (`tau_derivatives_spec`).
    """

    def __init__(self, dyns: Sequence[Dynamics], regressor=None, origins: Sequence[str] | None = None) -> None:
        if not dyns:
            raise ValueError("programs() needs at least one derivation")
        self.dyns = list(dyns)
        self.tree = not self.dyns[0].robot.is_chain  # M's LDLᵀ leaves first (functions.elimination_order)
        self.base_joint = self.dyns[0].robot.base_joint
        self.cands = [candidates(d, o) for d, o in zip(dyns, origins or [None] * len(dyns))]
        self.regressor = regressor
        self.task = TaskPrograms(self.dyns[0].robot, self.dyns[0].params)
        self.contacts = contact_names(self.dyns[0].robot)
        self.names = (
            *NAMES,
            *(("Y",) if self.regressor is not None else ()),
            *DERIVED,
            *self.task.names,
            *self.contacts,
        )
        self._chosen: dict[str, tuple[FunctionSpec, Program]] = {}
        self._built: dict[str, Program] = {}
        self._specs: dict[str, FunctionSpec] = {}
        self.engine = _engine(self.dyns[0].robot)

    def chosen(self, term: str) -> tuple[FunctionSpec, Program]:
        """(spec, program) of a term (tau, M, C, Cqd, G, F, bias) from the derivation that
        gives the fewest operations."""
        if term not in self._chosen:
            with engine.use(self.engine):
                extra = [christoffel_spec(c["Cqd"], c["M"], self.base_joint) for c in self.cands] if term == "C" else []
                self._chosen[term] = _cheapest([c[term] for c in self.cands if term in c] + extra)
        return self._chosen[term]

    def program(self, name: str) -> Program:
        """The program of one function (KeyError for a name not in `names`)."""
        if name not in self.names:
            raise KeyError(f"no function {name!r}: the functions are {', '.join(self.names)}")
        if name not in self._built:
            with engine.use(self.engine):
                self._built[name] = self._build(name)
        return self._built[name]

    def _build(self, name: str) -> Program:
        if name in self.task.names:
            return self.task.program(name)
        if name in self.contacts:
            return self._contact(name)
        if name in ("tau", "M", "C", "Cqd", "G", "F"):
            return self.chosen(name)[1]
        if name == "fdyn":
            return fdyn_spec(self.chosen("M")[0], self.chosen("bias")[0], tree=self.tree).program()
        if name == "Y":
            reg = self.regressor() if callable(self.regressor) else self.regressor
            return regressor_spec(reg, self.dyns[0]).program()
        if name == "tau_derivatives":
            return tau_derivatives_spec(self.chosen("tau")[0], self.base_joint).program()
        if name == "Minv":
            return self._minv().program()
        shared = self._shared_minv()  # M's terms and factor: fdyn's too
        return fdyn_derivatives_program(
            self.program("fdyn"), self.program("tau_derivatives"), self.program("Minv"), shared
        )

    def _contact_specs(self) -> ContactSpecs:
        if "contacts" not in self._specs:
            M, bias = self.chosen("M")[0], self.chosen("bias")[0]
            self._specs["contacts"] = ContactSpecs(self.dyns[0].robot, M, bias, tree=self.tree)
        return self._specs["contacts"]

    def _contact(self, name: str) -> Program:
        """A contact function's program: the dynamics from the chosen M and bias, their derivatives
        spliced from it, the residuals' Jacobians (from the chosen τ) and the KKT solve."""
        specs = self._contact_specs()
        kind = "fdyn" if name.startswith("contact_fdyn") else "impulse"
        if not name.endswith("_derivatives"):
            return specs.dynamics(kind).program()
        solve = specs.solve(2 * specs.n, identity=kind == "fdyn").program()
        return derivatives_program(
            kind, self.program(f"contact_{kind}"), self._residual(kind), solve, specs.shared(), self.dyns[0].robot
        )

    def _residual(self, kind: str) -> Program:
        key = f"residual_{kind}"
        if key not in self._built:
            with engine.use(self.engine):
                residual = self._contact_specs().residual(kind, self.chosen("tau")[0], self.base_joint)
                self._built[key] = residual.program()
        return self._built[key]

    def parts(self, name: str) -> Program:
        """A contact derivatives function's KKT parts (`contact_functions.parts_program`): what the
        C target's dense products start from, instead of `program(name)`'s unrolled solve."""
        if not (name in self.contacts and name.endswith("_derivatives")):
            raise KeyError(f"{name!r} is not a contact derivatives function of this model")
        key = f"parts_{name}"
        if key not in self._built:
            specs = self._contact_specs()
            kind = "fdyn" if name.startswith("contact_fdyn") else "impulse"
            vectors = self.tangents(name)
            residual = vectors[0] if vectors else self._residual(kind)
            dynamics, minv = self.program(f"contact_{kind}"), self._minv_factors() if vectors else self.program("Minv")
            with engine.use(self.engine):
                blocks = specs.blocks(rows=vectors is not None).program()
                self._built[key] = parts_program(
                    kind, dynamics, residual, minv, blocks, specs.shared() | self._shared_minv(), self.dyns[0].robot
                )
        return self._built[key]

    def tangents(self, name: str) -> tuple | None:
        """(the partials' program, its `tangents.Plan`, {direction: column of R}) of a contact
        derivatives function whose residuals' Jacobians the C target makes in vectors
        (`ContactSpecs.tangents`); None where it cannot (then `parts` holds R itself)."""
        key = f"tangents_{name}"
        if key not in self._built:
            kind = "fdyn" if name.startswith("contact_fdyn") else "impulse"
            with engine.use(self.engine):
                made = self._contact_specs().tangents(kind, self.chosen("tau")[0], self.base_joint)
                self._built[key] = None if made is None else (made[0].program(), *made[1:])
        return self._built[key]

    def _minv_factors(self) -> Program:
        """M⁻¹'s factors L⁻¹ and D⁻¹L⁻¹ (`minv_factors_spec`), for the C target's vector products."""
        if "Minv_factors" not in self._built:
            with engine.use(self.engine):
                self._built["Minv_factors"] = minv_factors_spec(self.chosen("M")[0], tree=self.tree).program()
        return self._built["Minv_factors"]

    def _shared_minv(self) -> frozenset:
        return frozenset(s for s, _ in self._minv().definitions)

    def _minv(self) -> FunctionSpec:
        if "Minv" not in self._specs:
            self._specs["Minv"] = minv_spec(self.chosen("M")[0], tree=self.tree)
        return self._specs["Minv"]

    def all(self, label: str = "") -> tuple[list[Program], dict[str, str]]:
        """(every function's program in the order of `names`, {function: why it is absent}): a
        robot whose M(q) is singular for every q (one read for its kinematics) has no forward
        dynamics, M⁻¹ or contact functions, and says so; its other functions are built.  A job over
        REPORT_AFTER_S says on stderr which function it is at and about how long is left (`label`)."""
        bar = progress.Progress(label or "symdyn: programs", len(self.names), after=progress.REPORT_AFTER_S)
        out, absent = [], {}
        for name in self.names:
            try:
                out.append(self.program(name))
            except SingularMass as exc:
                absent[name] = str(exc)
            bar.step(name)
        bar.done()
        return out, absent


def programs(
    dyns: Sequence[Dynamics], regressor=None, origins: Sequence[str] | None = None, label: str = ""
) -> tuple[list[Program], dict[str, str]]:
    """The programs of tau, M, C, Cqd, G, F, fdyn (and Y when `regressor` is given),
    tau_derivatives, fdyn_derivatives, Minv and the task space, and those absent (`Programs.all`)."""
    return Programs(dyns, regressor, origins).all(label)
