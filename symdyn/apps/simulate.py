"""Forward-dynamics simulation of a numeric arm: q̈ = M⁻¹(τ − C q̇ − G − F), integrated over time.

Two integrators behind one function: scipy's adaptive `solve_ivp`
(`Adaptive`) and classical fixed-step Runge–Kutta 4 (`RK4`).  Coulomb
friction's jump at q̇ = 0 would stall an adaptive solver and chatter in a
fixed-step one, so it is smoothed: |G|·Tc±·tanh(|q̇|/w) with a stated width
w (rad/s or m/s, joint side); w = 0 keeps the exact Toolbox sign law.
The right-hand side is the forward dynamics of `symdyn.numeric.backend.model`
(by default generated code where it exists, else the plain CasADi RNEA).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from ..derivation.progress import Progress
from ..model import Robot
from ..numeric import backend as backends
from ..numeric import reference

__all__ = [
    "Adaptive",
    "RK4",
    "Trajectory",
    "COULOMB_WIDTH",
    "smooth_friction",
    "simulate",
    "total_energy",
    "StderrProgress",
]

COULOMB_WIDTH = 0.01  # rad/s: Coulomb friction reaches tanh(1) = 76 % of Tc at |q̇| = 0.01 rad/s


@dataclass(frozen=True)
class Adaptive:
    """scipy `solve_ivp` with error control; `sample` (s) gives uniform output times, else the solver's steps."""

    rtol: float = 1e-9
    atol: float = 1e-9
    method: str = "DOP853"
    sample: float | None = None


@dataclass(frozen=True)
class RK4:
    """Classical 4th-order Runge–Kutta with fixed step `dt` (s); output at every step."""

    dt: float = 1e-3


@dataclass(frozen=True)
class Trajectory:
    """A simulated motion: t (N,), q and q̇ (N, n)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray


def smooth_friction(robot: Robot, qd, width: float = COULOMB_WIDTH) -> np.ndarray:
    """Joint friction (..., n): G²·B·q̇ + |G|·Tc±·tanh(|q̇|/width), Tc⁺ for q̇ > 0, Tc⁻ for q̇ < 0.

    width = 0 gives the exact law of `reference.friction` (a jump at rest).
    """
    if width == 0:
        return reference.friction(robot, qd)
    return _smooth_friction_law(robot, width)(qd)


def _smooth_friction_law(robot: Robot, width: float = COULOMB_WIDTH) -> Callable[[np.ndarray], np.ndarray]:
    """q̇ ↦ `smooth_friction(robot, q̇, width)` with the robot's constants read once (for the integrator's loop)."""
    if not (np.isfinite(width) and width >= 0):
        raise ValueError(f"Coulomb smoothing width must be a finite number >= 0, got {width!r}")
    if width == 0:
        return reference.friction_law(robot)
    G = np.array([float(link.G) for link in robot.links])
    B = np.array([float(link.B) for link in robot.links])
    Tc = np.array([[float(x) for x in link.Tc] for link in robot.links])

    def F(qd) -> np.ndarray:
        qd = np.asarray(qd, dtype=float)
        coulomb = np.where(qd >= 0, Tc[:, 0], Tc[:, 1]) * np.tanh(np.abs(qd) / width)
        return G**2 * B * qd + np.abs(G) * coulomb

    return F


class StderrProgress:
    """Progress lines on stderr (`symdyn.derivation.progress`) every `step` of the simulated span, then the run time."""

    def __init__(self, label: str, step: float = 0.1):
        self.lines = Progress(label, round(1 / step), lines=round(1 / step))
        self.step, self.next = step, step

    def __call__(self, fraction: float, t: float, T: float) -> None:
        while fraction >= self.next - 1e-12 and self.lines.count < self.lines.total:
            self.lines.step(f"(t = {t:.2f} of {T:.2f} s)")
            self.next += self.step
            if self.lines.count == self.lines.total:
                self.lines.done()


def simulate(
    robot: Robot,
    T: float,
    q0,
    qd0=None,
    torque: Callable | None = None,
    *,
    integrator: Adaptive | RK4 = Adaptive(),
    coulomb_width: float = COULOMB_WIDTH,
    progress: Callable[[float, float, float], None] | None = None,
    backend: str = "auto",
) -> Trajectory:
    """Integrate the forward dynamics from (q0, q̇0) over [0, T] s.

    torque(t, q, q̇) -> τ (n,) in N·m (or N), None for zero torque.  Friction
    as `smooth_friction(robot, q̇, coulomb_width)`.  progress(fraction, t, T)
    is called as time advances (e.g. `StderrProgress`).  backend: which
    implementation evaluates q̈ = M⁻¹(τ − C q̇ − G − F), as `symdyn.numeric.backend.model`
    (all agree to rounding; "reference" is ~100× slower per call).
    """
    robot.require_numeric("simulate")
    if not (np.isscalar(T) and np.isfinite(T) and T > 0):
        raise ValueError(f"T must be a positive finite time in seconds, got {T!r}")
    n = robot.n
    q0 = np.asarray(q0, dtype=float)
    qd0 = np.zeros(n) if qd0 is None else np.asarray(qd0, dtype=float)
    if q0.shape != (n,) or qd0.shape != (n,):
        raise ValueError(f"q0 and qd0 must have shape ({n},); got {q0.shape} and {qd0.shape}")
    friction = _smooth_friction_law(robot, coulomb_width)
    rigid = backends.model(robot.nofriction(all=True), backend)
    zero = np.zeros(n)

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        q, qd = x[:n], x[n:]
        tau = zero if torque is None else np.asarray(torque(t, q, qd), dtype=float)
        if tau.shape != (n,):
            raise ValueError(f"torque(t, q, qd) must return shape ({n},), got {tau.shape}")
        if progress is not None:
            progress(t / T, t, T)
        return np.concatenate([qd, rigid.fdyn(q, qd, tau - friction(qd))])

    x0 = np.concatenate([q0, qd0])
    if isinstance(integrator, RK4):
        t, x = _rk4(rhs, x0, float(T), integrator.dt)
    elif isinstance(integrator, Adaptive):
        t_eval = None
        if integrator.sample is not None:
            t_eval = np.linspace(0.0, T, int(round(T / integrator.sample)) + 1)
        sol = solve_ivp(
            rhs,
            (0.0, float(T)),
            x0,
            method=integrator.method,
            rtol=integrator.rtol,
            atol=integrator.atol,
            t_eval=t_eval,
        )
        if not sol.success:
            raise RuntimeError(f"forward dynamics integration of {robot.name!r} failed: {sol.message}")
        t, x = sol.t, sol.y.T
    else:
        raise ValueError(f"integrator must be Adaptive(...) or RK4(...), got {integrator!r}")
    if progress is not None:
        progress(1.0, float(T), float(T))
    return Trajectory(t, x[:, :n], x[:, n:])


def _rk4(f: Callable, x0: np.ndarray, T: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Fixed-step RK4 over [0, T]; the last step is shortened to land on T."""
    if not (np.isfinite(dt) and 0 < dt <= T):
        raise ValueError(f"RK4 step dt must be in (0, T = {T}] seconds, got {dt!r}")
    steps = int(np.ceil(T / dt - 1e-9))
    t = np.minimum(np.arange(steps + 1) * dt, T)
    x = np.empty((steps + 1, x0.size))
    x[0] = x0
    for k in range(steps):
        h, tk, xk = t[k + 1] - t[k], t[k], x[k]
        k1 = f(tk, xk)
        k2 = f(tk + h / 2, xk + h / 2 * k1)
        k3 = f(tk + h / 2, xk + h / 2 * k2)
        k4 = f(tk + h, xk + h * k3)
        x[k + 1] = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return t, x


def total_energy(robot: Robot, traj: Trajectory) -> np.ndarray:
    """Kinetic + potential energy (N,) in J along a trajectory (`reference.energy`)."""
    kinetic, potential = reference.energy(robot, traj.q, traj.qd)
    return kinetic + potential
