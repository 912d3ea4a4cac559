"""Whole robots (trees, floating bases) at the C level: symdyn's generated C against Pinocchio's C++.

The frictionless generated C (`harness.frictionless_sources`) compiled into the timing harness
(q of nq entries, v of nv) and the same model in Pinocchio's C++ (`pin_peer.cpp`, read from the
version-2 arm file `pin_peer.write_arm` writes from `peers.pinocchio_model`: a FreeFlyer or
Planar root carrying the base body, then the tree) time their functions on one states file,
with the same loop and flags, in alternating rounds.  Pairs: tau / rnea, M / crba (LOCAL, and
WORLD), fdyn / aba.  Both sides' outputs at state 3 are checked against the reference and
against each other to 1e-10 before any time is believed.  `symdyn bench --model FILE --tips all
--base-joint free` and `scripts/bench_whole.py` run it.
"""

from __future__ import annotations

import os

import numpy as np

from ..derivation.cache import cache_dir, writable
from ..model import Robot
from ..numeric import reference as ref
from . import pin_peer
from .harness import POOL, build_harness, check_harness, frictionless_sources, run_harness, write_states
from .peers import pinocchio_model
from .rows import Row

__all__ = ["PAIRS", "TOL", "floating_states", "compare_robot"]

TOL = 1e-10
#: (symdyn function, Pinocchio algorithm, its label)
PAIRS = (
    ("tau", "rnea", "rnea"),
    ("M", "crba", "crba (LOCAL, default)"),
    ("M", "crba_world", "crba (WORLD)"),
    ("fdyn", "aba", "aba"),
)


def floating_states(robot: Robot, count: int, seed: int = 0):
    """(q, v, a, τ): joints uniform in their limits (clipped to ±3), a floating base moved from the
    neutral pose along a random twist (unit quaternion), v, a uniform in ±2, ±5; τ by the reference."""
    rng = np.random.default_rng(seed)
    lo, hi = np.clip(np.array(robot.qlim, dtype=float).T, -3.0, 3.0)
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(lo, hi, (count, robot.n))
    if robot.base_joint is not None:
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n)) * 2
        q = robot.integrate(q, twist)
    v, a = rng.uniform(-2, 2, (count, robot.nv)), rng.uniform(-5, 5, (count, robot.nv))
    return q, v, a, ref.rne(robot, q, v, a)


def _relative(got, want) -> float:
    got, want = np.ravel(got), np.ravel(want)
    return float(np.abs(got - want).max() / max(1.0, np.abs(want).max()))


def compare_robot(robot: Robot, *, calls: int, reps: int, rounds: int, seed: int = 0, log=print) -> list[Row]:
    """The rows of one whole robot (see the module docstring).

    Raises:
        PeerUnavailable: Pinocchio's C++ headers or a C++ compiler are missing.
        RuntimeError: either side's outputs differ from the reference or the other's.
    """
    peer = pin_peer.peer_binary(log)  # first: without it there is nothing to compare with
    bare = robot.nofriction(all=True)
    log(f"{robot.name}: n={robot.n} nq={robot.nq} nv={robot.nv}; generating / compiling ...")
    src = frictionless_sources(robot)
    harness = build_harness(src["c"], src["h"])
    tree = pin_peer.tree_joints(pinocchio_model(bare))
    work = writable(cache_dir() / "bench")
    states = floating_states(bare, POOL, seed=seed)
    q, v, a, _ = states
    states_file = write_states(work / f"states-whole-{os.getpid()}.bin", *states)
    arm = pin_peer.write_tree(work / f"arm-whole-{os.getpid()}.txt", tree)
    ours_fns = sorted({p[0] for p in PAIRS})
    peer_algos = [p[1] for p in PAIRS]
    ours, theirs = [], []
    try:
        for r in range(rounds):
            for side in ("peer", "ours") if r % 2 else ("ours", "peer"):  # ABBA: slow drifts of load cancel
                if side == "ours":
                    t, ck_ours = run_harness(harness, states_file, calls, reps, ours_fns)
                    check_harness(bare, ck_ours, *states, rtol=TOL)
                    ours.append(t)
                else:
                    t, ck_peer = pin_peer.run_peer(peer, arm, states_file, calls, reps, peer_algos)
                    pin_peer.check_peer(bare, ck_peer, *states, rtol=TOL)
                    theirs.append(t)
            log(f"{robot.name}: round {r + 1}/{rounds} done")
    finally:
        states_file.unlink(missing_ok=True)
        arm.unlink(missing_ok=True)
    for fn, algo, _ in PAIRS:  # the two sides against each other at state 3
        err = _relative(ck_ours[fn], ck_peer[algo])
        if not err <= TOL:
            raise RuntimeError(f"{robot.name}: symdyn {fn} and Pinocchio {algo} differ by {err:.1e}")
    title = f"{robot.name} (whole robot, nq {robot.nq} / nv {robot.nv}), frictionless; ns per call, medians"
    return [
        Row(title, fn, tuple(t[fn] for t in ours), f"Pinocchio {label}", tuple(t[algo] for t in theirs))
        for fn, algo, label in PAIRS
    ]
