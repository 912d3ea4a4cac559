"""`Robot.from_mjcf` against MuJoCo itself: every MJCF convention, τ and M at 200 random states.

Each fixture in tests/mjcf_fixtures/ exercises one convention (compiler angle
and eulerseq, the orientation forms, default classes with childclass and
include, a joint's anchor and axis inside its body, inertials, gravity,
branches) or a Menagerie-style arm (armature, damping, frictionloss,
actuators).  MuJoCo's `mj_inverse` (contacts and constraints disabled) gives
qfrc_inverse = M(q)·q̈ + bias(q, q̇) − qfrc_passive, where M includes the
armature on its diagonal and qfrc_passive is −damping·q̇ (no springs here):
that is symdyn's τ with Jm = armature (G = 1) and viscous friction B =
damping, but without Coulomb friction, because MuJoCo's frictionloss is a
constraint force (disabled here) — so τ is compared with
`robot.nofriction()` (Coulomb removed, viscous kept).  `mj_fullM` gives M.
"""

from __future__ import annotations

import dataclasses
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")  # the test extra installs it: this only guards a bare checkout

from symdyn import reference as ref  # noqa: E402
from symdyn.model import MJCFError, MJCFWarning, Robot  # noqa: E402
from symdyn.model.command_line import load  # noqa: E402

FIXTURES = Path(__file__).parent / "mjcf_fixtures"
STATES = 200
RTOL = 1e-10

#: fixture → from_mjcf keywords (the chain and locks); each is one convention.
CASES = {
    "degree_euler": {},  # angle="degree" (the default), eulerseq="zyx", ref in degrees
    "radian_orientations": {},  # quat, axisangle, euler, xyaxes, zaxis
    "defaults_include": {},  # nested <default> classes, childclass, <include>
    "joint_anchor": {},  # joint pos and non-unit axis in the body; two joints in one body; slides; ref
    "inertia": {},  # diaginertia + quat/euler, fullinertia, inertia from geoms, a welded body
    "gravity": {},  # <option gravity> off the z axis
    "branch": {"tip_body": "tcp"},  # a camera and two fingers locked and merged; a free body left out
    "branch_locked": {"tip_body": "tcp", "locked": {"fl": 0.03, "cam_tilt": 0.7, "q3": 0.4}},
    "branch_from_link1": {"tip_body": "tcp", "base_body": "link1"},
    "menagerie_arm": {},  # armature, damping, frictionloss, actuators; absent mesh and texture files
}


def _png(path: Path) -> None:
    """A 1×1 PNG, so that MuJoCo itself can load the Menagerie-style file."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\0\xff\xff\xff"))
        + chunk(b"IEND", b"")
    )


@pytest.fixture(scope="module")
def with_assets(tmp_path_factory) -> Path:
    """menagerie_arm.xml beside stand-in mesh and texture files, for MuJoCo's own load (symdyn reads
    the fixture, where they are absent; with explicit inertials the meshes change no dynamics)."""
    folder = tmp_path_factory.mktemp("menagerie")
    shutil.copy(FIXTURES / "menagerie_arm.xml", folder)
    (folder / "assets").mkdir()
    tetrahedron = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    for mesh in ("base", "shoulder", "upperarm", "forearm", "wrist"):
        (folder / "assets" / f"{mesh}.obj").write_text(tetrahedron)
    _png(folder / "brushed_metal.png")
    return folder / "menagerie_arm.xml"


@pytest.fixture(scope="module")
def read(with_assets) -> dict:
    """{case: (robot, MuJoCo's model)}, each compiled once for the module."""
    out = {}
    for case, kw in CASES.items():
        stem = case.split("_locked")[0].split("_from")[0]
        with pytest.warns(MJCFWarning) if "base_body" in kw else _nothing():
            robot = Robot.from_mjcf(FIXTURES / f"{stem}.xml", **kw)
        source = with_assets if stem == "menagerie_arm" else FIXTURES / f"{stem}.xml"
        model = mujoco.MjModel.from_xml_path(str(source))
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        out[case] = robot, model
    return out


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _full_m(model, data) -> np.ndarray:
    M = np.zeros((model.nv, model.nv))
    if hasattr(data, "qM"):  # MuJoCo 3
        mujoco.mj_fullM(model, M, data.qM)
    else:  # MuJoCo 4: mj_fullM(m, d, dst)
        mujoco.mj_fullM(model, data, M)
    return M


def _mujoco(robot: Robot, model, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's τ (qfrc_inverse) and M of the chain's dofs, the locked joints at their values, at rest."""
    data = mujoco.MjData(model)
    joint = {j: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in robot.mjcf.joints}
    dofs = [model.jnt_dofadr[joint[j]] for j in robot.mjcf.joints]
    qadr = [model.jnt_qposadr[joint[j]] for j in robot.mjcf.joints]
    tau, M = [], []
    for k in range(len(q)):
        data.qpos[:], data.qvel[:], data.qacc[:] = model.qpos0, 0, 0
        for lock in robot.mjcf.locked:
            data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, lock.joint)]] = lock.value
        data.qpos[qadr], data.qvel[dofs], data.qacc[dofs] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(model, data)
        tau.append(data.qfrc_inverse[dofs].copy())
        M.append(_full_m(model, data)[np.ix_(dofs, dofs)])
    return np.array(tau), np.array(M)


@pytest.mark.parametrize("case", list(CASES))
def test_tau_and_mass_matrix_agree_with_mujoco(read, case):
    robot, model = read[case]
    rng = np.random.default_rng(7)
    q, qd, qdd = (rng.uniform(-2, 2, (STATES, robot.n)) for _ in range(3))
    tau_mj, M_mj = _mujoco(robot, model, q, qd, qdd)
    tau = ref.rne(robot.nofriction(), q, qd, qdd)  # MuJoCo's frictionloss is a constraint (disabled)
    M = ref.inertia(robot, q)
    scale_tau = np.abs(tau_mj).max(axis=-1, keepdims=True)
    scale_M = np.abs(M_mj).max(axis=(-1, -2), keepdims=True)
    assert np.abs(tau - tau_mj).max() / 1 <= RTOL * max(1.0, scale_tau.max()), case
    assert (np.abs(tau - tau_mj) / scale_tau).max() < RTOL, case
    assert (np.abs(M - M_mj).max(axis=(-1, -2), keepdims=True) / scale_M).max() < RTOL, case


def test_menagerie_arm_reads_armature_damping_frictionloss_ranges_and_effort_limits(read):
    robot, _ = read["menagerie_arm"]
    big, small = robot.links[0], robot.links[5]
    assert (big.Jm, big.G, big.B, big.Tc, big.qlim) == (0.25, 1, 3.0, (0.6, -0.6), (-6.28, 6.28))
    assert (small.Jm, small.B, small.Tc, small.qlim) == (0.02, 0.2, (0.05, -0.05), (-3.14, 3.14))
    assert robot.links[2].qlim == (-3.1415, 3.1415)
    # motor: |gear| × ctrlrange; servo: |gear| × forcerange; actuatorfrcrange bounds; no range: none
    assert [link.effort_limit for link in robot.links] == [150.0, 150.0, 125.0, 12.0, 12.0, 10.0]
    assert robot.mjcf.stripped == (
        "mesh 'base' (base.obj)",
        "mesh 'shoulder' (shoulder.obj)",
        "mesh 'upperarm' (upperarm.obj)",
        "mesh 'forearm' (forearm.obj)",
        "mesh 'wrist' (wrist.obj)",
        "texture 'brushed' (brushed_metal.png)",
    )
    text = str(robot)
    assert "armature 0.25 -> Jm (G = 1); damping 3.0 -> B; frictionloss 0.6 -> Tc = (f, -f)" in text
    assert "absent files left out" in text and "MJCF menagerie_arm.xml (sha256" in text


def test_coulomb_friction_is_frictionloss(read):
    robot, _ = read["menagerie_arm"]
    qd = np.array([1.0, -1.0, 0.5, -0.5, 2.0, 0.0])
    assert np.allclose(
        ref.friction(robot, qd), robot_viscous(robot) * qd + np.array([0.6, -0.6, 0.6, -0.05, 0.05, 0.0])
    )


def robot_viscous(robot: Robot) -> np.ndarray:
    return np.array([link.B for link in robot.links])


def test_gravity_is_corkes_sign_of_mujocos(read):
    assert read["gravity"][0].gravity == (-1.5, 2.0, 9.5)
    assert read["degree_euler"][0].gravity == (0.0, 0.0, 9.81)


def test_degrees_and_ref_become_radians_and_offset(read):
    robot, _ = read["degree_euler"]
    assert robot.links[0].qlim == pytest.approx((-170 * np.pi / 180, 170 * np.pi / 180), rel=1e-15)
    assert robot.links[0].offset == pytest.approx(-10 * np.pi / 180, rel=1e-15)


def test_two_joints_in_one_body_are_two_links_the_inner_massless(read):
    robot, _ = read["joint_anchor"]
    assert [link.joint for link in robot.links] == ["revolute", "revolute", "prismatic", "revolute", "prismatic"]
    assert robot.links[0].m == 0 and robot.links[2].m == 0 and robot.links[1].m == 1.7


def test_branches_are_locked_and_recorded(read):
    robot, _ = read["branch"]
    assert [(lock.joint, lock.value, lock.into) for lock in robot.mjcf.locked] == [
        ("cam_tilt", 0.2, "link1"),  # qpos0 = 0 lies outside its range [0.2, 1]: the nearest limit
        ("fl", 0.0, "hand"),
        ("fr", 0.0, "hand"),
    ]
    assert robot.mjcf.left_out == ("'object' and its subtree (free joint 'object_free' on body 'object')",)
    assert robot.links[0].m == pytest.approx(2.3)  # link1 and the camera


def test_snaps_are_recorded_and_tiny(read):
    robot, _ = read["radian_orientations"]
    assert robot.mjcf.snaps and robot.mjcf.max_snap < 1e-15
    assert any(s.where == "body 'a' rotation (quat)" and s.snapped == "quarter turns" for s in robot.mjcf.snaps)
    assert robot.links[0].origin[0][:3] == (0, -1, 0)  # exact, from quat="0.7071068 0 0 0.7071068"


def test_exclude_drops_a_subtree_as_if_it_were_not_in_the_file():
    text = (FIXTURES / "branch.xml").read_text()
    start, end = text.index('      <body name="camera"'), text.index('      <body name="link2"')
    without = Robot.from_mjcf(text[:start] + text[end:], tip_body="tcp")
    excluded = Robot.from_mjcf(FIXTURES / "branch.xml", tip_body="tcp", exclude=["camera"])
    assert excluded.links == without.links and excluded.mjcf.excluded == ("camera",)


def test_command_line_reads_mjcf_with_tip_body():
    robot = load(str(FIXTURES / "branch.xml"), tip="tcp", lock=["fl=0.01"])
    assert robot.name == "branch" and robot.mjcf.tip_body == "tcp" and robot.n == 3
    assert ("fl", 0.01, "given") in [(lock.joint, lock.value, lock.why) for lock in robot.mjcf.locked]


def test_generated_files_name_the_mjcf_file_and_rebuild_from_it(tmp_path):
    """The header of code generated for an MJCF arm names the file, its sha256 and the command
    that rebuilds it (as for URDF files): the record is the provenance."""
    import symdyn

    robot = load(str(FIXTURES / "branch.xml"), tip="tcp", lock=["fl=0.01"])
    (path,) = symdyn.generate(robot, "numpy", tmp_path)
    head = path.read_text()[:3000]
    assert f"MJCF branch.xml (sha256 {robot.mjcf.sha256}" in head
    assert "regenerate: symdyn generate branch.xml --base world --tip tcp --lock=fl=0.01 --target numpy" in head


BALL = """<mujoco><worldbody><body name="upper"><joint name="j" axis="0 0 1"/>
<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
<body name="cup"><joint name="socket" type="ball"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
</body></body></worldbody></mujoco>"""


def test_a_ball_joint_is_refused_by_name():
    with pytest.raises(MJCFError, match="ball joint 'socket' on body 'cup' is not supported yet"):
        Robot.from_mjcf(BALL)


def test_a_ball_joint_on_a_branch_that_moves_is_refused_and_exclude_is_suggested():
    text = BALL.replace("</body></body>", '</body><body name="tip"/></body>')
    with pytest.raises(MJCFError, match="ball joint 'socket' on body 'cup' is not supported yet.*exclude="):
        Robot.from_mjcf(text, tip_body="tip")
    assert Robot.from_mjcf(text, tip_body="tip", exclude="cup").n == 1


def test_a_body_whose_inertia_needs_an_absent_mesh_is_named(tmp_path):
    (tmp_path / "arm.xml").write_text(
        """<mujoco><asset><mesh name="m" file="gone.stl"/></asset><worldbody>
        <body name="link"><joint name="j"/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>"""
    )
    with pytest.raises(MJCFError, match="body 'link' .*gets its inertia from mesh 'm'.*'gone.stl' is absent"):
        Robot.from_mjcf(tmp_path / "arm.xml")


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({}, r"5 leaves \['object', 'camera', 'finger_left', 'finger_right', 'tcp'\].*tip_body="),
        ({"tip_body": "nope"}, "tip_body 'nope' is not a body of the file"),
        ({"tip_body": "tcp", "exclude": ["link2"]}, "excluded body 'link2' is on the chain"),
        (
            {"tip_body": "tcp", "locked": {"cam_tilt": 2.0}},
            r"locked value 2.0 of joint 'cam_tilt' is outside its range",
        ),
        ({"tip_body": "tcp", "locked": {"nope": 0.0}}, "locked joint 'nope' is not a joint of the file"),
    ],
)
def test_bad_choices_are_named(kw, message):
    with pytest.raises(MJCFError, match=message):
        Robot.from_mjcf(FIXTURES / "branch.xml", **kw)


def test_what_mujoco_adds_and_symdyn_does_not_model_is_warned():
    text = (
        (FIXTURES / "gravity.xml")
        .read_text()
        .replace('<joint name="g2" axis="0 1 0"/>', '<joint name="g2" axis="0 1 0" stiffness="5"/>')
    )
    with pytest.warns(MJCFWarning, match="joint 'g2' has a spring"):
        robot = Robot.from_mjcf(text)
    assert any("spring" in w for w in robot.mjcf.warnings)


def test_the_record_rebuilds_the_robot(read):
    robot, _ = read["branch_locked"]
    assert robot.mjcf.describes(robot)
    assert not robot.mjcf.describes(dataclasses.replace(robot, gravity=(0, 0, 1)))
    assert robot.mjcf.command_args().startswith("branch.xml --base world --tip tcp --lock=cam_tilt=0.7")
