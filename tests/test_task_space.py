"""The task space, generated: frames, Jacobians, drifts, centre of mass, centroidal momentum.

Every function against Pinocchio (`symdyn.bench.task_space`) at hundreds of random states —
the shipped arms' tools, the Panda's hand from Pinocchio's own reading of the URDF, random
trees on fixed, free and planar bases with frames at random placements — and against
central differences of the generated code itself (dp/dq·δ = J·δ, d/dt(J v) = drift,
d/dt of the centroidal momentum).  Frames by name, the default frames and the errors.
"""

import dataclasses
import importlib.metadata
from pathlib import Path

import numpy as np
import pytest

from symdyn import models
from symdyn.codegen.emit import Bundle, numpy as numpy_emit
from symdyn.codegen.task_functions import task_names, task_spec
from symdyn.derivation.task_space import arguments, parts, task_space
from symdyn.model import Robot
from symdyn.model.frames import Frame
from symdyn.model.random_arms import _rotation
from symdyn.model.random_robots import random_tree_robot
from tests.conftest import tiered

pin = pytest.importorskip("pinocchio", reason="the task space is checked against Pinocchio (the test extra)")
peer = pytest.importorskip("symdyn.bench.task_space")

RTOL = 1e-12
STATES = 200


def task_module(robot: Robot) -> dict:
    """The task-space functions of `robot` alone, through the NumPy emitter (no dynamics derived)."""
    ts = task_space(robot)
    programs = tuple(task_spec(ts, name).program() for name in task_names(ts))
    bundle = Bundle(robot.name, robot.n, "test", robot.fingerprint(), programs, nq=robot.nq, nv=robot.nv)
    namespace: dict = {}
    exec(compile(numpy_emit.module_source(bundle), f"<{robot.name} task space>", "exec"), namespace)
    return {name: namespace[name] for name in task_names(ts)}


def states(robot: Robot, count: int, seed: int = 0):
    """(q, v, a): joints within their limits, a floating base moved along a random twist."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(lo, hi, (count, robot.n))
    if robot.base_joint is not None:
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n))
        q = robot.integrate(q, twist)
    return q, rng.uniform(-2, 2, (count, robot.nv)), rng.uniform(-5, 5, (count, robot.nv))


def assert_close(got, want, what: str, rtol: float = RTOL) -> None:
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape, f"{what}: shape {got.shape}, expected {want.shape}"
    scale = max(1.0, float(np.abs(want).max()))
    err = float(np.abs(got - want).max()) / scale
    assert err <= rtol, f"{what}: relative error {err:.2e} > {rtol:.0e}"


def evaluate(functions: dict, q, v, a) -> dict:
    """Every task-space function at the states (batched)."""
    given = {"q": q, "v": v, "a": a}
    return {name: f(*(given[x] for x in arguments(name))) for name, f in functions.items()}


def assert_pinocchio(robot: Robot, functions: dict, model, ids, count: int = STATES, seed: int = 0) -> None:
    """Every function's output against Pinocchio's; one of several outputs (`TOGETHER`) part by part."""
    q, v, a = states(robot, count, seed)
    want = peer.evaluate(robot, model, ids, q, v, a)
    got = evaluate(functions, q, v, a)
    for name, value in got.items():
        values = value if len(parts(name)) > 1 else (value,)
        assert len(values) == len(parts(name)), f"{name}: {len(values)} outputs, expected {parts(name)}"
        for part, x in zip(parts(name), values):
            assert_close(x, want[part], f"{robot.name} {name}" + (f" ({part})" if part != name else ""))


def with_random_frames(robot: Robot, seed: int) -> Robot:
    """The robot with a frame at a random placement on every link and on the base, all served."""
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(-1, robot.n):
        T = np.eye(4)
        T[:3, :3] = _rotation(__import__("random").Random(seed * 31 + k))
        T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
        frames.append(Frame(f"f{k + 1}", k, tuple(map(tuple, T.tolist()))))
    robot = dataclasses.replace(robot, frame_catalog=tuple(frames))
    return robot.with_frames([f.name for f in frames])


# --------------------------------------------------------------------------- against Pinocchio


@pytest.mark.parametrize("name", tiered(["puma560", "puma560_mdh", "rrp", "ur5", "iiwa14", "panda"], 3))
def test_the_shipped_arms_tools_equal_pinocchio(name):
    robot = models.load(name)
    model, ids = peer.peer_model(robot)
    assert_pinocchio(robot, task_module(robot), model, ids)


@pytest.mark.parametrize("base_joint", [None, "free", "planar"])
@pytest.mark.parametrize("seed", tiered([1, 2, 3], 1))
def test_random_trees_with_frames_anywhere_equal_pinocchio(seed, base_joint):
    robot = with_random_frames(random_tree_robot(seed, n=4 if seed < 3 else 6, base_joint=base_joint), seed)
    model, ids = peer.peer_model(robot)
    assert_pinocchio(robot, task_module(robot), model, ids, count=50, seed=seed)


def test_the_pandas_hand_equals_pinocchios_reading_of_the_file():
    """Frames named in the URDF (the hand fixed to link 8 and the TCP beyond it) are where
    Pinocchio's own parser puts them."""
    panda = models.load("panda").with_frames(["panda_hand", "panda_hand_tcp", "panda_link5"])
    from importlib.resources import files

    path = files("symdyn.model.arms") / "data" / "panda.urdf"
    model, ids = peer.file_model(panda, str(path))
    assert_pinocchio(panda, task_module(panda), model, ids)


def test_a_link_named_as_a_joint_is_compared_at_the_link_s_frame(tmp_path):
    """A URDF may give a link and a joint one name (the Unitree Z1's `gripperStator`): Pinocchio's
    `getFrameId` alone refuses it; the peer takes the link's (BODY) frame, a frame the name
    names both ways is where Pinocchio's parser puts the link."""
    inertial = '<inertial><mass value="1"/><origin xyz="0.1 0 0.05"/><inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial>'
    text = (
        f'<robot name="same_names"><link name="base"/><link name="l1">{inertial}</link><link name="tip">{inertial}</link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        '<joint name="tip" type="revolute"><parent link="l1"/><child link="tip"/><origin xyz="0.3 0 0.1" rpy="0.2 0 0"/>'
        '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>'
    )
    path = tmp_path / "same_names.urdf"
    path.write_text(text)
    robot = Robot.from_urdf(str(path)).with_frames(["tip", "l1"])
    model, ids = peer.file_model(robot, str(path))
    import pinocchio as pin

    assert [(model.frames[i].name, model.frames[i].type) for i in ids] == [
        ("tip", pin.FrameType.BODY),
        ("l1", pin.FrameType.BODY),
    ]
    assert_pinocchio(robot, task_module(robot), model, ids)


def _solo_file() -> Path:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("Solo 12's URDF comes from example-robot-data (the test extra)")
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots/solo_description/robots/solo12.urdf"))
    if not path.is_file():
        pytest.skip(f"example-robot-data has no {path}")
    return path


FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]


@pytest.mark.slow
def test_solo12s_four_feet_on_a_free_base_equal_pinocchio_through_generated_c():
    """The issue's case: Solo 12 read from its URDF on a free base, its four feet (links merged
    by fixed joints) served by the generated C, equal to Pinocchio's own model of the file."""
    import symdyn

    path = _solo_file()
    solo = Robot.from_urdf(str(path), tips="all", base_joint="free").with_frames(FEET)
    model, ids = peer.file_model(solo, path)
    c = symdyn.load(solo, "c")
    functions = {name: getattr(c, name) for name in task_names(task_space(solo))}
    assert_pinocchio(solo, functions, model, ids, count=STATES)


# --------------------------------------------------------------------------- exact identities


def _central(f, x, dx, h=1e-6):
    return (f(x + h * dx) - f(x - h * dx)) / (2 * h)


@pytest.mark.parametrize("base_joint", [None, "free"])
def test_central_differences_of_position_velocity_and_momentum(base_joint):
    """dp/dq·δ = J_aligned·δ (q moved along δ on the manifold), d/dt(J v) = drift,
    d/dt(A_G v) = A_G a + Ȧ_G v, d/dt c = J_c v: the generated code against itself."""
    robot = with_random_frames(random_tree_robot(7, n=4, base_joint=base_joint), 7)
    f = task_module(robot)
    q, v, a = states(robot, 5, seed=7)
    h = 1e-6
    for qi, vi, ai in zip(q, v, a):
        at = lambda t: robot.integrate(qi, vi * t)  # noqa: E731 (a motion with velocity v, at a = 0)
        pose = lambda t: f["frame_pose"](at(t))[:, :3, 3]  # noqa: E731
        J = f["frame_jacobian_aligned"](qi)
        assert_close(_central(pose, 0.0, 1.0, h), J[:, :3] @ vi, "dp/dt = J v", 1e-7)
        Jv = lambda t: f["frame_jacobian_aligned"](at(t)) @ vi  # noqa: E731 (v held: the base's v is body-frame)
        drift = f["frame_drift"](qi, vi)
        assert_close(_central(Jv, 0.0, 1.0, h), drift, "d/dt (J v) = drift", 1e-6)
        hg = lambda t: f["centroidal_map"](at(t)) @ vi  # noqa: E731
        assert_close(_central(hg, 0.0, 1.0, h), f["centroidal_drift"](qi, vi), "d/dt h_G", 1e-6)
        com = lambda t: f["com"](at(t))  # noqa: E731
        assert_close(_central(com, 0.0, 1.0, h), f["com_jacobian"](qi) @ vi, "dc/dt", 1e-7)
        accel = f["frame_acceleration"](qi, vi, ai)
        assert_close(accel, J @ ai + drift, "classical acceleration = J a + drift")


def test_a_frame_on_another_branch_has_zero_columns_and_costs_nothing_there():
    robot = random_tree_robot(3, n=6)
    leaves = [k for k in range(robot.n) if k not in robot.parents]
    robot = robot.with_frames([f"link{leaves[0] + 1}"])
    J = task_module(robot)["frame_jacobian"](np.zeros(robot.nq))[0]
    on_path, k = set(), leaves[0]
    while k >= 0:
        on_path.add(k)
        k = robot.parents[k]
    for j in range(robot.n):
        if j not in on_path:
            assert not J[:, j].any(), f"column {j} of a joint the frame does not hang from"


# --------------------------------------------------------------------------- frames by name


def test_every_link_of_the_file_is_a_frame_and_the_default_is_the_tool():
    panda = models.load("panda")
    assert {"panda_link0", "panda_link7", "panda_hand", "panda_hand_tcp", "tool"} <= set(panda.frame_names)
    assert [f.name for f in panda.task_frames] == ["tool"]
    puma = models.load("puma560")
    assert puma.frame_names == ("base", "link1", "link2", "link3", "link4", "link5", "link6", "tool")


def test_an_unknown_frame_names_the_closest_known_ones():
    panda = models.load("panda")
    with pytest.raises(ValueError, match="no frame 'panda_hnd'.*panda_hand"):
        panda.with_frames(["panda_hnd"])
    with pytest.raises(ValueError, match="more than once"):
        panda.with_frames(["tool", "tool"])
    with pytest.raises(ValueError, match="list of frame names"):
        panda.with_frames("tool")


def test_a_misspelt_frame_is_matched_in_any_case_and_by_part_and_else_every_frame_is_listed():
    panda = models.load("panda")
    with pytest.raises(ValueError, match="closest known are panda_hand_tcp"):
        panda.with_frames(["tcp"])
    with pytest.raises(ValueError, match="closest known are panda_hand,"):
        panda.with_frames(["PANDA_HAND"])
    with pytest.raises(ValueError, match=r"no frame 'zzzz'; its frames are panda_link0, .*, tool$"):
        panda.with_frames(["zzzz"])


def test_frames_given_once_as_a_generator_are_served():
    panda = models.load("panda")
    chosen = panda.with_frames(name for name in ("panda_hand", "panda_link5"))
    assert [f.name for f in chosen.task_frames] == ["panda_hand", "panda_link5"]


def test_the_readers_take_frames_and_a_tree_read_by_its_tips_serves_them():
    """frames= on from_urdf and from_mjcf; the tips a tree was read with are its default frames
    (Solo's feet, links merged onto the lower legs), and a chain (on a free base, or read by one
    tip) serves its tool, which is the tip."""
    from symdyn.model.example_robots import robots_folder

    solo = robots_folder() / "solo_description" / "robots" / "solo12.urdf"
    feet = ["FL_FOOT", "HR_FOOT"]
    by_tips = Robot.from_urdf(solo, tips=feet, base_joint="free")
    assert [f.name for f in by_tips.task_frames] == feet
    chosen = Robot.from_urdf(solo, tips="all", base_joint="free", frames=["HR_FOOT", "base_link"])
    assert [f.name for f in chosen.task_frames] == ["HR_FOOT", "base_link"]
    assert chosen.dynamics_fingerprint() == Robot.from_urdf(solo, tips="all", base_joint="free").fingerprint()
    chain = Robot.from_urdf(solo, tip_link="FL_FOOT", base_joint="free")
    assert [f.name for f in chain.task_frames] == ["tool"]
    foot = next(f for f in chain.frame_catalog if f.name == "FL_FOOT")
    assert (foot.link, foot.placement) == (chain.n - 1, chain.tool)  # the tool is the foot
    with pytest.raises(ValueError, match="no frame 'fl_fot'.*FL_FOOT"):
        Robot.from_urdf(solo, tips="all", base_joint="free", frames=["fl_fot"])
    pytest.importorskip("mujoco", reason="MJCF files are compiled by MuJoCo (the test extra)")
    path = Path(__file__).parent / "mjcf_fixtures" / "menagerie_arm.xml"
    arm = Robot.from_mjcf(str(path), frames=["attachment_site", "shoulder_link"])
    assert [f.name for f in arm.task_frames] == ["attachment_site", "shoulder_link"]
    twice = Robot.from_mjcf(str(path), tips=iter(["forearm_link", "shoulder_link", "forearm_link"]))
    assert [f.name for f in twice.task_frames] == ["forearm_link", "shoulder_link"]  # each once, on one path
    one = Robot.from_mjcf(str(path), tips=["forearm_link"])  # one tip: a chain, whose tool is the tip
    forearm = next(f for f in one.frame_catalog if f.name == "forearm_link")
    assert [f.name for f in one.task_frames] == ["tool"] and (forearm.link, forearm.placement) == (one.n - 1, one.tool)


def test_chosen_frames_enter_the_fingerprint_and_the_default_does_not():
    puma = models.load("puma560")
    assert puma.with_frames(["link3"]).fingerprint() != puma.fingerprint()
    assert puma.with_frames(["link3"]).fingerprint() != puma.with_frames(["link4"]).fingerprint()
    assert dataclasses.replace(puma, frames=()).fingerprint() == puma.fingerprint()


def test_mjcf_bodies_and_sites_are_where_mujoco_puts_them():
    """Every body and site of an MJCF arm as a frame: its pose (xpos, xmat; site_xpos, site_xmat)
    and its Jacobian (mj_jacBody, mj_jacSite: world axes at the origin) equal MuJoCo's own."""
    mujoco = pytest.importorskip("mujoco", reason="MJCF files are compiled by MuJoCo (the test extra)")
    path = Path(__file__).parent / "mjcf_fixtures" / "menagerie_arm.xml"
    robot = Robot.from_mjcf(str(path))
    names = ["shoulder_link", "forearm_link", "wrist_3_link", "attachment_site"]
    robot = robot.with_frames(names)
    f = task_module(robot)
    from symdyn.model.mjcf.compile import compile_mjcf

    m = compile_mjcf(str(path)).model  # the file's absent meshes left out, as from_mjcf reads it
    d = mujoco.MjData(m)
    q, _, _ = states(robot, 20, seed=5)
    for qi in q:
        d.qpos[:] = qi
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        pose, J = f["frame_pose"](qi), f["frame_jacobian_aligned"](qi)
        for k, name in enumerate(names):
            site = name == "attachment_site"
            i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE if site else mujoco.mjtObj.mjOBJ_BODY, name)
            p = d.site_xpos[i] if site else d.xpos[i]
            R = (d.site_xmat[i] if site else d.xmat[i]).reshape(3, 3)
            jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            (mujoco.mj_jacSite if site else mujoco.mj_jacBody)(m, d, jacp, jacr, i)
            assert_close(pose[k, :3, 3], p, f"{name} position", 1e-9)
            assert_close(pose[k, :3, :3], R, f"{name} rotation", 1e-9)
            assert_close(J[k], np.vstack([jacp, jacr]), f"{name} Jacobian", 1e-9)


@pytest.mark.parametrize("target", ["numpy", "c", "casadi", "array-api"])
def test_every_target_serves_the_task_space_as_pinocchio_does(target):
    """The shipped Puma's generated files (generated/), target by target, against Pinocchio."""
    from symdyn.codegen.entry import load

    if target == "array-api":
        pytest.importorskip("array_api_compat", reason="the array-API target needs array-api-compat (the test extra)")
    robot = models.load("puma560")
    model, ids = peer.peer_model(robot)
    f = load("puma560", target)
    functions = {name: getattr(f, name) for name in task_names(task_space(robot))}
    assert_pinocchio(robot, functions, model, ids, count=50, seed=11)


# --------------------------------------------------------------------------- printed


def test_print_frames_gives_the_two_link_arms_forward_kinematics_as_a_textbook(capsys):
    from symdyn.cli import main

    assert main(["print", "twolink", "--frames"]) == 0
    out = capsys.readouterr().out
    assert "x = a1*cos(q1) + a2*cos(q1 + q2)" in out and "z = a1*sin(q1) + a2*sin(q1 + q2)" in out
    assert "J1_1 = -a1*sin(q1) - a2*sin(q1 + q2)" in out and "J1_2 = -a2*sin(q1 + q2)" in out


def test_print_frames_refuses_the_joint_space_options_and_names_only_numbers(capsys):
    """--term, --layout and --prune shape the joint-space equations: with --frames they are an error,
    not ignored; a symbolic arm's lengths are its own symbols, so no empty 'where' line."""
    from symdyn.cli import main

    assert main(["print", "twolink", "--frames", "--term", "M", "--prune", "1e-3"]) != 0
    assert "--term and --prune apply to the joint-space equations, not to --frames" in capsys.readouterr().err
    assert main(["print", "twolink", "--frames", "--constants"]) == 0
    out = capsys.readouterr().out
    assert "where" not in out and "x = C1*a1 + C12*a2" in out, out


def printed_elements(out: str, n: int) -> dict:
    """{element name: function of the joints} of a printed frame (its lines joined where a long
    element goes on over indented lines)."""
    import sympy as sp

    lines: list[str] = []
    for line in out.splitlines():
        if line.startswith("    ") and lines:
            lines[-1] += " " + line.strip()
        else:
            lines.append(line)
    q = sp.symbols(f"q1:{n + 1}", real=True)
    names = dict(zip(map(str, q), q))
    return {
        k: sp.lambdify(q, sp.sympify(v, locals=names))
        for k, v in (line.split(" = ", 1) for line in lines if " = " in line and not line.startswith("#"))
    }


def placed_by_the_base(elements: dict, joints, R0, p0, n: int):
    """(pose, world-aligned Jacobian with the free base's six columns first) of the printed frame,
    placed as the printed note says: p0 + R0·p, R0·R, [[R0, −R0[p×], R0 J_lin], [0, R0, R0 J_ang]]."""
    p = np.array([elements[a](*joints) for a in "xyz"], dtype=float)
    R = np.array([[elements[f"R{r}{c}"](*joints) for c in (1, 2, 3)] for r in (1, 2, 3)], dtype=float)
    Jb = np.zeros((6, n))
    for key, g in elements.items():
        if key.startswith("J"):
            r, c = map(int, key[1:].split("_"))
            Jb[r - 1, c - 1] = g(*joints)
    px = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    J = np.block([[R0, -R0 @ px, R0 @ Jb[:3]], [np.zeros((3, 3)), R0, R0 @ Jb[3:]]])
    return np.block([[R0 @ R, (p0 + R0 @ p)[:, None]], [0, 0, 0, 1]]), J


def test_a_floating_base_prints_its_frames_in_the_base_axes_and_the_world_follows(capsys):
    """Solo's foot on a free base printed in the base body's axes (functions of the joints alone,
    to --digits 17): placed by the base's pose as the printed note says, it is the generated
    pose and world-aligned Jacobian at random states."""
    from scipy.spatial.transform import Rotation

    from symdyn.cli import main
    from symdyn.model.example_robots import robots_folder

    solo = robots_folder() / "solo_description" / "robots" / "solo12.urdf"
    argv = ["print", str(solo), "--tips", "FL_FOOT,HR_FOOT", "--base-joint", "free", "--frames", "HR_FOOT"]
    assert main([*argv, "--digits", "17"]) == 0
    out = capsys.readouterr().out
    assert "in the world,\n#   origin p0 + R0 (x, y, z)" in out and "base_q" not in out.split("# the base")[0]
    robot = Robot.from_urdf(solo, tips=["FL_FOOT", "HR_FOOT"], base_joint="free").with_frames(["HR_FOOT"])
    elements, f = printed_elements(out, robot.n), task_module(robot)
    for qi in states(robot, 5, seed=2)[0]:
        R0 = Rotation.from_quat(qi[3:7]).as_matrix()  # scalar last, as Pinocchio's q
        pose, J = placed_by_the_base(elements, qi[7:], R0, qi[:3], robot.n)
        assert_close(f["frame_pose"](qi)[0], pose, "pose")
        assert_close(f["frame_jacobian_aligned"](qi)[0], J, "the world-aligned Jacobian")


def test_a_planar_base_prints_its_frames_the_same_way_under_the_robots_base_placement():
    """A random tree on a planar base whose world frame {0} is placed by a general `robot.base` B:
    the printed frame, placed by Rz(yaw), (x, y, 0) and then B as the note says (the base's
    columns vx, vy, wz of the free base's six), is the generated pose and Jacobian."""
    from symdyn.derivation.entry import derive
    from symdyn.presentation.task_space import frames_form

    robot = random_tree_robot(5, n=2, base_joint="planar").with_frames(["link2"])
    out = frames_form(derive(robot, "newton-euler"), digits=17)
    assert "all of it then placed by the robot's base B" in out
    B = np.array(robot.base, dtype=float)
    elements, f = printed_elements(out, robot.n), task_module(robot)
    for qi in states(robot, 5, seed=3)[0]:
        c, s = np.cos(qi[2]), np.sin(qi[2])
        R0 = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        pose, J = placed_by_the_base(elements, qi[3:], R0, np.r_[qi[:2], 0], robot.n)
        turn = np.kron(np.eye(2), B[:3, :3])
        assert_close(f["frame_pose"](qi)[0], B @ pose, "pose")
        assert_close(f["frame_jacobian_aligned"](qi)[0], turn @ J[:, [0, 1, 5, *range(6, 6 + robot.n)]], "Jacobian")


@pytest.mark.parametrize("name", ["puma560", "puma560_mdh"])
def test_the_pumas_tool_pose_in_named_constants_is_its_forward_kinematics(name, capsys):
    """Every printed element (DH lengths a2, a3, d3, d4 — Craig's names in either convention: a
    modified-DH link i holds a_{i-1} — and abbreviations C1, S23, …) evaluated at random q equals
    the reference's forward kinematics."""
    import sympy as sp

    from symdyn import reference
    from symdyn.cli import main

    assert main(["print", name, "--frames", "--constants"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "x = C1*C2*a2 + C1*C23*a3 - C1*S23*d4 + S1*d3" in lines
    where = dict(item.split(" = ") for item in lines[-2].lstrip("# where").split(", "))
    values = {sp.Symbol(k, real=True): float(v.split()[0]) for k, v in where.items()}
    abbr = dict(item.split(" = ") for item in lines[-1].lstrip("# ").split(", "))
    q = sp.symbols("q1:7", real=True)
    table = {sp.Symbol(k, real=True): sp.sympify(v, locals=dict(zip(map(str, q), q))) for k, v in abbr.items()}
    elements = dict(line.split(" = ", 1) for line in lines if " = " in line and not line.startswith("#"))
    puma = models.load(name)
    for qn in np.random.default_rng(3).uniform(-2, 2, (5, 6)):
        T = reference.fkine(puma, qn)
        at = {**values, **{s: float(e.subs(dict(zip(q, qn)))) for s, e in table.items()}}
        names = {
            "x": (0, 3),
            "y": (1, 3),
            "z": (2, 3),
            **{f"R{r + 1}{c + 1}": (r, c) for r in range(3) for c in range(3)},
        }
        for name, (r, c) in names.items():
            got = float(sp.sympify(elements[name], locals={str(s): s for s in at}).subs(at))
            assert abs(got - T[r, c]) < 1e-12, (name, got, T[r, c])
