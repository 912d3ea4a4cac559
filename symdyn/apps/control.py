"""Controllers of Corke's chapter 9 and a fixed-step closed-loop simulator.

Where it sits: a consumer of the flow model → derive → … → emit.  The arm's
dynamics come through `symdyn.numeric.backend.Model` (attributes tau, M, Cqd, G,
F, fdyn, all batched), built on generated code or on `symdyn.reference`,
so the controllers never care which.  Contents: joint-space trajectories
(`lspb`, `quintic`); `simulate` (RK4 at a fixed step, sampled controllers
with zero-order hold and computation delay); independent joint control of
the Puma shoulder (`JointDrive`, `VelocityLoop`, `PositionLoop`, §9.1);
torque feedforward (Eq. 9.11) and computed torque (Eq. 9.13); Khatib's
operational-space motion/force control (Eq. 9.15); a series-elastic
actuator with LQR state feedback.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.linalg import solve_continuous_are

from ..model import Robot
from ..numeric import reference as ref
from ..numeric.backend import Model
from .simulate import StderrProgress

__all__ = [
    "lspb",
    "quintic",
    "Trace",
    "simulate",
    "scale_inertia",
    "scaled",
    "JointDrive",
    "VelocityLoop",
    "PositionLoop",
    "TorqueFeedforward",
    "ComputedTorque",
    "Surface",
    "OperationalSpace",
    "SEA",
]


# --------------------------------------------------------------------------- trajectories


def _times(t) -> tuple[np.ndarray, bool]:
    a = np.asarray(t, dtype=float)
    return np.atleast_1d(a), a.ndim == 0


def lspb(q0, q1, T: float, t, V=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear segment with parabolic blends from q0 to q1 in T seconds (Corke's `lspb`).

    q0, q1 scalars or (n,); V the cruise speed, by default 1.5·(q1 − q0)/T as
    the Toolbox; it must lie between |q1 − q0|/T and 2|q1 − q0|/T.  Returns
    (q, q̇, q̈) of shape (len(t), n) (or (n,) for scalar t); held outside [0, T].
    """
    q0, q1 = np.atleast_1d(np.asarray(q0, float)), np.atleast_1d(np.asarray(q1, float))
    if not T > 0:
        raise ValueError(f"lspb: the duration T must be positive, got {T!r}")
    span = q1 - q0
    V = 1.5 * span / T if V is None else np.sign(span) * np.abs(np.broadcast_to(np.asarray(V, float), span.shape))
    moving = span != 0
    ratio = np.abs(V[moving]) * T / np.abs(span[moving])
    if np.any((ratio <= 1) | (ratio > 2)):
        raise ValueError(f"lspb: cruise speed V = {V} must satisfy |q1-q0|/T < |V| <= 2|q1-q0|/T")
    tb = np.full(span.shape, T / 3)  # blend time (any value where span = 0)
    tb[moving] = T - span[moving] / V[moving]
    acc = V / tb
    raw, scalar = _times(t)
    tt = np.clip(raw, 0.0, T)[:, None]
    first, last = tt <= tb, tt >= T - tb
    q = np.where(first, q0 + 0.5 * acc * tt**2, np.where(last, q1 - 0.5 * acc * (T - tt) ** 2, q0 + V * (tt - tb / 2)))
    qd = np.where(first, acc * tt, np.where(last, acc * (T - tt), V))
    qdd = np.where(first, acc, np.where(last, -acc, 0.0))
    qdd = np.where(((raw < 0) | (raw > T))[:, None], 0.0, qdd)
    return (q[0], qd[0], qdd[0]) if scalar else (q, qd, qdd)


def quintic(q0, q1, T: float, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic polynomial from q0 to q1 in T seconds, zero boundary velocity and
    acceleration (Corke's `jtraj`).  Shapes as `lspb`; held outside [0, T]."""
    q0, q1 = np.atleast_1d(np.asarray(q0, float)), np.atleast_1d(np.asarray(q1, float))
    if not T > 0:
        raise ValueError(f"quintic: the duration T must be positive, got {T!r}")
    tt, scalar = _times(t)
    s = np.clip(tt, 0.0, T)[:, None] / T
    span = q1 - q0
    q = q0 + span * (10 * s**3 - 15 * s**4 + 6 * s**5)
    qd = span * (30 * s**2 - 60 * s**3 + 30 * s**4) / T
    qdd = span * (60 * s - 180 * s**2 + 120 * s**3) / T**2
    return (q[0], qd[0], qdd[0]) if scalar else (q, qd, qdd)


# --------------------------------------------------------------------------- simulator


@dataclass(frozen=True)
class Trace:
    """A closed-loop run: t (K,), q and qd (K, ..., n), tau (K, ..., n) the
    torque applied over [t_k, t_k+1) (for continuous control: at t_k)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray


def _rk4_step(accel, tau_of, t, q, qd, dt, tau0):
    """One classical Runge–Kutta step of (q, q̇)' = (q̇, accel(t, q, q̇, tau_of(t, q, q̇)))."""
    k1v, k1a = qd, accel(t, q, qd, tau0)
    q2, qd2 = q + 0.5 * dt * k1v, qd + 0.5 * dt * k1a
    k2v, k2a = qd2, accel(t + dt / 2, q2, qd2, tau_of(t + dt / 2, q2, qd2))
    q3, qd3 = q + 0.5 * dt * k2v, qd + 0.5 * dt * k2a
    k3v, k3a = qd3, accel(t + dt / 2, q3, qd3, tau_of(t + dt / 2, q3, qd3))
    q4, qd4 = q + dt * k3v, qd + dt * k3a
    k4v, k4a = qd4, accel(t + dt, q4, qd4, tau_of(t + dt, q4, qd4))
    return q + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v), qd + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)


def simulate(
    accel: Callable,
    controller: Callable,
    T: float,
    q0,
    qd0=None,
    *,
    dt: float = 1e-3,
    period: float | None = None,
    delay: int = 0,
    progress: str | None = None,
) -> Trace:
    """Integrate a closed loop with fixed-step RK4 from (q0, qd0) over [0, T].

    accel(t, q, qd, tau) → q̈ is the plant and controller(t, q, qd) → tau
    the controller, both batched over the leading axes of q0 (..., n).
    period=None: continuous control, the controller is evaluated at every
    RK4 stage (it must then be a pure function of its arguments).  Otherwise
    it is sampled every `period` seconds (a whole number of steps dt), called
    once per sample in time order (so it may keep state), its output held
    (zero-order hold) and applied `delay` samples later (computation delay;
    zero torque before the first output arrives).  `progress`: a label for
    progress lines on stderr (`symdyn.apps.simulate.StderrProgress`).
    """
    if not (T > 0 and dt > 0):
        raise ValueError(f"simulate: T and dt must be positive, got T={T!r}, dt={dt!r}")
    K = int(round(T / dt))
    if abs(K * dt - T) > 1e-9 * T:
        raise ValueError(f"simulate: T = {T} is not a whole number of steps dt = {dt}")
    q = np.array(q0, dtype=float)
    qd = np.zeros_like(q) if qd0 is None else np.array(np.broadcast_to(qd0, q.shape), dtype=float)
    every = None
    if period is not None:
        every = int(round(period / dt))
        if every < 1 or abs(every * dt - period) > 1e-9 * period:
            raise ValueError(f"simulate: the control period {period} must be a whole number of steps dt = {dt}")
    if delay < 0 or (delay and period is None):
        raise ValueError(f"simulate: a delay of {delay} samples needs a sampled controller (period)")
    ts = np.arange(K + 1) * dt
    Q, QD, TAU = (np.empty((K + 1,) + q.shape) for _ in range(3))
    pending = [np.zeros_like(q)] * delay
    held = np.zeros_like(q)
    report = None if progress is None else StderrProgress(progress)
    for k in range(K):
        t = ts[k]
        Q[k], QD[k] = q, qd
        if every is None:
            tau_of = controller
        else:
            if k % every == 0:
                pending.append(np.asarray(controller(t, q, qd), dtype=float))
                held = np.broadcast_to(pending.pop(0), q.shape)
            tau_of = lambda t_, q_, qd_: held  # noqa: E731
        TAU[k] = np.broadcast_to(tau_of(t, q, qd), q.shape)
        q, qd = _rk4_step(accel, tau_of, t, q, qd, dt, TAU[k])
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise RuntimeError(
                f"simulate: the state became NaN or infinite at t = {t + dt:.4f} s; "
                f"try a smaller step dt (now {dt}) or gentler gains"
            )
        if report is not None:
            report((k + 1) / K, t + dt, T)
    Q[K], QD[K], TAU[K] = q, qd, TAU[K - 1]
    return Trace(ts, Q, QD, TAU)


# --------------------------------------------------------------------------- model variants


def scale_inertia(robot: Robot, factor: float) -> Robot:
    """A copy of `robot` with every link's mass and inertia tensor multiplied by
    `factor` (COM positions and motor parameters unchanged): the perturbed
    model used to test robustness to ±10 % inertial-parameter error."""
    if not factor > 0:
        raise ValueError(f"scale_inertia: factor must be positive, got {factor!r}")
    links = tuple(
        dataclasses.replace(l, m=l.m * factor, I=tuple(tuple(x * factor for x in row) for row in l.I))
        for l in robot.links
    )
    return dataclasses.replace(robot, links=links, name=f"{robot.name}*{factor:g}")


def scaled(base: Model, robot: Robot, factor) -> Model:
    """`base` with the link inertial parameters scaled by `factor`, exactly as
    `backend.model(scale_inertia(robot, factor))` but from the nominal functions.

    The dynamics are linear in the inertial parameters, so the link part of
    τ, M, C·q̇ and G scales by `factor`; the rotor inertia G²·Jm and the
    friction do not.  `factor` may be an array of shape (B,): one factor
    per row of a batch, so several perturbed models run as one batch.
    """
    f = np.asarray(factor, dtype=float)
    if np.any(f <= 0):
        raise ValueError(f"scaled: factors must be positive, got {factor!r}")
    rotor = np.array([float(l.G) ** 2 * float(l.Jm) for l in robot.links])
    fv, fm = f[..., None], f[..., None, None]

    def tau(q, qd, qdd):
        fixed = rotor * np.asarray(qdd, float) + base.F(qd)
        return fv * (base.tau(q, qd, qdd) - fixed) + fixed

    def M(q):
        return fm * (base.M(q) - np.diag(rotor)) + np.diag(rotor)

    def fdyn(q, qd, tau_):
        bias = fv * (base.Cqd(q, qd) + base.G(q)) + base.F(qd)
        return np.linalg.solve(M(q), (np.asarray(tau_, float) - bias)[..., None])[..., 0]

    return Model(
        n=base.n,
        tau=tau,
        M=M,
        Cqd=lambda q, qd: fv * base.Cqd(q, qd),
        G=lambda q: fv * base.G(q),
        F=base.F,
        fdyn=fdyn,
        source=f"{base.source}, link inertia x {factor}",
    )


# --------------------------------------------------------------------------- independent joint control (§9.1)


@dataclass(frozen=True)
class JointDrive:
    """One joint seen from the motor side of its gearbox (Table 9.2: the Puma
    shoulder).  Km N·m/A, Jm kg·m², Bm N·m·s/rad, Tc = (Tc⁺, Tc⁻) N·m, gear
    ratio G, torque limit tau_max N·m, speed limit qd_max rad/s; Jl the link
    inertia about the joint (3.66…5.21 kg·m² over the workspace; default
    4.42 gives the book's total J = 580e-6), referred through G²; tau_load a
    constant link-side load torque resisting positive motion (gravity, 20 N·m)."""

    Km: float = 0.228
    Jm: float = 200e-6
    Bm: float = 817e-6
    Tc: tuple = (0.126, -0.071)
    G: float = 107.815
    tau_max: float = 0.9
    qd_max: float = 165.0
    Jl: float = 4.42
    tau_load: float = 0.0

    @property
    def J(self) -> float:
        """Total inertia at the motor, J = Jm + Jl/G² (kg·m²)."""
        return self.Jm + self.Jl / self.G**2

    def friction(self, omega):
        """Motor friction Bm·ω + Tc⁺ (ω > 0) or Tc⁻ (ω < 0), 0 at rest (N·m)."""
        omega = np.asarray(omega, float)
        return self.Bm * omega + np.where(omega > 0, self.Tc[0], np.where(omega < 0, self.Tc[1], 0.0))

    def accel(self, t, theta, omega, tau):
        """Motor acceleration (rad/s²): J ω̇ = τ − Bm ω − Tc(ω) − tau_load/G."""
        return (np.asarray(tau, float) - self.friction(omega) - self.tau_load / self.G) / self.J

    def saturate(self, tau):
        """Motor torque clipped to ±tau_max (the amplifier's current limit)."""
        return np.clip(tau, -self.tau_max, self.tau_max)


class VelocityLoop:
    """Digital PI velocity controller of a `JointDrive` (Fig. 9.9).

    Output motor torque τ = sat(Km·(Kv·e + Ki·∫e) + tau_ff), e = ω* − ω, the
    controller's output a current demand (ideal amplifier), saturated at
    ±tau_max.  The integral is updated once per sample (backward rectangle,
    period s).  antiwindup=True: conditional integration (clamping) — the
    integral is frozen while the output is saturated and the error would push
    it further into saturation.  Call once per sample, in time order.
    """

    def __init__(
        self,
        drive: JointDrive,
        Kv: float,
        Ki: float = 0.0,
        *,
        period: float = 1e-3,
        antiwindup: bool = False,
        tau_ff: float = 0.0,
    ):
        self.drive, self.Kv, self.Ki, self.period = drive, Kv, Ki, period
        self.antiwindup, self.tau_ff = antiwindup, tau_ff
        self.integral = 0.0

    def __call__(self, demand, omega):
        e = demand - omega
        trial = self.integral + e * self.period
        raw = self.drive.Km * (self.Kv * e + self.Ki * trial) + self.tau_ff
        out = self.drive.saturate(raw)
        freeze = self.antiwindup & (raw != out) & (np.sign(e) == np.sign(raw))
        self.integral = np.where(freeze, self.integral, trial)
        return out


class PositionLoop:
    """P position loop around a `VelocityLoop` (Fig. 9.13), on the link angle
    q = θ_m/G: motor speed demand ω* = G·(Kp·(q* − q) + q̇*·[velocity_ff]),
    clipped to ±qd_max.  trajectory(t) → (q*, q̇*, q̈*) (link side).  As a
    controller for `simulate` with the motor state (θ_m, ω) of shape (..., 1)."""

    def __init__(self, inner: VelocityLoop, trajectory: Callable, Kp: float = 40.0, *, velocity_ff: bool = False):
        self.inner, self.trajectory, self.Kp, self.velocity_ff = inner, trajectory, Kp, velocity_ff

    def __call__(self, t, theta, omega):
        G = self.inner.drive.G
        qs, qds, _ = self.trajectory(t)
        demand = G * (self.Kp * (qs - theta / G) + (qds if self.velocity_ff else 0.0))
        demand = np.clip(demand, -self.inner.drive.qd_max, self.inner.drive.qd_max)
        return self.inner(demand, omega)


# --------------------------------------------------------------------------- arm controllers (§9.4)


class TorqueFeedforward:
    """Eq. 9.11: τ = M(q*)q̈* + C(q*, q̇*)q̇* + G(q*) + F(q̇*) + Kv(q̇* − q̇) + Kp(q* − q).

    The model part, `model.tau(q*, q̇*, q̈*)`, is evaluated every `ff_period`
    seconds (20 Hz by default) and held (zero-order hold); the PD feedback is
    evaluated at each call (every control sample).  Kp (N·m/rad), Kv
    (N·m·s/rad): scalars or (n,).  trajectory(t) → (q*, q̇*, q̈*).
    """

    def __init__(self, model: Model, trajectory: Callable, Kp, Kv, *, ff_period: float = 0.05):
        self.model, self.trajectory, self.Kp, self.Kv = model, trajectory, np.asarray(Kp), np.asarray(Kv)
        self.ff_period = ff_period
        self._sample, self._tau_ff = None, None

    def __call__(self, t, q, qd):
        k = math.floor(t / self.ff_period + 1e-9)
        if k != self._sample:
            self._sample = k
            self._tau_ff = self.model.tau(*self.trajectory(k * self.ff_period))
        qs, qds, _ = self.trajectory(t)
        return self._tau_ff + self.Kv * (qds - qd) + self.Kp * (qs - q)


class ComputedTorque:
    """Eq. 9.13: τ = M(q)(q̈* + Kv ė + Kp e) + C(q, q̇)q̇ + G(q) + F(q̇), e = q* − q,
    evaluated as one inverse-dynamics call `model.tau(q, q̇, q̈* + Kv ė + Kp e)`.
    With an exact model the error obeys ë + Kv ė + Kp e = 0, joint by joint.
    Kp (s⁻²), Kv (s⁻¹): scalars or (n,).  Stateless."""

    def __init__(self, model: Model, trajectory: Callable, Kp, Kv):
        self.model, self.trajectory, self.Kp, self.Kv = model, trajectory, np.asarray(Kp), np.asarray(Kv)

    def __call__(self, t, q, qd):
        qs, qds, qdds = self.trajectory(t)
        return self.model.tau(q, qd, qdds + self.Kv * (qds - qd) + self.Kp * (qs - q))


# --------------------------------------------------------------------------- operational space (§9.5)


@dataclass(frozen=True)
class Surface:
    """A horizontal compliant surface at height z (world, m) with stiffness k
    (N/m), frictionless.  wrench(T) is the wrench [f; n] (..., 6) the
    end-effector at pose T (..., 4, 4) exerts on it: f_z = −k·(z − z_ee) when
    below the surface, else 0 (what a wrist force sensor measures)."""

    z: float = -0.2
    k: float = 100.0

    def wrench(self, T):
        depth = np.maximum(self.z - np.asarray(T)[..., 2, 3], 0.0)
        W = np.zeros(depth.shape + (6,))
        W[..., 2] = -self.k * depth
        return W


def _orientation_error(R_goal, R):
    """½(n×n* + o×o* + a×a*): the rotation from R to R_goal as a world-frame
    vector, ≈ axis·sin(angle) (Luh, Walker & Paul)."""
    return 0.5 * np.cross(np.swapaxes(R, -1, -2), np.swapaxes(R_goal, -1, -2)).sum(-2)


class OperationalSpace:
    """Khatib's unified motion and force control in the world frame (Eq. 9.15).

    Task wrench F = Λ(q)a + μ(q, q̇) + p(q) + F_f and τ = Jᵀ F + F(q̇), with Λ =
    (J M⁻¹ Jᵀ)⁻¹.  The Puma's J (jacob0, [v; ω] at the tool point) is square,
    so this is τ = M J⁻¹(a − J̇q̇) + C q̇ + G + F + Jᵀ F_f, computed as one
    `model.tau` call.  Selection: `force_axes` (6 bools) are force-controlled,
    the rest position-controlled:
    a = S_p(Kp·[p* − p; e_o] − Kv·ẋ) − S_f·Kvf·ẋ,
    F_f = S_f(f* + Kf·(f* − f_s)),
    with f* the wrench to exert on the environment and f_s = sensor(q) the
    sensed one; e_o the orientation error to `pose`.  J̇q̇ by a central
    difference of J along q̇ (step 1e-6).  Stateless.
    """

    def __init__(
        self,
        model: Model,
        robot: Robot,
        pose,
        force,
        sensor: Callable,
        *,
        force_axes=(False, False, True, False, False, False),
        Kp=100.0,
        Kv=20.0,
        Kf=4.0,
        Kvf=12.0,
    ):
        self.model, self.robot, self.sensor = model, robot, sensor
        self.pose, self.force = np.asarray(pose, float), np.asarray(force, float)
        self.S_f = np.asarray(force_axes, dtype=float)
        self.Kp, self.Kv, self.Kf, self.Kvf = Kp, Kv, Kf, Kvf

    def __call__(self, t, q, qd):
        h = 1e-6
        T = ref.fkine(self.robot, q)
        J, Jp, Jm = ref.jacob0(self.robot, np.stack([q, q + h * qd, q - h * qd]))
        Jdqd = np.einsum("...ij,...j->...i", Jp - Jm, qd) / (2 * h)
        xd = np.einsum("...ij,...j->...i", J, qd)
        err = np.concatenate(
            [self.pose[:3, 3] - T[..., :3, 3], _orientation_error(self.pose[:3, :3], T[..., :3, :3])], -1
        )
        S_p = 1.0 - self.S_f
        a = S_p * (self.Kp * err - self.Kv * xd) - self.S_f * self.Kvf * xd
        F_f = self.S_f * (self.force + self.Kf * (self.force - self.sensor(q)))
        qdd = np.linalg.solve(J, (a - Jdqd)[..., None])[..., 0]
        return self.model.tau(q, qd, qdd) + np.einsum("...ji,...j->...i", J, F_f)


# --------------------------------------------------------------------------- series-elastic actuator (§9.6)


@dataclass(frozen=True)
class SEA:
    """Series-elastic actuator: motor mass m_motor (kg) driven by force u,
    spring k (N/m) to the load mass m_load (kg); values as RVC3's SEA model
    (0.5 kg, 1 kg, 5 N/m, |u| ≤ 2 N), no damping.  State x = [x_m, ẋ_m, x_l, ẋ_l].
    An optional obstacle at x_l = `obstacle` is a stiff, critically damped,
    unilateral wall (1e5 N/m; it pushes, never pulls)."""

    m_motor: float = 0.5
    m_load: float = 1.0
    k: float = 5.0
    force_limit: float = 2.0
    obstacle: float | None = None
    wall_k: float = 1e5

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear model ẋ = A x + B u (no obstacle, no force limit)."""
        k, m1, m2 = self.k, self.m_motor, self.m_load
        A = np.array([[0, 1, 0, 0], [-k / m1, 0, k / m1, 0], [0, 0, 0, 1], [k / m2, 0, -k / m2, 0]], float)
        return A, np.array([[0.0], [1 / m1], [0.0], [0.0]])

    def lqr(self, Q=(100.0, 10.0, 100.0, 10.0), R: float = 0.01) -> np.ndarray:
        """LQR gain K (4,) for u = K·(x* − x), from the continuous Riccati equation
        (scipy); Q diagonal weights on [x_m, ẋ_m, x_l, ẋ_l], R on u.  The defaults
        give gains near the book's [170, 63, −20, 71]."""
        A, B = self.matrices()
        P = solve_continuous_are(A, B, np.diag(np.asarray(Q, float)), np.array([[R]]))
        return (B.T @ P / R)[0]

    def spring_force(self, q):
        """Force in the spring k·(x_m − x_l) (N), positive when compressed by the motor."""
        q = np.asarray(q)
        return self.k * (q[..., 0] - q[..., 1])

    def wall_force(self, q, qd):
        """Force of the obstacle on the load (N, ≤ 0), zero without contact."""
        if self.obstacle is None:
            return np.zeros(np.shape(q)[:-1])
        depth = np.asarray(q)[..., 1] - self.obstacle
        push = self.wall_k * depth + 2 * math.sqrt(self.wall_k * self.m_load) * np.asarray(qd)[..., 1]
        return np.where(depth > 0, -np.maximum(push, 0.0), 0.0)

    def accel(self, t, q, qd, u):
        """Plant for `simulate`: q = [x_m, x_l], qd = [ẋ_m, ẋ_l], u = [motor force, unused]."""
        fs = self.spring_force(q)
        a = np.empty(np.shape(q))
        a[..., 0] = (u[..., 0] - fs) / self.m_motor
        a[..., 1] = (fs + self.wall_force(q, qd)) / self.m_load
        return a

    def controller(self, K, goal: float = 1.0) -> Callable:
        """State feedback u = sat(K·([goal, 0, goal, 0] − x)) as a `simulate` controller."""
        k1, k2, k3, k4 = (float(k) for k in K)

        def control(t, q, qd):
            u = np.zeros(np.shape(q))
            u[..., 0] = np.clip(
                k1 * (goal - q[..., 0]) - k2 * qd[..., 0] + k3 * (goal - q[..., 1]) - k4 * qd[..., 1],
                -self.force_limit,
                self.force_limit,
            )
            return u

        return control
