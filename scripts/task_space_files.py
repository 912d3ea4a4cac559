#!/usr/bin/env python3
"""The task space of every URDF example-robot-data ships, against Pinocchio's own reading of each
file (slow: 22 minutes for all of them here; name some to run fewer).

Run: .venv/bin/python scripts/task_space_files.py [FILE …] [--states 20] [--timeout 400]

FILE is a path below example-robot-data's `robots/` folder (default: every URDF in it, in order
of size).  Each file is read in a process of its own (`Robot.from_urdf(tips="all")`, on a free
base unless it is an arm, a hand or a robot on a fixed base: `FIXED`); a file refused with
`inertia='balance'` as its way out is read again with it, and the table says so.  Its frames:
up to three tips, up to two links merged by fixed joints onto moving ones, one onto the base,
and one moving link between, as a user would pick them (`_frames`).  The NumPy target's
task-space functions at `--states` random states against Pinocchio's reduced model of the same
file (`symdyn.bench.task_space`); each group's largest error relative to the largest entry (or
1).  Prints one row per file and the worst over all; a file symdyn refuses prints the first
line of its reason.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from symdyn.model.example_robots import robots_folder

#: Arms, hands and robots on a fixed base (every other file gets a free base), by folder or file.
FIXED = (
    "double_pendulum_description",
    "asr_twodof_description",
    "finger_edu_description",
    "ur_description",
    "panda_description",
    "so_arm_description",
    "z1_description",
    "xarm_description",
    "kinova_description",
    "talos_data/robots/talos_left_arm.urdf",
    "allegro_hand_description",
    "baxter_description",
    "tiago_description",
    "tiago_pro_description",
    "pr2_description",
)

GROUPS = {
    "pose": ("frame_pose",),
    "Jacobians": ("frame_jacobian", "frame_jacobian_aligned"),
    "velocity, accelerations": ("frame_velocity", "frame_acceleration", "frame_drift"),
    "centre of mass": ("com", "com_jacobian", "com_drift"),
    "centroidal": ("centroidal_map", "centroidal_drift"),
}

_ONE = r"""
import json, sys, time, warnings
import numpy as np
sys.path.insert(0, sys.argv[4])
from task_space_files import compare
print("RESULT " + json.dumps(compare(sys.argv[1], sys.argv[2] == "free", int(sys.argv[3]))))
"""


def _frames(robot, path) -> list[str]:
    """Up to three tips, two links merged onto moving ones by fixed joints, one merged onto the
    base and one moving link that is not a tip: six at most, in the file's names."""
    import xml.etree.ElementTree as ET

    import numpy as np

    from symdyn.model import frames

    joints = {
        j.find("child").get("link"): (j.get("type"), j.find("parent").get("link"))
        for j in ET.parse(path).getroot().findall("joint")
    }
    known = {f.name: f for f in robot.frame_catalog}
    parents = {parent for _, parent in joints.values()}
    tips = [n for n in frames.default_names(robot) if n in known] or [
        n for n in joints if n not in parents and n in known
    ]
    chosen = [tips[i] for i in sorted(set(np.linspace(0, len(tips) - 1, 3).round().astype(int)))] if tips else []
    fixed = [n for n, (kind, _) in joints.items() if kind == "fixed" and n in known and n not in chosen]
    chosen += [n for n in fixed if known[n].link >= 0][:2] + [n for n in fixed if known[n].link < 0][:1]
    moving = sorted(n for n, (kind, _) in joints.items() if kind != "fixed" and n in known and n not in tips)
    chosen += moving[len(moving) // 2 : len(moving) // 2 + 1]
    return list(dict.fromkeys(chosen))[:6]


def _reason(error: Exception) -> str:
    """An error's first line, the robots' folder left out of its paths."""
    return str(error).splitlines()[0].replace(f"{robots_folder()}/", "")[:300]


def compare(relative: str, free: bool, count: int) -> dict:
    """One file: how it was read, its frames, build seconds and each group's largest error."""
    import warnings

    import numpy as np

    from symdyn.bench import task_space as peer
    from symdyn.codegen.entry import load
    from symdyn.codegen.task_functions import task_names
    from symdyn.derivation.task_space import arguments, parts, task_space
    from symdyn.model import Robot
    from symdyn.model.urdf import URDFError

    path = robots_folder() / relative
    options = dict(tips="all", base_joint="free" if free else None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            robot, how = Robot.from_urdf(str(path), **options), "as it is"
        except URDFError as refused:
            if "inertia='balance'" not in str(refused):
                return {"refused": _reason(refused)}
            try:
                robot, how = Robot.from_urdf(str(path), inertia="balance", **options), "inertia='balance'"
            except URDFError as still:
                return {"refused": "with inertia='balance': " + _reason(still)}
    robot = robot.with_frames(_frames(robot, path))
    model, ids = peer.file_model(robot, path)
    start = time.perf_counter()
    f = load(robot, "numpy")
    names = task_names(task_space(robot))
    from task_space_robots import states  # beside this script

    q, v, a = states(robot, count)
    given = {"q": q, "v": v, "a": a}
    calls = {name: [getattr(f, name)(*(given[x][i] for x in arguments(name))) for i in range(count)] for name in names}
    built = time.perf_counter() - start
    want = peer.evaluate(robot, model, ids, q, v, a)
    errors: dict[str, float] = {}
    for name in names:
        for k, part in enumerate(parts(name)):
            got = np.array([out[k] if len(parts(name)) > 1 else out for out in calls[name]], dtype=float)
            err = float(np.abs(got - want[part]).max() / max(1.0, np.abs(want[part]).max()))
            errors[part] = max(errors.get(part, 0.0), err)
    return {
        "read": how,
        "n": robot.n,
        "frames": [fr.name for fr in robot.task_frames],
        "seconds": built,
        "errors": errors,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="*")
    parser.add_argument("--states", type=int, default=20)
    parser.add_argument("--timeout", type=int, default=400, help="seconds a file may take (default 400)")
    args = parser.parse_args(argv)
    folder = robots_folder()
    files = args.files or sorted(
        (str(p.relative_to(folder)) for p in folder.rglob("*.urdf")), key=lambda r: (folder / r).stat().st_size
    )
    print("| file | base | read | n | frames | " + " | ".join(GROUPS) + " | s |")
    print("|---|---|---|---:|---:|" + "---:|" * len(GROUPS) + "---:|")
    worst, compared = 0.0, 0
    for relative in files:
        free = not any(relative == f or relative.startswith(f + "/") for f in FIXED)
        cmd = [
            sys.executable,
            "-c",
            _ONE,
            relative,
            "free" if free else "fixed",
            str(args.states),
            str(Path(__file__).parent),
        ]
        start = time.perf_counter()
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
        except subprocess.TimeoutExpired:
            print(f"| {relative} | | over {args.timeout} s, not compared | | |" + " |" * (len(GROUPS) + 1), flush=True)
            continue
        lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
        if not lines:
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1][:200]
            print(f"| {relative} | | failed: {tail} | | |" + " |" * (len(GROUPS) + 1), flush=True)
            continue
        r = json.loads(lines[-1][len("RESULT ") :])
        base = "free" if free else "fixed"
        if "refused" in r:
            print(f"| {relative} | {base} | refused: {r['refused']} | | |" + " |" * (len(GROUPS) + 1), flush=True)
            continue
        cells = [max(r["errors"].get(p, 0.0) for p in parts_) for parts_ in GROUPS.values()]
        worst, compared = max(worst, *cells), compared + 1
        print(
            f"| {relative} | {base} | {r['read']} | {r['n']} | {len(r['frames'])} | "
            + " | ".join(f"{c:.0e}" for c in cells)
            + f" | {time.perf_counter() - start:.0f} |",
            flush=True,
        )
    print(f"\n{compared} of {len(files)} files compared; worst relative error {worst:.1e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
