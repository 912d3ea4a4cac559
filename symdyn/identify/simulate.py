"""A simulated bench: measurement-like data from a model whose parameters are perturbed.

The data step of identify without an arm at hand: `simulate(robot,
trajectory, perturb=0.2, noise=…, quantisation=…, seed=…)` draws a "true"
arm — every inertial and friction parameter of `robot` off by up to
±perturb (seeded, always a physical body) —, computes its joint torques
along the trajectory with the independent recursive reference
(`numeric.reference.rne`, not the regressor being identified), and adds what
a real bench adds: encoder quantisation of q and Gaussian torque noise.
`fourier` gives a fixed finite-Fourier-series trajectory (Swevers et al.
1997) for tests and for when no optimised excitation is at hand.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..model import Robot
from .data import Data, from_arrays, write_csv

if TYPE_CHECKING:
    from .excitation import Excitation

__all__ = [
    "simulate",
    "perturbed",
    "fourier",
    "Trajectory",
    "read_trajectory",
    "write",
    "write_truth",
    "write_trajectory",
]


@dataclass(frozen=True)
class Trajectory:
    """A motion: t (N,) in s, q, qd, qdd (N, n)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def perturbed(robot: Robot, perturb: float = 0.2, seed: int = 0) -> Robot:
    """`robot` with every inertial and friction parameter scaled by its own factor 1 + u,
    u uniform in [−perturb, perturb] (seeded): mass, each COM coordinate, the mass distribution's
    second moments (Σ = ½tr(I)·1 − I scaled as D·Σ·D, D diagonal, so the inertia stays
    physical; the principal moments of a link that waives the triangle inequality), rotor inertia, viscous and each Coulomb friction.  Zeros stay zeros."""
    robot.require_numeric("simulate")
    if not 0 <= perturb < 1:
        raise ValueError(f"perturb must lie in [0, 1), got {perturb}")
    rng = np.random.default_rng(seed)
    links = []
    floating = robot.base_joint is not None and robot.base_body is not None
    for link in (robot.base_body,) * floating + robot.links:
        u = lambda k=None: 1 + rng.uniform(-perturb, perturb, k)  # noqa: E731
        I = np.array(link.I, dtype=float)
        S = 0.5 * np.trace(I) * np.eye(3) - I
        D = np.diag(u(3))
        if np.linalg.eigvalsh(S)[0] >= -1e-12 * max(np.trace(I), 1e-300):
            S = D @ S @ D
            I_new = np.trace(S) * np.eye(3) - S
        else:  # published data that break the triangle inequality (Link(physical=False)): its principal moments
            lam, V = np.linalg.eigh(I)
            I_new = (V * (lam * np.diag(D))) @ V.T
        links.append(
            dataclasses.replace(
                link,
                m=float(link.m) * u(),
                r=tuple(float(x) * f for x, f in zip(link.r, u(3))),
                I=tuple(tuple(float(x) for x in row) for row in (I_new + I_new.T) / 2),
                Jm=float(link.Jm) * u(),
                B=float(link.B) * u(),
                Tc=tuple(float(x) * f for x, f in zip(link.Tc, u(2))),
            )
        )
    if floating:
        return dataclasses.replace(robot, base_body=links[0], links=tuple(links[1:]), name=f"{robot.name}_perturbed")
    return dataclasses.replace(robot, links=tuple(links), name=f"{robot.name}_perturbed")


def _trajectory(trajectory, robot: Robot) -> Trajectory:
    n, nv = robot.nq, robot.nv
    if isinstance(trajectory, (str, Path)):
        trajectory = read_trajectory(trajectory, robot)
    elif hasattr(trajectory, "sample") and not hasattr(trajectory, "t"):  # an optimised Excitation: 100 Hz
        trajectory = Trajectory(*trajectory.sample(100.0))
    try:
        t, q, qd, qdd = (np.asarray(getattr(trajectory, k), dtype=float) for k in ("t", "q", "qd", "qdd"))
    except AttributeError:
        raise ValueError(
            f"a trajectory has t, q, qd and qdd (a Trajectory, Data or CSV file), got {type(trajectory).__name__}"
        ) from None
    for name, x, size in (("q", q, n), ("qd", qd, nv or n), ("qdd", qdd, nv or n)):
        if x.ndim != 2 or x.shape != (len(t), size):
            raise ValueError(f"trajectory {name} must have shape ({len(t)}, {size}), got {x.shape}")
    return Trajectory(t, q, qd, qdd)


def simulate(
    robot: Robot,
    trajectory: Trajectory | Data | Excitation | str | Path,
    *,
    perturb: float = 0.2,
    noise: ArrayLike = 0.0,
    quantisation: ArrayLike = 0.0,
    seed: int = 0,
    truth: Robot | None = None,
) -> Data:
    """Measurement-like data along `trajectory` (a Trajectory, Data, or a CSV/NPZ file with t, q, qd,
    qdd) from `robot` perturbed by `perturbed(robot, perturb, seed)` (or the given `truth`).

    noise: σ of Gaussian torque noise, N·m (N), one number or one per joint.  quantisation: the
    encoder's resolution, rad (m), one number or one per joint: q is rounded to it (q̇ and q̈ stay the
    trajectory's, as from a good estimator; write the CSV without them to have `load_data`
    differentiate q instead).  The returned Data carries the true arm as `data.truth`.

    Raises:
        ValueError: a symbolic robot; a trajectory without t, q, qd and qdd or of the
            wrong shape, or a file that does not exist or cannot be read (as
            `load_data`'s); perturb outside [0, 1);
            noise or quantisation that is not one non-negative number or n; a truth
            with another joint count; time that does not increase, fewer than 2
            samples, or a NaN or infinite value.
    """
    robot.require_numeric("simulate")
    from ..numeric.reference import rne

    n, nb = robot.n, robot.nq - robot.n  # a floating base's coordinates come first
    traj = _trajectory(trajectory, robot)
    truth = truth if truth is not None else perturbed(robot, perturb, seed)
    rng = np.random.default_rng([seed, 1])
    tau = rne(truth, traj.q, traj.qd, traj.qdd)
    noise = _per_joint(noise, robot.nv, "noise")
    res = np.concatenate([np.zeros(nb), _per_joint(quantisation, n, "quantisation")])
    tau = tau + rng.standard_normal(tau.shape) * noise
    q = np.where(res > 0, np.round(traj.q / np.where(res > 0, res, 1)) * res, traj.q)
    data = from_arrays(
        traj.t,
        q,
        tau,
        qd=traj.qd,
        qdd=traj.qdd,
        joints=robot,
        source=f"simulated {truth.name} (perturb ±{perturb:g}, seed {seed})",
    )
    notes = data.notes + (f"torque noise σ {noise.tolist()}, encoder resolution {res.tolist()}",)
    return dataclasses.replace(data, notes=notes, truth=truth)


def _per_joint(x, n: int, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    a = np.broadcast_to(a, (n,)).copy() if a.ndim == 0 else a
    if a.shape != (n,) or np.any(a < 0) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: expected one non-negative number or {n} (one per joint), got {x!r}")
    return a


def fourier(
    robot: Robot,
    *,
    period: float = 10.0,
    harmonics: int = 5,
    rate: float = 100.0,
    seed: int = 0,
    fill: float = 0.6,
    periods: int = 1,
    rest: float = 0.0,
) -> Trajectory:
    """A random finite Fourier series per joint (Swevers et al. 1997), seeded:
    q_j(t) = c_j + Σ_k a_jk/(kω) sin(kωt) − b_jk/(kω) cos(kωt), ω = 2π/period, scaled so that q_j
    spans `fill` of its joint range around the range's middle; sampled at `rate` Hz over `periods`.
    rest > 0: over the last `rest` s the motion is brought to the middle of the range by a septic
    window (q and its first three derivatives continuous), then held there for `rest` s (q̇ = q̈ = 0: the samples that tell
    Coulomb friction's offset FO from a constant load such as gravity along a prismatic joint,
    sgn² q̇ being 1 while moving)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(period * periods * rate))) / rate
    w = 2 * np.pi / period
    k = np.arange(1, harmonics + 1)
    lo, hi = robot.qlim.T
    q = np.empty((len(t), robot.n))
    qd, qdd = np.empty_like(q), np.empty_like(q)
    # the window: 1, then a septic ramp to 0 over the last `rest` seconds (continuous up to the jerk, which
    # a low-pass differentiator would otherwise smear over tenths of a second)
    u = np.clip((t - (t[-1] + 1 / rate - rest)) / rest, 0, 1) if rest > 0 else np.zeros_like(t)
    win = 1 - (35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7)
    wd = -(140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6) / rest if rest > 0 else np.zeros_like(t)
    wdd = -(420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5) / rest**2 if rest > 0 else np.zeros_like(t)
    for j in range(robot.n):
        a, b = rng.standard_normal(harmonics) / k, rng.standard_normal(harmonics) / k
        s, c = np.sin(np.outer(t, k * w)), np.cos(np.outer(t, k * w))
        x = s @ (a / (k * w)) - c @ (b / (k * w))
        xd = c @ a + s @ b
        xdd = (-s @ (a * k * w)) + c @ (b * k * w)
        x = x - x.mean()
        g = fill * (hi[j] - lo[j]) / 2 / np.abs(x).max()
        q[:, j] = (lo[j] + hi[j]) / 2 + g * x * win
        qd[:, j] = g * (xd * win + x * wd)
        qdd[:, j] = g * (xdd * win + 2 * xd * wd + x * wdd)
    if robot.base_joint is not None:
        q, qd, qdd = _base_motion(robot, rng, t, q, qd, qdd, (k, w, fill, win, wd, wdd))
    hold = int(round(rest * rate))
    if hold:
        t = np.arange(len(t) + hold) / rate
        q = np.concatenate([q, np.repeat(q[-1:], hold, axis=0)])
        qd, qdd = (np.concatenate([x, np.zeros((hold, robot.nv))]) for x in (qd, qdd))
    return Trajectory(t, q, qd, qdd)


def _base_motion(robot: Robot, rng, t, q, qd, qdd, series) -> tuple:
    """A floating base's motion beside the joints': each body-frame velocity a Fourier series of the
    same harmonics (peak `fill` m/s or rad/s, windowed alike), the pose integrated from the neutral
    one along it (exponential map, midpoint velocity per sample: the pose follows v to second order;
    τ is computed at the stored states, so identification data stay exact)."""
    k, w, fill, win, wd, _ = series
    nb, count = robot.nv - robot.n, len(k)
    s, c = np.sin(np.outer(t, k * w)), np.cos(np.outer(t, k * w))
    v, a = np.empty((len(t), nb)), np.empty((len(t), nb))
    for j in range(nb):
        x_a, x_b = rng.standard_normal(count) / k, rng.standard_normal(count) / k
        x, xd = c @ x_a + s @ x_b, (-s @ (x_a * k * w)) + c @ (x_b * k * w)
        g = fill / np.abs(x).max()
        v[:, j] = g * x * win
        a[:, j] = g * (xd * win + x * wd)
    pose = np.empty((len(t), robot.nq))
    pose[0] = robot.neutral()
    zeros = np.zeros(robot.n)
    for i in range(1, len(t)):
        mid = np.concatenate([(v[i - 1] + v[i]) / 2, zeros])
        pose[i] = robot.integrate(pose[i - 1], mid, t[i] - t[i - 1])
    pose[:, robot.nq - robot.n :] = q  # the joints' own series
    return pose, np.hstack([v, qd]), np.hstack([a, qdd])


def read_trajectory(path, robot: Robot | None = None) -> Trajectory:
    """t, q1…qn and qd, qdd columns (q̇, q̈ by filtered differences where missing) of a CSV/NPZ file;
    torque columns, if any, are ignored.  `robot` on a floating base: its base's coordinate,
    velocity and acceleration columns too (`floating.base_columns`).

    Raises:
        ValueError: no such file, or columns `load_data` refuses.
    """
    from ..derivation.floating import base_columns

    from .data import _joint_columns, _read_csv, _read_npz

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no trajectory file {path}")
    names, values = (_read_npz if path.suffix.lower() == ".npz" else _read_csv)(path)
    cols = dict(zip(names, values.T))
    qs = _joint_columns(names, "q")
    wrench = base_columns(robot.base_joint)["tau"] if robot is not None and robot.base_joint else ()
    cols = {k: v for k, v in cols.items() if not k.startswith(("tau", "i")) and k not in wrench}
    zeros = np.zeros(len(values))
    cols.update((f"tau{j + 1}", zeros) for j in range(len(qs)))
    cols.update((c, zeros) for c in wrench)
    from .data import _from_columns

    data = _from_columns(
        cols,
        source=str(path),
        joints=robot if robot is not None and robot.base_joint else None,
        torque_constant=None,
        cutoff=None,
        order=4,
        decimate=1,
        first_line=1 if path.suffix.lower() != ".npz" else None,
    )
    return Trajectory(data.t, data.q, data.qd, data.qdd)


def write_trajectory(path, trajectory: Trajectory, robot: Robot | None = None) -> Path:
    """A trajectory as CSV: t, q1…qn, qd1…qdn, qdd1…qddn (what `simulate` and `read_trajectory` read);
    `robot` on a floating base: its base's columns first in each kind."""
    from ..derivation.floating import base_columns

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    base = base_columns(robot.base_joint) if robot is not None and robot.base_joint else {}
    header = ["t"]
    for k, a in (("q", trajectory.q), ("qd", trajectory.qd), ("qdd", trajectory.qdd)):
        named = base.get(k, ())
        header += [*named, *(f"{k}{j + 1}" for j in range(a.shape[1] - len(named)))]
    np.savetxt(
        path,
        np.column_stack([trajectory.t, trajectory.q, trajectory.qd, trajectory.qdd]),
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt="%.17g",
    )
    return path


def write(path, data: Data, *, derivatives: bool = True, robot: Robot | None = None) -> Path:
    """The data as CSV (`data.write_csv`), and beside it `<name>.truth.json` with the true arm's
    standard and base parameters when the data were simulated (`robot`: the unperturbed model,
    whose base parameter map the truth shares)."""
    path = write_csv(path, data, derivatives=derivatives)
    if getattr(data, "truth", None) is not None:
        write_truth(path.with_suffix(".truth.json"), data.truth, robot=robot)
    return path


def write_truth(path, truth: Robot, *, robot: Robot | None = None) -> Path:
    """The true arm's standard parameters (regressor frames) and base parameters as JSON."""
    from .parameters import base_map, robot_names, standard_vector

    pi = standard_vector(truth)
    bmap = base_map(robot if robot is not None else truth)
    doc = {
        "model": truth.name,
        "standard": dict(zip(robot_names(truth), pi.tolist())),
        "base": dict(zip(bmap.names, (bmap.P @ pi).tolist())),
        "links": [
            {
                "m": float(l.m),
                "r": [float(x) for x in l.r],
                "I": [[float(x) for x in row] for row in l.I],
                "Jm": float(l.Jm),
                "B": float(l.B),
                "Tc": [float(x) for x in l.Tc],
                "G": float(l.G),
            }
            for l in truth.links
        ],
    }
    if truth.base_joint is not None and truth.base_body is not None:  # the floating base's body
        body = truth.base_body
        doc["base_body"] = {
            "m": float(body.m),
            "r": [float(x) for x in body.r],
            "I": [[float(x) for x in row] for row in body.I],
        }
    Path(path).write_text(json.dumps(doc, indent=1) + "\n")
    return Path(path)
