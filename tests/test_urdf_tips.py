"""Trees and floating bases read from files (issue 35): `tips="all" | [links]` and `base_joint=…`.

The yardstick is Pinocchio's URDF parser: the moving joints in its depth-first order
(`model.names[1:]`, the joints below a link taken by name), each on the parent it gives
(`model.parents`), the same total mass; with `pin.JointModelFreeFlyer()` as root joint for
`base_joint="free"`.  Random trees (`symdyn.model.random_trees`) and small URDF texts whose
file order, link names and joint names disagree; no file outside the tests.
"""

import re
import warnings

import numpy as np
import pytest

from symdyn.model import Robot, URDFError, URDFWarning
from symdyn.model.command_line import load, parse_tips
from symdyn.model.random_trees import random_tree
from tests.conftest import tiered

pin = pytest.importorskip("pinocchio")

SEEDS = range(24)
MAIN = 8  # the random trees of the main suite; the other 16 of each test: make test-all


def _inertial(m: float) -> str:
    return (
        f'<inertial><origin xyz="0.01 0.02 -0.1"/><mass value="{m}"/>'
        '<inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0.002" izz="0.04"/></inertial>'
    )


def _joint(name: str, kind: str, parent: str, child: str, xyz="0 0 0.1", axis="0 0 1", extra="") -> str:
    limit = '<limit lower="-1" upper="1" effort="5" velocity="2"/>' if kind in ("revolute", "prismatic") else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="0.1 0 0.2"/><axis xyz="{axis}"/>{limit}{extra}</joint>'
    )


#: File order, link names and joint names each in a different order: only the joint names give
#: Pinocchio's (urdfdom keeps a link's joints in a map by name).  'zz' hangs on the base through a
#: fixed joint; the fixed 'a1' leads on to 'y'; 'x' and 'w' hang on 'zz''s link; 'B' is continuous.
TREE = (
    '<robot name="order"><link name="base">'
    + _inertial(3.0)
    + "</link>"
    + "".join(f'<link name="{n}">{_inertial(m)}</link>' for n, m in (("a", 1.0), ("b", 0.5), ("c", 0.2)))
    + "".join(f'<link name="{n}">{_inertial(m)}</link>' for n, m in (("d", 0.3), ("e", 0.4), ("f", 0.6), ("g", 0.1)))
    + _joint("mount", "fixed", "base", "g")
    + _joint("zz", "revolute", "g", "a", axis="0 1 0")
    + _joint("B", "continuous", "base", "b")
    + _joint("a1", "fixed", "a", "c", xyz="0.1 0 0")
    + _joint("y", "prismatic", "c", "d", axis="1 0 0")
    + _joint("x", "revolute", "a", "e", axis="0 0.6 0.8")
    + _joint("w", "revolute", "a", "f")
    + "</robot>"
)


def _unmimicked(seed: int) -> str:
    """A random tree with every mimic joint made a joint of its own."""
    return re.sub(r"<mimic[^>]*/>", "", random_tree(seed).text)


def _read(text, **kwargs) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFWarning)
        return Robot.from_urdf(text, **kwargs)


def _pinocchio_parents(model, first: int = 1) -> list:
    """Pinocchio's parents as symdyn's: 0-based link indices, -1 for the base (joints from `first`)."""
    return [max(p - first, -1) for p in model.parents[first:]]


# --------------------------------------------------------------------------- order, parents, mass


@pytest.mark.parametrize(
    "text", [TREE] + [_unmimicked(seed) for seed in SEEDS], ids=["order"] + [f"tree{s}" for s in SEEDS]
)
def test_every_joint_moves_in_pinocchios_order_on_its_parents_with_the_same_mass(text):
    robot = _read(text, tips="all")
    model = pin.buildModelFromXML(text)
    assert robot.joint_names == tuple(model.names[1:])
    assert robot.parents == tuple(_pinocchio_parents(model))
    assert robot.nq == robot.nv == model.nv
    mass = sum(float(link.m) for link in robot.links)
    assert mass == pytest.approx(sum(inertia.mass for inertia in model.inertias[1:]), rel=1e-12)


def test_the_order_is_by_joint_name_not_by_file_or_link():
    robot = _read(TREE, tips="all")
    assert robot.joint_names == tuple(pin.buildModelFromXML(TREE).names[1:]) == ("B", "zz", "y", "w", "x")
    assert robot.parents == (-1, -1, 1, 1, 1)
    assert not robot.is_chain


@pytest.mark.parametrize("seed", tiered(SEEDS, MAIN))
def test_a_free_base_floats_the_root_with_what_is_fixed_to_it(seed):
    text = _unmimicked(seed)
    robot = _read(text, tips="all", base_joint="free")
    model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    assert robot.base_joint == "free" and robot.nv == model.nv  # nq: Pinocchio gives continuous joints 2
    assert robot.joint_names == tuple(model.names[2:])
    assert robot.parents == tuple(_pinocchio_parents(model, 2))
    total = float(robot.base_body.m) + sum(float(link.m) for link in robot.links)
    assert total == pytest.approx(sum(inertia.mass for inertia in model.inertias[1:]), rel=1e-12)
    assert float(robot.base_body.m) == pytest.approx(model.inertias[1].mass, rel=1e-12)


def test_the_base_body_is_the_root_and_its_fixed_links():
    robot = _read(TREE, tips="all", base_joint="planar")
    assert robot.base_joint == "planar" and robot.nq == robot.n + 3
    assert float(robot.base_body.m) == pytest.approx(3.0 + 0.1)  # base and g, fixed to it
    fixed = _read(TREE, tips="all")
    assert fixed.base_body is None and sum(float(link.m) for link in fixed.links) == pytest.approx(3.0)


@pytest.mark.parametrize("seed", tiered(SEEDS, MAIN))
def test_locked_leaders_and_their_mimics_match_pinocchios_reduced_model(seed):
    """Mimic joints follow their locked leaders; what stays moves in Pinocchio's order."""
    tree = random_tree(seed)
    leaders = set(re.findall(r'<mimic joint="([^"]+)"', tree.text))
    locked = dict(tree.locked) | {j: _inside(tree.text, j) for j in sorted(leaders - set(tree.locked))}
    robot = _read(tree.text, tips="all", locked=locked)
    model = pin.buildModelFromXML(tree.text)
    values = {lock.joint: lock.value for lock in robot.urdf.locked}
    q0, lock = pin.neutral(model), []
    for jid in range(1, model.njoints):
        name, joint = model.names[jid], model.joints[jid]
        if name in robot.joint_names:
            continue
        lock.append(jid)
        value = values[name]
        if joint.nq == 2:
            q0[joint.idx_q : joint.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            q0[joint.idx_q] = value
    reduced = pin.buildReducedModel(model, lock, q0)
    assert robot.joint_names == tuple(reduced.names[1:])
    assert robot.parents == tuple(_pinocchio_parents(reduced))


def _inside(text: str, joint: str) -> float:
    """A value within the joint's limits (their middle; 0.3 for a continuous joint)."""
    match = re.search(rf'<joint name="{joint}"[^>]*>.*?</joint>', text)
    limit = re.search(r'<limit lower="([^"]+)" upper="([^"]+)"', match.group(0))
    return (float(limit.group(1)) + float(limit.group(2))) / 2 if limit else 0.3


# --------------------------------------------------------------------------- tips as chains


@pytest.mark.parametrize("seed", tiered(SEEDS, MAIN))
def test_one_tip_is_the_chain_to_it(seed):
    tree = random_tree(seed)
    chain = _read(tree.text, tip_link=tree.tip, locked=tree.locked)
    one = _read(tree.text, tips=[tree.tip], locked=tree.locked)
    assert one.fingerprint() == chain.fingerprint()
    assert one.joint_names == chain.joint_names and one.is_chain
    assert one.urdf.tips == (tree.tip,) and chain.urdf.tips == ()


def test_several_tips_move_the_union_of_their_chains():
    robot = _read(TREE, tips=["d", "f"])
    assert robot.joint_names == ("zz", "y", "w")
    assert robot.parents == (-1, 0, 0)
    assert [lock.joint for lock in robot.urdf.locked if lock.moves] == ["x"]
    assert [lock.joint for lock in robot.urdf.locked if not lock.moves] == ["B"]


def test_a_locked_joint_is_held_and_merged_into_its_parent():
    robot = _read(TREE, tips="all", locked={"zz": 0.3})
    assert robot.joint_names == ("B", "y", "w", "x")
    assert robot.parents == (-1, -1, -1, -1)
    lock = next(lock for lock in robot.urdf.locked if lock.joint == "zz")
    assert lock.on_chain and lock.value == 0.3 and not lock.moves


# --------------------------------------------------------------------------- the file's own floating joint

FLOATING = (
    '<robot name="floats"><link name="world"/><link name="pelvis">'
    + _inertial(4.0)
    + '</link><link name="leg">'
    + _inertial(1.0)
    + "</link>"
    + '<joint name="root" type="floating"><parent link="world"/><child link="pelvis"/>'
    + '<origin xyz="0.1 -0.2 0.9" rpy="0.3 -0.2 0.5"/></joint>'
    + _joint("hip", "revolute", "pelvis", "leg")
    + "</robot>"
)


def test_a_floating_joint_under_a_dummy_root_is_the_free_base():
    robot = _read(FLOATING, tips="all", base_joint="free")
    model = pin.buildModelFromXML(FLOATING)  # Pinocchio reads the floating joint as a free-flyer
    assert model.names[1] == "root" and robot.joint_names == tuple(model.names[2:])
    assert robot.urdf.file_base_joint == "root" and robot.urdf.base_link == "pelvis"
    assert float(robot.base_body.m) == pytest.approx(4.0)
    assert "--base-joint free" in robot.urdf.command_args()
    with pytest.raises(URDFError, match=r"own floating joint.*base_link='pelvis'"):
        _read(FLOATING, tips="all", base_joint="planar")


# --------------------------------------------------------------------------- what the record says


def test_print_says_which_joints_move_which_are_locked_and_the_base_joint():
    robot = _read(TREE, tips=["d", "f"], base_joint="free")
    text = str(robot)
    assert "tree from base, the chains to d, f: 3 moving joints" in text
    assert "zz (on base), y (on zz), w (on zz)" in text
    assert "base joint: free" in text and "floating body is link base" in text
    assert "x = 0.0 -> a (default)" in text and "B = 0.0 -> base (default)" in text
    args = robot.urdf.command_args()
    assert "--tips d,f" in args and "--base-joint free" in args and "--tip " not in args


def test_the_command_line_reads_the_same_tree(tmp_path):
    path = tmp_path / "order.urdf"
    path.write_text(TREE)
    robot = load(str(path), tips="all", base_joint="free")
    assert robot.joint_names == ("B", "zz", "y", "w", "x") and robot.base_joint == "free"
    assert load(str(path), tips="d,f").joint_names == ("zz", "y", "w")
    assert parse_tips("all") == "all" and parse_tips("a, b") == ["a", "b"]
    with pytest.raises(ValueError, match="--tips a,,b"):
        parse_tips("a,,b")
    with pytest.raises(URDFError, match="--tips and --tip d together"):
        load(str(path), tips="all", tip="d")


def test_a_tree_is_drawn():
    pytest.importorskip("matplotlib")
    robot = _read(TREE, tips="all", base_joint="free")
    assert robot.plot() is not None
    assert robot.plot(robot.neutral()) is not None


# --------------------------------------------------------------------------- refusals name the culprit

REFUSALS = {
    "tips and tip_link": (dict(tips="all", tip_link="d"), r"tips='all' and tip_link='d' together"),
    "a tip that is not a link": (dict(tips=["d", "nowhere"]), r"tip 'nowhere' is not a link"),
    "a tip above the base": (dict(tips=["b"], base_link="a"), r"tip 'b' is not below base_link 'a'"),
    "a single string": (dict(tips="d"), r"tips='d': expected 'all' or a list of link names"),
    "no tips": (dict(tips=[]), r"non-empty list of link names"),
    "an unknown base joint": (dict(tips="all", base_joint="floating"), r"unknown base_joint 'floating'"),
    "an excluded tip": (dict(tips=["d"], exclude=["a"]), r"tip 'd' is excluded"),
    "nothing moves": (dict(tips="all", locked={"B": 0}, exclude=["a"]), r"no joint moves from .base."),
}


@pytest.mark.parametrize("case", REFUSALS, ids=list(REFUSALS))
def test_bad_tips_and_base_joints_are_refused_by_name(case):
    kwargs, message = REFUSALS[case]
    with pytest.raises(URDFError, match=message):
        _read(TREE, **kwargs)


def test_a_mimic_joint_moves_on_its_own_with_every_joint_said_so_and_is_refused_on_a_path():
    """tips="all" reads a mimic joint whose leader moves as Pinocchio's parser does (its own degree
    of freedom), with a warning and record line saying so; on the path to a listed tip it is refused."""
    mimic = TREE.replace(
        '<joint name="w" type="revolute"><parent link="a"/><child link="f"/>',
        '<joint name="w" type="revolute"><parent link="a"/><child link="f"/><mimic joint="zz" multiplier="2"/>',
    )
    with pytest.warns(URDFWarning, match=r"mimic joints w move on their own .*lock their leaders"):
        free = Robot.from_urdf(mimic, tips="all")
    assert "w" in free.joint_names and "mimic joints w move on their own" in str(free)
    with pytest.raises(URDFError, match=r"'w'>: a mimic joint cannot move on its own"):
        _read(mimic, tips=["f"])
    held = _read(mimic, tips="all", locked={"zz": 0.25})
    assert "w" not in held.joint_names
    assert next(lock for lock in held.urdf.locked if lock.joint == "w").value == pytest.approx(0.5)


# --------------------------------------------------------------------------- dynamics against Pinocchio

STATES = 200


def _pinocchio_q(model, robot: Robot, q: np.ndarray) -> np.ndarray:
    """Pinocchio's configurations (count, model.nq) of symdyn's q (count, robot.nq): the base's
    coordinates as they are (the free-flyer's convention is symdyn's), (cos, sin) of continuous joints."""
    base = robot.nq - robot.n
    columns = [q[:, k] for k in range(base)]
    if robot.base_joint == "planar":  # x, y, yaw: Pinocchio's x, y, cos, sin
        columns = columns[:2] + [np.cos(q[:, 2]), np.sin(q[:, 2])]
    first = 2 if robot.base_joint else 1
    for k, joint in enumerate(model.joints[first:]):
        value = q[:, base + k]
        columns += [np.cos(value), np.sin(value)] if joint.nq == 2 else [value]
    return np.stack(columns, axis=1)


def _states(robot: Robot, seed: int):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (STATES, robot.nq))
    if robot.base_joint == "free":
        q[:, :3] = rng.uniform(-1, 1, (STATES, 3))
        quat = rng.normal(size=(STATES, 4))
        q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    v, a = rng.uniform(-2, 2, (2, STATES, robot.nv))
    return q, v, a


ROOT_JOINTS = {"free": "JointModelFreeFlyer", "planar": "JointModelPlanar"}


@pytest.mark.parametrize("base_joint", [None, "free", "planar"])
@pytest.mark.parametrize("seed", tiered(range(12), 4))  # the other 8 seeds: make test-all
def test_tau_of_a_tree_is_pinocchios_rnea(seed, base_joint):
    from symdyn.numeric import reference as ref

    text = _unmimicked(seed)
    robot = _read(text, tips="all", base_joint=base_joint, snap=False).nofriction(all=True)
    root = [getattr(pin, ROOT_JOINTS[base_joint])()] if base_joint else []
    model = pin.buildModelFromXML(text, *root)
    data = model.createData()
    q, v, a = _states(robot, seed)
    x = _pinocchio_q(model, robot, q)
    peer = np.array([pin.rnea(model, data, x[k], v[k], a[k]) for k in range(STATES)])
    tau = ref.rne(robot, q, v, a)
    scale = max(np.abs(peer).max(), 1.0)
    assert np.abs(tau - peer).max() / scale < 1e-10


def test_a_floating_joint_under_a_dummy_root_has_pinocchios_dynamics():
    from symdyn.numeric import reference as ref

    robot = _read(FLOATING, tips="all", base_joint="free")
    model = pin.buildModelFromXML(FLOATING)  # the file's floating joint: a free-flyer where its origin puts it
    assert robot.base != ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1))
    data = model.createData()
    q, v, a = _states(robot, 7)
    peer = np.array([pin.rnea(model, data, q[k], v[k], a[k]) for k in range(STATES)])
    assert np.abs(ref.rne(robot, q, v, a) - peer).max() / max(np.abs(peer).max(), 1.0) < 1e-10


# --------------------------------------------------------------------------- MJCF

HUMANOID = """<mujoco model="legs">
  <worldbody>
    <body name="torso" pos="0 0 1">
      <freejoint name="root"/>
      <inertial pos="0 0.01 0" mass="5" diaginertia="0.1 0.2 0.25"/>
      <body name="l_thigh" pos="0 0.1 -0.1" euler="0.2 0 0">
        <joint name="l_hip_x" type="hinge" axis="1 0 0" pos="0 0 0.05"/>
        <joint name="l_hip_y" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 -0.2" mass="2" diaginertia="0.02 0.02 0.005"/>
        <body name="l_shin" pos="0 0 -0.4">
          <joint name="l_knee" type="hinge" axis="0 1 0" range="-200 200"/>
          <inertial pos="0 0 -0.2" mass="1" diaginertia="0.01 0.01 0.002"/>
        </body>
      </body>
      <body name="r_thigh" pos="0 -0.1 -0.1">
        <joint name="r_hip" type="hinge" axis="0 1 0" pos="0 0 0.05"/>
        <inertial pos="0 0 -0.2" mass="2" diaginertia="0.02 0.02 0.005"/>
        <body name="r_shin" pos="0 0 -0.4">
          <joint name="r_knee" type="slide" axis="0 0 1"/>
          <inertial pos="0 0 -0.2" mass="1" diaginertia="0.01 0.01 0.002"/>
        </body>
      </body>
      <body name="head" pos="0 0 0.3"><inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/></body>
    </body>
  </worldbody>
</mujoco>
"""


def test_an_mjcf_tree_on_its_free_joint_moves_every_hinge_and_slide_in_mujocos_order():
    mujoco = pytest.importorskip("mujoco")
    robot = Robot.from_mjcf(HUMANOID, tips="all")
    model = mujoco.MjModel.from_xml_string(HUMANOID)
    assert robot.base_joint == "free" and robot.mjcf.free_joint == "root"
    assert robot.joint_names == tuple(model.joint(j).name for j in range(1, model.njnt))
    assert robot.parents == (-1, 0, 1, -1, 3)
    assert float(robot.base_body.m) == pytest.approx(6.0)  # the torso and its welded head
    assert float(robot.base_body.m) + sum(float(link.m) for link in robot.links) == pytest.approx(model.body_mass.sum())
    assert "--tips all" in robot.mjcf.command_args() and "base joint: free" in str(robot)
    legs = Robot.from_mjcf(HUMANOID, tips=["l_shin"], locked={"l_hip_y": 0.2})
    assert legs.joint_names == ("l_hip_x", "l_knee") and legs.is_chain is False  # on its free base


def test_an_mjcf_tree_on_a_fixed_base_has_mujocos_inverse_dynamics():
    mujoco = pytest.importorskip("mujoco")
    from symdyn.numeric import reference as ref

    fixed = HUMANOID.replace('<freejoint name="root"/>', "")
    robot = Robot.from_mjcf(fixed, tips="all")
    assert robot.base_joint is None and robot.parents == (-1, 0, 1, -1, 3)
    model = mujoco.MjModel.from_xml_string(fixed)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    q, v, a = rng.uniform(-1, 1, (3, STATES, robot.n))
    peer = []
    for k in range(STATES):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[k], v[k], a[k]
        mujoco.mj_inverse(model, data)
        peer.append(data.qfrc_inverse.copy())
    peer = np.array(peer)
    assert np.abs(ref.rne(robot, q, v, a) - peer).max() / max(np.abs(peer).max(), 1.0) < 1e-10


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(tips="all", tip_body="l_shin"), r"tips='all' and tip_body='l_shin' together"),
        (dict(tips=["nowhere"]), r"tip 'nowhere' is not a body"),
        (dict(tips="l_shin"), r"tips='l_shin': expected 'all' or a list of body names"),
        (dict(tips="all", base_joint="planar"), r"free joint 'root', which is not base_joint='planar'"),
        (dict(tips="all", base_joint="ball"), r"unknown base_joint 'ball'"),
    ],
)
def test_bad_mjcf_tips_and_base_joints_are_refused_by_name(kwargs, message):
    pytest.importorskip("mujoco")
    from symdyn.model import MJCFError

    with pytest.raises(MJCFError, match=message):
        Robot.from_mjcf(HUMANOID, **kwargs)


def test_an_mjcf_tree_on_its_free_joint_has_mujocos_inverse_dynamics():
    """MuJoCo's free joint: q = [x y z qw qx qy qz], v = [world linear, body angular], τ's force in
    the world frame; symdyn's (Pinocchio's): [x y z qx qy qz qw], body-frame v and force."""
    mujoco = pytest.importorskip("mujoco")
    from scipy.spatial.transform import Rotation

    from symdyn.numeric import reference as ref

    robot = Robot.from_mjcf(HUMANOID, tips="all")
    model = mujoco.MjModel.from_xml_string(HUMANOID)
    data = mujoco.MjData(model)
    q, v, a = _states(robot, 5)
    tau = ref.rne(robot, q, v, a)
    for k in range(STATES):
        R = Rotation.from_quat(q[k, 3:7]).as_matrix()  # scipy's order is symdyn's: x y z w
        lin, w = v[k, :3], v[k, 3:6]
        data.qpos[:] = np.concatenate([q[k, :3], q[k, [6, 3, 4, 5]], q[k, 7:]])
        data.qvel[:] = np.concatenate([R @ lin, w, v[k, 6:]])
        data.qacc[:] = np.concatenate([R @ (a[k, :3] + np.cross(w, lin)), a[k, 3:]])
        mujoco.mj_inverse(model, data)
        peer = data.qfrc_inverse.copy()
        peer[:3] = R.T @ peer[:3]
        assert np.abs(tau[k] - peer).max() / max(np.abs(peer).max(), 1.0) < 1e-10
