"""Build the release from a commit and check it (issue 27): `python -m build` gives an sdist
and a wheel (the wheel built from the sdist), `twine check` passes on both, and a wheel built
straight from the source tree holds the same files with the same contents as the one built
from the sdist.  Prints the sizes and the times; exits 1 on any failure.

    .venv/bin/python scripts/release_check.py            # HEAD
    .venv/bin/python scripts/release_check.py --ref v0.1.0

Needs the build and twine packages (pip install build twine).  About a minute: it builds twice.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import subprocess
import sys
import tarfile
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(*args: str, cwd: Path) -> float:
    start = time.perf_counter()
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True)
    if done.returncode:
        sys.exit(f"{' '.join(args)} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return time.perf_counter() - start


def contents(wheel: Path) -> dict[str, str]:
    """name → sha256 of every file of a wheel but its RECORD (which lists the hashes itself)."""
    with zipfile.ZipFile(wheel) as z:
        return {n: hashlib.sha256(z.read(n)).hexdigest() for n in z.namelist() if not n.endswith("/RECORD")}


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ref", default="HEAD", help="the commit to build (default HEAD)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        src, dist, direct = tmp / "src", tmp / "dist", tmp / "direct"
        archive = subprocess.run(["git", "archive", args.ref], cwd=ROOT, capture_output=True, check=True).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(src, filter="data")
        t_build = run(sys.executable, "-m", "build", "--outdir", str(dist), ".", cwd=src)
        sdist, wheel = next(dist.glob("*.tar.gz")), next(dist.glob("*.whl"))
        t_twine = run(sys.executable, "-m", "twine", "check", "--strict", str(sdist), str(wheel), cwd=tmp)
        t_direct = run(sys.executable, "-m", "build", "--wheel", "--outdir", str(direct), ".", cwd=src)
        a, b = contents(wheel), contents(next(direct.glob("*.whl")))
        differ = sorted(set(a) ^ set(b)) + sorted(n for n in set(a) & set(b) if a[n] != b[n])
        files = zipfile.ZipFile(wheel).namelist()
        print(
            f"{args.ref}: sdist {sdist.name} {sdist.stat().st_size / 1e3:.0f} kB, "
            f"wheel {wheel.name} {wheel.stat().st_size / 1e3:.0f} kB ({len(files)} files)"
        )
        print(
            f"python -m build (sdist, then the wheel from it): {t_build:.1f} s; twine check --strict: "
            f"{t_twine:.1f} s, passed; a wheel straight from the tree: {t_direct:.1f} s"
        )
        print(
            f"py.typed in the wheel: {'symdyn/py.typed' in files}; generated code in the wheel: "
            f"{any('/generated/' in f for f in files)}"
        )
        if differ:
            print(f"the sdist's wheel and the tree's wheel differ in: {', '.join(differ)}")
            return 1
        print("the sdist builds the same wheel as the tree (every file, byte for byte)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
