"""Cold build time per phase and operation counts, against the joint count (issue 33's benchmark).

"first τ" is the time from a `Robot` in hand to the first value of tau (base parameters,
derivations, τ's program, its compile); "every function" adds `model.build(batch=False)`,
every other function's program and scalar C compiled ahead on every core (the next program
made while the last compiles), then a first call of each.  Operation counts after one joint
CSE, with the model's friction.

Run: .venv/bin/python scripts/bench_build.py [--n 2,4,6,8,10,14,20,30] [--kinds general,dh]
     [--real] [--timeout 900] [--markdown docs/build_table.md] [--plot docs/img/build_time.png]

Every arm is built in its own process with an empty cache (SYMDYN_CACHE_DIR a fresh
folder), as `symdyn.load(robot, "c")` does it (`_build`).  An arm that runs past
--timeout is reported with the phase it was in.  Random arms are
`random_arm(7, ArmOptions(general=1 or 0, symbolic=0), n=n)`: every feature of the model
(prismatic joints, offsets, rotors, friction, payloads, generic and exact twists).
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import os
import sys
import tempfile
import time
from pathlib import Path

REAL = {
    "UR3": ("ur_description/urdf/ur3_robot.urdf", "tool0"),
    "Panda + hand": ("panda_description/urdf/panda.urdf", "panda_hand"),
    "xArm7": ("xarm_description/urdf/xarm7.urdf", "link7"),
    "Romeo arm + trunk": ("romeo_description/urdf/romeo.urdf", "l_gripper"),
    "G1 arm + waist": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", "left_wrist_yaw_link"),
}
PHASES = ("read", "base parameters", "derive", "τ: program", "τ: compile", "others: build()")


def _robot(spec: tuple):
    kind, arg = spec
    if kind == "real":
        import importlib.metadata

        from symdyn import Robot

        path, tip = REAL[arg]  # example-robot-data: the robots extra
        dist = importlib.metadata.distribution("example-robot-data")
        root = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
        return Robot.from_urdf(root / path, tip_link=tip)
    from symdyn.model.random_arms import ArmOptions, random_arm

    return random_arm(7, ArmOptions(general=1.0 if kind == "general" else 0.0, symbolic=0.0), n=arg)


def _build(spec: tuple, queue) -> None:
    """One arm as a user meets it, each phase's seconds sent as it ends: read the file, then
    `symdyn.load(robot, "c")` and a first call of every function, τ first.  The base
    parameters and the derivations are made first on their own (into the empty cache the
    load then reads them from), and each function's time is split into its program (built and
    printed: `symdyn.codegen.lazy`) and the rest (compile and load)."""
    os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-build-")
    import warnings

    warnings.simplefilter("ignore")
    import numpy as np

    import symdyn
    from symdyn.codegen import lazy
    from symdyn.codegen.choice import derivations
    from symdyn.derivation.regressor import base_parameters, generic_turns

    def phase(name, fn):
        queue.put(("start", name))
        start = time.perf_counter()
        value = fn()
        queue.put(("done", name, time.perf_counter() - start))
        return value

    robot = phase("read", lambda: _robot(spec))
    queue.put(("info", {"n": robot.n, "turns": generic_turns(robot)}))
    phase("base parameters", lambda: base_parameters(robot))
    phase("derive", lambda: derivations(robot))  # cached on disk: the load below reads them
    built, ops = {}, {}
    original = lazy._Sources._build

    def timed(self, function):
        start = time.perf_counter()
        text = original(self, function)
        built[function] = time.perf_counter() - start
        ops[function] = self.programs().program(function).op_count()["total"]
        return text

    lazy._Sources._build = timed
    model = symdyn.load(robot, "c")
    signatures = {s.name: s for s in lazy.signatures(robot.n)}

    def call(names):
        spent = 0.0
        for name in names:
            start = time.perf_counter()
            model.functions[name](*(np.full(k, 0.1) for _, k in signatures[name].inputs))
            spent += time.perf_counter() - start
        return spent

    queue.put(("start", "τ: program"))
    spent = call(["tau"])
    queue.put(("done", "τ: program", built["tau"]))
    queue.put(("done", "τ: compile", spent - built["tau"]))
    others = [f for f in model.functions if f != "tau"]
    queue.put(("start", "others: build()"))
    start = time.perf_counter()
    model.build(batch=False)
    call(others)
    queue.put(("done", "others: build()", time.perf_counter() - start))
    queue.put(("info", {"ops": ops, "programs": sum(v for f, v in built.items() if f != "tau")}))


def measure(spec: tuple, timeout: float) -> dict:
    """The phases of one arm in a child process; {"phases": {…}, "ops": …, "stopped": phase or None}."""
    queue = mp.get_context("spawn").Queue()
    proc = mp.get_context("spawn").Process(target=_build, args=(spec, queue))
    proc.start()
    row: dict = {"phases": {}, "stopped": None}
    deadline, current = time.monotonic() + timeout, None
    while True:
        try:
            msg = queue.get(timeout=max(0.1, deadline - time.monotonic()))
        except Exception:
            if proc.is_alive() and time.monotonic() < deadline:
                continue
            break
        if msg[0] == "start":
            current = msg[1]
            print(f"  {spec[1]}: {current} …", file=sys.stderr, flush=True)
        elif msg[0] == "done":
            row["phases"][msg[1]] = msg[2]
            current = None
        elif msg[0] == "info" and "ops" in msg[1]:
            row.update(msg[1])
            break
        else:
            row.update(msg[1])
    if current is not None or len(row["phases"]) < len(PHASES):
        row["stopped"] = current or "?"
    proc.kill()
    proc.join()
    return row


def _table(rows: list) -> str:
    head = (
        "| arm | joints | generic turns | "
        + " | ".join(PHASES)
        + " | of which programs | first τ | every function | τ ops | all ops |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for label, row in rows:
        cells = [f"{row['phases'][p]:.2f}" if p in row["phases"] else "" for p in PHASES]
        total, first = _total(row, False), _total(row, True)
        if row["stopped"]:
            cells[PHASES.index(row["stopped"])] = "**stopped**"
        ops = row.get("ops", {})
        more = "> " if row["stopped"] else ""
        lines.append(
            f"| {label} | {row.get('n', '')} | {row.get('turns', '')} | "
            + " | ".join(cells)
            + (f" | {row['programs']:.2f}" if "programs" in row else " | ")
            + f" | {first:.1f} | {more}{total:.1f} | {ops.get('tau', '')} | {sum(ops.values()) or ''} |"
        )
    return "\n".join(lines)


def _total(row: dict, first: bool) -> float:
    """Seconds from a Robot in hand to the first τ (`first`) or to every function called once."""
    return sum(v for k, v in row["phases"].items() if k != "read" and (not first or not k.startswith("others")))


def _slope(rows: list, value) -> float | None:
    """Least-squares slope of log(seconds) against log(n), over the finished arms with n ≥ 6."""
    pts = [(math.log(r["n"]), math.log(value(r))) for _, r in rows if r.get("n", 0) >= 6 and value(r) > 0]
    if len(pts) < 2:
        return None
    mx, my = sum(x for x, _ in pts) / len(pts), sum(y for _, y in pts) / len(pts)
    return sum((x - mx) * (y - my) for x, y in pts) / sum((x - mx) ** 2 for x, _ in pts)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", default="2,4,6,8,10,14,20,30")
    p.add_argument("--kinds", default="general", help="random arms: general, dh, or both (comma-separated)")
    p.add_argument("--real", action="store_true", help="also the example-robot-data arms (the robots extra)")
    p.add_argument("--timeout", type=float, default=900.0, help="seconds per arm")
    p.add_argument("--markdown", help="write the table (and slopes) here")
    p.add_argument("--plot", help="write the log-log curve here (matplotlib)")
    p.add_argument("--json", help="write the raw rows here")
    p.add_argument("--render", nargs="+", metavar="JSON", help="measure nothing: the table and plot of saved rows")
    args = p.parse_args()
    specs = [("real", name) for name in REAL] if args.real else []
    specs += [(kind, int(n)) for kind in args.kinds.split(",") if kind for n in args.n.split(",") if n]
    rows = [tuple(row) for path in args.render for row in json.loads(Path(path).read_text())] if args.render else []
    for spec in specs if not args.render else ():
        label = spec[1] if spec[0] == "real" else f"random {spec[0]} {spec[1]}"
        row = measure(spec, args.timeout)
        rows.append((label, row))
        print(_table(rows[-1:]).splitlines()[-1], flush=True)
    text = _table(rows)
    done = [r for r in rows if r[0].startswith("random") and not r[1]["stopped"]]
    slopes = {ph: _slope(done, lambda r, ph=ph: r["phases"].get(ph, 0)) for ph in PHASES[1:]}
    slopes["first τ"] = _slope(done, lambda r: _total(r, True))
    slopes["every function"] = _slope(done, lambda r: _total(r, False))
    text += "\n\nslope of log(seconds) against log(n), random arms with n ≥ 6: " + ", ".join(
        f"{ph} {s:.2f}" for ph, s in slopes.items() if s is not None
    )
    print("\n" + text)
    if args.markdown:
        Path(args.markdown).write_text(text + "\n")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.5))
        for kind in args.kinds.split(","):
            pts = sorted((r for label, r in rows if label.startswith(f"random {kind}")), key=lambda r: r["n"])
            for ph in PHASES[1:]:
                xs = [r["n"] for r in pts if ph in r["phases"]]
                ys = [r["phases"][ph] for r in pts if ph in r["phases"]]
                if xs:
                    ax.loglog(xs, ys, "o-", label=f"{ph} ({kind})", ms=3)
            for what, first in (("first τ", True), ("every function", False)):
                xs = [r["n"] for r in pts if not r["stopped"]]
                ys = [_total(r, first) for r in pts if not r["stopped"]]
                if xs:
                    ax.loglog(xs, ys, "s-" if first else "D-", lw=2, label=f"{what} ({kind})", ms=4)
        ns = sorted({r["n"] for _, r in rows if "n" in r})
        if ns:
            ax.loglog(ns, [0.01 * (n / ns[0]) ** 3 for n in ns], "k:", label="n³ (slope 3)")
        ax.set_xlabel("joints n")
        ax.set_ylabel("seconds, cold cache")
        ax.legend(fontsize=7, ncol=2)
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
