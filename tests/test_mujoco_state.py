"""MuJoCo's states and symdyn's (issue 44, defect 3): a file whose root body has a <freejoint/> is
read on that free base as the docstring says, and `robot.from_mujoco_state` / `to_mujoco_state`
convert between MuJoCo's qpos/qvel/qacc ([x y z qw qx qy qz], world linear velocity) and
Pinocchio's (w last, body-frame velocity), checked against MuJoCo's own inverse dynamics."""

from pathlib import Path

import numpy as np
import pytest

from symdyn import reference
from symdyn.model import Robot
from symdyn.model.mjcf.state import to_mujoco_force

mujoco = pytest.importorskip("mujoco", reason="MJCF files are compiled by MuJoCo (the test extra)")

FILE = Path(__file__).parent / "mjcf_fixtures" / "floating_legs.xml"


@pytest.fixture(scope="module")
def legs():
    """(the robot as from_mjcf reads the file alone, with the neck locked; MuJoCo's model)."""
    robot = Robot.from_mjcf(str(FILE), tips="all", locked={"neck": 0.4})
    from symdyn.model.mjcf.compile import compile_mjcf

    return robot, compile_mjcf(str(FILE)).model


def test_a_freejoint_root_is_read_as_the_free_base_without_being_asked():
    robot = Robot.from_mjcf(str(FILE), tip_body="left_foot")
    assert robot.base_joint == "free" and robot.mjcf.free_joint == "root"
    assert robot.joint_names == ("left_hip", "left_knee")


def test_mujocos_inverse_dynamics_is_symdyns_after_conversion(legs):
    """Random qpos, qvel, qacc: mj_inverse's qfrc equals symdyn's τ at the converted state
    (the free joint's force in world axes), and the conversions are each other's inverse."""
    robot, m = legs
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    neck = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "neck")]
    for _ in range(20):
        qpos = m.qpos0 + rng.uniform(-0.5, 0.5, m.nq)
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        qpos[neck] = 0.4  # the locked joint where symdyn holds it
        qvel = rng.uniform(-1, 1, m.nv)
        qvel[m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "neck")]] = 0.0
        qacc = rng.uniform(-2, 2, m.nv)
        qacc[m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "neck")]] = 0.0
        d.qpos[:], d.qvel[:], d.qacc[:] = qpos, qvel, qacc
        mujoco.mj_inverse(m, d)
        q, v, a = robot.from_mujoco_state(qpos, qvel, qacc)
        tau = reference.rne(robot, q, v, a)
        want = d.qfrc_inverse.copy()
        got = to_mujoco_force(robot, q, tau)
        keep = np.ones(m.nv, bool)
        keep[m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "neck")]] = False  # locked
        np.testing.assert_allclose(got[keep], want[keep], atol=1e-9 * max(1, np.abs(want).max()))
        back = robot.to_mujoco_state(q, v, a)
        for x, y in zip(back, (qpos, qvel, qacc)):
            np.testing.assert_allclose(x, y, atol=1e-12)


def test_conversions_refuse_what_they_cannot_convert(legs):
    robot, m = legs
    with pytest.raises(ValueError, match=rf"qpos must have shape \(\.\.\., {m.nq}\)"):
        robot.from_mujoco_state(np.zeros(3), np.zeros(m.nv))
    from symdyn import models

    with pytest.raises(ValueError, match="not read by Robot.from_mjcf"):
        models.load("puma560").from_mujoco_state(np.zeros(6), np.zeros(6))


def test_equality_constraints_are_named_and_those_gone_with_an_excluded_body_are_listed(tmp_path):
    """MuJoCo's equality constraints are not modelled: the warning names each by its type and the
    objects it joins (not by its index), and those that vanished with an excluded body too."""
    from symdyn.model import MJCFWarning

    xml = FILE.read_text().replace(
        "</worldbody>",
        "</worldbody><equality><connect body1='left_shin' body2='right_shin' anchor='0 0 0'/>"
        "<joint name='hips' joint1='left_hip' joint2='right_hip'/>"
        "<weld body1='head' body2='left'/></equality>",
    )
    path = tmp_path / "legs.xml"
    path.write_text(xml)
    with pytest.warns(MJCFWarning) as caught:
        Robot.from_mjcf(str(path), tips="all", exclude=["head"])
    said = " ".join(str(w.message) for w in caught)
    assert "connect 'left_shin'–'right_shin'" in said
    assert "joint 'hips' ('left_hip'–'right_hip')" in said
    assert "gone with the excluded bodies: weld 'head'–'left'" in said
