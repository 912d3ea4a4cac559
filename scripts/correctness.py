"""The correctness ladder on every shipped arm: the README's correctness table, one row per arm.

Run: .venv/bin/python scripts/correctness.py [--count 200] [MODEL ...]
Each model goes through `symdyn.bench.differential.check_arm` at `count` random
states within its joint limits — the reference against Pinocchio, the
derivations against the reference, Lagrange and Newton–Euler exactly at
rational points, every generated target and function against the reference,
the identities — and its generated derivatives (C target) against Pinocchio's
analytical ones.  Prints a Markdown row per arm with the worst relative error
of each stage; exits 1 when any comparison disagrees (1e-10; the exact stage
must be exactly 0).
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.bench.differential import (
    STAGES,
    check_arm,
    disagreements,
    pinocchio_derivatives,  # noqa: E402
    relative_error,
    states,
)
from symdyn.bench.peers import pinocchio_model  # noqa: E402
from symdyn.codegen import entry as codegen  # noqa: E402
from symdyn.model import arms  # noqa: E402

DERIVATIVES = {"tau_derivatives": ("dtau_dq", "dtau_dqd"), "fdyn_derivatives": ("qdd", "dqdd_dq", "dqdd_dqd", "Minv")}


def derivative_errors(robot, count: int) -> float:
    """Worst relative error of the generated C derivatives against Pinocchio's."""
    f = codegen.load(robot, "c")
    q, qd, qdd, tau = states(robot, count, seed=5)
    peer = pinocchio_derivatives(pinocchio_model(robot), robot, q, qd, qdd, tau)
    worst = 0.0
    for name, keys in DERIVATIVES.items():
        got = getattr(f, name)(q, qd, qdd if name == "tau_derivatives" else tau)
        got = got[1:] if name == "tau_derivatives" else got
        worst = max([worst] + [relative_error(g, peer[k], 1.0) for g, k in zip(got, keys)])
    return max(worst, relative_error(f.Minv(q), peer["Minv"], 1.0))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("models", nargs="*", default=list(codegen.SHIPPED) + ["puma560_mdh", "rrp"])
    p.add_argument("--count", type=int, default=200, help="random states per arm (default 200)")
    args = p.parse_args(argv)
    print("| arm | joints | " + " | ".join(STAGES) + " | derivatives vs Pinocchio | seconds |")
    print("|---|---:|" + "---:|" * (len(STAGES) + 2))
    failed = []
    for name in args.models:
        robot = arms.load(name)
        start = time.perf_counter()
        findings = check_arm(robot, count=args.count)
        worst = {s: max((f.error for f in findings if f.stage == s), default=float("nan")) for s in STAGES}
        deriv = derivative_errors(robot, args.count)
        failed += [f"{name}: {f.stage} {f.what} {f.error:.1e} {f.detail}" for f in disagreements(findings)]
        failed += [f"{name}: derivatives {deriv:.1e}"] if not deriv <= 1e-10 else []
        cells = " | ".join(f"{worst[s]:.0e}" if worst[s] else "0 (exact)" for s in STAGES)
        print(f"| {name} | {robot.n} | {cells} | {deriv:.0e} | {time.perf_counter() - start:.0f} |", flush=True)
    for line in failed:
        print("DISAGREES:", line, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
