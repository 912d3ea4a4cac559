"""Task-space goals, obstacles and costs for the optimal-control layer, on the generated frame poses.

A `TaskGoal` replaces a problem's final configuration by the pose of one frame (position, and
orientation unless told otherwise) and keeps chosen frames — points on the links, each with
a radius — clear of spheres at every node of the grid.  A `FrameCost` weighs a frame's distance
from a target (a fixed pose or position, or one per node: a path to follow) along the motion or
at its end.  Both are built on the generated CasADi `frame_pose` of a robot with those frames
(`symdyn.load(robot.with_frames([...]), "casadi")`: the model, or its `frame_pose`), so their
constraints, costs and derivatives are the generated code's; given the robot too, they take the
frames by name.  `Problem(task=…, task_costs=(…))` takes them (`symdyn.apps.ocp`); with a
`TaskGoal` the problem's `qf` is only the end of the starting guess (an inverse-kinematics
solution, say), and the re-simulation is judged against the optimised end.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .task_control import check_pose, frame_index

__all__ = ["Sphere", "TaskGoal", "FrameCost", "clearance"]


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


def _pose_function(given, robot, what: str) -> ca.Function:
    """The CasADi frame_pose (q) → (4m × 4) of `given`: the function itself, or a generated
    CasADi model's; checked against `robot` (its q's size and frame count) when given.

    Raises:
        ValueError: naming `what`: neither; a function of another robot's frames or q.
    """
    if not isinstance(given, ca.Function):
        function = getattr(given, "functions", {}).get("frame_pose")
        given = getattr(function, "function", function)
        if not isinstance(given, ca.Function):
            raise ValueError(
                f"{what}: frame_pose must be the generated CasADi frame_pose or its model "
                "(symdyn.load(robot.with_frames([...]), 'casadi'))"
            )
    if given.n_in() != 1 or given.size2_out(0) != 4 or given.size1_out(0) % 4:
        raise ValueError(f"{what}: frame_pose must map q to the frames' stacked 4x4 poses, got {given}")
    if robot is not None:
        m = len(robot.task_frames)
        if (given.numel_in(0), given.size1_out(0)) != (robot.nq, 4 * m):
            raise ValueError(
                f"{what}: frame_pose takes q of {given.numel_in(0)} and serves {given.size1_out(0) // 4} frames; "
                f"robot {robot.name!r} has nq = {robot.nq} and serves {m} frames: build it on this robot"
            )
    return given


@dataclass(frozen=True)
class TaskGoal:
    """The end pose of frame `frame` and the clearance of the frames `clear` ((frame, radius)
    pairs: balls on the links) from `obstacles` at every node; a frame is its index among the
    robot's task frames, or its name when `robot` is given.

    frame_pose: the generated CasADi `frame_pose` (q) → (4m × 4) of the robot with its frames, or
    that generated model; pose: the goal (4 × 4, world, a proper rotation); orientation: whether its
    rotation is imposed too (three equations: the skew part of R*ᵀR is zero, with tr(R*ᵀR) ≥ 1 to
    exclude the half turn).

    Raises:
        ValueError: pose not a pose (`check_pose`: 4 × 4, finite, [0 0 0 1], a rotation); an
            unknown frame or an index out of range; a clearance radius that is negative; a
            frame_pose that is not one, or not `robot`'s.
    """

    frame_pose: ca.Function
    pose: np.ndarray
    frame: int | str = 0
    orientation: bool = True
    obstacles: tuple = ()
    clear: tuple = ()
    robot: object = None

    def __post_init__(self) -> None:
        function = _pose_function(self.frame_pose, self.robot, "TaskGoal")
        pose = check_pose(self.pose, "TaskGoal: pose")
        m = function.size1_out(0) // 4
        frame = frame_index(self.robot, self.frame, "TaskGoal", m)
        clear = tuple((frame_index(self.robot, j, "TaskGoal clear", m), r) for j, r in self.clear)
        if any(not r >= 0 for _, r in clear):
            raise ValueError(f"TaskGoal: clearance radii must be ≥ 0, got {self.clear!r}")
        for name, value in (("frame_pose", function), ("pose", pose), ("frame", frame), ("clear", clear)):
            object.__setattr__(self, name, value)

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


@dataclass(frozen=True)
class FrameCost:
    """A task-space cost on frame `frame` (index, or name with `robot`): at each node k,

        c_k = position·|p_k − p*_k|² + orientation·(3 − tr(R*_kᵀ R_k))

    (3 − tr(R*ᵀR) = 2(1 − cos θ) ≈ θ², θ the angle between the orientations), summed over the
    motion by the trapezoidal rule, ∫ c dt (`over="path"`), or taken at the last node alone
    (`over="end"`: a soft goal, with `Problem(free_end=True)`).  target: a pose (4 × 4) or a
    position (3,), or one per node
    ((N + 1, 4, 4) or (N + 1, 3): a path to follow); a position alone leaves the orientation free
    (its weight must then be 0).  frame_pose: as `TaskGoal`'s.

    Raises:
        ValueError: a target that is neither (poses `check_pose`d, positions finite); weights
            not finite ≥ 0, or an orientation weight on a position target; `over` neither
            "path" nor "end"; an unknown frame; a frame_pose that is not one, or not `robot`'s.
    """

    frame_pose: ca.Function
    target: np.ndarray
    frame: int | str = 0
    position: float = 1.0
    orientation: float = 0.0
    over: str = "path"
    robot: object = None

    def __post_init__(self) -> None:
        function = _pose_function(self.frame_pose, self.robot, "FrameCost")
        frame = frame_index(self.robot, self.frame, "FrameCost", function.size1_out(0) // 4)
        if self.over not in ("path", "end"):
            raise ValueError(f"FrameCost: over must be 'path' (∫ c dt) or 'end' (the last node), got {self.over!r}")
        for name in ("position", "orientation"):
            w = getattr(self, name)
            if isinstance(w, bool) or not isinstance(w, numbers.Real) or not (math.isfinite(w) and w >= 0):
                raise ValueError(f"FrameCost: the weight {name} must be a finite number ≥ 0, got {w!r}")
        target = np.asarray(self.target, dtype=float)
        if target.shape[-1:] == (3,) and target.ndim in (1, 2):
            if not np.all(np.isfinite(target)):
                raise ValueError("FrameCost: the target positions must be finite")
            if self.orientation:
                raise ValueError("FrameCost: an orientation weight needs target poses (4x4), not positions")
        elif target.shape[-2:] == (4, 4) and target.ndim in (2, 3):
            shape = target.shape
            target = np.array([check_pose(t, f"FrameCost: target {k}") for k, t in enumerate(target.reshape(-1, 4, 4))])
            target = target.reshape(shape)
        else:
            raise ValueError(
                "FrameCost: target must be a pose (4x4), a position (3,), or one per node (N+1, 4, 4) or (N+1, 3); "
                f"got shape {target.shape}"
            )
        for name, value in (("frame_pose", function), ("frame", frame), ("target", target)):
            object.__setattr__(self, name, value)

    def cost(self, Q, h):
        """The cost over the nodes Q (n × (N + 1)) spaced h apart (a number or an expression).

        Raises:
            ValueError: a target per node whose count is not N + 1.
        """
        K = Q.shape[1]
        pose = self.target.shape[-2:] == (4, 4)
        per_node = self.target.ndim == (3 if pose else 2)
        if per_node and self.target.shape[0] != K:
            raise ValueError(f"FrameCost: {self.target.shape[0]} targets for the problem's {K} nodes (N + 1)")
        nodes = range(K) if self.over == "path" else [K - 1]
        f = self.frame
        poses = self.frame_pose.map(len(nodes))(Q[:, list(nodes)])  # (4m, 4K')
        terms = []
        for i, k in enumerate(nodes):
            goal = self.target[k] if per_node else self.target
            T = poses[4 * f : 4 * f + 3, 4 * i : 4 * i + 4]
            p_goal = goal[:3, 3] if pose else goal
            c = self.position * ca.sumsqr(T[:, 3] - ca.DM(p_goal))
            if self.orientation:
                c += self.orientation * (3 - ca.trace(ca.mtimes(ca.DM(goal[:3, :3]).T, T[:, :3])))
            terms.append(c)
        if self.over == "end":
            return terms[0]
        return h * (sum(terms[1:-1]) + (terms[0] + terms[-1]) / 2)


def clearance(goal: TaskGoal, poses: np.ndarray) -> float:
    """The smallest distance (m) between a clearing frame's ball and an obstacle over the poses
    (K, m, 4, 4) of a motion (negative: they overlap)."""
    worst = np.inf
    for j, r in goal.clear:
        p = poses[:, j, :3, 3]
        for s in goal.obstacles:
            worst = min(worst, float(np.min(np.linalg.norm(p - np.asarray(s.center), axis=1) - s.radius - r)))
    return worst
