"""Files that are almost right (issue 34, item 4): moving bodies without mass, impossible
inertias (the way out named, the explicit repair `inertia="balance"` / `--balance-inertia`),
and the command line speaking its own words (`--tip LINK`, `--exclude LINK`), one model name
from Python and from the command line, `--batch` of any size, MJCF files refusing xacro options."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from symdyn import Robot
from symdyn.cli import build_parser, main
from symdyn.model.command_line import load
from symdyn.model.urdf import URDFError, URDFWarning
from symdyn.model.urdf.bodies import balanced, nearest_physical

MJCF = Path(__file__).parent / "mjcf_fixtures" / "branch.xml"


def _inertial(m=1.0, moments=(0.01, 0.01, 0.01)) -> str:
    xx, yy, zz = moments
    return (
        f'<inertial><mass value="{m}"/><origin xyz="0 0 0.1"/>'
        f'<inertia ixx="{xx}" iyy="{yy}" izz="{zz}" ixy="0" ixz="0" iyz="0"/></inertial>'
    )


def _arm(base="", l1="", l2="", sensor=None, mount="") -> str:
    """base -j1-> l1 -j2-> l2, and off the chain on l1 (fixed): mount -> sensor."""
    off = ""
    if sensor is not None:
        off = (
            f'<link name="mount">{mount}</link><link name="sensor">{sensor}</link>'
            '<joint name="jm" type="fixed"><parent link="l1"/><child link="mount"/></joint>'
            '<joint name="js" type="revolute"><parent link="mount"/><child link="sensor"/>'
            '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    return (
        f'<robot name="same_for_all"><link name="base">{base}</link><link name="l1">{l1}</link>'
        f'<link name="l2">{l2}</link>{off}'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/>'
        '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint></robot>'
    )


def _file(tmp_path: Path, text: str, name: str = "arm.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ---------------------------------------------------------------- moving bodies without mass


def test_a_file_without_any_inertial_is_refused_saying_so(tmp_path):
    with pytest.raises(URDFError, match="no link of this file has an <inertial>") as caught:
        Robot.from_urdf(_file(tmp_path, _arm()))
    assert "pivot" not in str(caught.value) and "massless=True" in str(caught.value)


def test_moving_links_without_inertial_are_named(tmp_path):
    with pytest.raises(URDFError, match=r"the moving link l2 has no <inertial>.*joint 2 moves no mass"):
        Robot.from_urdf(_file(tmp_path, _arm(base=_inertial(), l1=_inertial())))


def test_a_massless_intermediate_link_is_fine(tmp_path):
    robot = Robot.from_urdf(_file(tmp_path, _arm(l2=_inertial())))  # l1 carries nothing, l2 does
    assert robot.links[0].m == 0 and robot.links[1].m == 1


def test_massless_reads_it_with_a_warning_in_the_record(tmp_path):
    with pytest.warns(URDFWarning, match="no link of this file has an <inertial>"):
        robot = Robot.from_urdf(_file(tmp_path, _arm()), massless=True)
    assert "no link of this file has an <inertial>" in str(robot)


def test_print_warns_and_generate_refuses_a_file_without_inertials(tmp_path, capsys):
    path = _file(tmp_path, _arm())
    with pytest.warns(URDFWarning, match="no link of this file has an <inertial>"):
        assert main(["print", str(path), "--term", "G", "--no-cache"]) == 0
    assert "# warning: " in capsys.readouterr().out
    assert main(["generate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "no link of this file has an <inertial>" in err and "pivot" not in err and "symdyn show" in err


# ---------------------------------------------------------------- impossible inertias

BAD = (0.001, 0.001, 0.01)  # PR2's sensor mounts: I1 + I2 < I3


def test_an_impossible_inertia_off_the_chain_suggests_exclude_and_balance(tmp_path):
    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(), sensor=_inertial(0.2, BAD)))
    with pytest.raises(URDFError) as caught:
        Robot.from_urdf(path, tip_link="l2")
    message = str(caught.value)
    assert "link 'sensor' is off the chain, riding on the moving link 'l1'" in message
    assert "exclude=['sensor'] (or the branch it hangs from: exclude=['mount'])" in message
    assert "inertia='balance'" in message
    assert Robot.from_urdf(path, tip_link="l2", exclude=["mount"]).n == 2  # the way out works
    with pytest.raises(URDFError) as caught:
        load(str(path), tip="l2")
    said = str(caught.value)
    assert "--exclude sensor (or the branch it hangs from: --exclude mount)" in said and "--balance-inertia" in said
    assert "exclude=[" not in said and "inertia='balance'" not in said


def test_an_impossible_inertia_on_the_chain_offers_the_repair(tmp_path):
    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(0.5, BAD)))
    with pytest.raises(URDFError, match="link 'l2' is on the chain: correct the file, or repair it with inertia="):
        Robot.from_urdf(path)


def test_balance_repairs_and_reports_each_body(tmp_path):
    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(0.5, BAD), sensor=_inertial(0.2, BAD)))
    with pytest.warns(URDFWarning, match="impossible inertia made physical"):
        robot = Robot.from_urdf(path, tip_link="l2", inertia="balance")
    repairs = {r.link: r for r in robot.urdf.repairs}
    assert set(repairs) == {"l2", "sensor"}
    r = repairs["l2"]
    assert r.before == pytest.approx(BAD) and r.after == pytest.approx(
        [0.011 / 3, 0.011 / 3, 0.022 / 3]
    )  # d = 0.008: +d/3, +d/3, -d/3
    assert r.change == pytest.approx(np.linalg.norm(np.subtract(r.after, r.before)) / 0.01)
    text = str(robot)
    assert "inertia='balance', --balance-inertia" in text and "I3 0.01 -> 0.00733333" in text
    assert "--balance-inertia" in robot.urdf.command_args()
    I = np.array(robot.links[1].I, dtype=float)  # the repaired body alone (nothing else rides on l2)
    eig = np.linalg.eigvalsh(I)
    assert eig[0] + eig[1] >= eig[2] * (1 - 1e-12) and np.allclose(eig, r.after)
    robot = load(str(path), tip="l2", balance_inertia=True)  # the command line's flag
    assert len(robot.urdf.repairs) == 2


def test_an_exporter_s_numerical_zeros_are_a_point_mass_by_default_and_under_balance(tmp_path):
    """iCub's URDF gives seven links inertias of ±5e-20 (an exporter's zeros), which Pinocchio reads
    as a point mass.  Every check takes them within the same tolerances (`symdyn.model.inertia`):
    the file loads as it is, the same with inertia='balance' (nothing to repair), and the link's
    inertia is what the file says.  The triangle test had no absolute floor, the semidefinite
    test and the repair had: the file was refused, and the repair it suggested failed.  A small
    body's real defect is still refused, however small its moments."""
    for k, zeros in enumerate([(-5.42101e-20, -5.42101e-20, 0.0), (-1.8e-22, 0.0, 4.08e-18), (1e-20, -3e-20, 2e-20)]):
        path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(0.5, zeros)), f"zeros{k}.urdf")
        for options in ({}, {"inertia": "balance"}):
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                robot = Robot.from_urdf(path, **options)
            assert np.array_equal(np.diag(np.array(robot.links[1].I, dtype=float)), zeros), options
            assert not robot.urdf.repairs
    for k, small in enumerate([(2e-13, 2e-13, 1e-12), (1e-13, 1e-13, 2.5e-13), (0.0, 0.0, 1e-14)]):
        path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(0.5, small)), f"small{k}.urdf")
        with pytest.raises(URDFError, match="violate the triangle inequality"):
            Robot.from_urdf(path)
        repaired = Robot.from_urdf(path, inertia="balance")  # the repair's result passes the same test
        assert [r.link for r in repaired.urdf.repairs] == ["l2"]


def _physical(moments, tol=1e-12) -> bool:
    a, b, c = moments
    scale = max(abs(a), abs(b), abs(c), 1e-300)
    return min(a + b - c, a + c - b, b + c - a) >= -tol * scale


@pytest.mark.parametrize(
    "moments",
    [(0.001, 0.001, 0.01), (1.0, 2.0, 5.0), (-1e-3, 1.0, 1.0), (-1.0, -1.0, 1.0), (-1.0, -2.0, -3.0), (1.0, 1.0, 1.0)],
)
def test_the_repair_is_the_nearest_physical_moments(moments):
    x = nearest_physical(moments)
    assert _physical(x)
    if _physical(moments):
        assert np.array_equal(x, moments)
    # no physical point of a fine grid around the moments is nearer (the cone is convex: a projection)
    rng = np.random.default_rng(0)
    span = 2 * np.linalg.norm(np.subtract(x, moments)) + 1e-9
    trial = np.asarray(moments) + rng.uniform(-span, span, (20000, 3))
    ok = np.array([_physical(t, 0) for t in trial])
    nearest = np.linalg.norm(trial[ok] - moments, axis=1).min() if ok.any() else np.inf
    assert np.linalg.norm(x - moments) <= nearest + 1e-12


def test_the_repair_is_the_nearest_physical_inertia_matrix():
    """Against a direct search over every physical inertia J = tr(S) 1 - S, S = L L^T >= 0 (any axes)."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(1)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    I0 = R @ np.diag([0.002, 0.003, 0.01]) @ R.T
    J, _, _ = balanced(tuple(map(tuple, I0)))
    ours = np.linalg.norm(np.array(J, dtype=float) - I0)

    def distance(v):
        L = np.array([[v[0], 0, 0], [v[1], v[2], 0], [v[3], v[4], v[5]]])
        S = L @ L.T
        return np.linalg.norm(np.trace(S) * np.eye(3) - S - I0)

    best = min(minimize(distance, rng.normal(scale=0.05, size=6), method="BFGS").fun for _ in range(8))
    assert ours <= best + 1e-9 and ours > 0


def test_inertia_takes_check_or_balance():
    with pytest.raises(URDFError, match="inertia must be 'check' or 'balance'"):
        Robot.from_urdf(_arm(), inertia="mujoco")


# ---------------------------------------------------------------- the command line's words


def test_several_leaves_suggest_tip_on_the_command_line(tmp_path):
    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial(), sensor=_inertial()))
    with pytest.raises(URDFError, match=r"tip_link=…"):
        Robot.from_urdf(path)
    with pytest.raises(URDFError) as caught:
        load(str(path))
    assert "--tip LINK" in str(caught.value) and "tip_link" not in str(caught.value)
    with pytest.raises(URDFError, match="--tip nowhere is not a link"):
        load(str(path), tip="nowhere")


def test_a_model_has_the_same_name_from_python_and_the_command_line(tmp_path):
    path = _file(tmp_path, _arm(l1=_inertial(), l2=_inertial()), "two_link.urdf")
    assert Robot.from_urdf(path).name == load(str(path)).name == "two_link"
    assert Robot.from_urdf(path, name="mine").name == load(str(path), name="mine").name == "mine"
    assert Robot.from_urdf(path.read_text()).name == "same_for_all"  # text has no file: its <robot name>


def test_an_mjcf_file_is_named_after_its_file_too():
    pytest.importorskip("mujoco")
    assert Robot.from_mjcf(MJCF, tip_body="tcp").name == "branch"


@pytest.mark.parametrize("option", [{"xacro_arg": ["a:=1"]}, {"package_path": ["/tmp"]}])
def test_an_mjcf_file_refuses_xacro_options_by_name(option):
    flag = "--xacro-arg" if "xacro_arg" in option else "--package-path"
    with pytest.raises(ValueError, match=f"{flag} apply to a xacro file, not to the MJCF file"):
        load(str(MJCF), tip="tcp", **option)


def test_tip_and_base_help_say_link_or_body():
    text = build_parser()._subparsers._group_actions[0].choices["generate"].format_help()
    assert "(an MJCF file's: BODY)" in " ".join(text.split())


def test_bench_batch_takes_any_size_from_one(monkeypatch):
    from symdyn.bench import compare

    class Reached(Exception):
        pass

    def reached(names):
        raise Reached

    monkeypatch.setattr(compare, "model_names", reached)
    for size in ("1", "1000"):
        with pytest.raises(Reached):
            compare.main(["--batch", size])
    with pytest.raises(ValueError, match="--batch, --calls, --pin-calls, --reps and --rounds must be at least 1"):
        compare.main(["--batch", "0"])


def test_no_warning_for_a_sound_file(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Robot.from_urdf(_file(tmp_path, _arm(l1=_inertial(), l2=_inertial())))


def test_every_impossible_inertia_is_named_in_one_error(tmp_path):
    """A file with several impossible inertias on moving bodies (ANYmal C has five) is refused once,
    naming each with its way out, so that a user fixes them all in one pass."""
    path = _file(tmp_path, _arm(l1=_inertial(0.5, BAD), l2=_inertial(0.5, BAD), sensor=_inertial(0.2, BAD)))
    with pytest.raises(URDFError) as caught:
        Robot.from_urdf(path, tip_link="l2")
    message = str(caught.value)
    assert "3 bodies that move are no physical body" in message
    for link in ("l1", "l2", "sensor"):
        assert f"link '{link}'" in message
    assert message.count("inertia='balance'") == 3
    with pytest.raises(URDFError) as caught:
        load(str(path), tip="l2")
    assert str(caught.value).count("--balance-inertia") == 3


def test_show_draws_a_file_with_impossible_inertias_and_says_so(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="pictures need matplotlib (the plot extra)")
    path = _file(tmp_path, _arm(l1=_inertial(0.5, BAD), l2=_inertial(0.5, BAD)))
    out = tmp_path / "arm.png"
    assert main(["show", str(path), "--out", str(out)]) == 0
    assert out.is_file()
    err = capsys.readouterr().err
    assert "2 bodies that move are no physical body" in err and "drawn with those inertias repaired" in err
