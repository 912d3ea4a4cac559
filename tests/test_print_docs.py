"""The committed docs/equations/twolink.md is what scripts/print_docs.py writes now (issue 14, item 5)."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_committed_twolink_equations_are_current():
    spec = importlib.util.spec_from_file_location("print_docs", ROOT / "scripts" / "print_docs.py")
    print_docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(print_docs)
    text, _ = print_docs.model_markdown("twolink")
    committed = (ROOT / "docs" / "equations" / "twolink.md").read_text()
    assert text == committed, (
        "docs/equations/twolink.md is stale: regenerate it with "
        "`python scripts/print_docs.py` (all models) and commit docs/equations/"
    )
