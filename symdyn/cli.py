"""`symdyn …`: the command line.

Subcommands: run (the main job), print (closed forms), generate (model
code), bench (speed against peers), study (the chapter's studies).  Each
delegates to the module that owns the work; this file only parses.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def _cmd_run(args: argparse.Namespace) -> int:
    """Load the Puma 560 and summarise its dynamics at the book poses."""
    from . import models, reference as ref

    robot = models.load("puma560")
    print(f"{robot.name}: {robot.n} joints, {robot.convention} DH, "
          f"total mass {sum(float(l.m) for l in robot.links):.2f} kg  [{robot.source}]")
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    for pose in ("qz", "qr", "qs", "qn"):
        q = getattr(robot, pose)
        M = ref.inertia(robot, q)
        print(f"\n{pose} = {q}")
        print(f"  G(q)      = {ref.gravload(robot, q)}  N·m")
        print(f"  diag M(q) = {np.diag(M)}  kg·m²")
        print(f"  cond M(q) = {np.linalg.cond(M):.1f}")
    return 0


def _cmd_study(args: argparse.Namespace) -> int:
    from . import studies

    if args.list or not args.name:
        for name, (summary, _) in sorted(studies.registry().items()):
            print(f"{name:28s} {summary}")
        return 0
    text = studies.run(args.name, Path(args.out))
    print(text)
    print(f"\nfigures and summary written to {Path(args.out) / args.name}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="symdyn", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="the main job: derive the Puma 560, generate its code, summarise")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("study", help="run one of the chapter's studies (--list to see them)")
    p.add_argument("name", nargs="?")
    p.add_argument("--list", action="store_true", help="list the studies")
    p.add_argument("--out", default="out", help="output folder (default: ./out)")
    p.set_defaults(func=_cmd_study)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (KeyError, ValueError, RuntimeError, FileNotFoundError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"symdyn: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
