"""xacro files read without ROS (issue 34, item 1).

`Robot.from_urdf` and every command that takes a URDF also take `.xacro`
files, expanded in-process by ROS's xacro (the PyPI package) with symdyn's
package resolution: `package_paths`/--package-path, ROS_PACKAGE_PATH,
AMENT_PREFIX_PATH, the folders above the file.  The fixtures are two small
ROS-style packages: arm_description (the arm, in xacro, and the same arm
written as plain URDF by hand) and arm_parts (its macros, in a folder named
`parts`: found by its package.xml).
"""

import hashlib
import importlib.util
import shlex
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from symdyn import cli, reference
from symdyn.model import Robot, URDFError, URDFWarning, command_line
from symdyn.model.urdf.xacro import PackageNotFound, Packages, XacroError

#: Expanding needs ROS's xacro package (the test extra): without it every test here skips, saying so.
pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("xacro") is None,
    reason="xacro files are expanded by the xacro package (the test extra): pip install 'symdyn[xacro]'",
)

FIXTURES = Path(__file__).parent / "xacro_fixtures"
XACRO = FIXTURES / "arm_description" / "urdf" / "arm.urdf.xacro"
PLAIN = FIXTURES / "arm_description" / "urdf" / "arm.urdf"
LONG = {"arm_type": "long"}


@pytest.fixture(scope="module")
def arm():
    return Robot.from_urdf(XACRO, xacro_args=LONG)


def test_expanded_robot_is_the_robot_written_as_plain_urdf(arm):
    """Macros from another package, $(find), $(arg), $(eval), properties and property blocks,
    ${pi/2}, ${2*50}, *block and **block parameters, xacro:if/unless: the same dynamics."""
    plain = Robot.from_urdf(PLAIN)
    assert arm.fingerprint() == plain.fingerprint()
    rng = np.random.default_rng(34)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, (3, arm.n))
        np.testing.assert_allclose(reference.rne(arm, q, qd, qdd), reference.rne(plain, q, qd, qdd), rtol=1e-14)
    assert [link.B for link in arm.links] == [0.5, 1.0, 0.5]  # ${effort/100} with effort="${2*50}"
    assert arm.links[1].m == 3.0  # $(eval 2 * 1.5)


def test_arguments_choose_the_robot(arm):
    short = Robot.from_urdf(XACRO, xacro_args={"arm_type": "short"})
    assert short.fingerprint() != arm.fingerprint()
    assert float(short.links[2].origin[2][3]) == 0.3 and float(arm.links[2].origin[2][3]) == 0.5
    bare = Robot.from_urdf(XACRO, xacro_args={"arm_type": "long", "with_tool": False})  # xacro:unless
    assert bare.urdf.tip_link == "flange" and arm.urdf.tip_link == "tool"
    assert bare.urdf.xacro_args == (("arm_type", "long"), ("with_tool", "false"))


def test_record_names_the_xacro_file_its_sha256_arguments_and_packages(arm):
    record = arm.urdf
    assert record.is_xacro and record.file == "arm.urdf.xacro"
    assert record.sha256 == hashlib.sha256(XACRO.read_bytes()).hexdigest()
    assert record.xacro_args == (("arm_type", "long"),) and record.packages == ("arm_parts",)
    assert len(record.expanded_sha256) == 64 and record.expanded_sha256 != record.sha256
    assert "--xacro-arg=arm_type:=long" in shlex.split(record.command_args())
    text = str(arm)
    assert f"xacro arm.urdf.xacro (sha256 {record.sha256})" in text
    assert "arguments arm_type:=long; packages arm_parts" in text
    assert str(FIXTURES) not in text  # folders are the reader's, not the model's


def test_package_paths_come_first_then_the_environment_then_the_folders_above(tmp_path, monkeypatch):
    for var in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"):
        monkeypatch.delenv(var, raising=False)
    ws = tmp_path / "ws" / "src" / "repo" / "renamed"
    ws.mkdir(parents=True)
    (ws / "package.xml").write_text("<package><name>arm_parts</name></package>")
    ament = tmp_path / "install" / "share" / "arm_parts"
    ament.mkdir(parents=True)
    start = XACRO.parent
    assert Packages((), start).find("arm_parts") == FIXTURES / "parts"  # above the file, by package.xml
    assert Packages((), start).find("arm_description") == FIXTURES / "arm_description"
    assert Packages([tmp_path / "ws"], start).find("arm_parts") == ws  # crawled below the given folder
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    assert Packages((), start).find("arm_parts") == ament
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    assert Packages((), start).find("arm_parts") == ws


def test_package_uri_in_an_include_and_xacro_text(tmp_path, arm):
    text = XACRO.read_text().replace("$(find arm_parts)", "package://arm_parts")
    assert "package://arm_parts/urdf/macros.xacro" in text
    copy = tmp_path / "arm.xacro"
    copy.write_text(text)
    robot = Robot.from_urdf(copy, xacro_args=LONG, package_paths=[FIXTURES])
    assert robot.fingerprint() == arm.fingerprint() and robot.urdf.file == "arm.xacro"
    from_text = Robot.from_urdf(text, xacro_args=LONG, package_paths=[FIXTURES])  # the xacro namespace says so
    assert from_text.fingerprint() == arm.fingerprint()


def test_missing_argument_is_named_with_how_to_give_it():
    with pytest.raises(XacroError) as exc:
        Robot.from_urdf(XACRO)
    assert "xacro argument 'arm_type' has no value and no default" in str(exc.value)
    assert "xacro_args={'arm_type': ...}" in str(exc.value) and "arm.urdf.xacro" in str(exc.value)
    assert isinstance(exc.value, URDFError) and isinstance(exc.value, ValueError)


def test_missing_package_names_it_and_every_place_looked(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rospath"))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    bad = tmp_path / "robot.urdf.xacro"
    bad.write_text(XACRO.read_text().replace("$(find arm_parts)", "$(find no_such_pkg)"))
    (tmp_path / "pp").mkdir()
    with pytest.raises(XacroError) as exc:
        Robot.from_urdf(bad, xacro_args=LONG, package_paths=[tmp_path / "pp"])
    message = str(exc.value)
    assert "ROS package 'no_such_pkg' not found" in message
    assert f"{tmp_path / 'pp'} (package path" in message
    assert f"{tmp_path / 'rospath'} (ROS_PACKAGE_PATH" in message
    assert f"{tmp_path} and its subfolders (above the file)" in message
    assert "(AMENT_PREFIX_PATH not set)" in message and "package_paths=['DIR']" in message
    with pytest.raises(PackageNotFound):
        Packages([tmp_path / "pp"], tmp_path).find("no_such_pkg")


def test_xacro_options_on_a_plain_urdf_are_refused():
    with pytest.raises(XacroError, match="xacro_args apply to a xacro file"):
        Robot.from_urdf(PLAIN, xacro_args=LONG)
    with pytest.raises(URDFError, match="package path .* is not a folder"):
        Robot.from_urdf(XACRO, xacro_args=LONG, package_paths=[FIXTURES / "nowhere"])


def test_without_the_xacro_package_the_error_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "xacro", None)
    with pytest.raises(XacroError, match=r"needs the xacro package: pip install 'symdyn\[xacro\]'"):
        Robot.from_urdf(XACRO, xacro_args=LONG)


def test_xacro_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.xacro"
    bad.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r"><xacro:nope/></robot>')
    with pytest.raises(XacroError, match=r"bad.xacro: xacro: .*nope"):
        Robot.from_urdf(bad)


def test_xacro_warnings_are_urdf_warnings(tmp_path):
    """What xacro prints as a warning (here: a property hiding the constant pi) reaches the caller."""
    path = tmp_path / "warn.urdf.xacro"
    path.write_text(
        XACRO.read_text().replace(
            '<xacro:property name="radius" value="0.05"/>',
            '<xacro:property name="radius" value="0.05"/>\n  <xacro:property name="pi" value="3"/>',
        )
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Robot.from_urdf(path, xacro_args=LONG, package_paths=[FIXTURES])
    messages = [str(w.message) for w in caught if issubclass(w.category, URDFWarning)]
    assert any("warn.urdf.xacro: xacro:" in m and "pi" in m for m in messages), messages


# ---- the command line
def test_is_urdf_and_help_know_xacro():
    assert command_line.is_urdf("robot.urdf.xacro") and command_line.is_urdf("robot.xacro")
    parser = __import__("argparse").ArgumentParser()
    command_line.add_arguments(parser)
    text = parser.format_help()
    assert "xacro (.xacro, .urdf.xacro" in text and "--xacro-arg NAME:=VALUE" in text and "--package-path DIR" in text


def test_cli_generate_on_a_xacro_file_rebuilds_by_its_regenerate_command(tmp_path, monkeypatch):
    out = tmp_path / "gen"
    argv = ["generate", str(XACRO), "--tip", "tool", "--xacro-arg", "arm_type:=long"]
    argv += ["--package-path", str(FIXTURES), "--target", "numpy", "--out", str(out)]
    assert cli.main(argv) == 0
    module = out / "arm.py"
    head = module.read_text().split('"""', 2)[1]
    assert f"xacro arm.urdf.xacro (sha256 {hashlib.sha256(XACRO.read_bytes()).hexdigest()})" in head
    assert "expanded by xacro with arguments arm_type:=long; packages arm_parts" in head
    regenerate = next(line for line in head.splitlines() if line.startswith("regenerate: "))
    assert "--xacro-arg=arm_type:=long" in regenerate and str(FIXTURES) not in head
    monkeypatch.chdir(XACRO.parent)  # run beside the file, as the header says
    again = tmp_path / "again"
    assert cli.main([*shlex.split(regenerate.split(": ", 1)[1])[1:], "--out", str(again)]) == 0
    assert (again / "arm.py").read_bytes() == module.read_bytes()


def test_cli_errors_name_the_flags(tmp_path, capsys):
    argv = ["generate", str(XACRO), "--target", "numpy", "--out", str(tmp_path)]
    assert cli.main(argv) != 0
    assert "pass --xacro-arg arm_type:=VALUE" in capsys.readouterr().err
    with pytest.raises(ValueError, match=r"--xacro-arg arm_type=long: expected NAME:=VALUE"):
        command_line.load(str(XACRO), xacro_arg=["arm_type=long"])
    bad = tmp_path / "robot.urdf.xacro"
    bad.write_text(XACRO.read_text().replace("$(find arm_parts)", "$(find no_such_pkg)"))
    with pytest.raises(XacroError, match="add the folder that holds it: --package-path DIR"):
        command_line.load(str(bad), xacro_arg=["arm_type:=long"])
    with pytest.raises(ValueError, match="--xacro-arg and --package-path apply to a xacro file"):
        command_line.load(str(PLAIN), package_path=[str(FIXTURES)])


def test_a_relative_package_path_is_taken_from_the_working_folder_once(tmp_path, monkeypatch, arm):
    """--package-path ws/src (relative): $(find pkg) names the package's absolute folder, so the
    includes are not joined to the including file's folder a second time."""
    copy = tmp_path / "elsewhere" / "arm.urdf.xacro"
    copy.parent.mkdir()
    copy.write_text(XACRO.read_text())
    monkeypatch.chdir(FIXTURES.parent)
    robot = Robot.from_urdf(copy, xacro_args=LONG, package_paths=[FIXTURES.name])
    assert robot.fingerprint() == arm.fingerprint()
    assert command_line.load(str(copy), xacro_arg=["arm_type:=long"], package_path=[FIXTURES.name]).n == robot.n


def test_symdyn_expand_prints_the_urdf_symdyn_reads(tmp_path, capsys, arm):
    """`symdyn expand FILE.xacro --xacro-arg k:=v > robot.urdf`: other tools get what symdyn read."""
    from symdyn.model import expand_xacro

    assert cli.main(["expand", str(XACRO), "--xacro-arg", "arm_type:=long"]) == 0
    text = capsys.readouterr().out
    assert text.rstrip("\n") == expand_xacro(XACRO, xacro_args=LONG).rstrip("\n")
    out = tmp_path / "robot.urdf"
    out.write_text(text)
    assert Robot.from_urdf(out).fingerprint() == arm.fingerprint()
    with pytest.raises(XacroError, match="is not a xacro file"):
        expand_xacro(PLAIN)
