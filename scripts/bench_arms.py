"""Seven-joint arms end to end (issue 15's benchmark): derivations, generation, cold cache.

Run: .venv/bin/python scripts/bench_arms.py [panda iiwa14 ur5 generic7]
Each model in a fresh temporary cache: Newton–Euler (named program), its
M, C, G, τ expanded to sympy matrices, Lagrange (named intermediates beyond
six joints), generation of every target (NumPy, C, CasADi) and the C
compile on first load.  `generic7` is a random 7-joint arm in the general
convention with no parallel or perpendicular axes (generic rpy and axes).
"""

import math
import os
import subprocess
import sys
import tempfile
import time


def _generic7():
    from symdyn.model import Link, Robot, placement
    from symdyn.model.random_arms import ArmOptions, random_arm

    base = random_arm(5000, ArmOptions(n_min=7, n_max=7, prismatic=0.0, symbolic=0.0))
    links = []
    for k, link in enumerate(base.links):  # generic rpy and a generic unit axis on every joint
        rpy = (0.3 + 0.17 * k, -0.4 + 0.11 * k, 0.25 * k + 0.1)
        axis = (
            math.sin(0.7 + k),
            math.cos(0.7 + k) * math.sin(0.3 * k + 0.2),
            math.cos(0.7 + k) * math.cos(0.3 * k + 0.2),
        )
        links.append(
            Link(
                origin=placement((0.05 * k, 0.1, 0.2), rpy),
                axis=axis,
                m=link.m,
                r=link.r,
                I=link.I,
                Jm=link.Jm,
                G=link.G,
                B=link.B,
                Tc=link.Tc,
                qlim=link.qlim,
            )
        )
    return Robot("generic7", tuple(links), convention="general")


def run(name: str) -> list:
    os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-bench-")
    import symdyn
    from symdyn import models
    from symdyn.derivation.entry import derive

    robot = _generic7() if name == "generic7" else models.load(name)
    rows = []

    def timed(label, fn):
        start = time.perf_counter()
        value = fn()
        rows.append((name, label, time.perf_counter() - start))
        return value

    ne = timed("Newton–Euler derivation (named program)", lambda: derive(robot, "newton-euler", cache=False))
    timed("  its M, C, G, tau as sympy matrices", lambda: [ne.M, ne.C, ne.G, ne.tau])
    timed("Lagrange derivation", lambda: derive(robot, "lagrange", cache=False))
    out = tempfile.mkdtemp(prefix="symdyn-gen-")
    timed("generate --target all (derivations included)", lambda: symdyn.generate(robot, "all", out))
    timed("  C compile on first load", lambda: symdyn.load(robot, "c", folder=out))
    return rows


def main(argv) -> int:
    names = argv or ["panda", "iiwa14", "ur5", "generic7"]
    print(f"{'model':10s} {'step':50s} {'seconds':>8s}", flush=True)
    for name in names:  # one process per model keeps the caches cold
        result = subprocess.run([sys.executable, __file__, "--one", name], capture_output=True, text=True)
        if result.returncode:
            print(result.stderr, file=sys.stderr)
            return 1
        total = 0.0
        for line in result.stdout.splitlines():
            model, label, seconds = line.split("\t")
            print(f"{model:10s} {label:50s} {float(seconds):8.2f}", flush=True)
            total += 0.0 if label.startswith("  its") else float(seconds)
        print(f"{name:10s} {'end to end (derive both ways, generate, compile)':50s} {total:8.2f}", flush=True)
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        for row in run(sys.argv[2]):
            print("\t".join(map(str, row)))
        sys.exit(0)
    sys.exit(main(sys.argv[1:]))
