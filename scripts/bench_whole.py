"""Whole robots on a free-flying base, C level (issue 35): symdyn's generated C against Pinocchio's C++.

Run: .venv/bin/python scripts/bench_whole.py [--robots solo12 talos] [--calls N] [--reps R] [--rounds K]
     [--batched] [--sizes 1000 100000] [--markdown PATH]

For each robot (example-robot-data's Solo 12 and Talos, every joint moving, `base_joint="free"`):
the frictionless generated C (`symdyn.bench.compare.frictionless_sources`) compiled into symdyn's
timing harness (symdyn/bench/harness.c, q of nq entries, v of nv) and the same model in Pinocchio's
C++ (symdyn/bench/pin_peer.cpp: a JointModelFreeFlyer root carrying the base body, then the tree, read
from the version-2 arm file that `pin_peer.write_arm` writes from `peers.pinocchio_model`) time their
functions on one states file, with the same loop (a pool of 1024 states cycled, one volatile sink per
call, median of REPS repetitions) and the same flags (-O3 -march=native), in alternating rounds
(medians over rounds reported).  Pairs: tau / rnea, M / crba (Pinocchio's default LOCAL convention,
and WORLD), fdyn / aba.  Before any time is believed, both sides' outputs at state 3 are checked
against symdyn's reference and against each other to 1e-10 (relative to the largest entry, or 1).
Prints a Markdown table and the machine; needs the `robots` and `bench` extras.

`--batched`: also ns per state of batched calls from Python, as `symdyn bench --batched` times
the chains (`symdyn.bench.batched`): the scalar loop, the SIMD kernels on 1 and every thread,
Pinocchio's `rneaInParallel` / `abaInParallel` on 1 and every thread (τ, q̈), every output
checked against the reference first, beside the machine's measured ceilings.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from pathlib import Path


from symdyn.bench import compare as bench
from symdyn.bench import whole
from symdyn.model import Robot

sys.path.insert(0, str(Path(__file__).parent))
from urdf_trees import robots_folder  # noqa: E402

ROBOTS = {
    "solo12": ("solo_description/robots/solo12.urdf", {}),
    "talos": (
        "talos_data/robots/talos_full_v2.urdf",
        {"locked": {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}},
    ),
}
PAIRS = whole.PAIRS


def load(name: str) -> Robot:
    file, options = ROBOTS[name]
    return Robot.from_urdf(str(robots_folder(None) / file), tips="all", base_joint="free", **options)


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cc = subprocess.run([os.environ.get("CXX", "c++"), "--version"], capture_output=True, text=True).stdout
    return f"{cpu}, {os.cpu_count()} CPUs; {cc.splitlines()[0] if cc else '?'}; Python {platform.python_version()}"


def bench_robot(name: str, args, log) -> tuple[list, dict]:
    """The robot's rows (`symdyn.bench.whole.compare_robot`) as this report's tuples."""
    robot = load(name)
    rows = whole.compare_robot(robot, calls=args.calls, reps=args.reps, rounds=args.rounds, seed=args.seed, log=log)
    out = []
    for row, (fn, _, label) in zip(rows, PAIRS):
        lo, hi = row.spread or (row.ratio, row.ratio)
        out.append((name, f"{robot.nq}/{robot.nv}", fn, label, row.symdyn_ns, row.peer_ns, row.ratio, lo, hi, None))
    return out, {}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    parser.add_argument("--calls", type=int, default=20000, help="calls per repetition (default 20000)")
    parser.add_argument("--reps", type=int, default=5, help="repetitions per round, median taken (default 5)")
    parser.add_argument("--rounds", type=int, default=4, help="alternating rounds, median taken (default 4)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--markdown", type=Path, help="also write the report here")
    parser.add_argument("--batched", action="store_true", help="also batched calls, ns per state")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 100_000], help="batch sizes (--batched)")
    args = parser.parse_args(argv)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    start = time.monotonic()
    rows = []
    for name in args.robots:
        rows += bench_robot(name, args, log)[0]
    import pinocchio

    lines = [
        "| robot | nq/nv | symdyn C | Pinocchio C++ | symdyn ns | Pinocchio ns | ratio (Pinocchio/symdyn) "
        "| ratio range over rounds | ≥ 3× | outputs agree (≤ 1e-10, checked before timing) |",
        "|---|---|---|---|---:|---:|---:|---|---|---:|",
    ]
    for name, dims, fn, label, s, p, ratio, lo, hi, err in rows:
        lines.append(
            f"| {name} | {dims} | {fn} | {label} | {s:.0f} | {p:.0f} | {ratio:.2f} | {lo:.2f}–{hi:.2f} "
            f"| {'yes' if ratio >= 3 else 'no'} | yes |"
        )
    lines += [
        "",
        f"Machine: {machine()}; Pinocchio {pinocchio.__version__} (C++ headers of the `pin` wheel); "
        f"flags -O3 -march=native on both sides; {args.calls} calls × {args.reps} repetitions × "
        f"{args.rounds} rounds, {bench.POOL} random states (seed {args.seed}); {time.monotonic() - start:.0f} s.",
    ]
    if args.batched:
        from symdyn.bench import batched

        ceil = batched.ceilings(len(os.sched_getaffinity(0)))
        results = [
            batched.run(load(name), sizes=args.sizes, functions=("tau", "M", "fdyn"), log=log) for name in args.robots
        ]
        lines += ["", batched.markdown_report(results, ceil)]
    report = "\n".join(lines)
    print(report)
    if args.markdown:
        args.markdown.write_text(report + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
