"""The legged OCPs side by side: symdyn's Solo 12 jump and trot (CasADi + IPOPT on the generated
functions, `symdyn.apps.studies.legged`), the same problems on the plain baseline (a free-base
recursion written in CasADi SX, `symdyn.numeric.casadi_legged`) and Crocoddyl's own jump and trot
(FDDP), in one run.

Run: .venv/bin/python scripts/legged_compare.py [--crocoddyl PYTHON]
PYTHON is the interpreter of an environment where Crocoddyl installs, pinned to the Pinocchio it
was built for (Crocoddyl's wheels do not pin it: with today's Pinocchio 4.1 `crocoddyl` 3.2.1
crashes), e.g.:

    python3 -m venv /tmp/crocenv
    /tmp/crocenv/bin/pip install crocoddyl==3.1.0 pin==3.8.0 libpinocchio==3.8.0 \\
        'cmeel-urdfdom>=4,<5' 'cmeel-tinyxml2>=10,<11'

Crocoddyl runs `scripts/crocoddyl_solo.py` there on the same URDF and standing q0.  The problems
are each tool's own (Crocoddyl's `SimpleQuadrupedalGaitProblem` tracks its feet and centre of mass
with costs; symdyn's are the studies' constrained minimum-effort problems), so the table compares
what each takes to a converged jump and trot, and where its time goes — not one NLP.  Prints
Markdown.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.apps import ocp_legged  # noqa: E402
from symdyn.apps.studies import legged  # noqa: E402
from symdyn.model.example_robots import robots_folder  # noqa: E402


TOOLS = {"symdyn": "symdyn's functions + IPOPT", "plain": "plain CasADi recursion + IPOPT"}


def symdyn_rows() -> list[dict]:
    robot = legged.solo12()
    rows = []
    for name, make in (("jump", legged.jump_problem), ("trot", legged.trot_problem)):
        for source in TOOLS:
            rows.append(_row(make(robot), name, source))
    return rows


def _row(problem: ocp_legged.LeggedProblem, name: str, source: str) -> dict:
    sol = ocp_legged.solve(problem, source=source)
    return {
        "tool": TOOLS[source],
        "problem": name,
        "knots": sum(p.nodes for p in problem.phases),
        "iterations": sol.iterations,
        "converged": sol.status == "Solve_Succeeded",
        "seconds": sol.seconds,
        "per_iteration_ms": 1e3 * sol.seconds / max(sol.iterations, 1),
        "functions_share": sol.function_seconds / sol.seconds,
        "build_seconds": sol.build_seconds,
    }


def crocoddyl_rows(python: str) -> list[dict]:
    robot = legged.solo12()
    urdf = robots_folder() / "solo_description" / "robots" / "solo12.urdf"
    q0 = ocp_legged.standing(robot, legged.STAND)
    script = Path(__file__).with_name("crocoddyl_solo.py")
    run = subprocess.run([python, str(script), str(urdf), json.dumps(q0.tolist())], capture_output=True, text=True)
    if run.returncode != 0:  # symdyn's rows are kept: the environment is the user's to repair
        tail = "\n".join(run.stderr.strip().splitlines()[-3:])
        print(f"Crocoddyl's run in {python} failed (exit {run.returncode}):\n{tail}", file=sys.stderr)
        return []
    found = json.loads(run.stdout.strip().splitlines()[-1])
    tool = f"Crocoddyl {found['crocoddyl']} FDDP (Pinocchio {found['pinocchio']})"
    return [{"tool": tool, "problem": name, **found[name]} for name in ("jump", "trot")]


def table(rows: list[dict]) -> str:
    lines = [
        "| tool | problem | knots | iterations | converged | to convergence | per iteration | functions' share | build |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        share = f"{r['functions_share']:.0%}" if "functions_share" in r else "—"
        build = f"{r['build_seconds']:.1f} s" if "build_seconds" in r else "—"
        lines.append(
            f"| {r['tool']} | {r['problem']} | {r['knots']} | {r['iterations']} | {'yes' if r['converged'] else 'no'} "
            f"| {r['seconds']:.2f} s | {r['per_iteration_ms']:.1f} ms | {share} | {build} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--crocoddyl", metavar="PYTHON", help="an interpreter with Crocoddyl (see the module)")
    args = p.parse_args(argv)
    rows = symdyn_rows()
    if args.crocoddyl:
        rows += crocoddyl_rows(args.crocoddyl)
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
