"""Every printed op count names its variant (issue 12 item 16).

τ's count of the Puma 560 was printed as 401, 359, 369 and 417 without
saying which is which: with or without friction, on the full or the
regrouped base parameters, mul + add or with sin/cos/sign calls.  Each place
that prints one — the generated files' headers, `symdyn run`, `symdyn
print`, the benchmark's tables, README and docs — must say after which
stage it counts and with or without friction.
"""

import re
from pathlib import Path

import pytest

from symdyn import cli
from symdyn.bench import compare as bench
from symdyn.codegen.entry import GENERATED
from symdyn.model import arms

ROOT = Path(__file__).resolve().parents[1]
FRICTION = re.compile(r"with(out)? (the model's |its )?friction|\+friction")
#: An op count in prose or a table: "401 mul", "1001 total ops", "401 + 16 fun", "230 mul + 171 add".
COUNT = re.compile(r"\b\d+ (total )?(ops|operations)\b|\b\d+ mul\b|\b\d+ \+ \d+ fun\b")


def _names_variant(text: str) -> bool:
    return "CSE" in text and bool(FRICTION.search(text))


@pytest.mark.parametrize(
    "path", sorted(p for p in GENERATED.glob("*/*") if p.suffix in (".c", ".h", ".py")), ids=lambda p: p.name
)
def test_generated_headers_name_friction_stage_and_derivation(path):
    head = path.read_text().split("\n\n", 1)[0].splitlines()
    heading = next(line for line in head if "operation counts" in line)
    robot = arms.load(path.parent.name)
    friction = "with the model's friction" if cli.friction_variant(robot) == "with friction" else "without friction"
    assert "after one joint CSE" in heading and friction in heading, heading
    counts = [line for line in head if re.search(r"\(\d+ total\)", line)]
    assert any(re.search(r"\btau\s+\d+ mul", line) for line in counts)
    assert all(re.search(r"\(\d+ total\)\s+\[[^]]+\]$", line) for line in counts), counts


def test_print_names_parameters_and_friction(capsys):
    assert cli.main(["print", "twolink", "--term", "tau"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if "operations" in line]
    assert lines == [
        "# twolink_sym by newton-euler; operations (mul + add) at each stage, full inertial "
        "parameters (not regrouped), without friction:"
    ]


def test_run_summary_names_its_variant(tmp_path, capsys, monkeypatch):
    """The summary line of `symdyn run` (stopped just after it, before generating code)."""

    def stop(*args, **kwargs):
        raise RuntimeError("stopped after the summary")

    monkeypatch.setattr("symdyn.codegen.entry.generate", stop)
    assert cli.main(["run", "--out", str(tmp_path)]) == 2
    line = next(line for line in capsys.readouterr().out.splitlines() if "operations" in line)
    assert "after one joint CSE, mul + add (Newton–Euler on regrouped base parameters, with friction;" in line
    assert re.search(r"tau (\d+) \((\d+) mul \+ (\d+) add\)", line)
    total, mul, add = map(int, re.search(r"tau (\d+) \((\d+) mul \+ (\d+) add\)", line).groups())
    assert total == mul + add == 401


def test_bench_tables_say_what_ops_count():
    assert _names_variant(bench.OPS_NOTE) and "base parameters" in bench.OPS_NOTE
    row = bench.Row(bench.C_PEER, "tau", (1.0,), "Pinocchio rnea", (8.0,), 369, 8)
    assert bench.OPS_NOTE in bench.format_table([row]) and bench.OPS_NOTE in bench.markdown_table([row])


def _sections(path: Path):
    """(heading, text) of each Markdown section (split at #-headings outside code blocks)."""
    heading, lines, fenced = path.name, [], False
    for line in path.read_text().splitlines():
        fenced ^= line.startswith("```")
        if not fenced and line.startswith("#"):
            yield heading, "\n".join(lines)
            heading, lines = line, []
        else:
            lines.append(line)
    yield heading, "\n".join(lines)


@pytest.mark.parametrize("path", [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))], ids=lambda p: p.name)
def test_docs_name_the_variant_of_every_op_count(path):
    """A section that prints an op count (in prose, or a table with an ops column) says after
    which stage it counts and with or without friction."""
    for heading, text in _sections(path):
        has_ops_column = any(re.match(r"\|.*\|\s*ops\s*\|", line) for line in text.splitlines())
        if COUNT.search(text) or has_ops_column:
            assert _names_variant(text), f"{path.name}, section {heading!r}: an op count without its variant"
