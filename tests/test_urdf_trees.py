"""URDF trees (issue 22): branches locked and merged, never dropped; one snapping rule;
tolerant where a defect cannot matter, strict where it can.

The yardstick is Pinocchio's `buildReducedModel` of the whole file with the same
joints locked at the same values (`symdyn.bench.reduced`): τ, M, G, C·q̇, the
Christoffel symbols, forward dynamics and the tool pose at 200 states within the
limits to 1e-10, on tests/urdf/tree.urdf (branches on the base, branches of
branches, a generic axis, a prismatic branch, a mimic finger, a chain joint
locked) and on random trees (`symdyn.model.random_trees`).
"""

import dataclasses
import math
import warnings

import pytest

import symdyn
from symdyn.bench.differential import check_arm, disagreements
from symdyn.bench.reduced import compare, reduced_model
from symdyn.model import Robot, URDFError, URDFWarning
from symdyn.model.random_trees import random_tree
from symdyn.model.snapping import ANGLE_TOLERANCE, snap_angle, snap_axis
from tests.conftest import tiered

pin = pytest.importorskip("pinocchio")

HERE = __import__("pathlib").Path(__file__).parent / "urdf"
TREE = HERE / "tree.urdf"
TOL = 1e-10


def _tree(**kwargs) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFWarning)  # the antenna's: tested on its own below
        return Robot.from_urdf(TREE, tip_link="tcp", **kwargs)


def _assert_agrees(robot, path, seed=0, count=200, **kwargs):
    errors = compare(robot, path, count=count, seed=seed, **kwargs)
    bad = {k: f"{v:.2e}" for k, v in errors.items() if not v <= TOL}
    assert not bad, f"{robot.name}: symdyn vs Pinocchio's reduced model beyond {TOL}: {bad}"


# --------------------------------------------------------------------------- against buildReducedModel

LOCKS = {
    "every branch at its default": {},
    "non-zero locks, a chain joint locked too": {
        "head_pan": 0.7,
        "head_tilt": -0.4,
        "slider": 0.05,
        "finger_left": 0.3,
        "wheel_joint": 1.0,
        "j3": 0.5,
    },
}


@pytest.mark.parametrize("case", LOCKS, ids=list(LOCKS))
def test_locked_branches_agree_with_pinocchios_reduced_model(case):
    _assert_agrees(_tree(locked=LOCKS[case]), TREE, seed=len(case))


def test_an_excluded_subtree_agrees_with_pinocchio_on_the_file_without_it():
    robot = _tree(exclude=["head"], snap=False)
    assert robot.urdf.excluded == ("head",)
    assert not any(lock.joint.startswith("head") for lock in robot.urdf.locked)
    _assert_agrees(robot, TREE, seed=3)


def test_the_comparison_has_teeth_wrong_lock_values_or_a_dropped_branch_disagree():
    """The same robot against a reduced model locked elsewhere, or against the file
    with the fingers cut (what the reader did before: drop them), must fail."""
    robot = _tree(locked={"finger_left": 0.3})
    moved = _tree(locked={"finger_left": -0.3})
    with pytest.raises(AssertionError, match="beyond"):
        _assert_agrees(dataclasses.replace(robot, urdf=moved.urdf), TREE, count=20)
    dropped = _tree(exclude=["finger_l", "finger_r"])
    with pytest.raises(AssertionError, match="beyond"):
        _assert_agrees(dataclasses.replace(dropped, urdf=robot.urdf), TREE, count=20)


# make test-all: a tree's generated code and derivatives are in the main suite on the two-arms and torso
# trees (tests/test_tree_derivations.py::test_generated_functions_of_a_tree_agree_with_the_reference and
# its derivatives), the locked tree against Pinocchio's reduced model in
# test_random_trees_agree_with_pinocchios_reduced_model
@pytest.mark.slow
def test_generated_code_and_its_derivatives_agree_with_the_reduced_model():
    robot = _tree(locked={"head_pan": 0.7, "finger_left": 0.3})
    _assert_agrees(robot, TREE, seed=11, functions=symdyn.load(robot, "numpy"))


@pytest.mark.parametrize("seed", tiered(range(24), 8))  # the other 16 trees: make test-all
def test_random_trees_agree_with_pinocchios_reduced_model(seed, tmp_path):
    tree = random_tree(seed)
    path = tmp_path / f"tree{seed}.urdf"
    path.write_text(tree.text)
    robot = Robot.from_urdf(path, tip_link=tree.tip, locked=tree.locked)
    assert reduced_model(path, robot).nv == robot.n
    _assert_agrees(robot, path, seed=seed, count=60)


# make test-all: both derivations' exact agreement on trees is in the main suite on smaller random trees
# (tests/test_tree_derivations.py::test_lagrange_and_newton_euler_agree_exactly_on_random_trees), the
# locked tree's merged bodies against Pinocchio in test_random_trees_agree_with_pinocchios_reduced_model
@pytest.mark.slow
def test_a_locked_tree_passes_every_derivation_stage():
    """Both derivations and their exact agreement on merged bodies (rational numbers)."""
    robot = _tree(locked=LOCKS["non-zero locks, a chain joint locked too"])
    bad = disagreements(check_arm(robot, count=8, seed=2, stages=("derive", "exact", "identities")), TOL)
    assert not bad, "\n".join(f"{f.stage}: {f.what}: {f.error:.3e} {f.detail}" for f in bad)


# --------------------------------------------------------------------------- what is recorded


def test_the_record_says_what_was_locked_at_which_value_into_which_body():
    robot = _tree()
    locks = {lock.joint: lock for lock in robot.urdf.locked}
    assert robot.urdf.joints == ("j1", "j2", "j3", "j4") and robot.n == 4
    assert (locks["head_pan"].value, locks["head_pan"].why) == (0.2, "default")  # 0 is below its limits
    assert locks["head_pan"].into == locks["head_tilt"].into == "l1"
    assert (locks["slider"].value, locks["slider"].into) == (0.0, "l2")
    assert locks["finger_right"].why == "mimic of finger_left"
    assert locks["finger_right"].value == pytest.approx(-1 * 0.0 + 0.05)
    assert locks["wheel_joint"].moves is False and locks["finger_left"].moves is True
    given = _tree(locked={"finger_left": 0.3, "j3": 0.5})
    locks = {lock.joint: lock for lock in given.urdf.locked}
    assert locks["finger_right"].value == pytest.approx(-0.3 + 0.05)
    assert locks["j3"].on_chain and locks["j3"].into == "l2" and given.urdf.joints == ("j1", "j2", "j4")
    text = str(given)
    for line in (
        "j3 = 0.5 -> l2 (given, a chain joint)",
        "finger_right = -0.25 -> l4 (mimic of finger_left)",
        "locked on the fixed base, no effect on the dynamics (1): wheel_joint = 0.0",
        "tree.urdf:87 joint 'j2' origin rpy[0]: -1.57079632679 -> -pi/2",
    ):
        assert line in text, text


def test_a_defect_on_a_body_resting_on_the_base_is_a_warning_naming_it():
    with pytest.warns(URDFWarning, match=r"tree.urdf:39: <inertia> of link 'antenna' .*cannot affect the dynamics"):
        robot = Robot.from_urdf(TREE, tip_link="tcp")
    assert len(robot.urdf.warnings) == 1 and "antenna" in robot.urdf.warnings[0]


def test_the_same_defect_on_a_body_in_the_dynamics_is_an_error_naming_its_line(tmp_path):
    text = TREE.read_text().replace(
        '<joint name="antenna_joint" type="fixed">\n    <parent link="base"/>',
        '<joint name="antenna_joint" type="fixed">\n    <parent link="l1"/>',
    )
    path = tmp_path / "tree.urdf"
    path.write_text(text)
    with pytest.raises(URDFError, match=rf"{path}:39: <inertia> of link 'antenna' .*triangle"):
        Robot.from_urdf(path, tip_link="tcp")
    assert Robot.from_urdf(path, tip_link="tcp", exclude=["antenna"]).n == 4


# --------------------------------------------------------------------------- bad locks and exclusions


@pytest.mark.parametrize(
    "kwargs, says",
    [
        ({"locked": {"nope": 0.1}}, "locked joint 'nope' is not a joint of robot 'tree'"),
        ({"locked": {"head_pan": 1.5}}, "<joint name='head_pan'>: locked value 1.5 is outside its limits [0.2, 1.0]"),
        ({"locked": {"finger_right": 0.1}}, "a mimic joint follows its leader 'finger_left'; lock the leader"),
        ({"locked": {"tcp_joint": 0.1}}, "a fixed joint cannot be locked"),
        ({"locked": {"slider": float("nan")}}, "locked value nan must be a finite number"),
        ({"locked": {"head_tilt": 0.1}, "exclude": ["head"]}, "<joint name='head_tilt'>: locked, but it is not below"),
        ({"exclude": ["l2"]}, "excluded link 'l2' is on the chain"),
        ({"exclude": ["nope"]}, "excluded link 'nope' is not a link"),
    ],
    ids=["unknown joint", "outside limits", "mimic", "fixed", "nan", "excluded", "exclude chain", "exclude unknown"],
)
def test_a_lock_or_exclusion_that_cannot_be_done_names_the_culprit(kwargs, says):
    with pytest.raises(URDFError) as caught:
        _tree(**kwargs)
    assert says in str(caught.value), str(caught.value)


def test_base_and_tip_are_keyword_only():
    with pytest.raises(TypeError, match="positional"):
        Robot.from_urdf(str(TREE), "l2")


@pytest.mark.parametrize(
    "text, says",
    [
        ("", "the file is empty"),
        ("   \n", "the file is empty"),
        ('<robot name="r"/>', "<robot> has no <link>"),
        ('<robot name="r"><link name="a"/><link name="b"/></robot>', "2 separate trees with roots ['a', 'b']"),
    ],
)
def test_an_empty_or_rootless_file_says_what_is_wrong(text, says, tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(text)
    with pytest.raises(URDFError, match=r"r\.urdf"):
        Robot.from_urdf(path)
    with pytest.raises(URDFError) as caught:
        Robot.from_urdf(path)
    assert says in str(caught.value)


# --------------------------------------------------------------------------- the snapping rule


def _quarter_turn(decimals: int | None, snap: bool = True) -> Robot:
    written = repr(-math.pi / 2) if decimals is None else f"{-math.pi / 2:.{decimals}f}"
    text = TREE.read_text().replace('rpy="-1.57079632679 0 0"', f'rpy="{written} 0 0"')
    assert written in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFWarning)
        return Robot.from_urdf(text, tip_link="tcp", snap=snap)


def test_a_quarter_turn_written_with_9_11_or_16_decimals_gives_one_exact_model():
    exact = _quarter_turn(None)
    assert not exact.urdf.snaps
    assert exact.links[1].origin[1][1] == 0 and exact.links[1].origin[1][2] == 1  # Rx(-π/2), exactly
    for decimals in (9, 11):
        robot = _quarter_turn(decimals)
        assert robot == exact and robot.fingerprint() == exact.fingerprint()
        (snap,) = robot.urdf.snaps
        assert snap.snapped == "-pi/2" and snap.change == abs(float(snap.value) + math.pi / 2) <= ANGLE_TOLERANCE
        assert robot.urdf.max_snap == snap.change
    six = _quarter_turn(6)
    assert six != exact and not six.urdf.snaps  # 3.3e-7 from π/2: taken as written


def test_snap_false_keeps_the_files_numbers():
    robot = _quarter_turn(11, snap=False)
    c = float(robot.links[1].origin[1][1])
    assert c == pytest.approx(math.cos(-1.57079632679), abs=1e-16) and c != 0
    assert not robot.urdf.snaps and robot.urdf.snap is False
    assert "--no-snap" in robot.urdf.command_args()


def test_the_rule_is_the_same_for_every_multiple_of_pi_and_for_axes():
    for k, d, label in ((1, 1, "pi"), (-3, 4, "-3pi/4"), (1, 6, "pi/6"), (5, 12, "5pi/12"), (0, 1, "0")):
        target = k * math.pi / d
        for error in (4e-10, -9e-10):
            snapped = snap_angle(target + error)
            assert snapped is not None and snapped.value == target and snapped.label == label
        assert snap_angle(target + 2e-9) is None  # past the tolerance: as written
        assert snap_angle(target) is None  # nothing to change
    assert snap_axis((0.0, 3e-10, -1.0)).value == (0, 0, -1)
    assert snap_axis((0.0, 0.6, 0.8)) is None


def test_a_nearly_axis_aligned_axis_is_snapped_and_reported(tmp_path):
    text = TREE.read_text().replace(
        '<axis xyz="1 0 0"/>\n    <limit lower="-0.1"', '<axis xyz="1 2e-10 0"/>\n    <limit lower="-0.1"'
    )
    assert "2e-10" in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFWarning)
        robot = Robot.from_urdf(text, tip_link="tcp")
    assert any(s.snapped == "axis +x" and "slider" in s.where for s in robot.urdf.snaps)
    assert robot == _tree()


def test_a_robot_changed_after_reading_no_longer_claims_its_file_rebuilds_it():
    from symdyn.codegen.entry import _provenance_lines

    robot = _tree(locked={"finger_left": 0.3})
    source, notes, command = _provenance_lines(robot)
    assert command.startswith("tree.urdf ") and "--lock=finger_left=0.3" in command
    assert robot.urdf.describes(robot)
    heavier = robot.payload(0.5, (0, 0, 0.1), additive=True)
    assert heavier.urdf is robot.urdf and not heavier.urdf.describes(heavier)
    source, notes, command = _provenance_lines(heavier)
    assert command == "" and "changed after reading" in source
