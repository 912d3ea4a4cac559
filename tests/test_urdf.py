"""URDF in (issue 15 item 2): `Robot.from_urdf` against Pinocchio's own URDF parser.

Each small file in tests/urdf/ exercises one feature (its header comment says
which); each is read by `Robot.from_urdf` and by `pin.buildModelFromUrdf`,
and symdyn's numeric reference must agree with Pinocchio on τ, M, G, C and
forward dynamics at 200 random states within the limits, to 1e-10 — and on
the tool pose.  Where a chain leaves part of the tree out (subtrees excluded
on purpose, a sub-chain chosen by base_link/tip_link), Pinocchio reads the
same file with only that chain's links kept; locked branches are compared
with Pinocchio's reduced model in test_urdf_trees.py.  Parsed values are checked by
hand where that is easy, every refusal must name the element and its line,
and two files go through every derivation stage and generated target.
"""

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import symdyn
from symdyn import models
from symdyn.bench.differential import check_arm, disagreements, relative_error
from symdyn.model import Robot, URDFError
from symdyn.model.placement import exact
from symdyn.numeric import reference as ref

pin = pytest.importorskip("pinocchio")

HERE = Path(__file__).parent / "urdf"
ARMS = Path(symdyn.__file__).parent / "model" / "arms" / "data"
TOL = 1e-10
COUNT = 200


# --------------------------------------------------------------------------- helpers


def _keep(path: Path, links: set, out: Path) -> Path:
    """`path` with only `links` and the joints between them, written to `out`."""
    tree = ET.parse(path)
    root = tree.getroot()
    for element in list(root):
        if element.tag == "link" and element.get("name") not in links:
            root.remove(element)
        if (
            element.tag == "joint"
            and not {element.find("parent").get("link"), element.find("child").get("link")} <= links
        ):
            root.remove(element)
    tree.write(out)
    return out


def _pin_q(model, q: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration of joint angles q: (cos, sin) for a continuous joint."""
    out = []
    for joint, x in zip(model.joints[1:], q):
        out += [np.cos(x), np.sin(x)] if joint.nq == 2 else [x]
    return np.array(out)


def _states(robot, seed):
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = rng.uniform(lo, hi, (COUNT, robot.n))
    qd = rng.uniform(-2, 2, (COUNT, robot.n))
    qdd = rng.uniform(-5, 5, (COUNT, robot.n))
    tau = rng.uniform(-20, 20, (COUNT, robot.n))
    return q, qd, qdd, tau


def _assert_agrees_with_pinocchio(robot, pin_path: Path, tip: str, seed: int = 0):
    """symdyn's reference on `robot` (frictionless) against Pinocchio's model of `pin_path`."""
    model = pin.buildModelFromUrdf(str(pin_path))
    assert model.nv == robot.n, f"Pinocchio sees {model.nv} moving joints, symdyn {robot.n}"
    data = model.createData()
    bare = robot.nofriction(all=True)
    q, qd, qdd, tau = _states(robot, seed)
    ours = {
        "tau": ref.rne(bare, q, qd, qdd),
        "M": ref.inertia(bare, q),
        "G": ref.gravload(bare, q),
        "C": ref.coriolis(bare, q, qd),
        "aba": ref.accel(bare, q, qd, tau),
        "tool": ref.fkine(bare, q),
    }
    theirs = {k: [] for k in ours}
    frame = model.getFrameId(tip)
    for x, v, a, t in zip(q, qd, qdd, tau):
        x = _pin_q(model, x)
        theirs["tau"].append(pin.rnea(model, data, x, v, a).copy())
        M = pin.crba(model, data, x)
        theirs["M"].append(np.triu(M) + np.triu(M, 1).T)
        theirs["G"].append(pin.computeGeneralizedGravity(model, data, x).copy())
        theirs["C"].append(pin.computeCoriolisMatrix(model, data, x, v).copy())
        theirs["aba"].append(pin.aba(model, data, x, v, t).copy())
        pin.framesForwardKinematics(model, data, x)
        theirs["tool"].append(data.oMf[frame].homogeneous.copy())
    scale = max(np.abs(ours["M"]).max(), np.abs(ours["tau"]).max())
    errors = {k: relative_error(ours[k], np.array(theirs[k]), scale if k != "aba" else 1e-6) for k in ours}
    bad = {k: f"{e:.2e}" for k, e in errors.items() if not e <= TOL}
    assert not bad, f"{robot.name}: symdyn vs Pinocchio beyond {TOL}: {bad}"
    # the comparison has teeth: the arm moves, feels gravity and has velocity products
    assert np.abs(ours["G"]).max() > 1e-3 and np.abs(ours["C"]).max() > 1e-3
    return model


# --------------------------------------------------------------------------- against Pinocchio

#: id → (file, from_urdf keywords, links Pinocchio keeps (None: the whole file), tip frame)
CASES = {
    "fixed joints (before, between, after; fixed side branch)": (
        "fixed_joints.urdf",
        {"tip_link": "tool"},
        None,
        "tool",
    ),
    "rotated origins, axes -y, -x and generic": ("rotated_origins.urdf", {}, None, "l3"),
    "rotated inertial frames": ("rotated_inertials.urdf", {}, None, "l3"),
    "prismatic, continuous, no limits, massless link": ("prismatic_continuous.urdf", {}, None, "l3"),
    "mass 0 with inertia, merged": ("zero_mass_inertia.urdf", {"tip_link": "l2"}, None, "l2"),
    "moving side branch excluded": (
        "branches.urdf",
        {"tip_link": "hand", "exclude": ["finger"]},
        {"base", "l1", "l2", "camera", "l3", "l4", "hand"},
        "hand",
    ),
    "sub-chain base_link..tip_link": (
        "branches.urdf",
        {"base_link": "l1", "tip_link": "l3", "exclude": ["finger", "l4"]},
        {"l1", "l2", "camera", "l3"},
        "l3",
    ),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_urdf_chain_agrees_with_pinocchios_parser(case, tmp_path):
    file, kwargs, keep, tip = CASES[case]
    robot = Robot.from_urdf(HERE / file, **kwargs)
    assert robot.convention == "general"
    pin_path = HERE / file if keep is None else _keep(HERE / file, keep, tmp_path / file)
    _assert_agrees_with_pinocchio(robot, pin_path, tip, seed=len(case))


@pytest.mark.parametrize(
    "name, file, tip",
    [
        ("panda", "panda.urdf", "panda_hand_tcp"),
        ("iiwa14", "iiwa14.urdf", "iiwa_link_ee"),
        ("ur5", "ur5.urdf", "tool0"),
    ],
)
def test_shipped_arm_agrees_with_pinocchios_parser_of_its_urdf(name, file, tip):
    robot = models.load(name)
    assert robot.n == (6 if name == "ur5" else 7)
    assert robot == Robot.from_urdf(ARMS / file, tip_link="tool0" if name == "ur5" else None)
    model = _assert_agrees_with_pinocchio(robot, ARMS / file, tip)
    # the limits Pinocchio reads are the ones symdyn keeps
    assert np.array_equal(robot.qlim, np.stack([model.lowerPositionLimit, model.upperPositionLimit], 1))
    assert [link.effort_limit for link in robot.links] == list(model.effortLimit)
    assert [link.velocity_limit for link in robot.links] == list(model.velocityLimit)
    assert [float(link.B) for link in robot.links] == list(model.damping)


def test_the_moving_branch_changes_the_dynamics_so_leaving_it_out_is_tested(tmp_path):
    """Against the whole tree (finger included) the chain must disagree: the check can fail."""
    robot = Robot.from_urdf(HERE / "branches.urdf", tip_link="hand", exclude=["finger"])
    whole = _keep(
        HERE / "branches.urdf",
        {"base", "l1", "l2", "camera", "l3", "l4", "hand", "finger"},
        tmp_path / "with_finger.urdf",
    )
    with pytest.raises(AssertionError, match="moving joints"):
        _assert_agrees_with_pinocchio(robot, whole, "hand")
    no_camera = _keep(HERE / "branches.urdf", {"base", "l1", "l2", "l3", "l4", "hand"}, tmp_path / "no_cam.urdf")
    with pytest.raises(AssertionError, match="beyond"):
        _assert_agrees_with_pinocchio(robot, no_camera, "hand")


def test_limits_effort_velocity_damping_friction_agree_with_pinocchio():
    for file, tip in (("fixed_joints.urdf", "tool"), ("prismatic_continuous.urdf", None)):
        robot = Robot.from_urdf(HERE / file, tip_link=tip)
        model = pin.buildModelFromUrdf(str(HERE / file))
        assert [float(link.B) for link in robot.links] == list(model.damping)
        assert [float(link.Tc[0]) for link in robot.links] == list(model.friction)
        # Pinocchio's "no limit" is infinity
        assert [link.effort_limit or np.inf for link in robot.links] == list(model.effortLimit)
        assert [link.velocity_limit or np.inf for link in robot.links] == list(model.velocityLimit)


def test_axes_that_are_not_unit_vectors_are_normalised_as_pinocchio_does(tmp_path):
    text = (HERE / "rotated_origins.urdf").read_text()
    text = text.replace('<axis xyz="0.48 0.6 0.64"/>', '<axis xyz="0.96 1.2 1.28"/>')
    text = text.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -2 0"/>')
    path = tmp_path / "long_axes.urdf"
    path.write_text(text)
    robot = Robot.from_urdf(path)
    assert robot.links[0].axis == (0, -1, 0) and robot.links[1].axis == (0.48, 0.6, 0.64)
    _assert_agrees_with_pinocchio(robot, path, "l3")


def test_a_mimic_joint_off_the_chain_that_follows_a_chain_joint_is_refused_unless_excluded(tmp_path):
    """Its body would move with the chain joint: it can be neither locked nor dropped silently."""
    text = (
        (HERE / "branches.urdf")
        .read_text()
        .replace(
            '<limit lower="0" upper="0.8" effort="5" velocity="1"/>',
            '<limit lower="0" upper="0.8" effort="5" velocity="1"/>\n    <mimic joint="j3"/>',
        )
    )
    assert "<mimic" in text
    with pytest.raises(URDFError, match=r"<joint name='finger_joint'>: mimics 'j3', which moves with the chain"):
        Robot.from_urdf(text, tip_link="hand")
    assert Robot.from_urdf(text, tip_link="hand", exclude=["finger"]) == Robot.from_urdf(
        HERE / "branches.urdf", tip_link="hand", exclude=["finger"]
    )


# --------------------------------------------------------------------------- parsed values by hand


def _exact(values):
    return [exact(x) for x in values]


def test_a_fixed_joint_merges_mass_com_and_inertia_exactly():
    """link1 (2 kg at its origin, diag(0.1, 0.2, 0.3)) + link1_ext (1 kg, diag(0.01, 0.02, 0.03)
    about its COM (0, 0.2, 0), placed at (0.5, 0, 0) turned by Rz(π/2)): the ext COM is at
    (0.3, 0, 0), its inertia diag(0.02, 0.01, 0.03); together 3 kg at (0.1, 0, 0), and by the
    parallel-axis theorem I = diag(0.1, 0.2 + 2·0.1², 0.3 + 2·0.1²) + diag(0.02, 0.01 + 0.2², 0.03 + 0.2²)."""
    link = Robot.from_urdf(HERE / "fixed_joints.urdf", tip_link="tool").links[0]
    R = sp.Rational
    assert exact(link.m) == 3
    assert _exact(link.r) == [R(1, 10), 0, 0]
    assert [_exact(row) for row in link.I] == [[R(12, 100), 0, 0], [0, R(27, 100), 0], [0, 0, R(39, 100)]]


def test_fixed_joints_after_the_last_joint_form_the_tool_and_carry_their_mass():
    """tool = (link3 → flange: (0.1, 0, 0.02), Ry(π/2)) · (flange → tool: (0, 0.01, 0.12), Rz(−0.5));
    the flange's 0.4 kg at (0, 0, 0.03) in its frame sits at (0.13, 0, 0.02) in link 3's."""
    robot = Robot.from_urdf(HERE / "fixed_joints.urdf", tip_link="tool")
    assert robot.n == 3
    R = sp.Rational
    assert _exact(np.array(robot.tool)[:3, 3]) == [R(22, 100), R(1, 100), R(2, 100)]
    c, s = np.cos(-0.5), np.sin(-0.5)
    Ry = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    np.testing.assert_allclose(
        np.array(robot.tool, dtype=float)[:3, :3], Ry @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]), rtol=0, atol=1e-15
    )
    link = robot.links[2]
    assert exact(link.m) == R(12, 10)
    assert _exact(link.r) == [
        (R(8, 10) * R(5, 100) + R(4, 10) * R(13, 100)) / R(12, 10),
        0,
        (R(8, 10) * R(1, 100) + R(4, 10) * R(2, 100)) / R(12, 10),
    ]


def test_limits_effort_velocity_damping_and_friction_are_read():
    j1 = Robot.from_urdf(HERE / "fixed_joints.urdf", tip_link="tool").links[0]
    assert (j1.qlim, j1.effort_limit, j1.velocity_limit, j1.B, j1.Tc) == ((-2.5, 2.25), 80, 2.5, 0.5, (0.25, -0.25))
    robot = Robot.from_urdf(HERE / "prismatic_continuous.urdf")
    continuous, prismatic, unlimited = robot.links
    assert continuous.is_revolute and continuous.qlim is None
    assert (continuous.effort_limit, continuous.velocity_limit, continuous.B, continuous.Tc) == (None, None, 0, (0, 0))
    assert continuous.m == 0 and continuous.I == ((0, 0, 0),) * 3  # l1 has no <inertial>
    assert prismatic.joint == "prismatic" and prismatic.axis == (0.6, 0, 0.8)
    assert (prismatic.qlim, prismatic.effort_limit, prismatic.velocity_limit) == ((-0.2, 0.4), 200, 0.5)
    assert (prismatic.B, prismatic.Tc) == (3, (1.5, -1.5))
    assert unlimited.qlim is None and (unlimited.effort_limit, unlimited.velocity_limit) == (10, 4)
    assert robot.qlim.tolist() == [[-np.pi, np.pi], [-0.2, 0.4], [-np.pi, np.pi]]


def test_damping_and_friction_enter_the_dynamics_as_viscous_and_coulomb_friction():
    robot = Robot.from_urdf(HERE / "prismatic_continuous.urdf")
    q, qd, qdd = np.zeros(3), np.array([0.5, -0.25, 1.0]), np.zeros(3)
    extra = ref.rne(robot, q, qd, qdd) - ref.rne(robot.nofriction(all=True), q, qd, qdd)
    np.testing.assert_allclose(extra, [0, 3 * -0.25 - 1.5, 0], rtol=0, atol=1e-14)


def test_an_axis_along_minus_y_and_quarter_turns_are_exact():
    robot = Robot.from_urdf(HERE / "zero_mass_inertia.urdf", tip_link="l2")
    assert robot.links[1].axis == (0, -1, 0)
    assert all(isinstance(x, int) for row in robot.links[1].origin for x in row[:3])  # Ry(−π/2): 0, ±1
    assert np.array(robot.links[1].origin)[:3, :3].tolist() == [[0, 0, -1], [0, 1, 0], [1, 0, 0]]


def test_a_link_with_zero_mass_keeps_its_inertia_through_a_merge():
    link = Robot.from_urdf(HERE / "zero_mass_inertia.urdf", tip_link="l2").links[0]
    c, s = np.cos(0.2), np.sin(0.2)  # about x by 0.2: Rx diag(0.1, 0.1, 0.2) Rxᵀ
    expected = np.diag([0.1, 0.1, 0.2])
    Rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    assert link.m == 0
    np.testing.assert_allclose(np.array(link.I, dtype=float), Rx @ expected @ Rx.T, rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- refusals

CHAIN = """<?xml version="1.0"?>
<robot name="bad">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="l1">
    <inertial>
      <mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
  <joint name="j2" type="revolute">
    <parent link="l1"/>
    <child link="l2"/>
    <origin xyz="0.3 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="l2">
    <inertial>
      <origin xyz="0.1 0 0"/>
      <mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/>
    </inertial>
  </link>
</robot>
"""
J2 = '<joint name="j2" type="revolute">'
L2_INERTIA = '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/>'

#: id → (edits of CHAIN, from_urdf keywords, the element the message names, a text on its line, what it says)
REFUSALS = {
    "floating joint": (
        {J2: '<joint name="j2" type="floating">'},
        {},
        "<joint name='j2'>",
        'type="floating"',
        "'floating'",
    ),
    "planar joint": ({J2: '<joint name="j2" type="planar">'}, {}, "<joint name='j2'>", 'type="planar"', "'planar'"),
    "mimic joint": (
        {'<axis xyz="0 1 0"/>': '<axis xyz="0 1 0"/><mimic joint="j1"/>'},
        {},
        "<joint name='j2'>",
        J2,
        "mimic",
    ),
    "negative mass": (
        {
            '<mass value="1"/>\n      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02"': '<mass value="-1"/>\n      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02"'
        },
        {},
        "<mass>",
        'value="-1"',
        "negative",
    ),
    "inertia not positive semidefinite": (
        {L2_INERTIA: L2_INERTIA.replace('izz="0.02"', 'izz="-0.02"')},
        {},
        "<inertia>",
        'izz="-0.02"',
        "not positive semidefinite",
    ),
    "inertia violating the triangle inequality": (
        {L2_INERTIA: L2_INERTIA.replace('izz="0.02"', 'izz="0.04"')},
        {},
        "<inertia>",
        'izz="0.04"',
        "triangle inequality",
    ),
    "joint naming an unknown link": (
        {'<child link="l2"/>': '<child link="l9"/>'},
        {},
        "<child>",
        '"l9"',
        "of joint 'j2' names unknown link 'l9'",
    ),
    "non-numeric xyz": (
        {'<origin xyz="0.3 0 0"/>': '<origin xyz="0.3 a 0"/>'},
        {},
        "<origin>",
        "0.3 a 0",
        "xyz='0.3 a 0' must be 3 finite numbers",
    ),
    "a cycle below the root": (
        {
            "</robot>": '<link name="a"/><link name="b"/>\n'
            '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>\n'
            '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>\n'
            "</robot>"
        },
        {"tip_link": "a"},
        "<joint name='ba'>",
        'name="ba"',
        "form a cycle",
    ),
    # l2's own inertia is impossible; merged with t (parallel axis) it would not be: refused before the merge
    "impossible inertia hidden by a merge": (
        {
            L2_INERTIA: L2_INERTIA.replace('izz="0.02"', 'izz="-0.001"'),
            "</robot>": '<joint name="f" type="fixed"><parent link="l2"/><child link="t"/><origin xyz="1 1 0"/>'
            '</joint>\n<link name="t"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" '
            'ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>\n</robot>',
        },
        {},
        "<inertia>",
        'izz="-0.001"',
        "of link 'l2' is not positive semidefinite",
    ),
}


@pytest.mark.parametrize("case", REFUSALS, ids=list(REFUSALS))
def test_a_urdf_the_model_cannot_take_is_refused_naming_the_element_and_line(case, tmp_path):
    edits, kwargs, element, on_line, says = REFUSALS[case]
    text = CHAIN
    for old, new in edits.items():
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    (line,) = [i for i, s in enumerate(text.splitlines(), 1) if on_line in s]
    with pytest.raises(URDFError) as caught:
        Robot.from_urdf(path, **kwargs)
    message = str(caught.value)
    assert f"{path}:{line}: {element}" in message and says in message, message


def test_the_unedited_chain_of_the_refusal_tests_loads():
    robot = Robot.from_urdf(CHAIN)
    assert robot.n == 2 and robot.name == "bad" and robot.links[1].axis == (0, 1, 0)


@pytest.mark.parametrize(
    "kwargs, says",
    [
        ({"base_link": "nope", "tip_link": "hand"}, "base_link 'nope' is not a link of robot 'branches'"),
        ({"tip_link": "nope"}, "tip_link 'nope' is not a link of robot 'branches'"),
        ({}, "several leaves ['camera', 'fingertip', 'hand']; choose the chain's end with tip_link"),
        ({"base_link": "l3", "tip_link": "l1"}, "tip_link 'l1' is not below base_link 'l3'"),
    ],
    ids=["unknown base_link", "unknown tip_link", "several leaves", "tip not below base"],
)
def test_a_chain_that_cannot_be_chosen_is_refused_naming_the_file(kwargs, says):
    path = HERE / "branches.urdf"
    with pytest.raises(URDFError) as caught:
        Robot.from_urdf(path, **kwargs)
    assert str(caught.value).startswith(f"{path}: ") and says in str(caught.value), str(caught.value)


def test_malformed_xml_is_refused_with_its_line():
    text = CHAIN.replace('</link>\n  <joint name="j2"', '</lnk>\n  <joint name="j2"')
    with pytest.raises(URDFError, match=r"<urdf string>: not well-formed XML: mismatched tag: line 15"):
        Robot.from_urdf(text)


def test_an_impossible_inertia_on_a_locked_branch_is_refused_and_loads_once_excluded():
    """The finger (a moving branch) is locked and merged into link 3, so its inertia enters the
    dynamics: its defect is an error naming the line; excluded on purpose, it no longer matters."""
    path = HERE / "branches.urdf"
    with pytest.raises(URDFError, match=r"branches.urdf:\d+: <inertia> of link 'finger'.*triangle"):
        Robot.from_urdf(path, tip_link="hand")
    assert Robot.from_urdf(path, tip_link="hand", exclude=["finger"]).n == 4
    with pytest.raises(URDFError, match=r"branches.urdf:\d+: <inertia> of link 'finger'.*triangle"):
        Robot.from_urdf(path, base_link="l3", tip_link="finger")


# --------------------------------------------------------------------------- every stage


# make test-all: every stage on a general-convention arm is in the main suite on a random one
# (tests/test_any_arm.py::test_random_general_arm_agrees_at_every_stage), these files' parsing against
# Pinocchio's in test_urdf_chain_agrees_with_pinocchios_parser
@pytest.mark.slow
@pytest.mark.parametrize(
    "file, tip, seed", [("prismatic_continuous.urdf", None, 5), ("zero_mass_inertia.urdf", "l2", 6)]
)
def test_a_general_urdf_arm_agrees_at_every_stage(file, tip, seed):
    """Both derivations, the exact comparison and every generated target (one C compile each)."""
    robot = Robot.from_urdf(HERE / file, tip_link=tip)
    bad = disagreements(check_arm(robot, count=12, seed=seed), TOL)
    assert not bad, "\n".join(f"{f.stage}: {f.what}: {f.error:.3e} {f.detail}" for f in bad)
