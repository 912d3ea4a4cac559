"""Long sweep of the random-arm differential check (issue 10).

    python scripts/fuzz_arms.py --arms 300 --seed 1000 [--n-min 1 --n-max 7] [--general 1] [--out fuzz.tsv] [--tol 1e-10]
    python scripts/fuzz_arms.py --arms 300 --workers 2 | --scheduler tcp://HOST:8786 [--sweep-out DIR] [--resume]

Draws arms with `symdyn.model.random_arms.random_arm(seed + k)`, runs every
stage of `symdyn.bench.differential.check_arm` on each, writes one row per
arm and stage (arm, n, joints, stage, worst error, what, seconds) and, for
every disagreement over the tolerance or crash, the arm as constructor
code.  Exits 1 on any disagreement (the exact stage must be exactly 0) or crash.

With --workers K (a local Dask cluster) or --scheduler ADDRESS (or
$DASK_SCHEDULER_ADDRESS) the arms are checked on the cluster through
`symdyn.sweep.engine`, one task per arm (the seed and options in, the same
rows out), recorded as they finish in --sweep-out/results.csv (--resume skips
the arms already there); the table printed at the end is the same, in seed
order.  Workers need symdyn with its test extra (Pinocchio).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

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
    p.add_argument(
        "--general",
        type=float,
        default=0.0,
        help="fraction of arms drawn in the general (URDF-like) convention (default 0: DH only)",
    )
    p.add_argument("--out", help="write the table here too (tab-separated)")
    p.add_argument("--stages", default=",".join(STAGES), help=f"comma-separated subset of {','.join(STAGES)}")
    p.add_argument(
        "--workers", type=int, default=None, help="check the arms on a local Dask cluster of this many worker processes"
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="check the arms on the Dask cluster at ADDRESS (e.g. tcp://10.0.0.5:8786)",
    )
    p.add_argument(
        "--sweep-out", default=None, help="the cluster run's results.csv and summary (default: a temporary folder)"
    )
    p.add_argument("--resume", action="store_true", help="with --sweep-out: skip the arms already checked there")
    args = p.parse_args(argv)
    stages = args.stages.split(",")
    rows, failures, crashes = [], [], 0
    worst_by_stage = defaultdict(float)
    start = time.perf_counter()
    header = "arm\tn\tjoints\tstage\tworst\twhat\tseconds"
    print(header, flush=True)
    items = [
        {
            "index": k,
            "seed": args.seed + k,
            "n_min": args.n_min,
            "n_max": args.n_max,
            "general": args.general,
            "states": args.states,
            "stages": stages,
            "tol": args.tol,
        }
        for k in range(args.arms)
    ]
    if args.workers is not None or args.scheduler is not None or _scheduler_from_environment():
        results = _on_cluster(items, args)
    else:
        results = (check_one(item) for item in items)
    for item, result in zip(items, results):
        seed = item["seed"]
        for stage, error, what, seconds in result["per_stage"]:
            row = f"{result['name']}\t{result['n']}\t{result['joints']}\t{stage}\t{error:.2e}\t{what}\t{seconds:.2f}"
            rows.append(row)
            print(row, flush=True)
            worst_by_stage[stage] = max(worst_by_stage[stage], error)
        bad = result["bad"]
        crashes += sum(what == "crashed" for _, what, _, _ in bad)
        if bad:
            failures.append(seed)
            for stage, what, error, detail in bad:
                print(f"# {result['name']}: {stage} {what}: {error:.3e} {detail}", file=sys.stderr)
            print(f"# seed {seed}:\n" + "\n".join(result["code"]), file=sys.stderr, flush=True)
    seconds = time.perf_counter() - start
    summary = (
        f"{args.arms} arms (seeds {args.seed}…{args.seed + args.arms - 1}, {args.n_min} ≤ n ≤ {args.n_max}), "
        f"{len(failures)} with disagreements over {args.tol:.0e}, {crashes} crashes, "
        f"worst per stage: " + ", ".join(f"{s} {worst_by_stage[s]:.1e}" for s in stages) + f"; {seconds:.0f} s"
    )
    print(summary)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write("\n".join([header, *rows, f"# {summary}"]) + "\n")
    return 1 if failures else 0


def check_one(item: dict) -> dict:
    """One arm, every stage: its per-stage worst (stage, error, what, seconds), its disagreements
    over the tolerance (stage, what, error, detail) and, if any, the arm as constructor code.
    A pure function of its small input, so it runs as a sweep task on any worker."""
    robot = random_arm(item["seed"], ArmOptions(n_min=item["n_min"], n_max=item["n_max"], general=item["general"]))
    findings = check_arm(robot, count=item["states"], seed=item["seed"], stages=item["stages"])
    per_stage = []
    for stage in item["stages"]:
        mine = [f for f in findings if f.stage == stage]
        worst = max(mine, key=lambda f: f.error)
        per_stage.append([stage, worst.error, worst.what, sum(f.seconds for f in mine)])
    bad = [[f.stage, f.what, f.error, f.detail] for f in disagreements(findings, item["tol"])]
    return {
        "name": robot.name,
        "n": robot.n,
        "joints": "".join(link.joint[0] for link in robot.links),
        "per_stage": per_stage,
        "bad": bad,
        "code": robot_code(robot).splitlines() if bad else [],
    }


def _scheduler_from_environment() -> bool:
    import os

    return bool(os.environ.get("DASK_SCHEDULER_ADDRESS"))


def _on_cluster(items: list[dict], args) -> list[dict]:
    """The arms' results, checked on a Dask cluster through the sweep engine, in seed order."""
    from symdyn.sweep.engine import Sweep, run

    sweep = Sweep(
        "fuzz-arms",
        "the random-arm differential check, one task per arm",
        check_one,
        inputs=lambda n: items,
        input_columns=("index", "seed", "n_min", "n_max", "general", "states", "stages", "tol"),
        result_columns=("name", "n", "joints", "per_stage", "bad", "code"),
    )
    out = Path(args.sweep_out or tempfile.mkdtemp(prefix="fuzz-arms-"))
    outcome = run(sweep, items, out, resume=args.resume, scheduler=args.scheduler, workers=args.workers)
    print(
        f"# cluster run: {outcome.ran} arms on {outcome.engine} in {outcome.wall_s:.0f} s; table {outcome.table}",
        file=sys.stderr,
        flush=True,
    )
    by_index = {int(r["index"]): r for r in outcome.rows}
    results = []
    for item in items:
        r = by_index[item["index"]]
        if r["error"]:  # the task itself failed (e.g. its worker died too often): a crash of every stage
            results.append(
                {
                    "name": f"seed {item['seed']}",
                    "n": 0,
                    "joints": "",
                    "code": [],
                    "per_stage": [[s, float("inf"), "crashed", 0.0] for s in item["stages"]],
                    "bad": [[s, "crashed", float("inf"), r["error"]] for s in item["stages"]],
                }
            )
        else:
            results.append(
                {
                    "name": r["name"],
                    "n": int(r["n"]),
                    "joints": r["joints"],
                    "code": json.loads(r["code"]),
                    "per_stage": json.loads(r["per_stage"]),
                    "bad": json.loads(r["bad"]),
                }
            )
    return results


if __name__ == "__main__":
    sys.exit(main())
