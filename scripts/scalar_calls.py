#!/usr/bin/env python3
"""Per-call time of a robot's generated scalar C functions, each case its own harness, the median
over copies of the compiled harness.

Run: .venv/bin/python scripts/scalar_calls.py talos centroidal_map com_jacobian+centroidal_map M
     .venv/bin/python scripts/scalar_calls.py solo12 frame_kinematics M Minv --copies 8

The robot is `symdyn bench --task-space`'s (`symdyn.bench.task_bench.CASES`); a case of several
functions joined by + calls them in turn.  The harness is the bench's (the lazy target's scalar
translation units, 20 000 calls on a pool of states, the median of 7 repetitions); each copy of
it is a new file, so a new place in physical memory: one binary ran Talos' two centroidal calls
in 770 ns from one file and 1 157 ns from another, the bytes identical.  The median over copies
is the figure; the range says how far placement moves it.  For an A/B of symdyn's code, run it
from a git worktree of each revision (PYTHONPATH) with a cache folder of its own
(SYMDYN_CACHE_DIR).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import statistics
import subprocess
import tempfile

from symdyn.bench import task_bench
from symdyn.bench.harness import POOL, write_states
from symdyn.derivation.cache import cache_dir, writable


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", choices=sorted(task_bench.CASES))
    parser.add_argument("cases", nargs="+", help="functions, several joined by +")
    parser.add_argument("--copies", type=int, default=8)
    args = parser.parse_args(argv)
    if args.copies < 1:
        parser.error("--copies must be at least 1")
    base = task_bench.CASES[args.robot]
    robot, _ = task_bench.case_robot(base)
    states = write_states(
        writable(cache_dir() / "bench") / f"calls-{os.getpid()}.bin", *task_bench._states(robot, POOL)
    )
    try:
        with tempfile.TemporaryDirectory() as folder:
            for functions in args.cases:
                case = dataclasses.replace(base, functions=tuple(functions.split("+")))
                harness = task_bench._symdyn_harness(robot, case, print, check=False)
                times = []
                for k in range(args.copies):
                    copy = shutil.copy(harness, os.path.join(folder, f"harness-{k}"))
                    run = subprocess.run([copy, str(states), "20000", "7"], capture_output=True, text=True, check=True)
                    times.append(float(run.stdout.split("time step")[1].split()[0]))
                    os.unlink(copy)
                print(
                    f"{functions}: {statistics.median(times):.1f} ns a call (copies {min(times):.0f}-{max(times):.0f})"
                )
    finally:
        states.unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
