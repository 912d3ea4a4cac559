"""The chapter's whole-arm exercises on the Puma 560: every joint under its
own velocity and position loop (ex. 1e), the force ellipsoid beside the
dynamic manipulability (acceleration) ellipsoid (ex. 10), and operational-space
control tracing a circle on an inclined surface of unknown height (ex. 11d).

Where it sits: an application of `symdyn.apps.control` and `symdyn.apps.analysis`
over the arm's model from `symdyn.numeric.backend` (generated code for the
shipped Puma); the studies in `symdyn.apps.studies.exercises_arm` plot it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..model import Robot
from ..numeric import reference as ref
from ..numeric.backend import Model
from .analysis import AXES, joint_transfer_functions
from .control import OperationalSpace

__all__ = [
    "IndependentJoints",
    "independent_gains",
    "force_ellipsoid",
    "major_axis_angle",
    "InclinedSurface",
    "CircleOperationalSpace",
]


# --------------------------------------------------------------------------- ex. 1e: six independent joints


class IndependentJoints:
    """Every joint under its own loops, on the motor side (Fig. 9.13 per joint):
    motor speed demand ω* = G·(Kp·(q* − q) + q̇*), motor torque
    τ_m = Kv·e + Ki·∫e with e = ω* − G·q̇ (the integral updated before use, as
    `control.VelocityLoop`), link torque G·τ_m.  Gains are motor-side torques
    (N·m·s/rad, N·m/rad): the current demand is τ_m/Km, so the torque
    constant only scales the controller's units.  `integral` (n,) may start at
    the value that holds the arm (gravity).  Call once per sample, in time order."""

    def __init__(self, G, trajectory: Callable, Kv, Ki, Kp: float, *, period: float = 1e-3, integral=0.0):
        self.G, self.trajectory = np.asarray(G, float), trajectory
        self.Kv, self.Ki, self.Kp, self.period = np.asarray(Kv, float), np.asarray(Ki, float), Kp, period
        self.integral = np.asarray(integral, float)

    def __call__(self, t, q, qd):
        qs, qds, _ = self.trajectory(t)
        e = self.G * (self.Kp * (qs - q) + qds) - self.G * qd
        self.integral = self.integral + e * self.period
        return self.G * (self.Kv * e + self.Ki * self.integral)


def independent_gains(robot: Robot, q, bandwidth: float = 300.0, integral: float = 10.0):
    """Per-joint velocity-loop gains for `IndependentJoints` giving each motor the same
    loop bandwidth: Kv = J′·bandwidth, Ki = integral·Kv, with J′ = Jm + M_jj,link(q)/G²
    the inertia the motor sees at pose q (`analysis.joint_transfer_functions`).
    Returns (Kv, Ki, J′), each (n,)."""
    J = joint_transfer_functions(robot, q).J
    Kv = J * bandwidth
    return Kv, integral * Kv, J


# --------------------------------------------------------------------------- ex. 10: force ellipsoid


@dataclass(frozen=True)
class Ellipsoid:
    """Principal radii (k,) ascending and unit axes (k, k) as columns, world frame."""

    radii: np.ndarray
    axes: np.ndarray

    @property
    def major(self) -> np.ndarray:
        """Unit direction of the largest radius."""
        return self.axes[:, -1]


def force_ellipsoid(robot: Robot, q, axes: str = "translational") -> Ellipsoid:
    """End-effector forces reachable with ‖τ‖ ≤ 1 N·m, τ = Jᵀ f: {f : fᵀ J Jᵀ f ≤ 1} over the
    chosen rows of J = jacob0, radii 1/√eig(J Jᵀ) (N per N·m) — large where velocity is small."""
    J = ref.jacob0(robot, np.asarray(q, float))[list(AXES[axes])]
    eig, vec = np.linalg.eigh(J @ J.T)
    return Ellipsoid(1.0 / np.sqrt(eig[::-1]), vec[:, ::-1])


def major_axis_angle(u, v) -> float:
    """Angle (degrees, 0..90) between two ellipsoid axes (directions without sign)."""
    c = abs(float(np.dot(u, v))) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(min(1.0, c)))


# --------------------------------------------------------------------------- ex. 11d: inclined surface


@dataclass(frozen=True)
class InclinedSurface:
    """A frictionless compliant plane through `point` (world, m), tilted by `slope` (rad)
    about the world y-axis (rising along +x), stiffness k (N/m).  wrench(T) is the
    wrench [f; n] (..., 6) the end-effector at pose T (..., 4, 4) exerts on it:
    f = −k·depth·n below the plane (n its upward unit normal), else 0."""

    point: tuple = (0.0, 0.0, -0.2)
    slope: float = math.radians(10.0)
    k: float = 100.0

    @property
    def normal(self) -> np.ndarray:
        """Upward unit normal."""
        return np.array([-math.sin(self.slope), 0.0, math.cos(self.slope)])

    def height(self, x):
        """Height z (m) of the plane at world x (m) (it does not vary along y)."""
        return self.point[2] + math.tan(self.slope) * (np.asarray(x) - self.point[0])

    def wrench(self, T):
        p = np.asarray(T)[..., :3, 3]
        depth = np.maximum((np.asarray(self.point) - p) @ self.normal, 0.0)
        W = np.zeros(depth.shape + (6,))
        W[..., :3] = -self.k * depth[..., None] * self.normal
        return W


class CircleOperationalSpace(OperationalSpace):
    """`OperationalSpace` with a moving position set-point: path(t) → (p*, ṗ*, p̈*) (3,) in the
    world, fed forward as a = S_p(p̈* + Kp·[p* − p; e_o] + Kv·([ṗ*; 0] − ẋ)) − S_f·Kvf·ẋ.
    Force axes and the orientation set-point (`pose`'s rotation) as the parent."""

    def __init__(self, model: Model, robot: Robot, pose, force, sensor: Callable, path: Callable, **gains):
        super().__init__(model, robot, pose, force, sensor, **gains)
        self.path = path

    def __call__(self, t, q, qd):
        h = 1e-6
        p_s, v_s, a_s = (np.concatenate([x, np.zeros(3)]) for x in self.path(t))
        T = ref.fkine(self.robot, q)
        J, Jp, Jm = ref.jacob0(self.robot, np.stack([q, q + h * qd, q - h * qd]))
        Jdqd = (Jp - Jm) @ qd / (2 * h)
        xd = J @ qd
        R, R_goal = T[:3, :3], self.pose[:3, :3]
        e_o = 0.5 * np.cross(R.T, R_goal.T).sum(0)  # ½(n×n* + o×o* + a×a*)
        err = np.concatenate([p_s[:3] - T[:3, 3], e_o])
        S_p = 1.0 - self.S_f
        a = S_p * (a_s + self.Kp * err + self.Kv * (v_s - xd)) - self.S_f * self.Kvf * xd
        F_f = self.S_f * (self.force + self.Kf * (self.force - self.sensor(q)))
        qdd = np.linalg.solve(J, a - Jdqd)
        return self.model.tau(q, qd, qdd) + J.T @ F_f
