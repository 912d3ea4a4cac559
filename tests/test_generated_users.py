"""The code a user's model gets, pinned byte for byte: generated/ pins the shipped models, built
with sympy; any other model is built with SymEngine (`symdyn.codegen.choice`), so the twolink and
the Puma 560 renamed (`<name>_user`) take that path, and their files' hashes are pinned in
tests/golden/symengine.json (`scripts/golden_symengine.py --write` rewrites it)."""

import importlib.util
import json
from pathlib import Path

import pytest
import symengine

from tests.conftest import tiered

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = json.loads((ROOT / "tests" / "golden" / "symengine.json").read_text())


def _script():
    spec = importlib.util.spec_from_file_location("golden_symengine", ROOT / "scripts" / "golden_symengine.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", tiered(sorted(GOLDEN["models"], key=lambda n: n != "twolink"), 1))
def test_a_users_model_is_generated_byte_for_byte_as_pinned(tmp_path, name):
    got = _script().hashes(name, tmp_path)
    want = GOLDEN["models"][name]
    assert sorted(got) == sorted(want)
    changed = sorted(f for f in want if got[f] != want[f])
    assert not changed, (
        f"{', '.join(changed)} of {name}_user differ from tests/golden/symengine.json (written with SymEngine "
        f"{GOLDEN['symengine']}, this is {symengine.__version__}): if the change is meant, "
        "`python scripts/golden_symengine.py --write`"
    )
