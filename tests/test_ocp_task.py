"""Task-space terms of the optimal-control layer (`symdyn.apps.ocp_task`): goals and costs on the
generated CasADi frame_pose, by frame name or index, their values against the C target's poses,
and a solve that follows a path in the task space; bad poses and frames refused by name."""

import casadi as ca
import numpy as np
import pytest

from symdyn import models
from symdyn.apps import ocp
from symdyn.apps.ocp_task import FrameCost, Sphere, TaskGoal
from symdyn.codegen.entry import load
from tests.test_task_control import bad_poses


@pytest.fixture(scope="module")
def arm2():
    robot = models.load("twolink")
    return robot, load(robot, "casadi"), load(robot, "c")


def test_a_goal_takes_the_generated_model_and_frames_by_name():
    robot = models.load("twolink").with_frames(["tool", "link1"])
    f = load(robot, "casadi")
    goal = TaskGoal(f, np.eye(4), frame="tool", clear=(("link1", 0.07),), robot=robot)
    assert (goal.frame, goal.clear, goal.frames) == (0, ((1, 0.07),), 2)
    with pytest.raises(ValueError, match="serves no frame 'link2'; it serves tool, link1"):
        TaskGoal(f, np.eye(4), frame="link2", robot=robot)
    with pytest.raises(ValueError, match="frame 'link1' is a name: give robot="):
        TaskGoal(f, np.eye(4), clear=(("link1", 0.07),))
    with pytest.raises(ValueError, match="frame 2 out of range: the model serves 2 frames"):
        TaskGoal(f, np.eye(4), frame=2)
    other = models.load("puma560")
    with pytest.raises(ValueError, match="robot 'puma560' has nq = 6 and serves 1 frames: build it on this robot"):
        TaskGoal(f, np.eye(4), robot=other)
    with pytest.raises(ValueError, match="must be the generated CasADi frame_pose or its model"):
        TaskGoal(load(robot, "c"), np.eye(4))
    for pose, why in bad_poses():
        with pytest.raises(ValueError, match=f"TaskGoal: pose.*{why}"):
            TaskGoal(f, pose)


def test_frame_costs_are_their_formula_on_the_c_targets_poses(arm2):
    """A FrameCost at numeric nodes: the trapezoid of position·|p − p*|² + orientation·(3 − tr(R*ᵀR))
    over the nodes (a fixed pose, one position per node) or the last node's term alone."""
    robot, f, c = arm2
    rng = np.random.default_rng(3)
    Q = rng.uniform(-2, 2, (5, robot.n))
    poses = c.frame_pose(Q)[:, 0]  # (5, 4, 4)
    target = c.frame_pose(np.array([0.4, -0.7]))[0]
    h = 0.1

    def terms(p_goal, R_goal, wp, wr):
        out = wp * ((poses[:, :3, 3] - p_goal) ** 2).sum(axis=1)
        if R_goal is not None:
            out = out + wr * (3 - np.einsum("ij,kij->k", R_goal, poses[:, :3, :3]))
        return out

    def value(term):
        return float(ca.DM(term.cost(ca.DM(Q.T), h)))

    t = terms(target[:3, 3], target[:3, :3], 2.0, 0.5)
    want = h * (t[1:-1].sum() + (t[0] + t[-1]) / 2)
    assert value(FrameCost(f, target, "tool", 2.0, 0.5, robot=robot)) == pytest.approx(want, rel=1e-12)
    path = rng.uniform(-1, 1, (5, 3))
    t = 3.0 * ((poses[:, :3, 3] - path) ** 2).sum(axis=1)
    assert value(FrameCost(f, path, position=3.0)) == pytest.approx(h * (t[1:-1].sum() + (t[0] + t[-1]) / 2))
    t = terms(target[:3, 3], target[:3, :3], 1.0, 4.0)
    assert value(FrameCost(f, target, orientation=4.0, over="end")) == pytest.approx(t[-1], rel=1e-12)
    with pytest.raises(ValueError, match="4 targets for the problem's 5 nodes"):
        FrameCost(f, path[:4]).cost(ca.DM(Q.T), h)


def test_frame_costs_refuse_bad_targets_weights_and_frames(arm2):
    robot, f, _ = arm2
    for pose, why in bad_poses()[:5]:
        with pytest.raises(ValueError, match=f"FrameCost: target 0.*{why}"):
            FrameCost(f, pose)
    with pytest.raises(ValueError, match="orientation weight needs target poses"):
        FrameCost(f, np.zeros(3), orientation=1.0)
    with pytest.raises(ValueError, match="weight position must be a finite number ≥ 0"):
        FrameCost(f, np.zeros(3), position=-1.0)
    with pytest.raises(ValueError, match="over must be 'path'"):
        FrameCost(f, np.zeros(3), over="middle")
    with pytest.raises(ValueError, match=r"got shape \(2,\)"):
        FrameCost(f, np.zeros(2))
    for bad in (("tool",), FrameCost(f, np.zeros(3)), (term for term in [FrameCost(f, np.zeros(3))])):
        with pytest.raises(ValueError, match="task_costs must be a tuple of FrameCost terms"):
            ocp.Problem(np.zeros(2), np.ones(2), T=1.0, task_costs=bad)
    panda = models.load("panda")
    with pytest.raises(ValueError, match="FrameCost's frame_pose takes q of 2, the problem's q0 has 7"):
        ocp.Problem(panda.qr, panda.qr, T=1.0, task_costs=(FrameCost(f, np.zeros(3)),))
    listed = [np.eye(4).tolist()] * 3  # one pose per node, as nested lists; weights any real number
    assert FrameCost(f, listed, position=np.int64(2), orientation=1).target.shape == (3, 4, 4)


@pytest.mark.parametrize("method", ocp.METHODS)
def test_a_frame_cost_on_a_path_makes_the_hand_follow_it(arm2, method):
    """The two-link arm from q0 to qf: at minimum effort the hand strays from the straight line
    between its end points (timed as a minimum-jerk path, at rest at both ends) by over a metre;
    with a FrameCost on that path (one position per node) it stays within millimetres of it, and
    the end points are still met."""
    robot, f, c = arm2
    q0, qf, N = np.array([0.3, 1.0]), np.array([1.4, 0.4]), 20
    ends = c.frame_pose(np.array([q0, qf]))[:, 0, :3, 3]
    s = np.linspace(0, 1, N + 1)
    line = ends[0] + (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None] * (ends[1] - ends[0])
    arm = ocp.dynamics(robot.nofriction(all=True), "plain", compiled=False)

    def largest_miss(task_costs):
        problem = ocp.Problem(q0, qf, T=1.0, N=N, method=method, task_costs=task_costs)
        sol = ocp.solve(problem, arm)
        assert sol.stats["success"], sol.stats["status"]
        assert np.abs(sol.q[-1] - qf).max() < 1e-8
        return np.abs(c.frame_pose(sol.q)[:, 0, :3, 3] - line).max()

    free = largest_miss(())
    held = largest_miss((FrameCost(f, line, position=1e6, robot=robot),))
    assert free > 0.5 and held < 0.005, (free, held)


def test_a_soft_goal_at_the_end_of_a_free_end_reaches_the_pose_as_its_weight_grows(arm2):
    """A FrameCost at the last node on a free end configuration (qf only ends the guess): the hand
    ends nearer the target pose the larger the weight, within a millimetre at the largest; with
    the end configuration imposed instead, the cost cannot move it."""
    robot, f, c = arm2
    q0, target = np.array([0.3, 1.0]), c.frame_pose(np.array([1.4, 0.4]))[0]
    arm = ocp.dynamics(robot.nofriction(all=True), "plain", compiled=False)

    def miss(weight, free_end=True):
        end = FrameCost(f, target, position=weight, orientation=weight, over="end", robot=robot)
        problem = ocp.Problem(q0, q0, T=1.0, N=16, method="trapezoidal", task_costs=(end,), free_end=free_end)
        sol = ocp.solve(problem, arm)
        assert sol.stats["success"], sol.stats["status"]
        return np.abs(c.frame_pose(sol.q[-1])[0] - target).max()

    misses = [miss(w) for w in (1.0, 1e2, 1e5)]
    assert misses[0] > misses[1] > misses[2] and misses[2] < 1e-3, misses
    assert miss(1e5, free_end=False) == pytest.approx(np.abs(c.frame_pose(q0)[0] - target).max())


@pytest.mark.slow  # the Panda's CasADi code with six frames, built cold: make test-all
def test_a_goal_with_obstacles_clears_them_with_named_frames():
    """The Panda's reach (the study, coarse): every ball keeps clear of the sphere at the nodes."""
    from symdyn.apps.ocp_task import clearance
    from symdyn.apps.studies.task_space import reach_problem

    robot, problem, task, _ = reach_problem(N=8)
    assert isinstance(task.obstacles[0], Sphere) and task.clear[0] == (0, 0.05)
    sol = ocp.solve(problem, ocp.dynamics(robot, compiled=False))
    assert sol.stats["success"], sol.stats["status"]
    c = load(robot, "c")
    assert clearance(task, c.frame_pose(sol.q)) > -1e-6
    assert np.abs(c.frame_pose(sol.q[-1])[0] - task.pose).max() < 1e-6
