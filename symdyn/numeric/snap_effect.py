"""What snapping a file's angles and axes does to the dynamics, measured by the reference.

A reader snaps near-exact angles and axes (`symdyn.model.snapping`) and keeps
both readings of the file, the robot as read and the robot as written
(`snap=False`).  This module, in the numeric stage because it runs the
reference, compares the two at random states: the largest relative change of
τ, M and forward dynamics q̈.  The `symdyn` package installs `snap_effect` as
the model's measure, so `print(robot)` and generated headers state it.
"""

from __future__ import annotations

import numpy as np

from ..model import Robot
from ..model.snapping import SnapEffect
from . import reference as ref

__all__ = ["STATES", "SEED", "effect_states", "snap_effect"]

#: How many random states, and the seed that draws them (fixed: a header is the same on every run).
STATES = 200
SEED = 0


def effect_states(robot: Robot, count: int = STATES, seed: int = SEED) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, q̈), (count, nq) and (count, nv): the joints' q uniform within the robot's limits
    (±π, or ±1 m, where a joint has none), a floating base's pose reached along a random twist
    from the origin, q̇ and q̈ uniform in [−1, 1] (rad/s, rad/s² or m/s, m/s²).

    Raises:
        ValueError: count below 1.
    """
    if count < 1:
        raise ValueError(f"count must be at least 1, got {count}")
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = lo + (hi - lo) * rng.random((count, robot.n))
    if robot.base_joint is not None:  # a floating base: a random pose reached along a random twist
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.uniform(-1.0, 1.0, (count, robot.nv - robot.n))
        q = robot.integrate(q, twist)
    qd, qdd = (rng.uniform(-1.0, 1.0, (count, robot.nv)) for _ in range(2))
    return q, qd, qdd


def _relative(a: np.ndarray, b: np.ndarray, axes: tuple) -> float:
    """max over states of max|a − b| / max|b| (b the yardstick), over `axes` per state."""
    scale = np.maximum(np.abs(b).max(axis=axes), np.finfo(float).tiny)
    return float((np.abs(a - b).max(axis=axes) / scale).max())


def snap_effect(snapped: Robot, literal: Robot, *, states: int = STATES, seed: int = SEED) -> SnapEffect:
    """How far the snaps move the dynamics: the largest relative change, from `literal` (the
    file's numbers) to `snapped` (the robot as read), of τ = RNEA(q, q̇, q̈), of M(q), and of
    q̈ = M⁻¹(τ − C q̇ − F − G) under the literal robot's τ, over `effect_states(literal)`.

    Raises:
        ValueError: robots of different joint counts, a symbolic robot, or states below 1.
    """
    if snapped.n != literal.n:
        raise ValueError(f"the snapped robot has {snapped.n} joints, the literal one {literal.n}: not one file's")
    q, qd, qdd = effect_states(literal, states, seed)
    tau = ref.rne(literal, q, qd, qdd)
    change_tau = _relative(ref.rne(snapped, q, qd, qdd), tau, (-1,))
    change_M = _relative(ref.inertia(snapped, q), ref.inertia(literal, q), (-2, -1))
    try:
        change_qdd = _relative(ref.accel(snapped, q, qd, tau), ref.accel(literal, q, qd, tau), (-1,))
    except ref.SingularInertia:
        change_qdd = None
    return SnapEffect(change_tau, change_M, change_qdd, states)
