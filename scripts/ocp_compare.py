"""OCP solve time: symdyn's functions vs a plain Newton–Euler, compiled and on SX (issues 6, 13).

Run: .venv/bin/python scripts/ocp_compare.py [--variants symdyn:compiled symdyn:sx plain:compiled plain:sx]
     [--quick] [--repeats K]
Solves the same Puma 560 minimum-time problems (Hermite–Simpson collocation on
τ = ID(q, q̇, q̈), multiple shooting on fdyn) with each source's functions in one
run and prints sizes, IPOPT iterations, set-up, time per iteration and total solve
time side by side with ratios (Markdown).  `--variants plain:sx plain:sx` validates the
harness (ratios ≈ 1).  As a function: `symdyn.apps.studies.ocp.compare(...)`.
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.apps.ocp import SOURCES  # noqa: E402
from symdyn.apps.studies.ocp import VARIANTS, compare, format_table  # noqa: E402

CHOICES = [f"{s}:{m}" for s in SOURCES for m in ("compiled", "sx")]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--variants",
        nargs="+",
        choices=CHOICES,
        default=[f"{s}:{'compiled' if c else 'sx'}" for s, c in VARIANTS],
        help="source:evaluation, the first is the reference of the ratios (default: all four)",
    )
    p.add_argument("--quick", action="store_true", help="coarse grids (seconds)")
    p.add_argument("--repeats", type=int, default=1, help="solves per source; the fastest is kept")
    args = p.parse_args(argv)
    variants = tuple((v.split(":")[0], v.endswith(":compiled")) for v in args.variants)
    rows = compare(variants, quick=args.quick, repeats=args.repeats)
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
