"""Optimal control of a legged robot on a free base through contact phases: a jump, a trot.

The `ocp` layer transcribes fixed and planar bases; a free base's quaternion and a contact
schedule need their own transcription, written here on the generated CasADi functions of each
phase's contact set (`contact_fdyn`, `contact_impulse`, `frame_pose` of the feet; `fdyn` in
flight), one model per set, all on one joint-space derivation.

Transcription (multiple shooting, semi-implicit Euler on the manifold; node k of a phase of
step h, its torques τ_k on the actuated joints, the base's zero):

    (a_k, f_k) = contact_fdyn(q_k, v_k, [0; τ_k])     (fdyn in flight: no f)
    v_{k+1} = v_k + h a_k,   q_{k+1} = q_k ⊕ h v_{k+1}    (`integrate_function`: SE(3)'s exponential)

and at a phase's first node whose contact set adds feet (a touchdown) the velocity is first
replaced by the inelastic impact's, v_k⁺ = contact_impulse(q_k, v_k), those feet at the ground's
height.  Each point foot's force lies in the linearised friction pyramid |f_x|, |f_y| ≤ μ f_z (the
world's axes: `LOCAL_WORLD_ALIGNED`), f_z ≥ 0; a flat sole's (`LeggedProblem.soles`: a surface
contact) force and moment lie in its rectangle's contact wrench cone (`wrench_cone`, in the sole's
axes), and it lands flat; the feet not in contact stay above the ground;
torques within the joints' effort limits.  Cost: h Σ (‖τ‖² + w_v ‖v‖²) — the effort — plus the
goal's own terms.  Solved by IPOPT (limited-memory Hessian: the contact dynamics' exact
Hessians cost more per iteration than they save).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..model import Robot
from . import wrench_cone

__all__ = ["Phase", "LeggedProblem", "LeggedSolution", "integrate_function", "solve", "standing"]


@dataclass(frozen=True)
class Phase:
    """A phase of the schedule: the feet in contact (() = flight; points, or the problem's soles),
    its nodes and its duration (s)."""

    contacts: tuple
    nodes: int
    duration: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "contacts", tuple(self.contacts))

    @property
    def step(self) -> float:
        return self.duration / self.nodes


@dataclass(frozen=True)
class LeggedProblem:
    """A legged OCP: the robot (a free base; its `frames` hold every foot), the schedule, the
    start q0 (at rest), the goal's base displacement (world x, y, z) at the end (at rest again),
    the friction coefficient and the weights.  `apex`: a least base height during the flight
    phases (m, world), or None.  `clearance`: a least height of the swinging feet (those out of
    contact while others hold the robot) at each such phase's middle node (m above the ground), or
    None.  `footholds`: each touchdown puts its feet where they stood at q0 moved by the
    displacement (a footstep plan of one step per foot: a trot's), rather than anywhere on the
    ground.  `baumgarte`: (kp, kd) of the contacts (`Robot.with_contacts`): each foot in contact then
    holds J a + γ = −kd J v − kp e, e its error from its anchor, where its stance began — what keeps
    the feet from creeping under semi-implicit Euler steps, which hold the acceleration only.
    `soles`: {foot: (half-length, half-width)} — the feet that are flat soles (surface contacts:
    force and moment, within the rectangle's contact wrench cone, `symdyn.apps.wrench_cone`; the
    frame at the sole's centre, z out of the sole); the other feet are points.  `hold`: the most a
    foot in contact may move from its anchor (m, each world axis, at every node of its stance), or
    None: the transcription's steps move a foot by h²·γ after a touchdown, which the optimum may
    otherwise use (a foot sliding or sinking millimetres at a landing)."""

    robot: Robot
    phases: tuple
    q0: np.ndarray
    displacement: tuple = (0.0, 0.0, 0.0)
    mu: float = 0.7
    apex: float | None = None
    velocity_weight: float = 1e-2
    ground: float = 0.0
    clearance: float | None = None
    footholds: bool = False
    baumgarte: tuple = (0.0, 0.0)
    soles: dict = field(default_factory=dict)
    hold: float | None = None

    def kind(self, foot: str) -> str:
        """ "surface" for a foot in `soles`, else "point"."""
        return "surface" if foot in self.soles else "point"


@dataclass
class LeggedSolution:
    """The optimum: node times, q (N+1, nq), v (N+1, nv), τ (N, n), each node's contact forces
    (world axes; an empty array in flight), IPOPT's status, iterations and seconds, and of those
    seconds the ones CasADi spent evaluating the problem's functions and derivatives (the rest is
    IPOPT's own: its linear solver, mostly)."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    forces: list
    status: str
    iterations: int
    seconds: float
    build_seconds: float
    phase_of_node: list = field(default_factory=list)
    function_seconds: float = float("nan")

    def save(self, path) -> None:
        """An animation-ready trajectory: t, q, v, τ and the forces (padded with NaN) as one .npz."""
        width = max((len(f) for f in self.forces), default=0)
        forces = np.full((len(self.forces), width), np.nan)
        for k, f in enumerate(self.forces):
            forces[k, : len(f)] = f
        np.savez(path, t=self.t, q=self.q, v=self.v, tau=self.tau, forces=forces, phase=np.array(self.phase_of_node))


def _series(theta2, coefficients):
    """Σ c_k θ^{2k} by Horner's rule in θ²: smooth at θ = 0, exact to 1e-12 for θ ≤ 1 rad."""
    out = 0
    for c in reversed(coefficients):
        out = out * theta2 + c
    return out


def _factorial(n: int) -> float:
    return float(np.prod(np.arange(1, n + 1))) if n > 1 else 1.0


def integrate_function(robot: Robot) -> ca.Function:
    """q ⊕ w for a free base (Pinocchio's `integrate` of the twist w in the base's frame, as
    `Robot.integrate`) as a casadi.Function: the exponential's coefficients as series in θ²
    (|ω| = θ ≤ 1 rad per step: error below 1e-12, and smooth at θ = 0, where the closed forms'
    derivatives are 0/0), the quaternion re-normalised."""
    if robot.base_joint != "free":
        raise ValueError(f"integrate_function({robot.name!r}): its base is {robot.base_joint or 'fixed'}, not free")
    q, w = ca.SX.sym("q", robot.nq), ca.SX.sym("w", robot.nv)
    p, quat, lin, om = q[:3], q[3:7], w[:3], w[3:6]
    theta2 = ca.dot(om, om)
    terms = range(7)
    half_sin = _series(theta2, [(-1) ** k / (2 ** (2 * k + 1) * _factorial(2 * k + 1)) for k in terms])  # sin(θ/2)/θ
    half_cos = _series(theta2, [(-1) ** k / (2 ** (2 * k) * _factorial(2 * k)) for k in terms])  # cos(θ/2)
    a = _series(theta2, [(-1) ** k / _factorial(2 * k + 2) for k in terms])  # (1 − cos θ)/θ²
    b = _series(theta2, [(-1) ** k / _factorial(2 * k + 3) for k in terms])  # (θ − sin θ)/θ³
    W = ca.skew(om)
    dp = lin + a * ca.mtimes(W, lin) + b * ca.mtimes(W, ca.mtimes(W, lin))
    x, y, z, s = quat[0], quat[1], quat[2], quat[3]
    R = ca.vertcat(
        ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - s * z), 2 * (x * z + s * y)),
        ca.horzcat(2 * (x * y + s * z), 1 - 2 * (x * x + z * z), 2 * (y * z - s * x)),
        ca.horzcat(2 * (x * z - s * y), 2 * (y * z + s * x), 1 - 2 * (x * x + y * y)),
    )
    d = ca.vertcat(half_sin * om, half_cos)  # (x, y, z, w) of exp(ω/2)
    u, ws = quat[:3], quat[3]
    prod = ca.vertcat(ws * d[:3] + d[3] * u + ca.cross(u, d[:3]), ws * d[3] - ca.dot(u, d[:3]))
    prod = prod / ca.norm_2(prod)
    out = ca.vertcat(p + ca.mtimes(R, dp), prod, q[7:] + w[6:])
    return ca.Function("integrate", [q, w], [out], ["q", "w"], ["q_next"])


def _check_soles(problem: LeggedProblem, feet: tuple, transcription: str, source: str) -> None:
    """Soles named among the feet, each with a positive half-length and half-width; what takes them.

    Raises:
        ValueError: a sole that is not a foot, or whose sizes are not two positive numbers; soles
            with the plain baseline (point feet only) or with kp in the forward transcription (its
            anchors are positions).
    """
    for foot, size in problem.soles.items():
        if foot not in feet:
            raise ValueError(f"soles: {foot!r} is not among the feet (robot.frames) {feet}")
        if len(tuple(size)) != 2 or not all(0 < float(x) < np.inf for x in size):
            raise ValueError(f"soles[{foot!r}]: (half-length, half-width) in m, two positive numbers; got {size!r}")
    if problem.soles and source == "plain":
        raise ValueError("the plain baseline (source='plain') takes point feet only; soles need source='symdyn'")
    if problem.soles and transcription == "forward" and problem.baumgarte[0]:
        raise ValueError("soles with a position gain kp take the inverse transcription (or kp = 0)")


def _anchor_error(now, anchor, rows: int):
    """A contact frame's error from its anchor, world axes, as `with_contacts`' corrector measures it:
    p − p_anchor for a point (rows 3); −R·log₆(M⁻¹M_anchor) for a surface (rows 6), M = (R | p)
    — the generated contact functions' log₆ (`codegen.contact_functions`) written in CasADi."""
    from ..codegen.contact_functions import log_series

    R, p, Ra, pa = now[:, :3], now[:, 3], anchor[:, :3], anchor[:, 3]
    if rows == 3:
        return p - pa
    h_terms, k_terms = ([float(c) for c in terms] for terms in log_series())
    Rr, t = ca.mtimes(R.T, Ra), ca.mtimes(R.T, pa - p)
    u = (3 - (Rr[0, 0] + Rr[1, 1] + Rr[2, 2])) / 2
    h, k = _series(u, h_terms), _series(u, k_terms)
    f = ca.sqrt(h / (1 - u / 2)) / 2
    w = ca.vertcat(Rr[2, 1] - Rr[1, 2], Rr[0, 2] - Rr[2, 0], Rr[1, 0] - Rr[0, 1]) * f
    g = k / (2 * h * (1 + ca.sqrt((1 - u / 2) * h)))
    wt = ca.cross(w, t)
    linear = t - wt / 2 + g * ca.cross(w, wt)
    return -ca.vertcat(ca.mtimes(R, linear), ca.mtimes(R, w))


def _functions(
    robot: Robot,
    feet: tuple,
    contacts: tuple,
    transcription: str,
    gains: tuple = (0.0, 0.0),
    source: str = "symdyn",
    kinds: dict | None = None,
) -> dict:
    """The CasADi functions one contact set needs (its own model; the derivation is shared): the
    forward transcription's contact_fdyn (fdyn in flight), the inverse one's τ, the feet's
    world-aligned Jacobians and drifts; both the feet's poses and, at a touchdown, the impact."""
    from ..codegen.choice import Programs, derivations
    from ..codegen.emit.casadi import function

    if source == "plain":  # the baseline: a free-base recursion written plainly in CasADi
        from ..numeric import casadi_legged

        return casadi_legged.functions(robot.with_frames(feet), contacts)
    model = robot.with_frames(feet)
    if contacts:
        model = model.with_contacts({f: (kinds or {}).get(f, "point") for f in contacts}, kp=gains[0], kd=gains[1])
    dyns, origins = derivations(model)
    programs = Programs(dyns, None, origins)
    names = ["frame_pose"] + (["contact_impulse"] if contacts else [])
    if transcription == "forward":
        names += ["contact_fdyn"] if contacts else ["fdyn"]
    else:
        names += ["tau", "frame_jacobian_aligned", "frame_drift"]
    return {name: function(programs.program(name)) for name in names}


def solve(
    problem: LeggedProblem,
    *,
    transcription: str = "inverse",
    max_iter: int = 1000,
    tol: float = 1e-6,
    print_level: int = 0,
    hessian: str = "exact",
    ipopt: dict | None = None,
    source: str = "symdyn",
) -> LeggedSolution:
    """The optimum of `problem` by IPOPT from a standing guess (q0 moved along the displacement,
    the torques and forces that hold q0).  `transcription`: "inverse" (the accelerations and
    contact forces are variables: τ(q, v, a) = [0; τ] + Jᵀf and J a + γ = 0 at each node — the
    generated τ, Jacobians and drifts, small functions; converges in far fewer iterations) or
    "forward" (a, f = contact_fdyn(q, v, [0; τ]): the generated contact dynamics themselves).
    `source`: "symdyn" (the generated functions) or "plain" (the baseline written plainly in CasADi,
    `symdyn.numeric.casadi_legged`: the inverse transcription only)."""
    if transcription not in ("inverse", "forward"):
        raise ValueError(f"transcription must be 'inverse' or 'forward', got {transcription!r}")
    if source not in ("symdyn", "plain") or (source == "plain" and transcription != "inverse"):
        raise ValueError(f"source must be 'symdyn' or 'plain' (with the inverse transcription), got {source!r}")
    robot = problem.robot
    if robot.base_joint != "free":
        raise ValueError(f"ocp_legged.solve({robot.name!r}): a legged OCP needs a free base")
    feet = tuple(frame.name for frame in robot.task_frames)
    for phase in problem.phases:
        unknown = [f for f in phase.contacts if f not in feet]
        if unknown or phase.nodes < 1 or not phase.duration > 0:
            raise ValueError(f"phase {phase}: feet {unknown} not among robot.frames {feet}, or no nodes/duration")
    gains = problem.baumgarte
    _check_soles(problem, feet, transcription, source)
    start = time.perf_counter()
    sets = {p.contacts for p in problem.phases}
    kinds = {foot: problem.kind(foot) for foot in feet}
    funcs = {s: _functions(robot, feet, s, transcription, gains, source, kinds) for s in sets}
    step = integrate_function(robot)
    nq, nv, n = robot.nq, robot.nv, robot.n
    nb = nv - n
    q0 = np.asarray(problem.q0, dtype=float)
    N = sum(p.nodes for p in problem.phases)
    stood = funcs[problem.phases[0].contacts]["frame_pose"](q0)
    holds = [
        stood[4 * i : 4 * i + 2, 3].full().ravel() + np.asarray(problem.displacement[:2], dtype=float)
        for i in range(len(feet))
    ]
    opti = ca.Opti()
    Q, V, U = opti.variable(nq, N + 1), opti.variable(nv, N + 1), opti.variable(n, N)
    A = opti.variable(nv, N) if transcription == "inverse" else None
    effort = np.array([link.effort_limit or np.inf for link in robot.links], dtype=float)
    finite = np.flatnonzero(np.isfinite(effort)).tolist()
    cost, forces, force_vars, phase_of_node, t = 0, [], [], [], [0.0]
    opti.subject_to(Q[:, 0] == q0)
    opti.subject_to(V[:, 0] == 0)
    k, previous, anchors = 0, None, {}
    for index, phase in enumerate(problem.phases):
        f = funcs[phase.contacts]
        h = phase.step
        touchdown = previous is not None and bool(set(phase.contacts) - set(previous))
        for j in range(phase.nodes):
            q, v, tau = Q[:, k], V[:, k], U[:, k]
            pose = f["frame_pose"](q)
            anchored = [foot for foot in phase.contacts if j == 0 and foot not in (previous or ()) or k == 0]
            for i, foot in enumerate(feet):  # a foot's anchor: its placement (R | p) where its stance began
                if foot in anchored:
                    anchors[foot] = pose[4 * i : 4 * i + 3, :]
                elif problem.hold is not None and (foot in phase.contacts or j == 0 and foot in (previous or ())):
                    moved = pose[4 * i : 4 * i + 3, 3] - anchors[foot][:, 3]
                    opti.subject_to(opti.bounded(-problem.hold, moved, problem.hold))
            heights = [pose[4 * i + 2, 3] for i in range(len(feet))]
            if j == 0 and touchdown:
                landing = [feet.index(foot) for foot in phase.contacts if foot not in previous]
                opti.subject_to(ca.vertcat(*(heights[i] for i in landing)) == problem.ground)
                for i in landing:  # a sole lands flat: its z along the world's
                    if kinds[feet[i]] == "surface":
                        opti.subject_to(ca.vertcat(pose[4 * i, 2], pose[4 * i + 1, 2]) == 0)
                if problem.footholds:
                    for i in landing:
                        opti.subject_to(pose[4 * i : 4 * i + 2, 3] == holds[i])
                v = f["contact_impulse"](q, v)[0]
            free = [heights[i] for i, foot in enumerate(feet) if foot not in phase.contacts]
            if free and j > 0:  # not at a phase's first node, where a lift-off leaves its feet on the ground
                opti.subject_to(ca.vertcat(*free) >= problem.ground)
            if free and phase.contacts and problem.clearance is not None and j == phase.nodes // 2:
                opti.subject_to(ca.vertcat(*free) >= problem.ground + problem.clearance)
            full = ca.vertcat(ca.DM.zeros(nb), tau)
            if transcription == "forward":
                if phase.contacts:
                    anchor = (ca.vertcat(*(anchors[foot][:, 3] for foot in phase.contacts)),) if gains[0] else ()
                    a, force = f["contact_fdyn"](q, v, full, *anchor)
                else:
                    a, force = f["fdyn"](q, v, full), None
            else:
                a = A[:, k]
                rows = [feet.index(foot) for foot in phase.contacts]
                sizes = [6 if kinds[feet[i]] == "surface" else 3 for i in rows]
                force = opti.variable(sum(sizes)) if rows else None
                force_vars.append(force)
                generalized = full
                if rows:
                    J = f["frame_jacobian_aligned"](q)  # (6·m, nv): frame i's rows 6i … 6i + 5
                    drift = f["frame_drift"](q, v)  # (m, 6)
                    Jc = ca.vertcat(*(J[6 * i : 6 * i + r, :] for i, r in zip(rows, sizes)))
                    gamma = ca.vertcat(*(drift[i, :r].T for i, r in zip(rows, sizes)))
                    generalized = full + ca.mtimes(Jc.T, force)
                    residual = ca.mtimes(Jc, a) + gamma
                    if gains[1]:  # Baumgarte (`with_contacts`' kd, kp): J a + γ = −kd J v − kp (p − p_anchor)
                        residual += gains[1] * ca.mtimes(Jc, v)
                    if gains[0]:
                        errors = [
                            _anchor_error(pose[4 * i : 4 * i + 3, :], anchors[feet[i]], r) for i, r in zip(rows, sizes)
                        ]
                        residual += gains[0] * ca.vertcat(*errors)
                    opti.subject_to(residual == 0)
                opti.subject_to(f["tau"](q, v, a) == generalized)
            if force is not None:
                at = 0
                for foot in phase.contacts:
                    if kinds[foot] == "point":
                        fx, fy, fz = force[at], force[at + 1], force[at + 2]
                        opti.subject_to(fz >= 0)
                        for side in (fx, -fx, fy, -fy):
                            opti.subject_to(side <= problem.mu * fz)
                        at += 3
                        continue
                    R = pose[4 * feet.index(foot) : 4 * feet.index(foot) + 3, :3]  # the sole's axes: its cone's
                    local = ca.mtimes(R.T, force[at : at + 3]), ca.mtimes(R.T, force[at + 3 : at + 6])
                    opti.subject_to(ca.vertcat(*wrench_cone.rows(*local, *problem.soles[foot], problem.mu)) <= 0)
                    at += 6
            elif problem.apex is not None and j == phase.nodes // 2:
                opti.subject_to(q[2] >= problem.apex)
            forces.append(force)
            opti.subject_to(V[:, k + 1] == v + h * a)
            opti.subject_to(Q[:, k + 1] == step(q, h * V[:, k + 1]))
            if finite:
                opti.subject_to(opti.bounded(-effort[finite], tau[finite], effort[finite]))
            cost += h * (ca.sumsqr(tau) + problem.velocity_weight * ca.sumsqr(V[:, k + 1]))
            phase_of_node.append(index)
            t.append(t[-1] + h)
            k += 1
        previous = phase.contacts
    goal = q0.copy()
    goal[:3] += np.asarray(problem.displacement, dtype=float)
    opti.subject_to(Q[:3, N] == goal[:3])
    opti.subject_to(V[:, N] == 0)
    opti.minimize(cost)
    hold, hold_forces = _holding(robot, problem)
    k = 0
    for phase in problem.phases:  # the standing guess, moved along the displacement, held still
        for j in range(phase.nodes):
            opti.set_initial(U[:, k], hold)
            if force_vars and force_vars[k] is not None and phase.contacts == problem.phases[0].contacts:
                opti.set_initial(force_vars[k], hold_forces)
            k += 1
    for j in range(N + 1):
        guess = q0.copy()
        guess[:3] += j / N * np.asarray(problem.displacement, dtype=float)
        opti.set_initial(Q[:, j], guess)
    options = {"max_iter": max_iter, "tol": tol, "print_level": print_level, "hessian_approximation": hessian}
    options.update(ipopt or {})
    opti.solver("ipopt", {"print_time": False}, options)
    build = time.perf_counter() - start
    begin = time.perf_counter()
    try:
        sol = opti.solve()
        value, stats = sol.value, sol.stats()
    except RuntimeError:
        value, stats = opti.debug.value, opti.debug.stats()
    seconds = time.perf_counter() - begin
    forces_out = [np.zeros(0) if force is None else np.ravel(value(force)) for force in forces]
    return LeggedSolution(
        np.array(t),
        np.asarray(value(Q)).T,
        np.asarray(value(V)).T,
        np.atleast_2d(np.asarray(value(U)).T),
        forces_out,
        stats.get("return_status", "?"),
        int(stats.get("iter_count", -1)),
        seconds,
        build,
        phase_of_node,
        sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_")),
    )


def _holding(robot: Robot, problem: LeggedProblem) -> tuple[np.ndarray, np.ndarray]:
    """The joint torques and feet forces that hold q0 at rest on the first phase's feet (whole-body
    inverse dynamics, least-norm forces): the guess's; zeros if the first phase is a flight."""
    from .contact_control import WholeBodyInverseDynamics

    first = problem.phases[0].contacts
    if not first:
        return np.zeros(robot.n), np.zeros(0)
    wbid = WholeBodyInverseDynamics(robot.with_contacts({f: problem.kind(f) for f in first}), "c")
    tau, force = wbid(problem.q0, np.zeros(robot.nv), np.zeros(robot.nv))
    return tau[robot.nv - robot.n :], force


def standing(robot: Robot, joints: dict, ground: float = 0.0) -> np.ndarray:
    """A standing q: the joints named in `joints` at their angles, the base level, its height set
    so that the lowest foot (robot.frames) touches the ground."""
    from ..codegen.entry import load

    q = robot.neutral().astype(float)
    index = {name: robot.nq - robot.n + i for i, name in enumerate(robot.joint_names)}
    for name, angle in joints.items():
        q[index[name]] = angle
    pose = load(dataclasses.replace(robot, contacts=(), baumgarte=(0.0, 0.0)), "c").frame_pose(q)
    q[2] += ground - float(np.min(pose[:, 2, 3]))
    return q
