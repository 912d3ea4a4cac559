"""symdyn's C binding is a real C file (`symdyn/codegen/emit/runtime/glue.c`, package data): it
compiles on its own with every warning as an error given its module's name, refuses to without it,
and the extension symdyn builds from it binds under that name."""

import subprocess
import sysconfig

import pytest
from symdyn.codegen.emit import cbuild, clib


@pytest.fixture(scope="module")
def headers():
    found = cbuild.python_headers()
    if found is None:
        pytest.skip("Python.h is not installed here (the ctypes binding serves without it)")
    return found


def _compile(headers, *defines: str) -> subprocess.CompletedProcess:
    includes = [f"-I{h}" for h in headers]
    command = [cbuild.compiler(), "-fsyntax-only", "-Wall", "-Wextra", "-Werror", "-Wno-unused-parameter", *defines]
    return subprocess.run([*command, *includes, str(clib.GLUE_C)], capture_output=True, text=True)


def test_the_binding_compiles_as_c_with_its_module_named(headers):
    run = _compile(headers, "-DSYMDYN_MODULE=_symdyn_glue_test")
    assert run.returncode == 0, run.stderr


def test_without_a_module_name_it_says_what_to_define(headers):
    run = _compile(headers)
    assert run.returncode != 0 and "define SYMDYN_MODULE" in run.stderr


def test_the_extension_symdyn_builds_is_named_by_its_source(headers):
    """Its name carries the digest of its source and flags (`clib._glue`), and it serves the calls."""
    ext = clib._glue(clib.CompileOptions().flags, headers)
    assert ext.__name__.startswith("_symdyn_glue_") and callable(ext._function) and callable(ext._set_threads)
    assert ext.__spec__.origin.endswith(sysconfig.get_config_var("EXT_SUFFIX"))
