"""A wheel installed elsewhere is a first-class symdyn (issues 12 and 27): the
README's examples run from another directory, the shipped models' code comes
from the wheel itself (no derivation on the first load; C only compiled, into
the cache), and nothing is ever written beside the installed package."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

# make test-all (building and installing the wheel: 10-15 s): the README's blocks run in the main suite
# from another directory on the checkout (tests/test_readme.py), generating a shipped model without
# out_dir is refused there too (tests/test_generated.py::test_generate_needs_out_dir_for_a_model_not_shipped_as_is)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """symdyn built as a wheel and installed (without dependencies: those of this
    environment serve) into a folder of its own; returns (site, environment)."""
    tmp = tmp_path_factory.mktemp("wheel")
    # Built from a copy of what the wheel is made of: setuptools builds in the source tree
    # (build/, *.egg-info), and two xdist workers building from the checkout at once collide.
    src = tmp / "src"
    shutil.copytree(ROOT / "symdyn", src / "symdyn", ignore=shutil.ignore_patterns("__pycache__", "generated"))
    shutil.copytree(ROOT / "generated", src / "generated")
    os.symlink("../generated", src / "symdyn" / "generated")  # as in the checkout
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(tmp / "dist"), str(src)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    wheel = next((tmp / "dist").glob("symdyn-*.whl"))
    site = tmp / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site), str(wheel)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    env = dict(os.environ, PYTHONPATH=str(site), SYMDYN_CACHE_DIR=str(tmp / "cache"))
    return site, env, tmp


def _run(args, env, cwd):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=600)


def test_the_wheel_runs_the_readme_from_another_directory(installed):
    site, env, tmp = installed
    from tests.test_readme import python_blocks

    # the first load of a shipped model derives nothing: NumPy imports the module the wheel carries
    # (measured here: 0.5-1.5 s from a cold interpreter, imports included; C would only compile)
    code = (
        "import os, pathlib, time; t = time.perf_counter(); import symdyn; symdyn.load('puma560', 'numpy'); "
        "print('first load', time.perf_counter() - t)\n"
        "assert not list(pathlib.Path(os.environ['SYMDYN_CACHE_DIR']).rglob('*.pickle')), 'it derived'\n"
    )
    code += "assert symdyn.__file__.startswith(%r), symdyn.__file__\n" % str(site)
    code += "\n".join(python_blocks())
    code += "\nprint('fdyn', float(np.abs(f.fdyn(q, qd, tau) - qdd).max()))"
    done = _run(["-c", code], env, tmp)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout.split("fdyn")[-1]) < 1e-10
    assert "generating" not in done.stderr, done.stderr  # the tour's loads use the wheel's code
    assert not (site / "generated").exists() and (site / "symdyn" / "generated" / "puma560" / "puma560.c").is_file()


def test_the_wheel_never_writes_beside_its_package(installed):
    site, env, tmp = installed
    done = _run(["-m", "symdyn", "generate", "puma560", "--target", "numpy"], env, tmp)
    assert done.returncode == 2 and "needs out_dir" in done.stderr
    before = sorted(p.relative_to(site) for p in site.rglob("*") if "__pycache__" not in p.parts)
    assert not (site / "generated").exists()
    done = _run(["-m", "symdyn", "generate", "twolink", "--target", "numpy", "--out", str(tmp / "out")], env, tmp)
    assert done.returncode == 0 and (tmp / "out" / "twolink.py").is_file()
    assert sorted(p.relative_to(site) for p in site.rglob("*") if "__pycache__" not in p.parts) == before
