"""The arms people use (issue 15): Panda, iiwa 14, UR5 through every stage but the exact one.

At 200 random states within the joint limits: the reference against Pinocchio,
and every target's checked-in generated code against the reference, to 1e-10
relative; on the UR5 also both derivations (Newton–Euler plain and on base
parameters, Lagrange) against the reference.  The 7-joint arms' derivations are
held by tests/test_generated.py instead (re-deriving them reproduces the checked-in
code byte for byte, which the targets stage checks here), 14 s of suite each;
`python scripts/correctness.py` runs every stage on every shipped arm, and
`python scripts/fuzz_arms.py` the exact one.  URDF parsing against Pinocchio's own
parser is tests/test_urdf.py.
"""

import pytest

from symdyn import models
from symdyn.bench.differential import check_arm, disagreements
from symdyn.model.random_arms import robot_code

#: The stages run per arm (see the module's docstring for why the 7-joint arms skip "derive").
STAGES = {
    "panda": ("pinocchio", "targets"),
    "iiwa14": ("pinocchio", "targets"),
    "ur5": ("pinocchio", "derive", "targets"),
}


# make test-all: every stage is in the main suite on smaller random arms, DH and general
# (tests/test_any_arm.py::test_random_arm_agrees_at_every_stage and
# test_random_general_arm_agrees_at_every_stage), the shipped arms' generated code in
# tests/test_generated.py (byte for byte) and tests/test_task_space.py
@pytest.mark.slow
@pytest.mark.parametrize("name", STAGES)
def test_shipped_arm_agrees_at_every_stage(name):
    robot = models.load(name)
    findings = check_arm(robot, count=200, seed=7, stages=STAGES[name])
    assert {f.stage for f in findings} == set(STAGES[name])
    bad = disagreements(findings, 1e-10)
    assert not bad, "\n".join(f"{f.stage}: {f.what}: {f.error:.3e} {f.detail}" for f in bad)


#: The moving mass summed by hand from each URDF's <mass> values: the Panda's links 1-7 plus the
#: hand (0.73 kg, merged through two fixed joints), the iiwa's links 1-7, the UR5's shoulder to wrist 3.
MOVING_MASS = {
    "panda": 4.970684 + 0.646926 + 3.228604 + 3.587895 + 1.225946 + 1.666555 + 0.735522 + 0.73,
    "iiwa14": 5.76 + 6.35 + 3.5 + 3.5 + 3.5 + 1.8 + 1.2,
    "ur5": 3.7 + 8.393 + 2.275 + 1.219 + 1.219 + 0.1879,
}


@pytest.mark.parametrize("name, n", [("panda", 7), ("iiwa14", 7), ("ur5", 6)])
def test_shipped_arm_has_its_published_joints_and_mass(name, n):
    """Joint count, moving mass and limits as the source URDFs give them."""
    mass = MOVING_MASS[name]
    robot = models.load(name)
    assert robot.n == n and robot.convention == "general"
    assert sum(float(link.m) for link in robot.links) == pytest.approx(mass, rel=1e-15)
    assert all(link.qlim is not None and link.effort_limit and link.velocity_limit for link in robot.links)
    assert robot_code(robot)  # printable as constructor code
