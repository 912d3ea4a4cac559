"""Studies in the task space: the Panda's hand driven around a circle by operational-space
control on the generated functions, its posture held in the null space.

The scene: the shipped Panda (its tool: the hand's TCP), started at rest where inverse
kinematics (`symdyn.apps.task_control.inverse_kinematics`) puts the hand at the circle's
start, then `OperationalSpaceController` tracks a horizontal circle at a fixed orientation
while a joint posture is held in the null space; the plant is the generated forward
dynamics, RK4 with continuous control.  Writes `task_osc_panda.png` and `summary.txt`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...codegen.entry import load
from ...model import arms
from ..control import simulate
from ..task_control import OperationalSpaceController, inverse_kinematics
from ._plot import finish, pyplot, save

RADIUS, PERIOD = 0.10, 2.0  # m, s: the circle the hand follows


def circle(center):
    """path(t) → (p*, ṗ*, p̈*): a horizontal circle of RADIUS around `center`, once per PERIOD,
    started smoothly (the angle's rate ramps up over the first half period)."""
    center = np.asarray(center, float)
    w = 2 * np.pi / PERIOD

    def path(t: float):
        ramp = PERIOD / 2
        if t < ramp:  # θ = w t² / (2 ramp): θ̇ from 0 to w
            th, thd, thdd = w * t * t / (2 * ramp), w * t / ramp, w / ramp
        else:
            th, thd, thdd = w * (t - ramp / 2), w, 0.0
        c, s = np.cos(th), np.sin(th)
        p = center + RADIUS * np.array([c - 1.0, s, 0.0])
        pd = RADIUS * np.array([-s, c, 0.0]) * thd
        pdd = RADIUS * (np.array([-c, -s, 0.0]) * thd**2 + np.array([-s, c, 0.0]) * thdd)
        return p, pd, pdd

    return path


def run_osc(T: float, dt: float = 1e-3):
    """(trace, hand positions (K, 3), goal positions (K, 3), controller) of the Panda's circle."""
    panda = arms.load("panda")
    f = load(panda, "c")
    start = f.frame_pose(panda.qr)[0]
    path = circle(start[:3, 3])
    ik = inverse_kinematics(f, panda, start, panda.qr)
    osc = OperationalSpaceController(f, panda, path, start[:3, :3], posture=panda.qr)
    trace = simulate(lambda t, q, v, tau: f.fdyn(q, v, tau), osc, T, ik.q, dt=dt, progress="operational-space control")
    hand = f.frame_pose(trace.q)[:, 0, :3, 3]
    goal = np.array([path(t)[0] for t in trace.t])
    return trace, hand, goal, osc


def osc_panda(out_dir: Path, quick: bool = False) -> str:
    """The Panda's hand around a 10 cm circle in 2 s by operational-space control, its posture in the null space."""
    T = 1.5 if quick else 2.5
    trace, hand, goal, osc = run_osc(T, dt=2e-3 if quick else 1e-3)
    err = np.linalg.norm(hand - goal, axis=1) * 1e3
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    a1.plot(goal[:, 0], goal[:, 1], "k--", lw=1, label="set-point")
    a1.plot(hand[:, 0], hand[:, 1], lw=1.5, label="hand (TCP)")
    a1.set_aspect("equal")
    a1.set_xlabel("x (m)")
    a1.set_ylabel("y (m)")
    a1.legend(fontsize=8)
    a1.grid(True)
    a1.set_title("Panda: hand path, seen from above")
    a2.semilogy(trace.t, np.maximum(err, 1e-6))
    a2.set_xlabel("time (s)")
    a2.set_ylabel("position error (mm)")
    a2.grid(True)
    a2.set_title("tracking error")
    save(fig, out_dir, "task_osc_panda")
    posture = np.linalg.norm(trace.q[-1] - osc.posture)
    lines = [
        f"Operational-space control of the Panda's hand (tool: TCP) around a {RADIUS * 100:.0f} cm circle every "
        f"{PERIOD:g} s at a fixed orientation; Kp = {osc.Kp:g}, Kv = {osc.Kv:g}; posture qr held in the null space "
        f"(Kq = {osc.Kq:g}, Kqv = {osc.Kqv:g}); plant: the generated forward dynamics, RK4 dt = "
        f"{trace.t[1] - trace.t[0]:g} s.",
        f"  largest position error {err.max():.3f} mm; after the first half period {err[trace.t > PERIOD / 2].max():.4f} mm; "
        f"final {err[-1]:.4f} mm",
        f"  joint posture distance from qr at the end {posture:.3f} rad (the circle needs the joints to move)",
    ]
    return finish(out_dir, lines)


# --------------------------------------------------------------------------- optimal control around an obstacle

#: The Panda's frames for the reach: the goal (the TCP) first, then balls on the links that must clear.
REACH_FRAMES = ("panda_hand_tcp", "panda_link4", "panda_link5", "panda_link6", "panda_link7", "panda_hand")
REACH_RADII = (0.05, 0.07, 0.07, 0.07, 0.07, 0.08)


def reach_problem(N: int = 30, T: float = 2.0):
    """(robot, problem, goal, IK result): the Panda's hand from qr to a pose 0.5 m to its side at
    the same orientation, around a sphere of 10 cm radius set on the straight path between them,
    every link ball clear of it at every node; minimum effort over T seconds."""
    from ..ocp import Cost, Limits, Problem
    from ..ocp_task import Sphere, TaskGoal

    robot = arms.load("panda").with_frames(REACH_FRAMES)
    f = load(robot, "casadi")
    start = f.frame_pose(robot.qr)[0]
    goal = start.copy()
    goal[:3, 3] += (0.0, 0.5, 0.0)
    center = (start[:3, 3] + goal[:3, 3]) / 2
    ik = inverse_kinematics(f, robot, goal, robot.qr, frame="panda_hand_tcp")
    task = TaskGoal(
        f,
        goal,
        frame="panda_hand_tcp",
        obstacles=(Sphere(tuple(center), 0.10),),
        clear=tuple(zip(REACH_FRAMES, REACH_RADII)),
        robot=robot,
    )
    problem = Problem(robot.qr, ik.q, T=T, N=N, limits=Limits.for_robot(robot), cost=Cost(effort=1.0), task=task)
    return robot, problem, task, ik


def ocp_panda_obstacle(out_dir: Path, quick: bool = False) -> str:
    """The Panda reaches a pose around a spherical obstacle its links must clear (CasADi + IPOPT)."""
    from ..ocp import dynamics, solve, verify
    from ..ocp_task import clearance

    robot, problem, task, ik = reach_problem(N=30)  # 20 intervals: gaps of 4e-2 rad between nodes
    arm = dynamics(robot, compiled=False)
    sol = solve(problem, arm)
    check = verify(robot, problem, sol, replay="intervals")  # the arm's open loop is unstable over 2 s
    f = load(robot, "c")
    poses = f.frame_pose(check.q)
    end = f.frame_pose(check.q[-1])[0]
    from ..task_control import pose_error

    miss = np.abs(pose_error(task.pose, end))
    straight = f.frame_pose(np.linspace(problem.q0, ik.q, 50))  # the joint-space line to the IK answer
    plt = pyplot()
    fig = plt.figure(figsize=(9, 4))
    a1 = fig.add_subplot(1, 2, 1)
    c, r = task.obstacles[0].center, task.obstacles[0].radius
    a1.add_patch(plt.Circle((c[1], c[2]), r, color="gray", alpha=0.4, label="obstacle (10 cm)"))
    for j, name in enumerate(REACH_FRAMES[:1] + REACH_FRAMES[2:3]):
        k = REACH_FRAMES.index(name)
        a1.plot(poses[:, k, 1, 3], poses[:, k, 2, 3], lw=1.5, label=f"{name} (optimal)")
    a1.plot(straight[:, 0, 1, 3], straight[:, 0, 2, 3], "k:", lw=1, label="TCP, joint-space line")
    a1.set_aspect("equal")
    a1.set_xlabel("y (m)")
    a1.set_ylabel("z (m)")
    a1.legend(fontsize=7)
    a1.grid(True)
    a1.set_title("Panda reach around a sphere (side view)")
    a2 = fig.add_subplot(1, 2, 2)
    a2.plot(sol.t, sol.tau)
    a2.set_xlabel("time (s)")
    a2.set_ylabel("joint torque (N m)")
    a2.grid(True)
    a2.set_title("minimum-effort torques")
    save(fig, out_dir, "task_ocp_panda_obstacle")
    st = sol.stats
    lines = [
        f"The Panda's hand (TCP) from qr to the pose 0.5 m to its side (same orientation) in {problem.T:g} s, "
        f"around a 10 cm sphere on the straight path; balls of {', '.join(f'{r * 100:g}' for r in REACH_RADII)} cm "
        f"on {', '.join(REACH_FRAMES)} kept clear at every node; {problem.method}, N = {problem.N}, minimum effort; "
        "constraints on the generated CasADi frame_pose.",
        f"  IPOPT {st['status']} in {st['iterations']} iterations, {st['solve_wall']:.2f} s "
        f"({st['per_iteration'] * 1e3:.1f} ms per iteration)",
        f"  re-simulated (reference dynamics, each interval from its node): {check.describe()}",
        f"  end pose of the re-simulation: position {miss[:3].max() * 1e3:.3f} mm, orientation "
        f"{np.degrees(miss[3:].max()):.4f} deg from the goal",
        f"  smallest clearance along the re-simulated nodes {clearance(task, poses) * 1e3:.2f} mm "
        f"(the joint-space line to the IK answer: {clearance(task, straight) * 1e3:.1f} mm)",
    ]
    return finish(out_dir, lines)


STUDIES = {
    "task-ocp-panda-obstacle": (
        "Panda: minimum-effort reach to a pose around a sphere its links clear (CasADi + IPOPT)",
        ocp_panda_obstacle,
    ),
    "task-osc-panda": (
        "Panda: operational-space control of the hand around a circle, posture in the null space",
        osc_panda,
    ),
}
