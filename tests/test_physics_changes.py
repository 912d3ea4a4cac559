"""What changes the physics of a robot read from a file is said (issue 34, item 3).

Snapping: a file that writes π/2 as 1.570796327 (2e-10 off, as the UR ROS 2
description does) is snapped to exact quarter turns, and the record —
`print(robot)`, generated headers — states how far that moves τ, M and q̈:
the largest relative change over 200 random states, computed by the reference
on both readings of the file.  Friction and rotor inertia read from the file
are said by `print(robot)` and on stderr by every command that loads a file;
`--no-friction` leaves the friction out, as `robot.nofriction(all=True)`.
"""

import argparse
from pathlib import Path

import numpy as np
import pytest

from symdyn import Robot, cli
from symdyn.codegen.entry import _provenance_lines
from symdyn.model import command_line, snapping
from symdyn.model.snapping import SnapEffect, Snapping
from symdyn.numeric import reference as ref
from symdyn.numeric.snap_effect import STATES, effect_states, snap_effect

INERTIALS = """
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0 0.1"/><mass value="2"/>
    <inertia ixx="0.02" iyy="0.03" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="1.5"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l3"><inertial><origin xyz="0.1 0.02 0"/><mass value="1"/>
    <inertia ixx="0.005" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
"""
LIMIT = '<limit lower="-3" upper="3" effort="10" velocity="2"/>'


def _urdf(rpy2: str, rpy3: str, dynamics: tuple = ("", "", "")) -> str:
    joints = [("j1", "base", "l1", "0 0 0.3", "0 0 0"), ("j2", "l1", "l2", "0 0 0.2", rpy2)]
    joints.append(("j3", "l2", "l3", "0.4 0 0", rpy3))
    body = "".join(
        f'  <joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/>{LIMIT}{extra}</joint>\n'
        for (name, parent, child, xyz, rpy), extra in zip(joints, dynamics)
    )
    return f'<robot name="arm">{INERTIALS}{body}</robot>\n'


#: Quarter turns to 9 decimals (1.570796327, 2.05e-10 off) on two joints; damping on j1 and j2,
#: Coulomb friction on j1.
FRICTION = ('<dynamics damping="0.5" friction="0.2"/>', '<dynamics damping="0.3"/>', "")
NINE_DECIMALS = _urdf("1.570796327 0 0", "-1.570796327 0 1.570796327", FRICTION)
EXACT = _urdf("0 0 0", "0 0 0")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("urdf")
    out = {}
    for name, text in (("nine", NINE_DECIMALS), ("exact", EXACT)):
        out[name] = folder / f"{name}.urdf"
        out[name].write_text(text)
    return out


@pytest.fixture(scope="module")
def nine(files) -> Robot:
    return Robot.from_urdf(files["nine"])


# --------------------------------------------------------------------------- snapping


def test_snap_effect_is_what_the_reference_computes_on_both_readings(files, nine):
    literal = Robot.from_urdf(files["nine"], snap=False)
    q, qd, qdd = effect_states(literal)
    assert len(q) == STATES >= 200
    tau = ref.rne(literal, q, qd, qdd)
    d_tau = np.abs(ref.rne(nine, q, qd, qdd) - tau).max(-1) / np.abs(tau).max(-1)
    M, M_lit = ref.inertia(nine, q), ref.inertia(literal, q)
    d_M = np.abs(M - M_lit).max((-2, -1)) / np.abs(M_lit).max((-2, -1))
    a, a_lit = ref.accel(nine, q, qd, tau), ref.accel(literal, q, qd, tau)
    d_a = np.abs(a - a_lit).max(-1) / np.abs(a_lit).max(-1)
    effect = nine.urdf.snapping.effect
    assert effect.states == STATES
    assert effect.tau == pytest.approx(d_tau.max(), rel=1e-12)
    assert effect.M == pytest.approx(d_M.max(), rel=1e-12)
    assert effect.qdd == pytest.approx(d_a.max(), rel=1e-12)
    # a 2e-10 rad snap moves the dynamics by about that much, and q̈ by M's conditioning more
    assert 1e-11 < effect.M < 1e-8 and 1e-11 < effect.tau < 1e-8 and 1e-11 < effect.qdd < 1e-5


def test_print_states_how_far_the_snaps_move_the_dynamics(nine):
    e = nine.urdf.snapping.effect
    line = (
        f"snaps change tau by at most {e.tau:.1e}, M by {e.M:.1e}, qdd by {e.qdd:.1e} "
        f"(relative, 200 random states; --no-snap or snap=False keeps the file's numbers)"
    )
    lines = str(nine).splitlines()
    assert line in lines
    assert lines.index(line) == lines.index("snapped to exact values (3, largest change 2.05e-10):") + 4


def test_the_header_states_it_and_stays_the_same_byte_for_byte(files, nine):
    source, notes, command = _provenance_lines(nine)
    assert nine.urdf.snapping.effect.line() in notes
    again = _provenance_lines(Robot.from_urdf(files["nine"]))
    assert again == (source, notes, command)


def test_a_file_without_snaps_reports_none(files):
    robot = Robot.from_urdf(files["exact"])
    assert robot.urdf.snaps == () and robot.urdf.snapping is None
    assert "snap" not in str(robot)


def test_snap_false_keeps_the_files_numbers_and_measures_nothing(files):
    literal = Robot.from_urdf(files["nine"], snap=False)
    assert literal.urdf.snapping is None and "numbers as written (snap=False)" in str(literal)
    assert "snaps change" not in str(literal)


def test_snapping_keeps_both_readings_without_their_records(files, nine):
    both = nine.urdf.snapping
    assert both.snapped.fingerprint() == nine.fingerprint() and both.snapped.urdf is None
    assert both.literal.fingerprint() == Robot.from_urdf(files["nine"], snap=False).fingerprint()
    assert both.literal.urdf is None and both.literal.fingerprint() != nine.fingerprint()


@pytest.mark.parametrize(
    "effect, said",
    [
        (
            SnapEffect(2.1e-10, 3.04e-11, 1.9e-8, 200),
            "snaps change tau by at most 2.1e-10, M by 3.0e-11, qdd by 1.9e-08",
        ),
        (SnapEffect(0.0, 0.0, 0.0, 200), "snaps leave tau, M and qdd unchanged, bit for bit (200 random states;"),
        (SnapEffect(4e-17, 0.0, 2e-10, 200), "snaps change tau by at most < 1e-13, M by 0, qdd by 2.0e-10"),
        (SnapEffect(1e-9, 1e-9, None, 200), "qdd not defined (M is singular)"),
    ],
)
def test_the_effect_line_reads_well(effect, said):
    assert said in effect.line() and effect.line().isascii()


def test_the_measure_needs_the_reference_installed(nine, monkeypatch):
    monkeypatch.setattr(snapping, "_measure", None)
    with pytest.raises(RuntimeError, match="no snap-effect measure is installed"):
        _ = Snapping(nine, nine).effect


def test_robots_of_different_files_are_refused(nine, files):
    with pytest.raises(ValueError, match="the snapped robot has 3 joints, the literal one 2"):
        snap_effect(nine, Robot.from_urdf(files["nine"], tip_link="l2"))
    with pytest.raises(ValueError, match="count must be at least 1"):
        effect_states(nine, 0)


# --------------------------------------------------------------------------- friction


FRICTION_LINE = (
    "friction read from the file: viscous on 2 joints (damping), Coulomb on 1 (friction): "
    "tau includes them; --no-friction (robot.nofriction(all=True)) leaves them out"
)
LEFT_OUT = (
    "friction read from the file, left out (--no-friction, robot.nofriction(all=True)): "
    "viscous on 2 joints (damping), Coulomb on 1 (friction); tau has none"
)


def test_print_shows_the_friction_read_from_the_file(nine, files):
    assert FRICTION_LINE in str(nine).splitlines()
    assert (nine.urdf.viscous, nine.urdf.coulomb) == (("j1", "j2"), ("j1",))
    assert "friction" not in str(Robot.from_urdf(files["exact"]))


def test_nofriction_says_what_it_left_out(nine):
    bare = nine.nofriction(all=True)
    assert LEFT_OUT in str(bare).splitlines() and FRICTION_LINE not in str(bare)
    assert bare.urdf.describes(bare) and bare.urdf.command_args().endswith("--no-friction")
    viscous = nine.nofriction()
    assert (
        "friction read from the file: viscous on 2 joints (damping): tau includes it; Coulomb on 1 (friction) "
        "left out (robot.nofriction()); --no-friction leaves out both"
    ) in str(viscous).splitlines()
    assert not viscous.urdf.describes(viscous)  # no option rebuilds it: a header says it changed
    assert LEFT_OUT in str(viscous.nofriction(all=True)).splitlines()


def _parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    command_line.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_every_command_that_loads_a_file_says_its_friction(files, nine, capsys):
    robot = command_line.from_args(_parse(str(files["nine"])))
    assert capsys.readouterr().err.splitlines() == [f"symdyn: {FRICTION_LINE}"]
    q, qd, qdd = np.array([0.3, -0.7, 1.1]), np.array([0.5, -1.0, 0.8]), np.array([0.2, 0.1, -0.4])
    assert np.array_equal(ref.rne(robot, q, qd, qdd), ref.rne(nine, q, qd, qdd))
    command_line.from_args(_parse(str(files["exact"])))
    assert capsys.readouterr().err == ""


def test_no_friction_leaves_the_files_friction_out(files, nine, capsys):
    robot = command_line.from_args(_parse(str(files["nine"]), "--no-friction"))
    assert capsys.readouterr().err.splitlines() == [f"symdyn: {LEFT_OUT}"]
    q, qd, qdd = np.array([0.3, -0.7, 1.1]), np.array([0.5, -1.0, 0.8]), np.array([0.2, 0.1, -0.4])
    tau = ref.rne(robot, q, qd, qdd)
    assert np.array_equal(tau, ref.rne(nine.nofriction(all=True), q, qd, qdd))
    assert not np.allclose(tau, ref.rne(nine, q, qd, qdd))
    assert robot.fingerprint() == nine.nofriction(all=True).fingerprint()
    assert "--no-friction" in _provenance_lines(robot)[2]  # the header's command rebuilds it


def test_the_command_line_says_it(files, capsys):
    assert cli.main(["print", str(files["nine"]), "--term", "G", "--no-cache"]) == 0
    out, err = capsys.readouterr()
    assert f"symdyn: {FRICTION_LINE}" in err.splitlines() and f"# {FRICTION_LINE}" in out.splitlines()
    assert "# snaps change tau by at most" in out


def test_no_friction_is_for_files(capsys):
    with pytest.raises(ValueError, match="--no-friction apply to a URDF file, not to the shipped model 'puma560'"):
        command_line.load("puma560", no_friction=True)


def test_mjcf_rotor_inertia_and_friction_are_said(capsys):
    pytest.importorskip("mujoco")
    arm = Path(__file__).parent / "mjcf_fixtures" / "menagerie_arm.xml"
    robot = command_line.from_args(_parse(str(arm)))
    rotor = (
        "rotor inertia read from the file: armature on 6 joints (Jm, G = 1): M includes it on its diagonal; "
        "--no-friction keeps it"
    )
    friction = (
        "friction read from the file: viscous on 6 joints (damping), Coulomb on 6 (frictionloss): tau includes "
        "them; --no-friction (robot.nofriction(all=True)) leaves them out"
    )
    assert capsys.readouterr().err.splitlines() == [f"symdyn: {rotor}", f"symdyn: {friction}"]
    assert {rotor, friction} <= set(str(robot).splitlines())
    bare = command_line.from_args(_parse(str(arm), "--no-friction"))
    assert all(link.B == 0 and link.Tc == (0, 0) and link.Jm != 0 for link in bare.links)
    assert bare.mjcf.describes(bare) and bare.mjcf.command_args().endswith("--no-friction")
    assert "friction read from the file, left out (--no-friction" in capsys.readouterr().err
