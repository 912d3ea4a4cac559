"""The chapter's motor-side exercises: root locus of the sampled velocity loop
(ex. 1b), a voltage-driven motor with back EMF (ex. 1c) and a series-elastic
actuator that touches an object, filters motion and meets a collision (ex. 12).

Where it sits: an application of `symdyn.apps.control` (the Puma shoulder's
`JointDrive`, the `SEA`); pure NumPy/SciPy, no arm model.  The studies in
`symdyn.apps.studies.exercises_motor` plot what these functions compute.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .control import SEA, JointDrive

__all__ = [
    "SampledVelocityLoop",
    "VoltageDrive",
    "current_loop",
    "bandwidth",
    "GuardedTouch",
    "sea_frequency_response",
    "collision_steady_state",
]


# --------------------------------------------------------------------------- ex. 1b: root locus


@dataclass(frozen=True)
class SampledVelocityLoop:
    """The velocity loop of `control.VelocityLoop` as a linear discrete system:
    the drive's J·ω̇ = Km·i − Bm·ω held over a period T (zero-order hold), the
    current demand applied one sample late (computation delay), controller
    i = Kv·e (+ Ki·T·Σe, backward rectangle).  Coulomb friction, a constant
    disturbance, and the torque limit are left out: they do not move poles."""

    drive: JointDrive = JointDrive()
    T: float = 1e-3

    @property
    def a(self) -> float:
        """Pole of the sampled motor, exp(−Bm·T/J)."""
        return math.exp(-self.drive.Bm * self.T / self.drive.J)

    @property
    def b(self) -> float:
        """Motor speed gained per sample per ampere, Km·(1 − a)/Bm (rad/s per A)."""
        return self.drive.Km * (1 - self.a) / self.drive.Bm

    def closed_loop(self, Kv: float, Ki: float | None = None) -> np.ndarray:
        """Closed-loop state matrix over [ω, applied current, integral of e] (P, Ki None: the first two)."""
        a, b, T = self.a, self.b, self.T
        if Ki is None:
            return np.array([[a, b], [-Kv, 0.0]])
        return np.array([[a, b, 0.0], [-(Kv + Ki * T), 0.0, Ki], [-T, 0.0, 1.0]])

    def poles(self, Kv: float, Ki: float | None = None) -> np.ndarray:
        """Closed-loop poles in the z-plane (eigenvalues of `closed_loop`)."""
        return np.linalg.eigvals(self.closed_loop(Kv, Ki))

    def max_gain(self, integral_ratio: float | None = None) -> float:
        """Largest Kv (A·s/rad) with every pole inside the unit circle, PI with Ki = integral_ratio·Kv
        (None: P), found on the locus where the spectral radius crosses 1 (P control: exactly 1/b)."""
        ki = lambda K: None if integral_ratio is None else integral_ratio * K  # noqa: E731
        radius = lambda K: np.abs(self.poles(K, ki(K))).max() - 1.0  # noqa: E731
        guess = 1.0 / self.b
        return brentq(radius, 0.2 * guess, 3.0 * guess, xtol=1e-12)


# --------------------------------------------------------------------------- ex. 1c: voltage drive


@dataclass(frozen=True)
class VoltageDrive:
    """The Puma shoulder motor driven by a voltage: L·di/dt = v − R·i − Kb·ω,
    J·ω̇ = Km·i − Bm·ω, with Kb = Km (SI units).  Winding 1 mH, 1.6 Ω (ex. 1c)."""

    drive: JointDrive = JointDrive()
    L: float = 1e-3
    R: float = 1.6
    back_emf: bool = True

    @property
    def Kb(self) -> float:
        """Back-EMF constant (V·s/rad), equal to the torque constant; 0 without back EMF."""
        return self.drive.Km if self.back_emf else 0.0

    @property
    def damping(self) -> float:
        """Viscous damping of the motor at low frequency, Bm + Km·Kb/R (N·m·s/rad)."""
        return self.drive.Bm + self.drive.Km * self.Kb / self.R

    def open_loop(self) -> tuple[np.ndarray, np.ndarray]:
        """Ω(s)/V(s) = Km / ((Ls + R)(Js + Bm) + Km·Kb) as (num, den) in s (rad/s per V)."""
        d = self.drive
        return np.array([d.Km]), np.polyadd(np.polymul([self.L, self.R], [d.J, d.Bm]), [d.Km * self.Kb])

    def closed_loop(self, Kv: float) -> tuple[np.ndarray, np.ndarray]:
        """Speed loop v = Kv·(ω* − ω), Kv in V·s/rad: Ω/Ω* = Kv·Km / (den_open + Kv·Km)."""
        num, den = self.open_loop()
        return Kv * num, np.polyadd(den, Kv * num)


def current_loop(drive: JointDrive, Kv: float) -> tuple[np.ndarray, np.ndarray]:
    """Speed loop of an ideal current amplifier, i = Kv·e (A·s/rad): Ω/Ω* = Kv·Km/(Js + Bm + Kv·Km)."""
    return np.array([Kv * drive.Km]), np.array([drive.J, drive.Bm + Kv * drive.Km])


def bandwidth(num, den) -> float:
    """−3 dB frequency (rad/s) of a low-pass num/den in s: the lowest ω with |H(jω)| = |H(0)|/√2."""
    h0 = abs(np.polyval(num, 0) / np.polyval(den, 0))
    gain = lambda w: abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)) - h0 / math.sqrt(2)  # noqa: E731
    hi = 1.0
    while gain(hi) > 0:
        hi *= 2
    return brentq(gain, hi / 2 if hi > 1 else 0.0, hi, xtol=1e-10)


# --------------------------------------------------------------------------- ex. 12: series-elastic actuator


class GuardedTouch:
    """Touch an object at an unknown distance and settle at a force, through the spring of a `SEA`.

    The motor is a velocity source (u = Kb·(v* − ẋ_m) + f_s, the sensed
    spring force f_s = k(x_m − x_l) fed forward, |u| ≤ the SEA's limit) and its
    speed demand is an admittance on the spring force, v* = Ka·(f_ref − f_s),
    Ka = 2/√(k·m_load) (critically damped load).  Free space: f_ref = v/Ka,
    so the arm approaches at speed v with f_s → 0.  Contact (the load, having
    moved, stops: |ẋ_l| < v/50) latches f_ref = `force`: the spring winds up to
    exactly `force` (v* = 0 only there).  Call once per sample, in time order.
    """

    def __init__(self, sea: SEA, force: float = 5.0, speed: float = 0.2, Kb: float = 50.0):
        self.sea, self.force, self.speed, self.Kb = sea, force, speed, Kb
        self.Ka = 2.0 / math.sqrt(sea.k * sea.m_load)
        self.moved, self.contact_time = False, None

    def __call__(self, t, q, qd):
        fs = float(self.sea.spring_force(q))
        self.moved |= qd[1] > 0.5 * self.speed
        if self.contact_time is None and self.moved and abs(qd[1]) < self.speed / 50:
            self.contact_time = t
        f_ref = self.speed / self.Ka if self.contact_time is None else self.force
        v = self.Ka * (f_ref - fs)
        u = np.clip(self.Kb * (v - qd[0]) + fs, -self.sea.force_limit, self.sea.force_limit)
        return np.array([u, 0.0])


def sea_frequency_response(k: float, m_load: float, w, zeta: float = 0.05) -> np.ndarray:
    """X₂(jω)/X₁(jω) of the load on the spring, motor position as input:
    (2ζω_n s + ω_n²)/(s² + 2ζω_n s + ω_n²), ω_n = √(k/m_load), with a spring damper
    c = 2ζ√(k·m) (the book's SEA has none: ζ = 0 would make the peak infinite)."""
    wn = math.sqrt(k / m_load)
    s = 1j * np.asarray(w, float)
    return (2 * zeta * wn * s + wn**2) / (s**2 + 2 * zeta * wn * s + wn**2)


def collision_steady_state(sea: SEA, K, force: float, goal: float = 1.0) -> np.ndarray:
    """Rest state [x_m, x_l] of the LQR-held SEA (u = K·([goal, 0, goal, 0] − x)) under a
    constant force `force` (N) on the load: solves m·ẍ = 0 for both masses."""
    k1, _, k3, _ = (float(x) for x in K)
    # motor: u − k(x_m − x_l) = 0, u = k1(goal − x_m) + k3(goal − x_l); load: k(x_m − x_l) + force = 0
    A = np.array([[-k1 - sea.k, -k3 + sea.k], [sea.k, -sea.k]])
    rhs = np.array([-(k1 + k3) * goal, -force])
    return np.linalg.solve(A, rhs)
