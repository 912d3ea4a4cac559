"""A warning about a robot file reads on the command line as its errors do (issue 34's new user).

Found reading MuJoCo Menagerie's Panda and xArm7 (scripts/real_descriptions.py):
`symdyn generate panda.xml` printed Python's raw warning, the symdyn source file
and line that raised it and the code on that line
(`…/command_line.py:298: MJCFWarning: … return Robot.from_mjcf(…)`).
Run in a fresh process: pytest records warnings, so they never reach stderr in-process.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("mujoco")

#: two joints tied by an equality constraint, which symdyn does not model: it warns
COUPLED = """<mujoco model="coupled"><worldbody>
<body name="a"><joint name="j1" axis="0 0 1"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
<body name="b" pos="0 0 1"><joint name="j2" axis="0 1 0"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
</body></body></worldbody>
<equality><joint joint1="j1" joint2="j2"/></equality></mujoco>
"""


def test_a_file_warning_is_one_symdyn_line_without_python_source(tmp_path):
    path = tmp_path / "coupled.xml"
    path.write_text(COUPLED)
    done = subprocess.run(
        [sys.executable, "-m", "symdyn", "print", str(path), "--term", "G", "--no-cache"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert "symdyn: warning: coupled.xml: 1 equality constraint(s) not modelled: joint 'j1'–'j2'" in lines
    assert "MJCFWarning" not in done.stderr and ".py:" not in done.stderr and "Robot.from_mjcf" not in done.stderr


def test_other_warnings_keep_pythons_format():
    import warnings

    from symdyn.cli import _format_warning

    text = _format_warning(DeprecationWarning("old"), DeprecationWarning, "x.py", 3, "f()")
    assert text == warnings.formatwarning(DeprecationWarning("old"), DeprecationWarning, "x.py", 3, "f()")
