#!/usr/bin/env python3
"""The task space of real robots against Pinocchio's own reading of their files (slow: minutes).

Run: .venv/bin/python scripts/task_space_robots.py [--robots solo12 talos] [--states 200]

Each robot is read from example-robot-data's URDF on a free base (`tips="all"`), its frames
chosen by their names in the file, its task-space functions generated as C (the lazy target:
each compiled when first called) and evaluated state by state at random states; Pinocchio's
reduced model of the same file gives getFrameJacobian, getFrameClassicalAcceleration,
jacobianCenterOfMass, computeCentroidalMap and computeCentroidalMomentumTimeVariation at the
same states (`symdyn.bench.task_space`).  Prints each function's largest relative error and
the cold build time of the task-space functions.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from symdyn.bench import task_space as peer
from symdyn.model.example_robots import robots_folder
from symdyn.codegen.entry import load
from symdyn.codegen.task_functions import task_names
from symdyn.derivation.task_space import arguments, parts, task_space
from symdyn.model import Robot

ROBOTS = {
    "solo12": ("solo_description/robots/solo12.urdf", {}, ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")),
    "talos": (
        "talos_data/robots/talos_full_v2.urdf",
        {"locked": {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}},
        ("left_sole_link", "right_sole_link", "gripper_left_base_link", "gripper_right_base_link"),
    ),
}


def states(robot: Robot, count: int, seed: int = 0):
    """Random (q, v, a): the joints within their limits (and ±3), a floating base moved by a random
    twist from its neutral pose."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(np.maximum(lo, -3), np.minimum(hi, 3), (count, robot.n))
    if robot.base_joint is not None:
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n))
        q = robot.integrate(q, twist)
    return q, rng.uniform(-2, 2, (count, robot.nv)), rng.uniform(-5, 5, (count, robot.nv))


def check(name: str, count: int) -> list[str]:
    file, options, frames = ROBOTS[name]
    path = robots_folder() / file
    robot = Robot.from_urdf(str(path), tips="all", base_joint="free", **options).with_frames(frames)
    model, ids = peer.file_model(robot, path)
    start = time.perf_counter()
    c = load(robot, "c")
    names = task_names(task_space(robot))
    rest = {"q": robot.neutral(), "v": np.zeros(robot.nv), "a": np.zeros(robot.nv)}
    for f in names:  # generated and compiled (scalar code) now: the build, timed
        getattr(c, f)(*(rest[x] for x in arguments(f)))
    built = time.perf_counter() - start
    q, v, a = states(robot, count)
    want = peer.evaluate(robot, model, ids, q, v, a)
    given = {"q": q, "v": v, "a": a}
    lines = [f"{name}: nq = {robot.nq}, nv = {robot.nv}, frames {', '.join(frames)}; {count} states"]
    for f in names:
        calls = [getattr(c, f)(*(given[x][i] for x in arguments(f))) for i in range(count)]
        for k, part in enumerate(parts(f)):  # a function of several returns a tuple, its parts in order
            got = np.array([out[k] if len(parts(f)) > 1 else out for out in calls])
            err = np.abs(got - want[part]).max() / max(1.0, np.abs(want[part]).max())
            label = f if part == f else f"{f}: {part}"
            lines.append(f"  {label:40s} largest relative error {err:.1e}")
    lines.append(f"  the task-space functions derived, generated and compiled in {built:.1f} s (cached parts reused)")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    p.add_argument("--states", type=int, default=200)
    args = p.parse_args(argv)
    worst = 0.0
    for name in args.robots:
        lines = check(name, args.states)
        print("\n".join(lines), flush=True)
        worst = max([worst] + [float(line.split()[-1]) for line in lines if "relative error" in line])
    print(f"worst relative error {worst:.1e}")
    return 0 if worst <= 1e-12 else 1


if __name__ == "__main__":
    sys.exit(main())
