"""Generated C compiles without a single warning under -Wall -Wextra -std=c99 -pedantic (issue 22).

Users build the .c/.h pair into their own projects, many with -Werror: an
unused variable (a dead assignment left in a program) or an unused parameter
(a function that does not depend on one of its inputs, such as F of a model
without friction) breaks their build.  -fsyntax-only reports every such
warning of the front end in ~0.05 s a file; an -O2 build, which could add the
optimiser's (-Wmaybe-uninitialized), found none either and takes ~11 s for
the five arms.
"""

import shutil
import subprocess

import pytest

from symdyn import models
from symdyn.codegen import entry as codegen

FLAGS = ("-Wall", "-Wextra", "-std=c99", "-pedantic", "-Werror", "-fsyntax-only")

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")


def _warnings(*args) -> str:
    """The compiler's messages for `cc FLAGS args` ("" when it is silent and succeeds)."""
    done = subprocess.run(["cc", *FLAGS, *map(str, args)], capture_output=True, text=True)
    return (done.stdout + done.stderr).strip() or ("" if done.returncode == 0 else f"cc exited {done.returncode}")


@pytest.mark.parametrize("name", codegen.SHIPPED)
def test_shipped_c_compiles_without_warnings(name):
    folder = codegen.GENERATED / name
    assert _warnings(folder / f"{name}.c", "-I", folder) == ""


@pytest.mark.parametrize("name", codegen.SHIPPED)
def test_shipped_header_compiles_without_warnings_on_its_own(name, tmp_path):
    unit = tmp_path / "user.c"
    unit.write_text(f'#include "{name}.h"\nint main(void) {{ return {name.upper()}_NDOF > 0 ? 0 : 1; }}\n')
    assert _warnings(unit, "-I", codegen.GENERATED / name) == ""


def test_symbolic_model_c_compiles_without_warnings(tmp_path):
    """A symbolic model's functions take the parameters p as a last argument that
    some of them (F without friction parameters) do not read."""
    robot = models.load("twolink", symbolic=True)
    written = codegen.generate(robot, "c", tmp_path)
    c_file = next(p for p in written if p.suffix == ".c")
    assert _warnings(c_file, "-I", tmp_path) == ""


def test_a_function_emitted_as_parts_compiles_without_warnings(tmp_path, monkeypatch):
    """A large function's parts all take the inputs, the outputs they may store and the array of
    passed values; one that leaves a parameter alone says so ((void)x), so that -Wextra does not
    warn: the Puma's functions forced into parts of 17 steps."""
    from symdyn.codegen.emit import c as c_emit

    monkeypatch.setattr(c_emit, "SPLIT_ABOVE", 40)
    monkeypatch.setattr(c_emit, "PART_SIZE", 17)
    bundle = codegen.bundle(codegen._robot("puma560"))
    (tmp_path / "puma560.c").write_text(c_emit.c_source(bundle))
    (tmp_path / "puma560.h").write_text(c_emit.h_source(bundle))
    text = (tmp_path / "puma560.c").read_text()
    assert "puma560_Minv_part2(" in text and "    (void)Minv;" in text
    assert _warnings(tmp_path / "puma560.c", "-I", tmp_path) == ""
