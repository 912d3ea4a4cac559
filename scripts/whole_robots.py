"""Whole robots from example-robot-data against Pinocchio (issue 35): the slow check.

Run: .venv/bin/python scripts/whole_robots.py [--robots NAME ...] [--states N] [--code] [--markdown PATH]

Each robot is read by `Robot.from_urdf` with several chains or every joint
moving (`tips=`), on a fixed, planar or free base (`base_joint=`), and
compared by `symdyn.bench.reduced.compare_whole` with Pinocchio's model of the
same file (its FreeFlyer / Planar root joint for a floating base; joints
symdyn locks — the grippers, whose fingers mimic a leader — locked by
`buildReducedModel` at the same values): the reference's τ, M, G, C·v and
forward dynamics at random states, each a relative error that must be
≤ 1e-10 (else FAIL, exit status 1).  `--code` also generates and compiles each robot's C (up to CODE_MAX_JOINTS joints)
(`symdyn.load(robot, "c")` and `build()`, in the cache `SYMDYN_CACHE_DIR` names) and compares
its τ, M, C (computeCoriolisMatrix), G, C·v, q̈, M⁻¹ and ∂τ/∂(q, v) (tangent space: computeRNEADerivatives) with
Pinocchio at the same states.  Needs the `robots` extra (example-robot-data) and Pinocchio (`pin`).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from urdf_trees import robots_folder  # noqa: E402

TOL = 1e-10
#: `--code` generates the robots up to this many joints (TIAGo++'s 101 joints would take hours:
#: fdyn_derivatives grows like n³).
CODE_MAX_JOINTS = 50


@dataclass(frozen=True)
class Case:
    """One robot: `from_urdf(file, **options)`."""

    name: str
    file: str  # relative to example-robot-data's robots/ folder
    what: str
    options: dict = field(default_factory=dict)


CASES = (
    Case(
        "tiago++",
        "tiago_description/robots/tiago_dual.urdf",
        "TIAGo++: torso and both arms on a planar base (antennas' impossible inertias left out)",
        dict(
            tips=["arm_left_tool_link", "arm_right_tool_link"],
            base_joint="planar",
            exclude=["base_antenna_left_link", "base_antenna_right_link"],
        ),
    ),
    Case(
        "tiago++ all",
        "tiago_description/robots/tiago_dual.urdf",
        "TIAGo++: every joint, wheels, casters and hands",
        dict(tips="all"),
    ),
    Case(
        "baxter",
        "baxter_description/urdf/baxter.urdf",
        "Baxter: head and both arms (grippers locked)",
        dict(tips="all", locked={"l_gripper_l_finger_joint": 0.0, "r_gripper_l_finger_joint": 0.0}),
    ),
    Case(
        "talos",
        "talos_data/robots/talos_full_v2.urdf",
        "Talos: whole body on a free base (grippers locked)",
        dict(tips="all", base_joint="free", locked={"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}),
    ),
    Case(
        "talos full",
        "talos_data/robots/talos_full_v2.urdf",
        "Talos: every joint on a free base, the grippers' mimic joints moving on their own (Pinocchio's full model)",
        dict(tips="all", base_joint="free"),
    ),
    Case(
        "solo12", "solo_description/robots/solo12.urdf", "Solo 12 on a free base", dict(tips="all", base_joint="free")
    ),
    Case(
        "b1+z1",
        "b1_description/urdf/b1-z1.urdf",
        "B1 quadruped with its Z1 arm on a free base (impossible inertias balanced, reported)",
        dict(tips="all", base_joint="free", inertia="balance"),
    ),
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", nargs="*", help="names of the cases to run (default all)")
    parser.add_argument("--states", type=int, default=200)
    parser.add_argument("--markdown", type=Path)
    parser.add_argument("--code", action="store_true", help="also the generated C, against Pinocchio")
    parser.add_argument("--data", help="example-robot-data's robots/ folder (default: the installed wheel's)")
    args = parser.parse_args(argv)
    from symdyn.bench.reduced import compare_whole
    from symdyn.model import Robot

    folder = robots_folder(args.data)
    rows, failed = [], False
    header = "| robot | joints | nq / nv | base | read | worst error (τ, M, G, C·v, q̈) |"
    header += " C: build | C: worst error (τ, M, C, G, C·v, q̈, M⁻¹, ∂τ) | what |" if args.code else " what |"
    header += "\n" + "|---" * (header.count("|") - 1) + "|"
    for case in CASES:
        if args.robots and case.name not in args.robots:
            continue
        print(f"{case.name} …", file=sys.stderr, flush=True)
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            robot = Robot.from_urdf(folder / case.file, **case.options)
        read = time.perf_counter() - start
        model, built = None, " – |" if args.code else ""
        if args.code and robot.n <= CODE_MAX_JOINTS:
            import symdyn

            start = time.perf_counter()
            model = symdyn.load(robot, "c")
            model.build(batch=False)
            built = f" {time.perf_counter() - start:.0f} s |"
        errors = compare_whole(robot, folder / case.file, count=args.states, functions=model)
        worst = max(e for k, e in errors.items() if not k.startswith("generated"))
        cells = [f"{worst:.1e}{'' if worst <= TOL else ' **FAIL**'}"]
        if model is not None:
            code = max(e for k, e in errors.items() if k.startswith("generated"))
            cells.append(f"{code:.1e}{'' if code <= TOL else ' **FAIL**'}")
            worst = max(worst, code)
        failed |= not worst <= TOL
        rows.append(
            f"| {case.name} | {robot.n} | {robot.nq} / {robot.nv} | {robot.base_joint or 'fixed'} | {read:.2f} s "
            f"| {cells[0]} |{built}{f' {cells[1]} |' if model is not None else ' – |' if args.code else ''} {case.what}"
            f"{f'; {len(caught)} warnings' if caught else ''} |"
        )
        print(rows[-1], file=sys.stderr, flush=True)
    table = "\n".join([header, *rows])
    print(table)
    if args.markdown:
        args.markdown.write_text(table + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
