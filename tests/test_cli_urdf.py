"""`symdyn generate` and `symdyn print` on any URDF file (issue 22, item 5).

MODEL is a shipped model's name or a URDF file; --tip, --base, --lock,
--exclude and --no-snap choose the chain as `Robot.from_urdf` does.  The
generated files name the file by its name and sha256 (never its folder), list
what was locked, excluded and snapped, and say the command that rebuilds them,
which does so byte for byte.
"""

import hashlib
import shlex
from pathlib import Path

import pytest

from symdyn import cli
from symdyn.model import arms, command_line

URDF = Path(__file__).parent / "urdf" / "branches.urdf"
#: branches.urdf's main chain with its last joint held at 0.5 rad (three joints move), the finger and the
#: camera left out (the finger's inertia is physically impossible: it must not enter).
OPTIONS = ["--tip", "hand", "--lock", "j4=0.5", "--exclude", "finger", "--exclude", "camera"]


def _header(path: Path) -> list[str]:
    """The provenance comment of a generated .c/.h/.py."""
    return [line.lstrip("/* ").rstrip() for line in path.read_text().split("\n\n", 1)[0].splitlines()]


def _field(lines: list[str], name: str) -> str:
    return next(line for line in lines if line.startswith(f"{name}: ")).split(": ", 1)[1]


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """C of branches.urdf (given by its absolute path) written into a fresh folder."""
    out = tmp_path_factory.mktemp("gen")
    assert cli.main(["generate", str(URDF.resolve()), *OPTIONS, "--target", "c", "--out", str(out)]) == 0
    return out


def test_generate_writes_the_files_named_after_the_urdf_file(generated):
    assert sorted(p.name for p in generated.iterdir()) == ["branches.c", "branches.h"]


@pytest.mark.parametrize("suffix", [".c", ".h"])
def test_header_names_the_file_by_name_and_sha256_and_no_folder(generated, suffix):
    text = (generated / f"branches{suffix}").read_text()
    head = "\n".join(_header(generated / f"branches{suffix}"))
    assert str(URDF.parent.resolve()) not in text and str(generated) not in text and "/tests/" not in head
    source = _field(_header(generated / f"branches{suffix}"), "model source")
    assert "branches.urdf" in source and hashlib.sha256(URDF.read_bytes()).hexdigest() in source


def test_header_lists_what_was_locked_and_excluded(generated):
    head = "\n".join(_header(generated / "branches.c"))
    assert "j4 = 0.5 -> l3" in head
    assert "excluded" in head and "finger" in head and "camera" in head


def test_regenerate_line_rebuilds_the_files_byte_for_byte(generated, tmp_path, monkeypatch):
    command = shlex.split(_field(_header(generated / "branches.c"), "regenerate"))
    assert command[:3] == ["symdyn", "generate", "branches.urdf"], command
    monkeypatch.chdir(URDF.parent)  # the line names the file alone: it runs beside it
    assert cli.main([*command[1:], "--out", str(tmp_path)]) == 0
    for name in ("branches.c", "branches.h"):
        assert (tmp_path / name).read_bytes() == (generated / name).read_bytes(), name


@pytest.mark.parametrize("model", ["branches.urdf", "twolink"])
def test_chosen_frames_are_on_the_regenerate_line_and_rebuild_the_files(model, tmp_path, monkeypatch):
    """--frames changes the generated code: the header's command says them, and rebuilds the files
    byte for byte (a file's tree and a shipped arm)."""
    monkeypatch.chdir(URDF.parent)
    options, link = (OPTIONS, "l2") if model.endswith(".urdf") else ([], "link1")
    argv = ["generate", model, *options, "--frames", link, "tool", "--target", "numpy", "--out", str(tmp_path / "a")]
    assert cli.main(argv) == 0
    (written,) = (tmp_path / "a").iterdir()
    command = shlex.split(_field(_header(written), "regenerate"))
    assert command[-5:] == ["--frames", link, "tool", "--target", "numpy"], command
    assert cli.main([*command[1:], "--out", str(tmp_path / "b")]) == 0
    assert (tmp_path / "b" / written.name).read_bytes() == written.read_bytes()


def test_generate_without_out_writes_out_and_the_file_stem(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert (
        cli.main(["generate", str(URDF), "--tip", "hand", "--exclude", "finger", "--no-snap", "--target", "numpy"]) == 0
    )
    head = _header(tmp_path / "out" / "branches" / "branches.py")
    assert "--no-snap" in _field(head, "regenerate") and any("snap=False" in line for line in head)


def test_print_reads_a_urdf_file(capsys):
    assert cli.main(["print", str(URDF), *OPTIONS, "--term", "G"]) == 0
    out = capsys.readouterr().out
    assert "G1 = " in out and "G3 = " in out and "G4" not in out
    assert "# branches by newton-euler" in out
    assert "j4 = 0.5 -> l3" in out  # what was locked, as in the generated headers


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["generate", "no/such/arm.urdf", "--target", "c", "--out", "{tmp}"], "no URDF file no/such/arm.urdf"),
        (["print", "no_such_arm.urdf"], "no URDF file no_such_arm.urdf"),
        (["generate", "puma", "--out", "{tmp}"], "unknown model 'puma'"),
        (["print", "puma"], "unknown model 'puma'"),
        (["generate", str(URDF), "--tip", "hand", "--lock", "j1=abc", "--out", "{tmp}"], "--lock j1=abc"),
        (["print", str(URDF), "--lock", "j1"], "--lock j1:"),
        (["generate", "twolink", "--tip", "l2", "--out", "{tmp}"], "--tip apply to a URDF file"),
    ],
)
def test_errors_name_the_culprit(argv, culprit, tmp_path, capsys):
    assert cli.main([a.format(tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err
    assert culprit in err, err
    if "unknown model" in culprit:
        assert all(name in err for name in arms.NAMES) and ".urdf" in err


def test_lock_values_are_numbers_per_joint():
    assert command_line.parse_locks(["a=0.5", "b = -1e-3", "a=0.5"]) == {"a": 0.5, "b": -0.001}
    for bad in ("a", "=1", "a=", "a=nan", "a=1;b=2"):
        with pytest.raises(ValueError, match="JOINT=VALUE"):
            command_line.parse_locks([bad])
    with pytest.raises(ValueError, match="already locked at 0.5"):
        command_line.parse_locks(["a=0.5", "a=0.6"])


# make test-all: `symdyn bench --model FILE` is in the main suite on the same file as a whole robot
# without the C++ peer (test_bench_takes_a_whole_robot_from_the_command_line)
@pytest.mark.slow
def test_bench_takes_a_urdf_file(capsys):
    """The peers are built from the same Robot; the smallest run (no C++ peer, no CasADi baseline)."""
    argv = [
        "bench",
        "--model",
        str(URDF),
        *OPTIONS,
        "--calls",
        "1000",
        "--pin-calls",
        "100",
        "--reps",
        "1",
        "--rounds",
        "1",
        "--batch",
        "1024",
        "--no-pin",
        "--no-casadi",
    ]
    assert cli.main(argv) == 0
    assert "branches, frictionless" in capsys.readouterr().out


def test_bench_takes_a_whole_robot_from_the_command_line(capsys, monkeypatch):
    """`symdyn bench --model FILE --tips all --base-joint free` (it crashed: q of nq columns expected,
    a chain's n given): a whole robot gets the whole-robot section; without the C++ peer it says so."""
    from symdyn.bench import pin_peer

    def unavailable(log=None):
        raise pin_peer.PeerUnavailable("no headers here (a test)")

    monkeypatch.setattr(pin_peer, "peer_binary", unavailable)
    argv = ["bench", "--model", str(URDF), "--tips", "all", "--base-joint", "free", "--exclude", "finger"]
    argv += ["--exclude", "camera", "--reps", "1", "--rounds", "1"]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "Pinocchio C++ not measured: no headers here (a test)" in out


def test_bench_takes_a_lone_body_on_a_free_base(tmp_path, capsys, monkeypatch):
    """A drone (no joint) on a free base: `symdyn bench` times it; its arm file for the C++ peer
    has a free root and no joint (refused on a fixed base, where nothing would move)."""
    from symdyn.bench import pin_peer

    def unavailable(log=None):
        raise pin_peer.PeerUnavailable("no headers here (a test)")

    monkeypatch.setattr(pin_peer, "peer_binary", unavailable)
    path = tmp_path / "drone.urdf"
    path.write_text(
        '<robot name="drone"><link name="body"><inertial><mass value="1.2"/>'
        '<inertia ixx="0.01" iyy="0.012" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>'
    )
    argv = ["bench", "--model", str(path), "--base-joint", "free", "--reps", "1", "--rounds", "1"]
    assert cli.main(argv) == 0
    assert "Pinocchio C++ not measured: no headers here (a test)" in capsys.readouterr().out
    body = (1.2, (0.0, 0.0, 0.0), ((0.01, 0, 0), (0, 0.012, 0), (0, 0, 0.02)))
    text = pin_peer.write_arm(tmp_path / "arm.txt", [], (0, 0, -9.81), parents=[], root="free", base=body).read_text()
    assert text.splitlines()[2] == "n 0"
    with pytest.raises(ValueError, match="an arm on a fixed base needs at least one joint"):
        pin_peer.write_arm(tmp_path / "arm.txt", [], (0, 0, -9.81))
