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
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from symdyn.bench import compare as bench
from symdyn.bench import pin_peer
from symdyn.bench.peers import pinocchio_model
from symdyn.derivation.cache import cache_dir, writable
from symdyn.model import Robot
from symdyn.numeric import reference as ref

sys.path.insert(0, str(Path(__file__).parent))
from urdf_trees import robots_folder  # noqa: E402

TOL = 1e-10
ROBOTS = {
    "solo12": ("solo_description/robots/solo12.urdf", {}),
    "talos": (
        "talos_data/robots/talos_full_v2.urdf",
        {"locked": {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}},
    ),
}
# (symdyn function, Pinocchio algorithm, its label)
PAIRS = (
    ("tau", "rnea", "rnea"),
    ("M", "crba", "crba (LOCAL, default)"),
    ("M", "crba_world", "crba (WORLD)"),
    ("fdyn", "aba", "aba"),
)


def load(name: str) -> Robot:
    file, options = ROBOTS[name]
    return Robot.from_urdf(str(robots_folder(None) / file), tips="all", base_joint="free", **options)


def floating_states(robot: Robot, count: int, seed: int = 0):
    """(q, v, a, τ): joints uniform in their limits (clipped to ±3), the base moved from the neutral pose
    along a random twist (unit quaternion), v, a uniform in ±2, ±5; τ by the reference RNEA."""
    rng = np.random.default_rng(seed)
    lo, hi = np.clip(np.array(robot.qlim, dtype=float).T, -3.0, 3.0)
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(lo, hi, (count, robot.n))
    twist = np.zeros((count, robot.nv))
    twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n)) * 2
    q = robot.integrate(q, twist)
    v, a = rng.uniform(-2, 2, (count, robot.nv)), rng.uniform(-5, 5, (count, robot.nv))
    return q, v, a, ref.rne(robot, q, v, a)


def relative(got, want) -> float:
    got, want = np.ravel(got), np.ravel(want)
    return float(np.abs(got - want).max() / max(1.0, np.abs(want).max()))


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
    robot = load(name)
    bare = robot.nofriction(all=True)
    log(f"{name}: n={robot.n} nq={robot.nq} nv={robot.nv}; generating / compiling ...")
    src = bench.frictionless_sources(robot)
    harness = bench.build_harness(src["c"], src["h"])
    tree = pin_peer.tree_joints(pinocchio_model(bare))
    assert tree.root == "free", tree.root
    peer = pin_peer.peer_binary(log)
    work = writable(cache_dir() / "bench")
    states = floating_states(bare, bench.POOL, seed=args.seed)
    q, v, a, tau = states
    states_file = bench.write_states(work / f"states-whole-{os.getpid()}.bin", *states)
    arm = pin_peer.write_arm(
        work / f"arm-whole-{os.getpid()}.txt",
        tree.joints,
        tree.gravity,
        parents=tree.parents,
        root=tree.root,
        base=tree.base,
    )
    ours_fns = sorted({p[0] for p in PAIRS})
    peer_algos = [p[1] for p in PAIRS]
    ours, theirs, errors = [], [], {}
    try:
        for r in range(args.rounds):
            order = ("peer", "ours") if r % 2 else ("ours", "peer")  # ABBA: slow drifts of load cancel
            for side in order:
                if side == "ours":
                    t, ck_ours = bench.run_harness(harness, states_file, args.calls, args.reps, ours_fns)
                    bench.check_harness(bare, ck_ours, *states, rtol=TOL)
                    ours.append(t)
                else:
                    t, ck_peer = pin_peer.run_peer(peer, arm, states_file, args.calls, args.reps, peer_algos)
                    pin_peer.check_peer(bare, ck_peer, *states, rtol=TOL)
                    theirs.append(t)
            log(f"{name}: round {r + 1}/{args.rounds} done")
    finally:
        states_file.unlink(missing_ok=True)
        arm.unlink(missing_ok=True)
    # the two sides against each other at state 3 (each was checked against the reference above)
    for fn, algo, _ in PAIRS:
        errors[algo] = relative(ck_ours[fn], ck_peer[algo])
        if not errors[algo] <= TOL:
            raise RuntimeError(f"{name}: symdyn {fn} and Pinocchio {algo} differ by {errors[algo]:.1e}")
    errors["reference tau"] = relative(ck_ours["tau"], ref.rne(bare, q[3], v[3], a[3]))
    rows = []
    for fn, algo, label in PAIRS:
        s = statistics.median(t[fn] for t in ours)
        p = statistics.median(t[algo] for t in theirs)
        ratios = [pt[algo] / st[fn] for st, pt in zip(ours, theirs)]
        rows.append((name, f"{robot.nq}/{robot.nv}", fn, label, s, p, p / s, min(ratios), max(ratios), errors[algo]))
    return rows, errors


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
        "| ratio range over rounds | ≥ 3× | |Δ| at state 3 (rel.) |",
        "|---|---|---|---|---:|---:|---:|---|---|---:|",
    ]
    for name, dims, fn, label, s, p, ratio, lo, hi, err in rows:
        lines.append(
            f"| {name} | {dims} | {fn} | {label} | {s:.0f} | {p:.0f} | {ratio:.2f} | {lo:.2f}–{hi:.2f} "
            f"| {'yes' if ratio >= 3 else 'no'} | {err:.1e} |"
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
