#!/usr/bin/env python3
"""The cold build of a robot's task-space functions against its joint-space ones.

Run: .venv/bin/python scripts/task_space_build.py panda|solo12|talos

In a fresh cache (SYMDYN_CACHE_DIR set to a new folder), `load(robot, "c").build(functions,
batch=False)` derives, generates and compiles the scalar C of the joint-space functions (tau …
Minv), then of the task-space ones (frame_pose … centroidal_drift); prints both times, the
share the task space adds, and the CPU time of each build (this process's, and its compilers'):
with every core busy, the share of work is the bound on the share of time.
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import time

os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-task-build-")

from symdyn.bench import task_bench  # noqa: E402
from symdyn.codegen.entry import load  # noqa: E402
from symdyn.codegen.lazy import FUNCTIONS, signatures  # noqa: E402


def _cpu() -> tuple[float, float]:
    """CPU seconds so far of this process and of its finished children (the compilers)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


def _timed(c, functions: list[str]) -> tuple[float, float, float]:
    """(wall, Python CPU, compilers' CPU) seconds of building `functions`' scalar code."""
    own, children, start = *_cpu(), time.perf_counter()
    c.build(functions, batch=False)
    wall = time.perf_counter() - start
    own_after, children_after = _cpu()
    return wall, own_after - own, children_after - children


def main(argv=None) -> int:
    name = (argv or sys.argv[1:] or ["panda"])[0]
    robot, _ = task_bench.case_robot(task_bench.CASES[name])
    c = load(robot, "c")
    task = [s.name for s in signatures(robot) if s.name not in FUNCTIONS]
    joint = _timed(c, list(FUNCTIONS))
    ts = _timed(c, task)
    print(f"{name}: joint space {joint[0]:.1f} s, task space {ts[0]:.1f} s (+{100 * ts[0] / joint[0]:.0f} %)")
    for label, (_, own, cc) in (("joint space", joint), ("task space", ts)):
        print(f"  {label}: {own:.2f} CPU-s of Python, {cc:.2f} of the compilers")
    print(f"  work: +{100 * sum(ts[1:]) / sum(joint[1:]):.0f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
