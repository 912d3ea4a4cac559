#!/usr/bin/env python3
"""The cold build of a robot's task-space functions against its joint-space ones.

Run: .venv/bin/python scripts/task_space_build.py panda|solo12|talos

In a fresh cache (SYMDYN_CACHE_DIR set to a new folder), `load(robot, "c").build(functions,
batch=False)` derives, generates and compiles the scalar C of the joint-space functions (tau …
Minv), then of the task-space ones (frame_pose … centroidal_drift); prints both times and the
share the task space adds.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time

os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-task-build-")

from symdyn.bench import task_bench  # noqa: E402
from symdyn.codegen.entry import load  # noqa: E402
from symdyn.codegen.lazy import FUNCTIONS, signatures  # noqa: E402


def main(argv=None) -> int:
    name = (argv or sys.argv[1:] or ["panda"])[0]
    robot, _ = task_bench.case_robot(task_bench.CASES[name])
    c = load(robot, "c")
    task = [s.name for s in signatures(robot) if s.name not in FUNCTIONS]
    start = time.perf_counter()
    c.build(list(FUNCTIONS), batch=False)
    joint = time.perf_counter() - start
    start = time.perf_counter()
    c.build(task, batch=False)
    ts = time.perf_counter() - start
    print(f"{name}: joint space {joint:.1f} s, task space {ts:.1f} s (+{100 * ts / joint:.0f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
