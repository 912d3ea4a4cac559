"""Task-space goals and obstacles for the optimal-control layer, on the generated frame poses.

A `TaskGoal` replaces a problem's final configuration by the pose of one frame (position, and
orientation unless told otherwise) and keeps chosen frames — points on the links, each with
a radius — clear of spheres at every node of the grid.  It is built on the generated CasADi
`frame_pose` of a robot with those frames (`symdyn.load(robot.with_frames([...]), "casadi")`),
so its constraints and their derivatives are the generated code's.  `Problem(task=…)` takes
it (`symdyn.apps.ocp`); the problem's `qf` is then only the end of the starting guess (an
inverse-kinematics solution, say), and the re-simulation is judged against the optimised end.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

__all__ = ["Sphere", "TaskGoal", "clearance"]


@dataclass(frozen=True)
class Sphere:
    """A spherical obstacle: centre (3,) in the world (m) and radius (m)."""

    center: tuple
    radius: float

    def __post_init__(self) -> None:
        c = np.asarray(self.center, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"Sphere: center must be 3 finite numbers, got {self.center!r}")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"Sphere: radius must be a positive number, got {self.radius!r}")


@dataclass(frozen=True)
class TaskGoal:
    """The end pose of frame `frame` (its index among the robot's task frames) and the clearance
    of the frames `clear` ((index, radius) pairs: balls on the links) from `obstacles` at every node.

    frame_pose: the generated CasADi `frame_pose` (q) → (4m × 4) of the robot with its frames;
    pose: the goal (4 × 4, world); orientation: whether its rotation is imposed too (three
    equations: the skew part of R*ᵀR is zero, with tr(R*ᵀR) ≥ 1 to exclude the half turn).

    Raises:
        ValueError: pose not 4 × 4 or not finite; a frame index out of range; a clearance radius
            that is negative.
    """

    frame_pose: ca.Function
    pose: np.ndarray
    frame: int = 0
    orientation: bool = True
    obstacles: tuple = ()
    clear: tuple = ()

    def __post_init__(self) -> None:
        pose = np.asarray(self.pose, dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ValueError(f"TaskGoal: pose must be a finite 4x4 transform, got shape {pose.shape}")
        m = self.frames
        for index in [self.frame, *(j for j, _ in self.clear)]:
            if not (isinstance(index, (int, np.integer)) and 0 <= index < m):
                raise ValueError(f"TaskGoal: frame index {index!r} out of range: frame_pose serves {m} frames")
        if any(not r >= 0 for _, r in self.clear):
            raise ValueError(f"TaskGoal: clearance radii must be ≥ 0, got {self.clear!r}")
        object.__setattr__(self, "pose", pose)

    @property
    def frames(self) -> int:
        """The number of frames `frame_pose` serves."""
        return self.frame_pose.size1_out(0) // 4

    def constrain(self, opti: ca.Opti, Q) -> None:
        """The end pose at Q[:, −1] and the clearances at every column of Q (n × (N + 1))."""
        f = self.frame
        T = self.frame_pose(Q[:, -1])
        opti.subject_to(T[4 * f : 4 * f + 3, 3] == self.pose[:3, 3])
        if self.orientation:
            R, goal = T[4 * f : 4 * f + 3, :3], ca.DM(self.pose[:3, :3])
            E = ca.mtimes(goal.T, R)
            opti.subject_to(ca.vertcat(E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]) == 0)
            opti.subject_to(ca.trace(E) >= 1)
        if not (self.clear and self.obstacles):
            return
        poses = self.frame_pose.map(Q.shape[1])(Q)  # (4m, 4(N+1)): node k's pose in columns 4k … 4k+3
        for j, r in self.clear:
            p = poses[4 * j : 4 * j + 3, 3::4]  # (3, N+1): frame j's origin at every node
            for s in self.obstacles:
                c = ca.DM(np.asarray(s.center, dtype=float))
                opti.subject_to(ca.sum1((p - c) ** 2) >= (s.radius + r) ** 2)


def clearance(goal: TaskGoal, poses: np.ndarray) -> float:
    """The smallest distance (m) between a clearing frame's ball and an obstacle over the poses
    (K, m, 4, 4) of a motion (negative: they overlap)."""
    worst = np.inf
    for j, r in goal.clear:
        p = poses[:, j, :3, 3]
        for s in goal.obstacles:
            worst = min(worst, float(np.min(np.linalg.norm(p - np.asarray(s.center), axis=1) - s.radius - r)))
    return worst
