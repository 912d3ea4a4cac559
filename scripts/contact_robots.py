#!/usr/bin/env python3
"""The contact dynamics of real robots against Pinocchio's own reading of their files (slow: minutes).

Run: .venv/bin/python scripts/contact_robots.py [--sets solo12-4 solo12-2 talos-2 talos-1] [--states 200]

Each contact set (Solo 12 on four feet and on two, point contacts; Talos on two soles and on one,
surface contacts) is read from example-robot-data's URDF on a free base (`tips="all"`, without
friction, which Pinocchio's rigid constraints have not), its contact functions generated as C
(the lazy target) and evaluated state by state at random states; Pinocchio's reduced model of the
same file, its frames found by their names in the file, gives constraintDynamics, impulseDynamics
and their derivatives at the same states (`symdyn.bench.contact_peer`).  Prints each function's
largest relative error and exits non-zero above 1e-10, the issue's bound.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from symdyn.bench import contact_peer
from symdyn.bench.task_space import file_model
from symdyn.codegen.entry import load
from symdyn.model import Robot
from symdyn.model.example_robots import robots_folder
from task_space_robots import ROBOTS, states  # this folder's: the robots' files and their random states

#: Each set: (robot of `ROBOTS`, {frame: contact kind}).
SETS = {
    "solo12-4": ("solo12", dict.fromkeys(("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"), "point")),
    "solo12-2": ("solo12", dict.fromkeys(("FL_FOOT", "HR_FOOT"), "point")),
    "talos-2": ("talos", dict.fromkeys(("left_sole_link", "right_sole_link"), "surface")),
    "talos-1": ("talos", {"left_sole_link": "surface"}),
}
NAMES = ("contact_fdyn", "contact_impulse", "contact_fdyn_derivatives", "contact_impulse_derivatives")
BOUND = 1e-10


def _relative(got, want) -> float:
    return float(np.abs(np.asarray(got) - want).max() / max(1.0, np.abs(want).max()))


def check(key: str, count: int) -> tuple[list[str], float]:
    """The report lines of one contact set and its largest relative error."""
    name, contacts = SETS[key]
    file, options, _ = ROBOTS[name]
    path = robots_folder() / file
    robot = Robot.from_urdf(str(path), tips="all", base_joint="free", **options).nofriction(all=True)
    robot = robot.with_frames(list(contacts)).with_contacts(contacts)
    model, ids = file_model(robot, path)
    peer = contact_peer.setup(robot, model, ids)
    start = time.perf_counter()
    c = load(robot, "c")
    q, v, tau = states(robot, count, seed=3)
    errors = dict.fromkeys(NAMES, 0.0)
    for i in range(count):
        a, force, v_after, impulse = contact_peer.contacts(robot, q[i], v[i], tau[i], peer)
        fdyn, jump = contact_peer.derivatives(robot, q[i], v[i], tau[i], peer)
        pairs = {
            "contact_fdyn": zip(c.contact_fdyn(q[i], v[i], tau[i]), (a, force)),
            "contact_impulse": zip(c.contact_impulse(q[i], v[i]), (v_after, impulse)),
            "contact_fdyn_derivatives": zip(c.contact_fdyn_derivatives(q[i], v[i], tau[i]), fdyn),
            "contact_impulse_derivatives": zip(c.contact_impulse_derivatives(q[i], v[i]), jump),
        }
        for f, outputs in pairs.items():
            errors[f] = max([errors[f]] + [_relative(got, want) for got, want in outputs])
    kinds = ", ".join(f"{frame} ({kind})" for frame, kind in contacts.items())
    lines = [f"{key}: nq = {robot.nq}, nv = {robot.nv}, contacts {kinds}; {count} states"]
    lines += [f"  {f:28s} largest relative error {errors[f]:.1e}" for f in NAMES]
    lines.append(f"  built and checked in {time.perf_counter() - start:.0f} s")
    return lines, max(errors.values())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sets", nargs="+", default=list(SETS), choices=list(SETS))
    p.add_argument("--states", type=int, default=200)
    args = p.parse_args(argv)
    worst = 0.0
    for key in args.sets:
        lines, err = check(key, args.states)
        print("\n".join(lines), flush=True)
        worst = max(worst, err)
    print(f"worst relative error {worst:.1e} (bound {BOUND:.0e})")
    return 0 if worst <= BOUND else 1


if __name__ == "__main__":
    sys.exit(main())
