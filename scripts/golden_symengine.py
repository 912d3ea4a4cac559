"""The SymEngine path's golden hashes: the code a user's model gets, pinned byte for byte.

Run: .venv/bin/python scripts/golden_symengine.py [--write]
Code generation builds the shipped models' programs with sympy (their generated/ files are pinned
byte for byte) and every other model's with SymEngine (`symdyn.codegen.choice`).  This generates
the twolink and the Puma 560 renamed — `<name>_user`, so that they take the users' path — for
every target and prints the SHA-256 of each file; `--write` stores them in
tests/golden/symengine.json, which `tests/test_generated.py` checks against.  Rewrite it when a
change to code generation (or a SymEngine release) is meant to change users' code.
"""

import argparse
import dataclasses
import hashlib
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import symengine  # noqa: E402

from symdyn.codegen import entry  # noqa: E402
from symdyn.model import arms  # noqa: E402

GOLDEN = Path(__file__).resolve().parent.parent / "tests" / "golden" / "symengine.json"
MODELS = ("twolink", "puma560")


def hashes(name: str, folder: Path) -> dict:
    """{file name: SHA-256} of every target of the shipped model `name` generated as a user's model."""
    robot = dataclasses.replace(arms.load(name), name=f"{name}_user")
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in entry.generate(robot, "all", folder)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--write", action="store_true", help=f"store the hashes in {GOLDEN.relative_to(GOLDEN.parents[2])}")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        found = {name: hashes(name, Path(tmp) / name) for name in MODELS}
    record = {"symengine": symengine.__version__, "models": found}
    text = json.dumps(record, indent=1, sort_keys=True) + "\n"
    if args.write:
        GOLDEN.write_text(text)
    print(text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
