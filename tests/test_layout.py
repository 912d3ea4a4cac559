"""The package's shape (docs/architecture.md): one folder per stage, imports
only downhill (model < derivation < codegen < numeric < presentation < apps <
identify < sweep < bench < the top-level modules), no import circles, and a
reference that never touches sympy.

Every module under symdyn/ is read with `ast` (not imported); every import
counts, at module level or inside a function, except those under
`if TYPE_CHECKING:`, which never run.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import symdyn

PACKAGE = Path(symdyn.__file__).resolve().parent

#: Data beside the stages: the shipped models' generated code (symdyn/generated links to the checkout's
#: generated/; the wheel carries it as package data), not modules of the package.
DATA = ("generated",)
#: The stage folders, downhill first: a module may import its own stage and those before it.
#: presentation (closed forms printed, named constants, a model drawn) is a consumer of derivations
#: and of the numeric reference's frames, which nothing below it imports: it ranks after numeric.
STAGES = ("model", "derivation", "codegen", "numeric", "presentation", "apps", "identify", "sweep", "bench")
#: Top-level modules: the package, the command line and the documented names kept as thin re-exports.
TOP_MODULES = ("symdyn", "symdyn.__main__", "symdyn.cli", "symdyn.models", "symdyn.reference", "symdyn.ocp")
TOP = len(STAGES)
#: The one name a lower module may take from the package itself (always loaded before any of its modules).
ROOT_NAMES = {"__version__"}
#: The independent yardstick (its public functions and the chain and recursion they run on):
#: NumPy only, and nothing of symdyn but the model and each other.
REFERENCE = ("symdyn.numeric.reference", "symdyn.numeric.chain")


@dataclass(frozen=True)
class Import:
    importer: str
    target: str  # a module of the package, or a third-party top-level name ("sympy")
    line: int
    text: str

    def __str__(self) -> str:
        return f"{self.importer} (line {self.line}: {self.text})"


def _module_name(path: Path) -> str:
    parts = ("symdyn",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py")) if p.relative_to(PACKAGE).parts[0] not in DATA}


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def stage(module: str) -> int:
    """Rank of a module: the index of its stage folder, TOP for the top-level modules."""
    parts = module.split(".")
    return STAGES.index(parts[1]) if len(parts) > 1 and parts[1] in STAGES else TOP


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    return skip


def imports(module: str, source: str | None = None) -> list[Import]:
    """Every import in `module` (or in `source` read as that module), resolved:
    `from . import x` names module x when x is a module, else the package it
    comes from; third-party imports keep their top-level name."""
    tree = ast.parse(MODULES[module].read_text() if source is None else source, str(MODULES[module]))
    skip = _type_checking_nodes(tree)
    here = module if _is_package(module) else module.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        text = ast.unparse(node) if isinstance(node, (ast.Import, ast.ImportFrom)) else ""
        if isinstance(node, ast.Import):
            out += [Import(module, _known(a.name), node.lineno, text) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(here.split(".")[: len(here.split(".")) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            else:
                base = node.module
            for a in node.names:
                target = f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else _known(base)
                if target == "symdyn" and a.name in ROOT_NAMES:
                    continue
                out.append(Import(module, target, node.lineno, text))
    return out


def _known(name: str) -> str:
    """The package module `name` (or its nearest package), else its top-level name."""
    while name not in MODULES and "." in name and name.startswith("symdyn."):
        name = name.rpartition(".")[0]
    return name if name in MODULES else name.partition(".")[0]


def _edges() -> dict[str, list[Import]]:
    """module → its imports of other package modules (one per target), with the
    packages that importing them runs (`import a.b.c` runs a.b's __init__
    unless the importer lives in a.b already)."""
    graph = {}
    for module in MODULES:
        found = {}
        for imp in imports(module):
            if imp.target not in MODULES:
                continue
            found.setdefault(imp.target, imp)
            parts = imp.target.split(".")
            for k in range(2, len(parts)):
                parent = ".".join(parts[:k])
                if not (module + ".").startswith(parent + "."):
                    found.setdefault(parent, Import(module, parent, imp.line, imp.text))
        graph[module] = list(found.values())
    return graph


def test_the_package_is_one_folder_per_stage():
    folders = sorted(p.name for p in PACKAGE.iterdir() if p.is_dir() and p.name not in ("__pycache__", *DATA))
    assert folders == sorted(STAGES), f"symdyn/ holds {folders}: each folder must be one of the stages {STAGES}"
    assert (PACKAGE / "generated").resolve() == PACKAGE.parent / "generated"  # a link, in a checkout
    flat = sorted(m for m in MODULES if m.count(".") <= 1 and m.split(".")[-1] not in STAGES)
    assert flat == sorted(TOP_MODULES), (
        f"top-level modules {sorted(set(flat) - set(TOP_MODULES))}: put new code in its stage's folder"
    )


def test_imports_run_only_downhill():
    names = " < ".join(STAGES) + " < cli"
    upward = [
        f"{imp} imports {imp.target}, a later stage ({names})"
        for module in MODULES
        for imp in imports(module)
        if imp.target in MODULES and stage(imp.target) > stage(module)
    ]
    assert not upward, "upward imports:\n" + "\n".join(upward)


def test_there_are_no_import_circles():
    graph = _edges()
    circles, done = {}, set()

    def visit(module: str, path: list[Import], on_path: set[str]) -> None:
        for imp in graph[module]:
            if imp.target in on_path:
                steps = path + [imp]
                steps = steps[next(i for i, step in enumerate(steps) if step.importer == imp.target) :]
                text = " → ".join(map(str, steps)) + f" → {imp.target}"
                circles.setdefault(frozenset(step.importer for step in steps), text)
            elif imp.target not in done:
                visit(imp.target, path + [imp], on_path | {imp.target})
        done.add(module)

    for module in MODULES:
        if module not in done:
            visit(module, [], {module})
    assert not circles, "import circles:\n" + "\n".join(circles.values())


def test_the_reference_never_imports_sympy_nor_the_symbolic_stages():
    bad = [
        f"{imp} imports {imp.target}"
        for module in REFERENCE
        for imp in imports(module)
        if imp.target == "sympy"
        or (imp.target in MODULES and imp.target not in REFERENCE and stage(imp.target) > STAGES.index("model"))
    ]
    assert not bad, "the reference must stay NumPy-only and independent of what it checks:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "module, line, target",
    [
        ("symdyn.model.arms.puma560", "from ..robot import Link", "symdyn.model.robot"),
        ("symdyn.codegen.functions", "from .. import model", "symdyn.model"),
        ("symdyn.codegen.emit.c", "from ...derivation.program import lower", "symdyn.derivation.program"),
        ("symdyn.apps.studies.ocp", "from ...model import arms", "symdyn.model.arms"),
        ("symdyn.derivation.entry", "from .. import __version__", None),
        ("symdyn.derivation.dynamics", "from symdyn.codegen.emit.clib import compiler", "symdyn.codegen.emit.clib"),
        ("symdyn.numeric.reference", "import sympy.polys", "sympy"),
    ],
)
def test_imports_inside_functions_are_resolved_to_modules(module, line, target):
    found = [imp.target for imp in imports(module, f"def f():\n    {line}\n")]
    assert found == ([target] if target else [])


def test_documented_paths_still_work():
    """README and docs/: symdyn.derive/generate/load, Link, Robot, models, reference, ocp, python -m symdyn."""
    from symdyn import model, models, ocp, reference
    from symdyn.apps import ocp as apps_ocp
    from symdyn.model import arms, robot
    from symdyn.numeric import reference as numeric_reference

    assert all(callable(f) for f in (symdyn.derive, symdyn.generate, symdyn.load))
    assert (symdyn.Link, symdyn.Robot, model.Link, model.Robot) == (robot.Link, robot.Robot) * 2
    assert (models.load, models.NAMES) == (arms.load, arms.NAMES)
    for name in (
        "rne",
        "inertia",
        "coriolis",
        "christoffel",
        "gravload",
        "friction",
        "accel",
        "fdyn",
        "fkine",
        "jacob0",
        "energy",
    ):
        assert getattr(reference, name) is getattr(numeric_reference, name), name
    for name in ("Limits", "Problem", "Cost", "solve", "dynamics", "verify", "OCPError", "SOURCES"):
        assert getattr(ocp, name) is getattr(apps_ocp, name), name
    run = subprocess.run([sys.executable, "-m", "symdyn", "--help"], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.startswith("usage: symdyn"), run.stderr


#: The size past which a module is split by concern (issue 44: one home per concept).
MAX_LINES = 800


def test_no_module_outgrows_one_concern():
    big = {name: n for name, path in MODULES.items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines (split them by concern): {big}"
