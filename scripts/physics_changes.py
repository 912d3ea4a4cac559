"""What snapping and a file's friction change, against Pinocchio (issue 34, item 3): the numbers
of docs/arms.md, "What changes the physics".

Friction: example-robot-data's xArm7 and Z1 give `<dynamics damping friction>`, which symdyn's
τ includes and Pinocchio's `rnea` does not: symdyn's τ as read, and with `--no-friction`
(`nofriction(all=True)`), against `pin.rnea`.  Snapping: example-robot-data's UR10 writes π/2
as 1.57079632679 (4.9e-12 off), the UR ROS 2 description as 1.570796327 (2.1e-10 off; made
here from the UR10 by rewriting those digits): what the record states the snaps change, and
symdyn's q̈ as read and with `snap=False` against `pin.aba`, which reads the file literally.

Needs Pinocchio (`pin`) and example-robot-data (the `robots` extra):

    python scripts/physics_changes.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from symdyn import Robot
from symdyn.model import example_robots
from symdyn.numeric import reference as ref
from symdyn.numeric.snap_effect import effect_states

FRICTION = {"xArm7": "xarm_description/urdf/xarm7.urdf", "Z1": "z1_description/urdf/z1.urdf"}
UR10 = "ur_description/urdf/ur10_robot.urdf"


def robots_folder() -> Path:
    """example-robot-data's robots/ folder, or the exit that says what to install."""
    try:
        return example_robots.robots_folder()
    except FileNotFoundError:
        sys.exit("physics_changes: pip install example-robot-data pin (or pip install -e '.[robots,test]')")


def pinocchio_model(path: Path, robot: Robot):
    """Pinocchio's model of the file, every joint off symdyn's chain locked where symdyn locked it."""
    import pinocchio as pin

    full = pin.buildModelFromUrdf(str(path))
    locks = {lock.joint: lock.value for lock in robot.urdf.locked}
    q0 = pin.neutral(full)
    lock_ids = []
    for name in full.names[1:]:
        if name not in robot.urdf.joints:
            j = full.getJointId(name)
            q0[full.joints[j].idx_q] = locks.get(name, 0.0)
            lock_ids.append(j)
    model = pin.buildReducedModel(full, lock_ids, q0) if lock_ids else full
    assert list(model.names[1:]) == list(robot.urdf.joints), (model.names, robot.urdf.joints)
    return model


def relative(a: np.ndarray, b: np.ndarray) -> float:
    """max over states of ‖a − b‖∞ / ‖b‖∞ (b Pinocchio's)."""
    return float((np.abs(a - b).max(-1) / np.abs(b).max(-1)).max())


def friction_rows(folder: Path) -> list[str]:
    import pinocchio as pin

    rows = [
        "| arm | friction read from the file | max abs(tau - pin.rnea) as read | relative | with --no-friction |",
        "|---|---|---|---|---|",
    ]
    for name, file in FRICTION.items():
        robot = Robot.from_urdf(folder / file)
        model = pinocchio_model(folder / file, robot)
        data = model.createData()
        q, qd, qdd = effect_states(robot)
        theirs = np.array([pin.rnea(model, data, *x).copy() for x in zip(q, qd, qdd)])
        ours, bare = ref.rne(robot, q, qd, qdd), ref.rne(robot.nofriction(all=True), q, qd, qdd)
        said = robot.urdf.friction_report()[0].split(": ")[1]
        rows.append(
            f"| {name} | {said} | {np.abs(ours - theirs).max():.3g} N·m | {relative(ours, theirs):.2g} "
            f"| {relative(bare, theirs):.1e} |"
        )
    return rows


def snap_rows(folder: Path) -> list[str]:
    import pinocchio as pin

    rows = [
        "| file | the record says | q̈ vs pin.aba as read | with snap=False |",
        "|---|---|---|---|",
    ]
    text = (folder / UR10).read_text()
    with tempfile.TemporaryDirectory() as tmp:
        nine = Path(tmp) / "ur10_nine_decimals.urdf"
        nine.write_text(text.replace("1.57079632679", "1.570796327"))
        for label, path in (("UR10, 1.57079632679", folder / UR10), ("UR10, 1.570796327 (as UR's ROS 2)", nine)):
            robot = Robot.from_urdf(path, tip_link="tool0")
            literal = Robot.from_urdf(path, tip_link="tool0", snap=False)
            model = pinocchio_model(path, robot)
            data = model.createData()
            q, qd, qdd = effect_states(robot)
            tau = ref.rne(literal.nofriction(all=True), q, qd, qdd)
            theirs = np.array([pin.aba(model, data, *x).copy() for x in zip(q, qd, tau)])
            ours = ref.accel(robot.nofriction(all=True), q, qd, tau)
            as_written = ref.accel(literal.nofriction(all=True), q, qd, tau)
            said = robot.urdf.snapping.effect.line().split(" (relative")[0]
            rows.append(f"| {label} | {said} | {relative(ours, theirs):.1e} | {relative(as_written, theirs):.1e} |")
    return rows


def main() -> int:
    folder = robots_folder()
    print("\n".join(friction_rows(folder)))
    print()
    print("\n".join(snap_rows(folder)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
