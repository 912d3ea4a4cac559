"""`Robot.to_urdf`: the URDF with the robot's inertials, read back by symdyn and by Pinocchio.

A robot read from a URDF is written as that file with only the moving links'
inertials (and changed friction) replaced; what rides on a moving link
(the Panda's hand, through a fixed joint) keeps its own inertial and the
link gets the difference.  A DH robot gets a fresh chain.  The yardsticks:
the reference `rne` of the robot read back, symdyn's fingerprint, and
Pinocchio's `rnea` on the written text.
"""

from __future__ import annotations

import dataclasses
from importlib import resources

import numpy as np
import pinocchio as pin
import pytest

from symdyn import models
from symdyn.model import Robot, URDFWarning, from_urdf
from symdyn.numeric.reference import rne


def _panda_text() -> str:
    return resources.files("symdyn.model.arms").joinpath("data", "panda.urdf").read_text()


def _states(robot, seed=0, count=12):
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    return (
        rng.uniform(lo, hi, (count, robot.n)),
        rng.uniform(-2, 2, (count, robot.n)),
        rng.uniform(-5, 5, (count, robot.n)),
    )


def _as_read(x: float):
    """A number as the URDF reader makes it: integral values are ints (a float 0.0 reads back
    as the int 0, the same dynamics but another fingerprint)."""
    return int(x) if float(x).is_integer() else float(x)


def _changed(robot: Robot, links=None, seed=1) -> Robot:
    """Every (or the listed) link heavier, its COM moved and its inertia scaled (still
    physical), its viscous and Coulomb friction changed; numbers as the reader makes them."""
    rng = np.random.default_rng(seed)
    out = []
    for j, link in enumerate(robot.links):
        if links is not None and j not in links:
            out.append(link)
            continue
        k = 1 + 0.2 * rng.uniform(0.2, 1)
        I = np.array(link.I, dtype=float) * k + 1e-4 * np.eye(3)
        out.append(
            dataclasses.replace(
                link,
                m=_as_read(float(link.m) * k),
                r=tuple(_as_read(float(x) + 0.01) for x in link.r),
                I=tuple(tuple(_as_read(x) for x in row) for row in I),
                B=float(link.B) + 0.5,
                Tc=(0.3, -0.3),
            )
        )
    return dataclasses.replace(robot, links=tuple(out))


def _assert_same_dynamics(a: Robot, b: Robot, tol=1e-12):
    q, qd, qdd = _states(a)
    ta, tb = rne(a, q, qd, qdd), rne(b, q, qd, qdd)
    assert np.abs(ta - tb).max() <= tol * np.abs(ta).max(), np.abs(ta - tb).max()


def _pin_q(model, x):
    out = []
    for joint, v in zip(model.joints[1:], x):
        out += [np.cos(v), np.sin(v)] if joint.nq == 2 else [v]
    return np.array(out)


def _assert_pinocchio_agrees(robot: Robot, text: str, tol=1e-11):
    model = pin.buildModelFromXML(text)
    assert model.nv == robot.n
    data = model.createData()
    q, qd, qdd = _states(robot, seed=3)
    ours = rne(robot.nofriction(all=True), q, qd, qdd)
    theirs = np.array([pin.rnea(model, data, _pin_q(model, x), v, a).copy() for x, v, a in zip(q, qd, qdd)])
    assert np.abs(ours - theirs).max() <= tol * np.abs(ours).max()


def test_an_unchanged_urdf_arm_is_its_file_byte_for_byte():
    panda = models.load("panda")
    assert panda.to_urdf() == _panda_text()


def test_changed_inertials_are_spliced_into_the_file_and_read_back_with_the_same_fingerprint():
    panda = models.load("panda")
    changed = _changed(panda, links=range(6))  # links 1–6 carry nothing else
    text = changed.to_urdf()
    back = from_urdf(text, name="panda")
    assert back.fingerprint() == changed.fingerprint()
    # the rest of the file is untouched: the chain's geometry, the limits, the hand
    original = _panda_text()
    for keep in (
        '<joint name="panda_hand_joint" type="fixed">',
        'effort="87.0" lower="-2.8973"',
        '<link name="panda_hand_tcp">',
    ):
        assert keep in original and keep in text
    assert text.count("<inertial>") == original.count("<inertial>")


def test_a_link_carrying_a_fixed_body_gets_the_difference_and_reads_back_to_the_same_dynamics():
    """Link 7 carries the hand (fixed joint): the hand keeps its inertial, link 7's own becomes
    body − hand, and the reader's exact merge gives the body back to rounding (not bit for bit:
    the merge is exact rational arithmetic on the written decimals, so the fingerprint differs)."""
    panda = models.load("panda")
    changed = _changed(panda)
    text = changed.to_urdf()
    back = from_urdf(text, name="panda")
    assert back.links[:6] == changed.links[:6]
    got, want = back.links[6], changed.links[6]
    assert float(got.m) == pytest.approx(float(want.m), rel=1e-14)
    np.testing.assert_allclose(np.array(got.r, dtype=float), np.array(want.r, dtype=float), rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.array(got.I, dtype=float), np.array(want.I, dtype=float), rtol=0, atol=1e-14)
    _assert_same_dynamics(changed, back)
    assert text.count("<inertial>") == _panda_text().count("<inertial>")  # the hand's is still there
    _assert_pinocchio_agrees(changed, text)


def test_a_link_lighter_than_what_rides_on_it_takes_the_whole_body_and_says_so():
    panda = models.load("panda")
    last = panda.links[6]
    light = dataclasses.replace(panda, links=panda.links[:6] + (dataclasses.replace(last, m=0.2),))
    text = light.to_urdf()
    assert "could not be split from what rides on it (panda_link8, panda_hand, panda_hand_tcp)" in text
    assert text.count("<inertial>") == _panda_text().count("<inertial>") - 1  # the hand's was removed
    assert 'name="panda_hand">\n  </link>' in text
    back = from_urdf(text, name="panda")
    _assert_same_dynamics(light, back)
    _assert_pinocchio_agrees(light, text)


@pytest.mark.parametrize("name", ["twolink", "rrp"])
def test_a_dh_robot_gets_a_fresh_chain_with_the_same_dynamics(name):
    """A DH robot becomes a general-convention chain (modified-DH frames), so its fingerprint
    cannot be the DH robot's: the dynamics are compared instead.  Rotor inertia and asymmetric
    Coulomb friction have no place in URDF: they are named in a comment and a warning."""
    robot = models.load(name)
    if any(float(link.Jm) for link in robot.links):
        with pytest.warns(URDFWarning, match="rotor inertia"):
            robot.to_urdf()
    urdf_able = dataclasses.replace(
        robot, links=tuple(dataclasses.replace(link, Jm=0, Tc=(link.Tc[0], -link.Tc[0])) for link in robot.links)
    )
    text = urdf_able.to_urdf()
    back = from_urdf(text)
    assert back.convention == "general" and back.n == robot.n
    _assert_same_dynamics(urdf_able, back)
    _assert_pinocchio_agrees(urdf_able, text)


def test_a_urdf_robot_whose_file_is_not_at_hand_needs_source(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(_panda_text())
    robot = from_urdf(str(path), name="arm")
    other = tmp_path / "other.urdf"
    other.write_text(_panda_text().replace("4.970684", "4.970685"))
    with pytest.raises(ValueError, match="is not the file robot 'arm' was read from"):
        robot.to_urdf(source=other)
    written = tmp_path / "out.urdf"
    text = _changed(robot, links=[0]).to_urdf(written, source=path)
    assert written.read_text() == text


def test_a_massless_self_closing_link_gets_an_inertial_element():
    text = """<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="2"/>
  </joint>
  <link name="l1"/>
  <joint name="j2" type="revolute">
    <parent link="l1"/>
    <child link="l2"/>
    <origin xyz="0.3 0 0" rpy="1.5707963267948966 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="2"/>
  </joint>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>
"""
    robot = from_urdf(text)
    heavier = dataclasses.replace(
        robot,
        links=(
            dataclasses.replace(robot.links[0], m=2.5, r=(0.1, 0.02, 0), I=((0.02, 0, 0), (0, 0.03, 0), (0, 0, 0.04))),
            robot.links[1],
        ),
    )
    out = heavier.to_urdf(source=text)
    assert '<link name="l1">\n' in out and out.count("<inertial>") == 2
    back = from_urdf(out)
    assert back.fingerprint() == heavier.fingerprint()
    _assert_pinocchio_agrees(heavier, out)


@pytest.mark.parametrize("base_joint", [None, "free", "planar"])
def test_a_tree_on_any_base_round_trips_through_a_fresh_urdf(base_joint):
    """read → write → read gives the same τ for a tree on a fixed, free or planar base (the fresh
    writer wrote a chain, without the floating body, and renamed the joints); the file's own
    floating joint carries the body, with its inertial."""
    import dataclasses
    import warnings

    from symdyn.model.random_robots import random_tree_robot

    robot = random_tree_robot(4, n=5, base_joint=base_joint).nofriction(all=True)
    links = tuple(dataclasses.replace(link, Jm=0, name=f"j{k}") for k, link in enumerate(robot.links))
    robot = dataclasses.replace(robot, gravity=(0, 0, 9.81), links=links)  # what URDF can say
    text = robot.to_urdf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = Robot.from_urdf(text, tips="all", base_joint=base_joint)
    assert back.parents == robot.parents and back.joint_names == robot.joint_names
    assert (back.base_body is None) == (robot.base_body is None)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = robot.integrate(robot.neutral(), rng.normal(size=robot.nv)) if base_joint else rng.uniform(-1, 1, robot.n)
        v, a = rng.normal(size=(2, robot.nv))
        np.testing.assert_allclose(rne(back, q, v, a), rne(robot, q, v, a), atol=1e-12)


@pytest.mark.parametrize("change", [False, True])
def test_inertias_repaired_on_reading_are_written_and_read_back_without_repair(tmp_path, change):
    """inertia='balance' repairs (a chain link, and a rider on a locked branch) are what symdyn
    computes with, so they are what the spliced file holds: read → write → read (with the default
    check, nothing left to repair) gives the same τ, each repair said in a comment where it was."""
    import warnings

    from symdyn.model.urdf.xml import URDFError
    from tests.test_almost_right import BAD, _arm, _file, _inertial

    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(0.5, BAD), sensor=_inertial(0.2, BAD)))
    with pytest.raises(URDFError, match="impossible"):
        Robot.from_urdf(path, tip_link="l2")
    with pytest.warns(URDFWarning, match="impossible inertia made physical"):
        robot = Robot.from_urdf(path, tip_link="l2", inertia="balance")
    if change:  # an identified model: l1 (which carries the repaired sensor) and l2 changed
        robot = _changed(robot)
    text = robot.to_urdf(source=path)
    # the sensor's repair stays in its own inertial; l2's inertial is the identified body when changed
    assert text.count("impossible inertia made physical") == (1 if change else 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", URDFWarning)
        back = Robot.from_urdf(text, tip_link="l2")
    assert back.urdf.repairs == ()
    _assert_same_dynamics(robot, back)
    if not change:
        assert back.fingerprint() == robot.fingerprint()


def test_self_closing_elements_last_in_their_parent_are_replaced_alone():
    """expat reports a self-closing element's end at the next token: a `<dynamics/>` right before
    `</joint>` (and an `<inertia/>` before `</inertial>`) is replaced without its parent's end tag."""
    text = (
        '<robot name="arm"><link name="base"/><link name="l1"><inertial><mass value="1"/>'
        '<inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="5" velocity="2"/><dynamics damping="0.1"/></joint></robot>'
    )
    robot = from_urdf(text)
    changed = dataclasses.replace(robot, links=(dataclasses.replace(robot.links[0], B=0.7, m=2),))
    out = changed.to_urdf(source=text)
    assert out.count("</joint>") == 1 and '<dynamics damping="0.7" friction="0.0"/></joint>' in out
    back = from_urdf(out)
    assert float(back.links[0].B) == 0.7 and back.links[0].m == 2
