"""Physically consistent standard parameters from identified base parameters.

The identification stage's last step before a `Robot` comes back: least
squares gives the base parameters β (exact combinations P·π of the standard
ones, `symdyn.derivation.regressor.base_parameters`); this finds standard
parameters π — per link mass, first moments, inertia about the link-frame
origin, rotor inertia and friction — that reproduce β as closely as the
data allow and are physically realisable: each link's 4×4 pseudo-inertia

    J = [[Σ, h], [hᵀ, m]],  Σ = ½ tr(I_o)·1 − I_o   (Wensing, Kim & Slotine, RA-L 2017)

positive semidefinite (a mass distribution exists: m ≥ 0, I_c ⪰ 0 and the
triangle inequality of its principal moments), IA ≥ 0, FV ≥ 0 and FS ≥ |FO|
(Tc⁺ ≥ 0 ≥ Tc⁻, which `Link` requires; it implies FS ≥ 0).

The problem, in parameters scaled per link (mass, first moment and inertia
scales from the prior), is convex and solved in two stages:

    1. ρ* = min ‖W (P π − β̂)‖                       subject to J_j(π) ⪰ 0, …
    2.      min ‖W (P π − β̂)‖ + λ ‖Q S⁻¹(π − π₀)‖  subject to the same and
                                                    ‖W (P π − β̂)‖² ≤ ρ*²(1 + 1e-6)

W = Σ_β^{-1/2} when the base covariance is given, else the inverse scale of
each base parameter; Q projects onto the null space of P S (the parameters
the data cannot see).  The prior π₀ (the URDF/CAD model) therefore chooses
among the standard sets that fit (almost) equally well and never trades
fit for closeness: noise-free base parameters of a realisable arm are
reproduced to solver tolerance (1e-11 on the Puma and the Panda), where
one weighted sum with λ = 1e-3 moved them by ~1e-5 (stage 1 carries the
prior with weight 1e-9 only to make its minimiser unique).

Two solvers: an SDP handed to Clarabel directly (convex, the global
optimum, singular pseudo-inertias — point masses, planar links — included;
norms, not squares, so the tolerance bounds the residual itself) and a
CasADi NLP (IPOPT) over a log-Cholesky factor J = U Uᵀ, diag U = exp(·)
(Rucker & Wensing 2022), feasible by construction but strictly inside the
cone.  The SDP is the default where Clarabel is installed (the extra
`identify`, a 1.2 MB wheel): measured on the Puma and the Panda
(scripts/bench_identify_design.py) it takes 0.2–0.3 s and reproduces β̂ to
1e-9, the NLP 10–30 s and 5e-4 (measured when IPOPT stopped at tol; it now stops at
tol², which on the floating-base test trees takes 2–5 s instead of 0.5–2 s and reproduces the
torques to 3e-11 instead of 1e-6 — the Puma and Panda figures are not re-measured).  The same SDP written in cvxpy (measured
at commit 726aca8) gave the same solutions in 0.4–0.5 s, but cvxpy brings
SCS, OSQP, HiGHS: 67 MB of wheels, 231 MB installed, 1.9 s to import.  The parameters refer to the regressor's frames
(modified DH; `robot.to_modified()`); `Consistent.robot` carries them back
to the robot's own link frames exactly (mass, COM, inertia about the COM).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import sympy as sp

from ..derivation.kinematics import along_z
from ..derivation.regressor import BODY, FRICTION, INERTIAL, BaseParameters, base_parameters, parameter_values
from ..model import Link, Robot

__all__ = ["physical", "Consistent", "pseudo_inertia", "METHODS"]

PER = len(INERTIAL) + len(FRICTION)  # 14 standard parameters per link
METHODS = ("sdp", "casadi")
_BASE_CACHE: dict = {}


@dataclass(frozen=True)
class Consistent:
    """The physically consistent estimate.

    robot: the model with the standard parameters found (links' m, r, I, Jm,
    B, Tc in their own frames); standard: name → value (regressor frames, the
    names of `parameter_symbols`); base_names, target (the β̂ given) and
    achieved (P·π); margins: the smallest eigenvalue of each link's
    pseudo-inertia (≥ 0 up to solver tolerance); moved: ‖W(Pπ − β̂)‖ / ‖W β̂‖ with
    W = diag(1/scales), each base parameter's typical size (of its pivot, from the prior),
    how far the base parameters had to move (0 for a realisable β̂);
    sigmas: ‖Σ^{-1/2}(Pπ − β̂)‖ when a covariance was given (the move in
    standard deviations), else None.
    """

    robot: Robot
    standard: dict
    base_names: tuple
    target: np.ndarray
    achieved: np.ndarray
    margins: np.ndarray
    moved: float
    sigmas: float | None
    method: str
    seconds: float
    status: str
    regularisation: float = field(default=0.0)
    scales: np.ndarray | None = None

    def table(self) -> str:
        """Per link: mass, COM and the pseudo-inertia margin, as text."""
        lines = [f"{'link':>4} {'m':>10} {'r_x':>9} {'r_y':>9} {'r_z':>9} {'margin':>10}"]
        for j, (link, margin) in enumerate(zip(self.robot.links, self.margins)):
            r = [float(x) for x in link.r]
            lines.append(f"{j + 1:>4} {float(link.m):>10.4g} {r[0]:>9.4f} {r[1]:>9.4f} {r[2]:>9.4f} {margin:>10.3g}")
        return "\n".join(lines)


def pseudo_inertia(Io, h, m) -> np.ndarray:
    """The 4×4 pseudo-inertia [[½tr(Io)·1 − Io, h], [hᵀ, m]] (Io about the frame origin)."""
    Io = np.asarray(Io, dtype=float)
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(Io) * np.eye(3) - Io
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


def _from_J(J: np.ndarray) -> list:
    """The ten inertial parameters XX … M of a pseudo-inertia (inverse of pseudo_inertia)."""
    S = J[:3, :3]
    Io = np.trace(S) * np.eye(3) - S
    return [Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2], J[0, 3], J[1, 3], J[2, 3], J[3, 3]]


# --------------------------------------------------------------------------- the problem's data


def _base(robot: Robot) -> BaseParameters:
    key = robot.fingerprint()
    if key not in _BASE_CACHE:
        _BASE_CACHE[key] = base_parameters(robot)
    return _BASE_CACHE[key]


def _matrix_P(base: BaseParameters) -> np.ndarray:
    """β = P π as a float matrix (rows: base parameters, columns: standard)."""
    index = {s: k for k, s in enumerate(base.params)}
    P = np.zeros((len(base.expressions), len(base.params)))
    for b, e in enumerate(base.expressions):
        for term in sp.Add.make_args(sp.expand(e)):
            coeff, sym = term.as_independent(*base.params)
            P[b, index[sym]] = float(coeff)
    return P


def _prior_vector(robot: Robot, prior, names: list) -> np.ndarray:
    if prior is None:
        prior = robot
    if isinstance(prior, Robot):
        return np.array([float(v) for v in parameter_values(prior)])
    values = dict(zip(names, (float(v) for v in parameter_values(robot))))
    unknown = sorted(set(prior) - set(values))
    if unknown:
        raise ValueError(
            f"prior names {unknown} are not standard parameters of {robot.name!r} (they are {names[0]} … {names[-1]})"
        )
    values.update({k: float(v) for k, v in prior.items()})
    return np.array([values[k] for k in names])


def _scales(pi0: np.ndarray, n: int, beta: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Per standard parameter a typical size (from the prior), per link a mass scale, and a length L."""
    blocks = pi0.reshape(n, PER)
    m0 = np.maximum(blocks[:, 9], 0)
    mean = m0.mean() if m0.mean() > 0 else 1.0
    ms = np.maximum(m0, 0.1 * mean)
    trace = blocks[:, 0] + blocks[:, 3] + blocks[:, 5]
    L = float(np.sqrt(max(trace.sum(), 0) / (2 * m0.sum()))) if m0.sum() > 0 else 0.3
    L = min(max(L, 0.05), 2.0)
    s = np.empty(n * PER)
    for j in range(n):
        s[j * PER : j * PER + 6] = ms[j] * L * L
        s[j * PER + 6 : j * PER + 9] = ms[j] * L
        s[j * PER + 9] = ms[j]
        s[j * PER + 10] = max(abs(blocks[j, 10]), 1e-2 * ms[j] * L * L)
        for k in (11, 12, 13):  # friction: its own base parameter; its size from the data or the prior
            rows = np.nonzero(P[:, j * PER + k])[0]
            s[j * PER + k] = max(abs(blocks[j, k]), *(abs(beta[r]) for r in rows), 1e-3)
    return s, ms, L


# --------------------------------------------------------------------------- solvers


def _linear_map(n: int, ms: np.ndarray, L: float) -> np.ndarray:
    """π = T·x for x = per link the 10 upper entries of the scaled pseudo-inertia Ĵ and IA, FV, FS, FO
    (J = m_s·D Ĵ D, D = diag(L, L, L, 1))."""
    upper = [(a, b) for a in range(4) for b in range(a, 4)]
    T = np.zeros((n * PER, n * PER))
    for j in range(n):
        D = np.array([L, L, L, 1.0])
        for u, (a, b) in enumerate(upper):
            E = np.zeros((4, 4))
            E[a, b] = E[b, a] = 1.0
            J = ms[j] * np.outer(D, D) * E
            T[j * PER : j * PER + 10, j * PER + u] = _from_J(J)
        for k in range(10, 14):
            T[j * PER + k, j * PER + k] = 1.0
    return T


def _upper_to_J(x: Sequence) -> list:
    upper = [(a, b) for a in range(4) for b in range(a, 4)]
    J = [[None] * 4 for _ in range(4)]
    for u, (a, b) in enumerate(upper):
        J[a][b] = J[b][a] = x[u]
    return J


#: The second stage may give up this fraction of the best fit's square (and an absolute 1e-14
#: of ‖Wβ̂‖²) to come nearer the prior: below any estimate's σ, above the solvers' tolerance.
SLACK = 1e-6
#: In the first stage the prior breaks ties with this weight (the fit alone has a null space).
TIE = 1e-9


def _solve_clarabel(fit, reg, lam, n, x0, tol, nomotor):
    """Both stages as conic programmes handed to Clarabel directly: z = [x, t₁, t₂],
    minimise t₁ + w·t₂ subject to ‖R₁x − c₁‖ ≤ t₁, ‖R₂x − c₂‖ ≤ t₂ (second-order cones), each
    scaled pseudo-inertia in the PSD cone (svec: upper triangle by columns, off-diagonals ×√2),
    IA, FV ≥ 0 and FS ≥ |FO| (non-negative cone), no motor parameters where G = 0 (zero cone)."""
    try:
        import clarabel
    except ImportError:
        raise ImportError(
            "method='sdp' needs Clarabel: pip install 'symdyn[identify]' (or use method='casadi')"
        ) from None
    from scipy import sparse

    (R1, c1), (R2, c2) = fit, reg
    N = n * PER
    t1, t2 = N, N + 1
    upper = {(a, b): u for u, (a, b) in enumerate((a, b) for a in range(4) for b in range(a, 4))}

    def blocks(bound):
        rows, rhs, cones = [], [], []

        def row(entries, value=0.0):
            r = np.zeros(N + 2)
            for k, v in entries:
                r[k] += v
            rows.append(r)
            rhs.append(value)

        zero = [j * PER + 10 + k for j in nomotor for k in range(4)]
        for k in zero:
            row([(k, 1.0)])
        if zero:
            cones.append(clarabel.ZeroConeT(len(zero)))
        count = 0
        for j in range(n):
            IA, FV, FS, FO = (j * PER + 10 + k for k in range(4))
            for entries in ([(IA, -1.0)], [(FV, -1.0)], [(FS, -1.0), (FO, 1.0)], [(FS, -1.0), (FO, -1.0)]):
                row(entries)
                count += 1
        if bound is not None:
            row([(t1, 1.0)], bound)
            count += 1
        cones.append(clarabel.NonnegativeConeT(count))
        for t, (R, c) in ((t1, (R1, c1)), (t2, (R2, c2))):
            row([(t, -1.0)])
            for i in range(R.shape[0]):
                rows.append(np.r_[-R[i], 0.0, 0.0])
                rhs.append(-c[i])
            cones.append(clarabel.SecondOrderConeT(R.shape[0] + 1))
        for j in range(n):
            for b in range(4):
                for a in range(b + 1):
                    row([(j * PER + upper[(a, b)], -(1.0 if a == b else np.sqrt(2.0)))])
            cones.append(clarabel.PSDTriangleConeT(4))
        return sparse.csc_matrix(np.array(rows)), np.array(rhs), cones

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    P = sparse.csc_matrix((N + 2, N + 2))

    def solve(weight, bound):
        A, b, cones = blocks(bound)
        q = np.zeros(N + 2)
        q[t1], q[t2] = 1.0, weight
        solution = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
        return np.array(solution.x)[:N], str(solution.status)

    x, status = solve(TIE, None)
    if status not in ("Solved", "AlmostSolved"):
        raise RuntimeError(f"the consistency SDP failed: Clarabel says {status}")
    if lam > 0:
        best = float(np.sum((R1 @ x - c1) ** 2))
        x2, status2 = solve(lam, np.sqrt(best * (1 + SLACK) + 1e-14 * float(c1 @ c1)))
        if status2 in ("Solved", "AlmostSolved"):
            x, status = x2, status2
        else:  # the fit's bound leaves the cone a sliver: stage 1 (its own tie-break) stands
            status = f"{status} (stage 2: {status2}, stage 1 kept)"
    return x, status


def _log_cholesky_start(x0, n, nomotor):
    """θ of a start point: the log-Cholesky factor of each pseudo-inertia, nudged inside the cone."""
    th0 = np.zeros(n * PER)
    for j in range(n):
        J = np.array(_upper_to_J(x0[j * PER : j * PER + 10]), dtype=float)
        w, V = np.linalg.eigh(J)
        J = (V * np.maximum(w, 1e-6 * max(w.max(), 1.0))) @ V.T
        U = np.linalg.cholesky(J[::-1, ::-1])[::-1, ::-1]  # J = U Uᵀ, U upper triangular
        k = 0
        for a in range(4):
            for b in range(a, 4):
                th0[j * PER + k] = np.log(U[a, b]) if a == b else U[a, b]
                k += 1
        IA, FV, FS, FO = x0[j * PER + 10 : j * PER + 14]
        th0[j * PER + 10 : j * PER + 14] = [max(IA, 0), max(FV, 0), max(FS, abs(FO)), FO] if j not in nomotor else 0
    return th0


def _solve_casadi(fit, reg, lam, n, x0, tol, nomotor):
    """Both stages as NLPs over θ (IPOPT): J = U Uᵀ, U upper triangular, diag U = exp(θ)."""
    import casadi as ca

    (R1, t1), (R2, t2) = fit, reg
    theta = ca.SX.sym("theta", n * PER)
    xs = []
    for j in range(n):
        t = theta[j * PER : (j + 1) * PER]
        U = ca.SX.zeros(4, 4)
        k = 0
        for a in range(4):
            for b in range(a, 4):
                U[a, b] = ca.exp(t[k]) if a == b else t[k]
                k += 1
        J = U @ U.T
        xs += [J[a, b] for a in range(4) for b in range(a, 4)] + [t[10 + i] for i in range(4)]
    x = ca.vertcat(*xs)
    e1, e2 = ca.mtimes(ca.DM(R1), x) - ca.DM(t1), ca.mtimes(ca.DM(R2), x) - ca.DM(t2)
    f, r = ca.dot(e1, e1), ca.dot(e2, e2)
    fs = [theta[j * PER + 12] for j in range(n)]
    fo = [theta[j * PER + 13] for j in range(n)]
    friction = ca.vertcat(*(s - o for s, o in zip(fs, fo)), *(s + o for s, o in zip(fs, fo)))
    lbx, ubx = -np.inf * np.ones(n * PER), np.inf * np.ones(n * PER)
    for j in range(n):
        lbx[j * PER + 10] = lbx[j * PER + 11] = 0.0
    for j in nomotor:
        lbx[j * PER + 10 : j * PER + 14] = ubx[j * PER + 10 : j * PER + 14] = 0.0
    options = {
        "ipopt.print_level": 0,
        "print_time": False,
        # the objective is the squared residual that the SDP's tolerance bounds as a norm: its
        # square, so that both routes stop at the same residual (tol alone left 1e-6 of τ)
        "ipopt.tol": tol * tol,
        "ipopt.max_iter": 3000,
        "ipopt.sb": "yes",
        "show_eval_warnings": False,
    }
    first = ca.nlpsol("consistent_fit", "ipopt", {"x": theta, "f": f + TIE * r, "g": friction}, options)
    sol = first(x0=_log_cholesky_start(x0, n, nomotor), lbx=lbx, ubx=ubx, lbg=0, ubg=np.inf)
    status = first.stats()["return_status"]
    if lam > 0:
        best = float(sol["f"])
        bound = best * (1 + SLACK) + 1e-14 * float(t1 @ t1)
        second = ca.nlpsol(
            "consistent_prior", "ipopt", {"x": theta, "f": f + lam * r, "g": ca.vertcat(friction, f)}, options
        )
        sol = second(x0=sol["x"], lbx=lbx, ubx=ubx, lbg=0, ubg=np.r_[np.inf * np.ones(2 * n), bound])
        status = second.stats()["return_status"]
    xfun = ca.Function("x", [theta], [x])
    return np.asarray(xfun(sol["x"]), dtype=float).ravel(), status


# --------------------------------------------------------------------------- back to a Robot


def _frame_maps(robot: Robot) -> list:
    """Per link (R, p): a point x of the robot's own link frame is R·x + p in the regressor's
    (modified-DH) frame, read off `to_modified` itself (`kinematics.along_z`, trees too) so that
    the two never disagree."""

    def probe(v):
        links = tuple(dataclasses.replace(link, r=v, I=((0, 0, 0),) * 3, m=1) for link in robot.links)
        mdh = along_z(dataclasses.replace(robot, links=links))
        return np.array([[float(x) for x in link.r] for link in mdh.links])

    p = probe((0, 0, 0))
    cols = [probe(tuple(int(i == k) for i in range(3))) - p for k in range(3)]
    return [(np.stack([c[j] for c in cols], axis=1), p[j]) for j in range(robot.n)]


def _rounded_onto_physical(I: np.ndarray, scale: float) -> np.ndarray:
    """A COM inertia from a pseudo-inertia on the cone's boundary (a point mass, a rod, a plate)
    may miss `Link`'s checks by rounding (principal moments −4e-16, 0, 1e-22): its moments
    are clipped at 0 and to the triangle inequality where they miss it by ≤ 1e-9 of the body's scale."""
    I = (I + I.T) / 2
    w, V = np.linalg.eigh(I)
    tol = 1e-9 * max(scale, 1e-300)
    fixed = w.copy()
    fixed[(fixed < 0) & (fixed > -tol)] = 0.0
    if fixed[2] > fixed[0] + fixed[1] and fixed[2] - fixed[0] - fixed[1] <= tol:
        fixed[2] = fixed[0] + fixed[1]
    if np.array_equal(fixed, w):
        return I
    I = (V * fixed) @ V.T
    return (I + I.T) / 2


def _padded(x: np.ndarray) -> np.ndarray:
    """A floating base's π (or P's columns) with four zeros after the body's ten: a block like a link's."""
    return np.insert(x, [len(BODY)] * (PER - len(BODY)), 0.0, axis=-1)


def _robot_from(robot: Robot, pi: np.ndarray, maps: list) -> Robot:
    body = len(BODY) if robot.base_joint is not None else 0
    if body:  # the base body in its own frame, the recursion's frame {0}
        v = pi[:body]
        Io = np.array([[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]])
        m = float(v[9])
        c = v[6:9] / m if m > 0 else np.zeros(3)
        Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
        robot = dataclasses.replace(
            robot,
            base_body=dataclasses.replace(
                robot.base_body or Link(),
                m=max(m, 0.0),
                r=tuple(float(x) for x in c),
                I=tuple(tuple(float(x) for x in row) for row in _rounded_onto_physical(Ic, np.abs(Io).max())),
            ),
        )
        pi = pi[body:]
    links = []
    for j, (link, (R, p)) in enumerate(zip(robot.links, maps)):
        v = pi[j * PER : (j + 1) * PER]
        Io = np.array([[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]])
        h, m = v[6:9], v[9]
        if m > 0:
            c = h / m
            Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
            r = R.T @ (c - p)
        else:  # no mass: no centre of mass; the inertia is the same about any point
            Ic, r, m = Io, np.zeros(3), 0.0
        I = _rounded_onto_physical(R.T @ Ic @ R, np.abs(Io).max())
        G = float(link.G)
        IA, FV, FS, FO = v[10:14]
        if G == 0:
            if max(abs(IA), abs(FV), abs(FS), abs(FO)) > 0:
                raise ValueError(
                    f"link {j + 1} has gear ratio 0 but identified motor parameters "
                    f"IA={IA}, FV={FV}, FS={FS}, FO={FO}: give the model its gear ratio"
                )
            motor = {}
        else:
            motor = {"Jm": IA / G**2, "B": FV / G**2, "Tc": ((FS + FO) / abs(G), (FO - FS) / abs(G))}
        links.append(
            dataclasses.replace(
                link,
                m=float(m),
                r=tuple(float(x) for x in r),
                I=tuple(tuple(float(x) for x in row) for row in I),
                **motor,
            )
        )
    return dataclasses.replace(robot, links=tuple(links))


# --------------------------------------------------------------------------- the entry point


def physical(
    robot: Robot,
    base_names: Sequence[str],
    base_values,
    base_cov=None,
    *,
    prior=None,
    regularisation: float = 1e-3,
    method: str | None = None,
    base: BaseParameters | None = None,
    tol: float = 1e-8,
) -> Consistent:
    """Standard parameters for every link that reproduce the base parameters `base_values`
    (named `base_names`, the names of the standard parameters they are pivoted on: ZZ1,
    FV1, XX2, …, as `base_parameters(robot)` orders them or in any order) as closely as
    possible and are physically realisable (module docstring).

    base_cov: their covariance (b × b) from the estimate, which weighs the fit (None: each
    base parameter relative to its scale).  prior: the model the null space is regularised
    towards — a Robot, or {name: value} over the robot's own values; None: `robot`.
    regularisation: λ, the weight of the prior's term (> 0 makes the solution unique).
    method: "sdp" (Clarabel, the extra `identify`: exact, fast) or "casadi" (IPOPT over a
    log-Cholesky factor, stopped at tol²: no extra, slower, as close as the interior of the cone
    lets it come: 3e-11 of τ on the floating-base test trees, where the SDP gives 4e-12); None:
    "sdp" where Clarabel is installed, else "casadi".
    base: the robot's `BaseParameters`, when already at hand.  Returns a `Consistent`.
    """
    if method is None:
        try:
            import clarabel  # noqa: F401

            method = "sdp"
        except ImportError:
            method = "casadi"
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: expected one of {METHODS}")
    robot.require_numeric("physically consistent parameters")
    start = time.perf_counter()
    base = base or _base(robot)
    floating = robot.base_joint is not None
    n = robot.n + floating  # blocks of PER: a floating base's body is the first, its motor terms held at 0
    names = [str(s) for s in base.params]
    pivots = [names[k] for k in base.independent]
    base_names = [str(s) for s in base_names]
    values = np.asarray(base_values, dtype=float).ravel()
    if len(values) != len(base_names):
        raise ValueError(f"{len(base_names)} base names but {len(values)} values")
    missing = sorted(set(pivots) - set(base_names), key=pivots.index)
    unknown = [b for b in base_names if b not in pivots]
    if missing or unknown:
        raise ValueError(
            f"base parameters of {robot.name!r} are {', '.join(pivots)}; "
            + (f"missing {missing}" if missing else "")
            + ("; " if missing and unknown else "")
            + (f"not base parameters: {unknown}" if unknown else "")
        )
    if not np.all(np.isfinite(values)):
        bad = [b for b, v in zip(base_names, values) if not np.isfinite(v)]
        raise ValueError(f"base values of {bad} are not finite")
    order = [base_names.index(b) for b in pivots]
    beta = values[order]
    P = _matrix_P(base)
    pi0 = _prior_vector(robot, prior, names)
    if floating:  # the body's ten padded to a block of fourteen
        P, pi0 = _padded(P), _padded(pi0)
    s, ms, L = _scales(pi0, n, beta, P)

    # weights of the fit: Σ^{-1/2}, or the inverse scale of each base parameter's pivot
    if base_cov is not None:
        C = np.asarray(base_cov, dtype=float)
        if C.shape != (len(values), len(values)):
            raise ValueError(f"base_cov must be {len(values)}×{len(values)}, got {C.shape}")
        C = C[np.ix_(order, order)]
        scale = np.array([s[k] for k in base.independent])
        C = (C + C.T) / 2 + np.diag((1e-9 * scale) ** 2)  # noise-free σ = 0 must not divide by 0
        W = np.linalg.inv(np.linalg.cholesky(C))
    else:
        W = np.diag([1 / s[k] for k in base.independent])
    Wrel = np.diag([1 / s[k] for k in base.independent])

    # the two terms, linear in x (the solvers' variables): ‖W(P T x − β̂)‖² and ‖Q S⁻¹(T x − π₀)‖²
    T = _linear_map(n, ms, L)
    A = P * s  # P S
    Q = np.eye(len(s)) - np.linalg.pinv(A) @ A
    Q = (Q + Q.T) / 2
    fit = (W @ P @ T, W @ beta)
    reg = (Q @ (T / s[:, None]), Q @ (pi0 / s))
    x0 = np.linalg.lstsq(T, pi0, rcond=None)[0]

    solve = _solve_clarabel if method == "sdp" else _solve_casadi
    nomotor = [0] * floating + [
        j + floating for j, link in enumerate(robot.links) if float(link.G) == 0
    ]  # no motor: IA = FV = FS = FO = 0
    x, status = solve(fit, reg, regularisation, n, x0, tol, nomotor)

    # onto the constraint set exactly (a solver's tolerance may leave −1e-10)
    for j in range(n):
        Jm = np.array(_upper_to_J(x[j * PER : j * PER + 10]), dtype=float)
        w, V = np.linalg.eigh(Jm)
        Jm = (V * np.maximum(w, 0)) @ V.T
        x[j * PER : j * PER + 10] = [Jm[a, b] for a in range(4) for b in range(a, 4)]
        IA, FV, FS, FO = x[j * PER + 10 : j * PER + 14]
        x[j * PER + 10 : j * PER + 14] = [max(IA, 0), max(FV, 0), max(FS, abs(FO)), FO] if j not in nomotor else 0
    pi = T @ x
    achieved = P @ pi
    margins = np.array(
        [
            np.linalg.eigvalsh(
                pseudo_inertia([[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]], v[6:9], v[9])
            ).min()
            for v in pi.reshape(n, PER)
        ]
    )
    r = achieved - beta
    moved = float(np.linalg.norm(Wrel @ r) / max(np.linalg.norm(Wrel @ beta), 1e-300))
    sigmas = float(np.linalg.norm(W @ r)) if base_cov is not None else None
    if floating:
        pi = np.delete(pi, slice(len(BODY), PER))
    new = _robot_from(robot, pi, _frame_maps(robot))
    seconds = time.perf_counter() - start
    # report in the caller's order
    back = np.empty_like(beta)
    back[order] = beta
    got = np.empty_like(achieved)
    got[order] = achieved
    return Consistent(
        robot=new,
        standard=dict(zip(names, pi.tolist())),
        base_names=tuple(base_names),
        target=back,
        achieved=got,
        margins=margins,
        moved=moved,
        sigmas=sigmas,
        method=method,
        seconds=seconds,
        status=str(status),
        regularisation=regularisation,
        scales=np.array([s[k] for k in base.independent])[np.argsort(order)],
    )


def base_vector(robot: Robot, base: BaseParameters | None = None) -> tuple[list, np.ndarray]:
    """The robot's base parameters as (names, float values), in `base_parameters` order; `base`
    may be another robot's of the same geometry (its combinations P applied to this robot's π)."""
    base = base or _base(robot)
    pi = np.array([float(v) for v in parameter_values(robot)])
    return [str(base.params[k]) for k in base.independent], _matrix_P(base) @ pi
