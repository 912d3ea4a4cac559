"""Why the legged studies hold their feet with Baumgarte gains: Solo 12's jump and trot solved
without gains, with the studies' (400, 40) (ω = 20 rad/s, critically damped) and stiffer ones —
the gains alone: no bound on how far a foot in contact moves unless `--hold` gives one.

Run: .venv/bin/python scripts/legged_gains.py [--gains KP,KD ...] [--problems jump trot] [--hold M]
Prints, per problem and gains: IPOPT's status, iterations and seconds, how far a foot in contact
moves within its phase (`legged.slip`), the lowest foot (below 0: into the ground) and the base's
highest rise above standing.  A few minutes on one core.
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn import load  # noqa: E402
from symdyn.apps import ocp_legged  # noqa: E402
from symdyn.apps.studies import legged  # noqa: E402

PROBLEMS = {"jump": legged.jump_problem, "trot": legged.trot_problem}


def _gains(text: str) -> tuple:
    kp, kd = (float(x) for x in text.split(","))
    return kp, kd


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gains", nargs="+", type=_gains, default=[(0.0, 0.0), legged.GAINS, (900.0, 60.0)])
    p.add_argument("--problems", nargs="+", choices=sorted(PROBLEMS), default=["jump", "trot"])
    p.add_argument("--hold", type=float, default=None, help="the feet's hold (m, LeggedProblem.hold); default: none")
    args = p.parse_args(argv)
    robot = legged.solo12()
    poses = load(robot, "c")
    print(
        "| problem | kp, kd | status | iterations | seconds | slip in stance (mm) | lowest foot (mm) | base rise (cm) |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for name in args.problems:
        for gains in args.gains:
            problem = PROBLEMS[name](robot, gains, args.hold)
            sol = ocp_legged.solve(problem)
            feet = poses.frame_pose(sol.q)[:, :, :3, 3]
            print(
                f"| {name} | {gains[0]:g}, {gains[1]:g} | {sol.status} | {sol.iterations} | {sol.seconds:.1f} | "
                f"{1e3 * legged.slip(problem, sol, feet):.2f} | {1e3 * feet[:, :, 2].min():+.2f} | "
                f"{1e2 * (sol.q[:, 2].max() - problem.q0[2]):.1f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
