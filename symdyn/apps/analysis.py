"""The chapter-9 analyses of a numeric arm: what its dynamic model says about it.

Gravity-load maps, inertia variation, payload effect, base wrench,
dynamic manipulability (Asada) and the acceleration ellipsoid, the
motor-side joint transfer functions, and the small two-link arm of the
chapter's exercise 3.  Every function is pure (robot in, arrays out) and
batched over leading axes of q.  Model terms come through
`model_functions(robot)`, the one place that decides which implementation
(`symdyn.numeric.backend`: generated code, else the reference recursion) evaluates
M and G.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..model import Robot, rotx
from ..numeric import backend as backends
from ..numeric import reference
from ..numeric.backend import Model

__all__ = [
    "EARTH_GRAVITY",
    "LUNAR_GRAVITY",
    "FULL_TURN",
    "model_functions",
    "with_gravity",
    "inverted",
    "joint_grid",
    "Extreme",
    "Sweep",
    "gravity_load_map",
    "inertia_map",
    "inertia_curve",
    "PayloadEffect",
    "payload_effect",
    "base_wrench",
    "total_mass",
    "AXES",
    "cartesian_inertia",
    "dynamic_manipulability",
    "AccelerationEllipsoid",
    "acceleration_ellipsoid",
    "JointTransferFunctions",
    "joint_transfer_functions",
    "twolink_exercise_arm",
]

EARTH_GRAVITY = 9.81  # m/s², the shipped models' g
LUNAR_GRAVITY = 1.62  # m/s²
FULL_TURN = (-math.pi, math.pi)


# --------------------------------------------------------------------------- model evaluation


def model_functions(robot: Robot, backend: str = "auto") -> Model:
    """M, G, C·q̇, … of a numeric robot (`symdyn.numeric.backend.model`): by default the
    generated code of a shipped model, else the reference recursion (an
    analysis makes a few large batched calls; the reference vectorises them
    and needs no CasADi build)."""
    robot.require_numeric("numeric analysis")
    return backends.model(robot, backend, fallback="reference")


# --------------------------------------------------------------------------- robot variants


def with_gravity(robot: Robot, g: float) -> Robot:
    """The robot with its gravity vector rescaled to magnitude g (m/s²), direction kept."""
    vec = np.array(robot.gravity, dtype=float)
    norm = np.linalg.norm(vec)
    if norm == 0:
        raise ValueError(f"robot {robot.name!r} has zero gravity; there is no direction to scale")
    if not (math.isfinite(g) and g >= 0):
        raise ValueError(f"gravity magnitude must be a finite number >= 0, got {g!r}")
    return dataclasses.replace(robot, gravity=tuple((vec * (g / norm)).tolist()))


def inverted(robot: Robot) -> Robot:
    """The robot hung upside down: base ← Rx(π)·base (e.g. ceiling-mounted)."""
    base = np.array(rotx(math.pi), dtype=float) @ np.array(robot.base, dtype=float)
    return dataclasses.replace(robot, base=tuple(map(tuple, base.tolist())))


# --------------------------------------------------------------------------- sweeps


def joint_grid(
    robot: Robot, joints: tuple[int, ...], resolution: int, *, pose=None, span: tuple[float, float] = FULL_TURN
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Joint states over a regular grid of the given joints (0-based), the others at `pose`.

    Returns (axes, q): one 1-D array of `resolution` angles per swept joint
    (over `span`), and q of shape (resolution, …, resolution, n), indexed 'ij'.
    """
    joints = tuple(int(j) for j in joints)
    bad = [j for j in joints if not 0 <= j < robot.n]
    if bad:
        raise ValueError(f"joint index {bad[0]} out of range for {robot.name!r} with {robot.n} joints (0-based)")
    if len(set(joints)) != len(joints):
        raise ValueError(f"swept joints must differ, got {joints}")
    if int(resolution) < 2:
        raise ValueError(f"resolution must be at least 2 points per joint, got {resolution}")
    base = np.zeros(robot.n) if pose is None else np.asarray(pose, dtype=float)
    if base.shape != (robot.n,):
        raise ValueError(f"pose must have shape ({robot.n},), got {base.shape}")
    axes = tuple(np.linspace(span[0], span[1], int(resolution)) for _ in joints)
    mesh = np.meshgrid(*axes, indexing="ij")
    q = np.broadcast_to(base, mesh[0].shape + (robot.n,)).copy()
    for j, m in zip(joints, mesh):
        q[..., j] = m
    return axes, q


@dataclass(frozen=True)
class Extreme:
    """Range of one swept quantity: min and max, the swept angles where they occur, max/min."""

    label: str
    min: float
    argmin: tuple
    max: float
    argmax: tuple

    @property
    def ratio(self) -> float:
        """max/min, or nan when the quantity changes sign or touches zero."""
        return self.max / self.min if self.min > 0 or self.max < 0 else math.nan


@dataclass(frozen=True)
class Sweep:
    """Quantities sampled over a grid of joint angles.

    `joints` (0-based) are swept over `axes`; `values` has shape
    (len(axes[0]), …, k), one last-axis entry per `labels`.
    """

    joints: tuple
    axes: tuple
    values: np.ndarray
    labels: tuple

    def extremes(self) -> tuple[Extreme, ...]:
        """Min and max of each quantity with the joint angles where they occur."""
        out = []
        grid = self.values.shape[:-1]
        for k, label in enumerate(self.labels):
            v = self.values[..., k]
            at = lambda flat: tuple(float(a[i]) for a, i in zip(self.axes, np.unravel_index(flat, grid)))  # noqa: E731
            out.append(Extreme(label, float(v.min()), at(v.argmin()), float(v.max()), at(v.argmax())))
        return tuple(out)


def gravity_load_map(
    robot: Robot, *, joints=(1, 2), loads=None, resolution: int = 73, pose=None, span=FULL_TURN
) -> Sweep:
    """Gravity load G_j(q) (N·m) of joints `loads` (default: the swept ones) over a grid of `joints`.

    Default: joints 2 and 3 of an arm (0-based 1, 2) over a full turn, others
    at zero, as Corke's surface plots.  Values (res, res, len(loads)).
    """
    loads = tuple(joints if loads is None else loads)
    axes, q = joint_grid(robot, joints, resolution, pose=pose, span=span)
    G = model_functions(robot).G(q)
    return Sweep(tuple(joints), axes, G[..., list(loads)], tuple(f"G{j + 1}" for j in loads))


def inertia_map(
    robot: Robot, *, elements=((0, 0), (0, 1)), joints=(1, 2), resolution: int = 73, pose=None, span=FULL_TURN
) -> Sweep:
    """Inertia-matrix elements M_ij (kg·m², 0-based (i, j)) over a grid of `joints` (default M11, M12 over q2, q3)."""
    axes, q = joint_grid(robot, joints, resolution, pose=pose, span=span)
    M = model_functions(robot).M(q)
    values = np.stack([M[..., i, j] for i, j in elements], -1)
    return Sweep(tuple(joints), axes, values, tuple(f"M{i + 1}{j + 1}" for i, j in elements))


def inertia_curve(
    robot: Robot, *, element=(1, 1), joint: int = 2, resolution: int = 181, pose=None, span=FULL_TURN
) -> Sweep:
    """One inertia element against one joint angle (default M22 against q3), a 1-D `Sweep`."""
    return inertia_map(robot, elements=(element,), joints=(joint,), resolution=resolution, pose=pose, span=span)


# --------------------------------------------------------------------------- payload, base


@dataclass(frozen=True)
class PayloadEffect:
    """M and G at one pose without (M0, G0) and with (M1, G1) a payload."""

    q: np.ndarray
    M0: np.ndarray
    M1: np.ndarray
    G0: np.ndarray
    G1: np.ndarray

    @property
    def M_ratio(self) -> np.ndarray:
        """Element-wise M1/M0 (n, n); nan where M0 is (numerically) zero."""
        return _ratio(self.M1, self.M0)

    @property
    def G_ratio(self) -> np.ndarray:
        """Element-wise G1/G0 (n,); nan where G0 is (numerically) zero."""
        return _ratio(self.G1, self.G0)


def _ratio(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    tiny = 1e-12 * max(1.0, float(np.abs(b).max()))
    nonzero = np.abs(b) > tiny
    return np.divide(a, b, out=np.full(np.shape(a), np.nan), where=nonzero)


def payload_effect(robot: Robot, m: float, p, q, *, additive: bool = False) -> PayloadEffect:
    """How a payload of m kg at p (last link frame, m) changes M and G at pose q (n,).

    additive=False is the book's `payload` (the last link's mass and COM
    replaced); additive=True adds a point mass to the last link (see
    `Robot.payload`).
    """
    q = np.asarray(q, dtype=float)
    loaded = robot.payload(m, p, additive=additive)
    f0, f1 = model_functions(robot), model_functions(loaded)
    return PayloadEffect(q, f0.M(q), f1.M(q), f0.G(q), f1.G(q))


def base_wrench(robot: Robot, q, qd=None, qdd=None) -> np.ndarray:
    """Wrench [f; n] (..., 6) the base exerts on link 1 (N, N·m; frame {0}, moment about its origin).

    Weight and inertial forces, no friction; q̇, q̈ default to zero (static).
    """
    q = np.asarray(q, dtype=float)
    qd = np.zeros_like(q) if qd is None else qd
    qdd = np.zeros_like(q) if qdd is None else qdd
    return reference.rne(robot, q, qd, qdd, base_wrench=True)[1]


def total_mass(robot: Robot) -> float:
    """Sum of the link masses (kg)."""
    robot.require_numeric("total_mass")
    return float(sum(float(link.m) for link in robot.links))


# --------------------------------------------------------------------------- manipulability

AXES = {"translational": (0, 1, 2), "rotational": (3, 4, 5), "all": (0, 1, 2, 3, 4, 5)}


def _rows(axes) -> list[int]:
    """Rows of jacob0 ([v; ω]) named by `axes`: a key of AXES or a sequence of row indices 0..5."""
    if isinstance(axes, str):
        if axes not in AXES:
            raise ValueError(f"unknown axes {axes!r}: expected one of {', '.join(AXES)} or row indices 0..5")
        return list(AXES[axes])
    rows = [int(r) for r in axes]
    if not rows or len(set(rows)) != len(rows) or not all(0 <= r < 6 for r in rows):
        raise ValueError(f"axes must be distinct Jacobian rows in 0..5 ([vx vy vz wx wy wz]), got {axes!r}")
    return rows


def cartesian_inertia(robot: Robot, q, axes="translational") -> np.ndarray:
    """Asada's Cartesian inertia Mx = pinv(J)ᵀ M pinv(J) (..., k, k) over the chosen rows of J = jacob0."""
    J = reference.jacob0(robot, q)[..., _rows(axes), :]
    Ji = np.linalg.pinv(J)
    return np.swapaxes(Ji, -1, -2) @ model_functions(robot).M(q) @ Ji


def dynamic_manipulability(robot: Robot, q, axes="translational") -> np.ndarray:
    """Asada's dynamic manipulability min(eig Mx)/max(eig Mx) (...,), 1 = isotropic.

    `axes`: "translational" (default: a ratio of eigenvalues mixing kg
    and kg·m² would depend on the length unit), "rotational", "all" (the
    Robotics Toolbox's default), or row indices, e.g. (0, 2) for an arm
    moving in the world x–z plane.
    """
    eig = np.linalg.eigvalsh(cartesian_inertia(robot, q, axes))
    return eig[..., 0] / eig[..., -1]


@dataclass(frozen=True)
class AccelerationEllipsoid:
    """End-effector accelerations J M⁻¹ τ reachable with ‖τ‖ ≤ 1 N·m, from rest and without gravity.

    `radii` (k,) ascending, `axes` (k, k) unit principal directions as
    columns (world frame), `matrix` J M⁻¹ M⁻ᵀ Jᵀ (its eigenvalues are radii²).
    """

    radii: np.ndarray
    axes: np.ndarray
    matrix: np.ndarray

    def surface(self, points: int = 24) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x, y, z (points, points) of the (3-D) ellipsoid surface, for plotting."""
        if self.radii.shape != (3,):
            raise ValueError(f"surface needs a 3-D ellipsoid, this one has {self.radii.size} axes")
        u, v = np.meshgrid(np.linspace(0, 2 * np.pi, points), np.linspace(0, np.pi, points))
        sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
        xyz = np.einsum("ij,j,jab->iab", self.axes, self.radii, sphere)
        return xyz[0], xyz[1], xyz[2]


def acceleration_ellipsoid(robot: Robot, q, axes="translational") -> AccelerationEllipsoid:
    """The acceleration ellipsoid at one pose q (n,): eigen-decomposition of J M⁻¹ M⁻ᵀ Jᵀ."""
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.n,):
        raise ValueError(f"acceleration_ellipsoid takes one pose of shape ({robot.n},), got {q.shape}")
    J = reference.jacob0(robot, q)[_rows(axes)]
    JMi = np.linalg.solve(model_functions(robot).M(q).T, J.T).T  # J M⁻¹
    A = JMi @ JMi.T
    eig, vec = np.linalg.eigh(A)
    return AccelerationEllipsoid(np.sqrt(np.clip(eig, 0, None)), vec, A)


# --------------------------------------------------------------------------- joint dynamics


@dataclass(frozen=True)
class JointTransferFunctions:
    """Motor-side Ω(s)/U(s) = 1/(J′s + B′) of every joint at one pose (SI units, motor side).

    `M_link` (n,) is the link-side inertia each joint sees without its own
    rotor: M_jj − G²·Jm.
    """

    q: np.ndarray
    Jm: np.ndarray
    G: np.ndarray
    M_link: np.ndarray
    J: np.ndarray
    B: np.ndarray

    @property
    def pole(self) -> np.ndarray:
        """The real pole −B′/J′ (rad/s) of each joint."""
        return -self.B / self.J

    @property
    def time_constant(self) -> np.ndarray:
        """J′/B′ (s); infinite for a joint without viscous friction."""
        return np.divide(self.J, self.B, out=np.full_like(self.J, np.inf), where=self.B > 0)

    def tf(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and denominator coefficients of joint j (0-based), for scipy.signal."""
        return np.array([1.0]), np.array([self.J[j], self.B[j]])


def joint_transfer_functions(robot: Robot, q) -> JointTransferFunctions:
    """Motor-side transfer functions at pose q (n,): J′ = Jm + M_jj,link/G², B′ = B.

    M_jj,link excludes the rotor term G²·Jm that M_jj already contains, so
    the rotor is counted once.  The Robotics Toolbox (`jointdynamics`) adds
    Jm to M_jj/G² with M_jj *including* G²·Jm, i.e. it counts the rotor
    twice (J′ = 2·Jm + M_jj,link/G²).
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.n,):
        raise ValueError(f"joint_transfer_functions takes one pose of shape ({robot.n},), got {q.shape}")
    G = np.array([float(link.G) for link in robot.links])
    if np.any(G == 0):
        missing = [j + 1 for j in np.flatnonzero(G == 0)]
        raise ValueError(
            f"joint(s) {missing} of {robot.name!r} have gear ratio G = 0 (no motor model); "
            "a motor-side transfer function needs G != 0"
        )
    Jm = np.array([float(link.Jm) for link in robot.links])
    B = np.array([float(link.B) for link in robot.links])
    M_link = np.diag(model_functions(robot).M(q)) - G**2 * Jm
    return JointTransferFunctions(q, Jm, G, M_link, Jm + M_link / G**2, B)


# --------------------------------------------------------------------------- the exercise arm


def twolink_exercise_arm(
    m1: float = 0.45, m2: float = 0.35, r1: float = 0.08, r2: float = 0.08, a1: float = 0.16, a2: float = 0.16
) -> Robot:
    """The two-link arm of the chapter's exercise 3: m1 = 0.45 kg, m2 = 0.35 kg, COM r1 = r2 = 8 cm from each joint.

    The exercise gives no link lengths; we take a1 = a2 = 16 cm, putting each
    COM at mid-link as in the shipped arm (whose 1 m links would not fit
    8 cm COM offsets of a 0.8 kg arm).  Point masses, as `arms.load("twolink")`,
    whose links this rescales (COM at r_i − a_i along x of frame {i}).
    """
    from ..model import arms

    arm = arms.load("twolink")
    first, second = arm.links
    links = (
        dataclasses.replace(first, a=a1, m=m1, r=(r1 - a1, 0, 0)),
        dataclasses.replace(second, a=a2, m=m2, r=(r2 - a2, 0, 0)),
    )
    return dataclasses.replace(arm, name="twolink_exercise3", links=links)
