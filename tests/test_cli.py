"""The command line meets a user: help, version, unwritable folders, Ctrl-C (issue 12)."""

import os
import signal
import subprocess
import sys
import time

import pytest

from symdyn import __version__, cli

COMMANDS = [["generate", "twolink", "--target", "numpy"], ["run"], ["study", "gravity-load"]]


def test_version_and_help_say_what_the_tool_is(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"symdyn {__version__}"
    help_text = cli.build_parser().format_help()
    assert "rigid-body dynamics of robot arms" in help_text
    print_help = cli.build_parser()._subparsers._group_actions[0].choices["print"].format_help()
    assert "twolink" in print_help and "puma560" in print_help


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
def test_an_out_folder_under_a_regular_file_is_one_line_and_exit_2(tmp_path, capsys, command):
    blocker = tmp_path / "afile"
    blocker.write_text("not a folder")
    start = time.perf_counter()
    assert cli.main([*command, "--out", str(blocker / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"symdyn: error: cannot write to {blocker / 'out'}: Not a directory"]
    assert time.perf_counter() - start < 1.0  # refused before any work


def test_ctrl_c_prints_one_line_and_exits_130(tmp_path):
    env = dict(os.environ, SYMDYN_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "symdyn", "run", "--out", str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    first = proc.stderr.readline()  # the first progress line: inside the (cold, ~10 s) main job
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert first and proc.returncode == 130, first + err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "symdyn: interrupted"


def test_progress_without_a_terminal_is_a_handful_of_lines(capsys):
    import symdyn
    from symdyn import models

    symdyn.derive(models.load("puma560"), "newton-euler", cache=False, progress=True)
    lines = capsys.readouterr().err.strip().splitlines()
    assert 2 <= len(lines) <= 6 and lines[-1].startswith("newton-euler puma560: done in")
