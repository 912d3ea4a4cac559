"""OCP solve time with symdyn's CasADi functions against a plain SX Newton–Euler (issue 6).

Run: .venv/bin/python scripts/ocp_compare.py [--sources symdyn plain] [--quick] [--repeats K]
Solves the same Puma 560 minimum-time problems (Hermite–Simpson collocation on
τ = ID(q, q̇, q̈), multiple shooting on fdyn) with each source's functions in one
run and prints sizes, IPOPT iterations, set-up, time per iteration and total solve
time side by side with ratios (Markdown).  `--sources plain plain` validates the
harness (ratios ≈ 1).  As a function: `symdyn.apps.studies.ocp.compare(...)`.
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.apps.ocp import SOURCES  # noqa: E402
from symdyn.apps.studies.ocp import compare, format_table  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sources", nargs="+", default=["symdyn", "plain"], choices=SOURCES,
                   help="dynamics sources, first is the reference of the ratios (default: symdyn plain)")
    p.add_argument("--quick", action="store_true", help="coarse grids (seconds)")
    p.add_argument("--repeats", type=int, default=1, help="solves per source; the fastest is kept")
    args = p.parse_args(argv)
    rows = compare(tuple(args.sources), quick=args.quick, repeats=args.repeats)
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
