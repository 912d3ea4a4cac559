"""Crocoddyl's own Solo 12 jump and trot (its `SimpleQuadrupedalGaitProblem`, FDDP), timed: run by
`scripts/legged_compare.py` in an environment where Crocoddyl installs (it pins its Pinocchio),
e.g. `python3 -m venv /tmp/crocenv && /tmp/crocenv/bin/pip install crocoddyl example-robot-data`.

Usage: crocoddyl_solo.py SOLO12_URDF Q0_JSON — the URDF symdyn reads and its standing q0 (the
same robot and start as symdyn's study; the model built by Pinocchio on a free-flyer root).
Prints one JSON object: for each problem its knots, FDDP's iterations, whether it converged, the
seconds to convergence and per iteration, and the versions."""

from __future__ import annotations

import json
import sys
import time

import crocoddyl
import numpy as np
import pinocchio
from crocoddyl.utils.quadruped import SimpleQuadrupedalGaitProblem


def solve(problem, x0, max_iter: int = 200) -> dict:
    """FDDP from the standing state repeated (Crocoddyl's examples' warm start), timed."""
    solver = crocoddyl.SolverFDDP(problem)
    xs = [x0] * (problem.T + 1)
    us = problem.quasiStatic([x0] * problem.T)
    start = time.perf_counter()
    converged = solver.solve(xs, us, max_iter, False)
    seconds = time.perf_counter() - start
    return {
        "knots": problem.T,
        "iterations": solver.iter,
        "converged": bool(converged),
        "seconds": seconds,
        "per_iteration_ms": 1e3 * seconds / max(solver.iter, 1),
        "cost": solver.cost,
    }


def main() -> None:
    model = pinocchio.buildModelFromUrdf(sys.argv[1], pinocchio.JointModelFreeFlyer())
    q0 = np.array(json.loads(sys.argv[2]), dtype=float)
    model.referenceConfigurations["standing"] = q0  # the gait problem regularises towards it
    x0 = np.concatenate([q0, np.zeros(model.nv)])
    gait = SimpleQuadrupedalGaitProblem(model, "FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
    out = {"crocoddyl": crocoddyl.__version__, "pinocchio": pinocchio.__version__}
    # the jump: 15 cm forward, 10 knots of 0.03 s on the ground before and after, a flight between
    out["jump"] = solve(gait.createJumpingProblem(x0, 0.15, [0.15, 0.0, 0.0], 0.03, 10, 6), x0)
    # the trot: two steps of 10 cm (one gait cycle), 8 knots per swing of 0.025 s, 2 in support
    out["trot"] = solve(gait.createTrottingProblem(x0, 0.1, 0.03, 0.025, 8, 2), x0)
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
