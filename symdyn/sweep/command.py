"""`symdyn sweep NAME …`: run one sweep on a Dask cluster from the command line (`--list` lists them).

Where it sits: the command line's side of `symdyn.sweep` (cli.py only hands
the subcommand's parser here).  Common options: --n, --out, --resume,
--scheduler / $DASK_SCHEDULER_ADDRESS, --workers (0: serial, in this process);
each sweep's own options (its `Sweep.options`) are checked against the sweep
chosen, so an option that does not apply is an error, not silently ignored.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import MODULES, get

#: The sweeps' own options: flag -> (dest, type, help).  Defaults come from each Sweep.options.
OWN = {
    "--arm": ("arm", str, "the arm (trajectory-library: puma560, panda or twolink; monte-carlo: puma560 or twolink)"),
    "--N": ("N", int, "collocation intervals per motion (trajectory-library; default 40, panda 60)"),
    "--seed": ("seed", int, "seed of the random inputs (default 0)"),
    "--spread": ("spread", float, "relative parameter spread x, factors in [1 - x, 1 + x] (monte-carlo; default 0.1)"),
    "--T": ("T", float, "duration of the tracked motion, s (monte-carlo; default 2)"),
}


def configure_parser(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "name",
        nargs="?",
        choices=list(MODULES),
        metavar="NAME",
        help=f"the sweep: {', '.join(MODULES)} (--list describes them)",
    )
    p.add_argument("--list", action="store_true", help="list the sweeps")
    p.add_argument("--n", type=int, default=None, help="number of tasks (motions, draws); default 200")
    p.add_argument(
        "--out", default=None, help="output folder: results.csv, summary.txt, figures (default: out/sweep/NAME)"
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="keep the results in --out and run only the missing tasks (and those that raised)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: $DASK_SCHEDULER_ADDRESS, else a local cluster)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="worker processes of the local cluster (default: one per CPU); 0 runs the tasks here, one after the other",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    p.add_argument(
        "--no-verify", action="store_true", help="trajectory-library: skip the re-simulation of each motion (faster)"
    )
    for flag, (dest, kind, text) in OWN.items():
        p.add_argument(flag, dest=dest, type=kind, default=None, help=text)
    p.set_defaults(func=run_command)


def run_command(args: argparse.Namespace) -> int:
    from .engine import SweepInterrupted, run

    if args.list or not args.name:
        for name in MODULES:
            sweep = get(name)
            print(f"{name:20s} {sweep.summary}")
            print(
                f"{'':20s} options: "
                + ", ".join(f"--{k}" + ("" if v[0] is None else f" (default {v[0]})") for k, v in sweep.options.items())
            )
        return 0
    sweep = get(args.name)
    options = {}
    for flag, (dest, _, _) in OWN.items():
        value = getattr(args, dest)
        if value is not None:
            if dest not in sweep.options:
                raise ValueError(
                    f"{flag} does not apply to the {sweep.name} sweep (its options: "
                    + ", ".join(f"--{k}" for k in sweep.options)
                    + ")"
                )
            options[dest] = value
    if args.no_verify:
        if "verify" not in sweep.options:
            raise ValueError(f"--no-verify does not apply to the {sweep.name} sweep")
        options["verify"] = False
    n = 200 if args.n is None else args.n
    out = Path(args.out) if args.out else Path("out") / "sweep" / sweep.name
    inputs = sweep.inputs(n, **options)
    try:
        outcome = run(
            sweep,
            inputs,
            out,
            resume=args.resume,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=not args.no_progress,
            options={"n": n, **options},
        )
    except SweepInterrupted as exc:
        print(f"\nsymdyn: {exc}", file=sys.stderr)
        return 130
    print((out / "summary.txt").read_text(), end="")
    print(f"\nresults in {outcome.table}, summary and figures in {out}")
    return 0
