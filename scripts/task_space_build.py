#!/usr/bin/env python3
"""The cold build of a robot's task-space functions against its joint-space ones.

Run: .venv/bin/python scripts/task_space_build.py panda|solo12|talos [--rounds 3]

Each build runs in a process of its own with a fresh cache (SYMDYN_CACHE_DIR a new folder):
`load(robot, "c").build(functions, batch=False)` derives, generates and compiles the scalar C.
Two measures, each the best of `--rounds`:

- **in one build**: the joint-space functions (tau … Minv) alone, then with the task-space ones
  (frame_pose … centroidal_drift, frame_kinematics, centroidal) in the same build; what the
  frames add to a robot's cold build.
- **after**: the task space built on its own once the joint space is in the cache, with the CPU
  time of each build (the process's Python, and its compilers'): with every core busy, the
  share of work bounds the share of time.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

_BUILD = r"""
import atexit, json, os, resource, shutil, sys, tempfile, time
os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-task-build-")
atexit.register(shutil.rmtree, os.environ["SYMDYN_CACHE_DIR"], True)
from symdyn.bench import task_bench
from symdyn.codegen.entry import load
from symdyn.codegen.lazy import FUNCTIONS, signatures

def cpu():
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime

robot, _ = task_bench.case_robot(task_bench.CASES[sys.argv[1]])
c = load(robot, "c")
task = [s.name for s in signatures(robot) if s.name not in FUNCTIONS]
out = {}
steps = {"joint": [list(FUNCTIONS)], "both": [list(FUNCTIONS) + task], "after": [list(FUNCTIONS), task]}[sys.argv[2]]
for k, functions in enumerate(steps):
    own, children, start = *cpu(), time.perf_counter()
    c.build(functions, batch=False)
    wall = time.perf_counter() - start
    own_after, children_after = cpu()
    out[k] = (wall, own_after - own, children_after - children)
print(json.dumps(out))
"""


def _run(name: str, kind: str) -> dict:
    """One build in a fresh process and cache (removed after): {step: (wall, Python CPU,
    compilers' CPU)}; a build that fails stops the script with its error."""
    done = subprocess.run([sys.executable, "-c", _BUILD, name, kind], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"the {kind} build of {name} failed:\n{done.stderr[-3000:]}")
    return {int(k): v for k, v in json.loads(done.stdout.splitlines()[-1]).items()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?", default="panda")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    joint, both, after = [], [], []
    for _ in range(args.rounds):  # interleaved: the machine's load falls on each alike
        joint.append(_run(args.robot, "joint")[0][0])
        both.append(_run(args.robot, "both")[0][0])
        after.append(_run(args.robot, "after"))
    j, b = min(joint), min(both)
    print(f"{args.robot}, best of {args.rounds}:")
    print(f"  in one build: joint space {j:.2f} s, with the task space {b:.2f} s (+{100 * (b - j) / j:.0f} %)")
    best = min(after, key=lambda r: r[1][0])
    (jw, jp, jc), (tw, tp, tc) = best[0], best[1]
    print(f"  after: joint space {jw:.2f} s, then the task space {tw:.2f} s (+{100 * tw / jw:.0f} %)")
    for label, py, cc in (("joint space", jp, jc), ("task space", tp, tc)):
        print(f"    {label}: {py:.2f} CPU-s of Python, {cc:.2f} of the compilers")
    print(f"    work: +{100 * (tp + tc) / (jp + jc):.0f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
