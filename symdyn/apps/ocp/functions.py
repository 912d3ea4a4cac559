"""The dynamics an optimal-control problem is posed on: an arm's CasADi functions (`ArmFunctions`),
from symdyn's generated code or a plain recursion traced into CasADi (`dynamics`, SOURCES), and the
compiled integrator step."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca

from ...derivation.progress import reported
from ...model import Robot
from ...numeric import casadi_rnea

SOURCES = ("symdyn", "plain")


@dataclass(frozen=True)
class ArmFunctions:
    """CasADi dynamics of one arm: tau(q, qd, qdd) -> τ (needed by collocation) and
    fdyn(q, qd, tau) -> q̈ (needed by multiple shooting); either may be None.

    Raises:
        ValueError: neither tau nor fdyn, or one that is not a `casadi.Function` of
            3 inputs and 1 output.
    """

    tau: ca.Function | None
    fdyn: ca.Function | None
    source: str = "custom"
    compiled: bool = False
    fdyn_sx: ca.Function | None = None  # the SX fdyn compiled ones come from: the shooting step's
    #: (q, q̇, τ) → (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹) on SX when the source generates it (symdyn's
    #: `fdyn_derivatives`); else the shooting step takes CasADi's AD of fdyn_sx.
    fdyn_derivatives_sx: ca.Function | None = None
    name: str = ""  # the arm's, for progress lines
    #: (q, v) → q̇ of a planar base, whose velocities are in its own frame (`planar_rates`);
    #: None: q̇ = v.
    rates: ca.Function | None = None

    def shooting_step(self, substeps: int) -> ca.Function:
        """(q, q̇, τ, h) → (q⁺, q̇⁺), `substeps` RK4 steps: compiled with explicit Jacobian and
        Hessian (`ocp_step.rk4_step`, built once into the cache) when these dynamics are
        compiled from SX and q̇ = v, else CasADi's AD through the RK4 stages."""
        if self.compiled and self.fdyn_sx is not None and self.rates is None:
            return _compiled_step(self.fdyn_sx, self.n, substeps, self.fdyn_derivatives_sx, self.name)
        return _rk4_step(self.need("multiple-shooting"), self.n, substeps, self.rates)

    @property
    def label(self) -> str:
        """The source and how it is evaluated, e.g. "symdyn compiled", "plain SX"."""
        return f"{self.source} {'compiled' if self.compiled else 'SX'}"

    def __post_init__(self) -> None:
        if self.tau is None and self.fdyn is None:
            raise ValueError("ArmFunctions needs tau(q, qd, qdd), fdyn(q, qd, tau) or both")
        for name in ("tau", "fdyn"):
            f = getattr(self, name)
            if f is not None and (f.n_in() != 3 or f.n_out() != 1):
                raise ValueError(f"{name} must be a casadi.Function of 3 inputs and 1 output, got {f}")

    @property
    def n(self) -> int:
        return (self.tau or self.fdyn).size1_in(0)

    def need(self, method: str) -> ca.Function:
        """The function `method` transcribes: fdyn for multiple shooting, else tau."""
        name = "fdyn" if method == "multiple-shooting" else "tau"
        if getattr(self, name) is None:
            raise ValueError(f"{method} needs the {name} function, but this {self.source!r} dynamics has none")
        return getattr(self, name)


@functools.lru_cache(maxsize=16)
def dynamics(robot: Robot, source: str = "symdyn", *, compiled: bool = True) -> ArmFunctions:
    """The arm's inverse and forward dynamics as CasADi Functions, friction included
    (pass `robot.nofriction()` to drop the non-smooth Coulomb term).

    source="symdyn": symdyn's simplified generated functions
    (`symdyn.load(robot, target="casadi")`, derived and cached on first use for
    a robot that is not shipped); "plain": the unsimplified SX Newton–Euler of
    `symdyn.numeric.casadi_rnea`.  compiled=True (the default): each function is
    a `casadi.external` on compiled C, with its Jacobian and the Hessian of λᵀf
    compiled beside it (`symdyn.codegen.emit.casadi.compiled`, built once into
    the cache, ~15 s for the Puma's fdyn), and multiple shooting's whole interval
    is compiled with explicit derivatives (`ArmFunctions.shooting_step`);
    compiled=False: CasADi's SX virtual machine and its AD at every evaluation
    (no compiler needed).  A step that takes over `progress.REPORT_AFTER_S` (a
    first build; not a read from the cache) says what it builds on stderr, and
    how long it took (`symdyn.derivation.progress.reported`).

    A planar base (`Robot.base_joint`) adds its coordinates' rates (`planar_rates`): q and v
    both have nq = nv entries, v's base part in the base's own frame; whether the base is
    driven is the problem's (`Problem.unactuated`).

    Returns:
        An `ArmFunctions` (cached per robot, source and compiled).

    Raises:
        ValueError: an unknown source, or an arm whose code cannot be derived or
            generated (a symbolic robot); a free base (q has 7 base entries, v 6: not
            transcribed) or source="plain" on a floating base.
        RuntimeError: compiled=True without a C compiler, or a failed build.
    """
    from ...codegen.emit.casadi import compiled as compile_function

    if robot.base_joint == "free":
        raise ValueError(
            f"ocp.dynamics({robot.name!r}): a free base is not transcribed (its quaternion makes q 7 "
            "entries long and v 6); a planar base is, and any fixed base"
        )
    if robot.base_joint is not None and source == "plain":
        raise ValueError(f"ocp.dynamics({robot.name!r}): the plain source has no floating base: use source='symdyn'")
    rates = planar_rates(robot) if robot.base_joint == "planar" else None
    derivatives = None
    if source == "plain":
        tau, fdyn = casadi_rnea.rnea_function(robot), casadi_rnea.fdyn_function(robot)
    elif source == "symdyn":
        from ...codegen import entry as codegen

        with reported(f"ocp {robot.name}: symdyn's CasADi functions (derived and generated once, into the cache)"):
            f = codegen.load(robot, "casadi")
        tau, fdyn, derivatives = (f.functions[k] for k in ("tau", "fdyn", "fdyn_derivatives"))
    else:
        raise ValueError(f"unknown dynamics source {source!r}: expected one of {SOURCES}")
    if compiled:
        built = []
        for name, f in (("tau", tau), ("fdyn", fdyn)):
            with reported(
                f"ocp {robot.name}: compiling {name} ({source}) with its Jacobian and Hessian (once, into the cache)"
            ):
                built.append(compile_function(f))
        return ArmFunctions(*built, source, True, fdyn, derivatives, robot.name, rates)
    return ArmFunctions(tau, fdyn, source, False, name=robot.name, rates=rates)


def planar_rates(robot: Robot) -> ca.Function:
    """(q, v) → q̇ of a robot on a planar base: ẋ, ẏ = R(yaw)·(vx, vy), the yaw rate ω and the
    joints' q̇ = v (`symdyn.model.base_joint.coordinate_rates`, in CasADi).

    Raises:
        ValueError: a robot whose base is not planar.
    """
    if robot.base_joint != "planar":
        raise ValueError(f"planar_rates({robot.name!r}): its base is {robot.base_joint or 'fixed'}, not planar")
    q, v = ca.SX.sym("q", robot.nq), ca.SX.sym("v", robot.nv)
    c, s = ca.cos(q[2]), ca.sin(q[2])
    qd = ca.vertcat(c * v[0] - s * v[1], s * v[0] + c * v[1], v[2:])
    return ca.Function("rates", [q, v], [qd], ["q", "v"], ["qd"])


@functools.lru_cache(maxsize=16)
def _compiled_step(
    fdyn: ca.Function, n: int, substeps: int, derivatives: ca.Function | None, name: str = ""
) -> ca.Function:
    from ..ocp_step import rk4_step

    with reported(
        f"ocp {name or f'{n}-joint arm'}: compiling the multiple-shooting interval "
        f"({substeps} RK4 step{'s' * (substeps != 1)}, explicit derivatives; once, into the cache)"
    ):
        return rk4_step(fdyn, n, substeps, derivatives)


def _rk4_step(fdyn: ca.Function, n: int, substeps: int, rates: ca.Function | None = None) -> ca.Function:
    """(q, qd, tau, h) -> (q⁺, qd⁺): `substeps` RK4 steps of q̈ = fdyn(q, q̇, τ), τ held;
    q̇ = rates(q, v) where given (a planar base)."""
    q, qd, tau, h = ca.MX.sym("q", n), ca.MX.sym("qd", n), ca.MX.sym("tau", n), ca.MX.sym("h")
    qdot = (lambda x: x[n:]) if rates is None else (lambda x: rates(x[:n], x[n:]))  # noqa: E731
    x = rk4_steps(lambda x: ca.vertcat(qdot(x), fdyn(x[:n], x[n:], tau)), ca.vertcat(q, qd), h, substeps)
    return ca.Function("rk4", [q, qd, tau, h], [x[:n], x[n:]])


def rk4_steps(f, x, h, substeps: int):
    """x after `substeps` classical RK4 steps of ẋ = f(x) over the time h (NumPy or CasADi alike)."""
    dt = h / substeps
    for _ in range(substeps):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x
