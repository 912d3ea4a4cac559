"""Long sweep of the random-arm differential check (issue 10).

    python scripts/fuzz_arms.py --arms 300 --seed 1000 [--n-min 1 --n-max 7] [--general 1] [--out fuzz.tsv] [--tol 1e-10]

Draws arms with `symdyn.model.random_arms.random_arm(seed + k)`, runs every
stage of `symdyn.bench.differential.check_arm` on each, writes one row per
arm and stage (arm, n, joints, stage, worst error, what, seconds) and, for
every disagreement over the tolerance or crash, the arm as constructor
code.  Exits 1 on any disagreement (the exact stage must be exactly 0) or crash.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict

from symdyn.bench.differential import STAGES, check_arm, disagreements
from symdyn.model.random_arms import ArmOptions, random_arm, robot_code


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--arms", type=int, default=300, help="number of arms (default 300)")
    p.add_argument("--seed", type=int, default=1000, help="first seed (default 1000)")
    p.add_argument("--n-min", type=int, default=1, help="fewest joints per arm (default 1)")
    p.add_argument("--n-max", type=int, default=7, help="most joints per arm (default 7)")
    p.add_argument("--tol", type=float, default=1e-10, help="largest relative error accepted (default 1e-10)")
    p.add_argument("--states", type=int, default=12, help="random states per arm (default 12)")
    p.add_argument("--general", type=float, default=0.0,
                   help="fraction of arms drawn in the general (URDF-like) convention (default 0: DH only)")
    p.add_argument("--out", help="write the table here too (tab-separated)")
    p.add_argument("--stages", default=",".join(STAGES), help=f"comma-separated subset of {','.join(STAGES)}")
    args = p.parse_args(argv)
    stages = args.stages.split(",")
    rows, failures, crashes = [], [], 0
    worst_by_stage = defaultdict(float)
    start = time.perf_counter()
    header = "arm\tn\tjoints\tstage\tworst\twhat\tseconds"
    print(header, flush=True)
    for k in range(args.arms):
        seed = args.seed + k
        robot = random_arm(seed, ArmOptions(n_min=args.n_min, n_max=args.n_max, general=args.general))
        joints = "".join(link.joint[0] for link in robot.links)
        findings = check_arm(robot, count=args.states, seed=seed, stages=stages)
        for stage in stages:
            mine = [f for f in findings if f.stage == stage]
            worst = max(mine, key=lambda f: f.error)
            row = f"{robot.name}\t{robot.n}\t{joints}\t{stage}\t{worst.error:.2e}\t{worst.what}\t{sum(f.seconds for f in mine):.2f}"
            rows.append(row)
            print(row, flush=True)
            worst_by_stage[stage] = max(worst_by_stage[stage], worst.error)
        bad = disagreements(findings, args.tol)
        crashes += sum(f.what == "crashed" for f in bad)
        if bad:
            failures.append((seed, robot, bad))
            for f in bad:
                print(f"# {robot.name}: {f.stage} {f.what}: {f.error:.3e} {f.detail}", file=sys.stderr)
            print(f"# seed {seed}:\n{robot_code(robot)}", file=sys.stderr, flush=True)
    seconds = time.perf_counter() - start
    summary = (f"{args.arms} arms (seeds {args.seed}…{args.seed + args.arms - 1}, {args.n_min} ≤ n ≤ {args.n_max}), "
               f"{len(failures)} with disagreements over {args.tol:.0e}, {crashes} crashes, "
               f"worst per stage: " + ", ".join(f"{s} {worst_by_stage[s]:.1e}" for s in stages)
               + f"; {seconds:.0f} s")
    print(summary)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write("\n".join([header, *rows, f"# {summary}"]) + "\n")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
