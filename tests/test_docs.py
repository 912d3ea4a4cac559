"""The documentation site's sources (issue 27): every public name has an API reference
entry, every page of the navigation exists, and every Python example on the site runs
as written.  Building the site itself (`make docs`: mkdocs --strict, the arms' equations
printed during the build) and checking the built pages is `tests/test_site.py`, run by
`make docs-check` after the suite (.ci/run)."""

from __future__ import annotations

import importlib
import importlib.util
import os
import re
from pathlib import Path

import pytest

import symdyn

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
REFERENCE = DOCS / "reference"
#: Public modules beside those named in `symdyn.__all__`: each has a reference page that
#: documents every name of its `__all__`.
PUBLIC_MODULES = (
    "symdyn.models",
    "symdyn.model",
    "symdyn.reference",
    "symdyn.ocp",
    "symdyn.identify",
    "symdyn.sweep",
    "symdyn.sweep.engine",
    "symdyn.sweep.table",
)


def documented_modules() -> list[str]:
    named = [f"symdyn.{n}" for n in symdyn.__all__ if type(getattr(symdyn, n)).__name__ == "module"]
    modules = []
    for name in dict.fromkeys([*named, *PUBLIC_MODULES]):
        try:
            importlib.import_module(name)
        except ImportError:
            if name in named:
                raise
            continue  # a capability not landed (or its optional extra absent)
        modules.append(name)
    return modules


def reference_entries() -> set[str]:
    """The objects the reference pages render (`::: name`) or describe by hand (a `## \\`name\\`` heading)."""
    entries = set()
    for page in REFERENCE.glob("*.md"):
        text = page.read_text()
        entries |= set(re.findall(r"^::: ([\w.]+)\s*$", text, re.M))
        entries |= set(re.findall(r"^#+ `([\w.]+)`\s*$", text, re.M))
    return entries


def expected_entries() -> set[str]:
    expected = {"symdyn", *(f"symdyn.{n}" for n in symdyn.__all__)}
    for name in documented_modules():
        expected.add(name)
        expected |= {f"{name}.{n}" for n in getattr(importlib.import_module(name), "__all__", ())}
    return expected


def test_every_public_name_has_a_reference_entry():
    missing = sorted(expected_entries() - reference_entries())
    assert not missing, f"public names without an entry under docs/reference/: {missing}"


def test_the_reference_documents_only_public_names():
    extra = sorted(reference_entries() - expected_entries())
    assert not extra, f"reference entries that are not public names (not in an __all__): {extra}"


def nav_pages() -> list[str]:
    """Every page the mkdocs navigation names (the equations' section is filled by the build hook)."""
    return re.findall(r":\s+([\w/.-]+\.md)\s*$", (ROOT / "mkdocs.yml").read_text(), re.M)


def test_every_page_of_the_navigation_exists():
    pages = nav_pages()
    assert "index.md" in pages and "reference/index.md" in pages
    assert [p for p in pages if not (DOCS / p).is_file()] == []


def test_every_reference_page_is_in_the_navigation():
    pages = set(nav_pages())
    assert (
        sorted(
            p.relative_to(DOCS).as_posix()
            for p in REFERENCE.glob("*.md")
            if p.relative_to(DOCS).as_posix() not in pages
        )
        == []
    )


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", page.read_text(), re.S | re.M)


def examples(page: Path) -> list[tuple[str, str | None]]:
    """Each Python block of a page and why it is not run (None: it runs).  Not run, only
    compiled: a block after an `<!-- no-run: why -->` comment, a listing of a module inside
    symdyn (relative imports), and a block importing a package this environment lacks (a
    cluster's client, say): the page's later blocks are then not run either."""
    found, missing = [], None
    for before, block in re.findall(r"((?:^[^\n]*\n){0,3}?)^```python\n(.*?)^```", page.read_text(), re.S | re.M):
        why = None
        if marker := re.search(r"<!--\s*no-run:?\s*(.*?)\s*-->", before):
            why = f"marked no-run ({marker.group(1)})"
        elif re.search(r"^\s*from \.", block, re.M):
            why = "a listing of a module inside symdyn (relative imports)"
        else:
            for name in re.findall(r"^\s*(?:from|import)\s+(\w+)", block, re.M):
                if importlib.util.find_spec(name) is None:
                    missing = missing or f"needs {name}, not installed here"
            why = missing
        found.append((block, why))
    return found


#: Pages whose examples take long (compiling CasADi's C for a Puma OCP: ~40 s; XLA compiling
#: the JAX target: ~5 s; generating four contact sets' functions: ~25 s): run by `make docs-check`
#: (SYMDYN_SLOW_DOCS=1), not by the suite.
SLOW_PAGES = {"studies_ocp.md", "jax_torch.md", "contacts.md"}
PAGES_WITH_CODE = sorted(
    (p for p in DOCS.rglob("*.md") if "equations" not in p.parts and python_blocks(p)), key=lambda p: p.as_posix()
)


def test_the_site_has_examples():
    assert {"index.md", "arms.md", "code.md"} <= {p.name for p in PAGES_WITH_CODE}


@pytest.mark.parametrize("page", PAGES_WITH_CODE, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_every_python_block_of_a_page_runs_in_order(page, tmp_path, monkeypatch):
    """The blocks of one page share a namespace, as a reader following the page would.
    Every block compiles; those `examples` does not excuse run."""
    if page.name in SLOW_PAGES and not os.environ.get("SYMDYN_SLOW_DOCS"):
        pytest.skip(f"{page.name}'s examples are slow: SYMDYN_SLOW_DOCS=1 runs them (make docs-check)")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    for k, (block, why) in enumerate(examples(page)):
        code = compile(block, f"{page.relative_to(ROOT)} python block {k + 1}", "exec")
        if why is None:
            exec(code, namespace)


#: The Python the project writes (generated/ is the emitters' output, checked byte for byte).
PYTHON_TREES = ("symdyn", "tests", "scripts", "docs/_hooks")


def _ruff(*args: str):
    import shutil
    import subprocess
    import sys

    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    assert ruff is not None, "ruff is part of the test extra: pip install -e '.[test]'"
    return subprocess.run([ruff, *args, *PYTHON_TREES], cwd=ROOT, capture_output=True, text=True, timeout=120)


def test_ruff_is_clean_on_the_project():
    """The linter configured in pyproject.toml ([tool.ruff]) finds nothing in the project's Python."""
    done = _ruff("check")
    assert done.returncode == 0, done.stdout + done.stderr


def test_ruff_format_keeps_the_project_formatted():
    done = _ruff("format", "--check")
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_package_is_typed():
    assert (ROOT / "symdyn" / "py.typed").is_file()
    import tomllib

    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "py.typed" in package_data["symdyn"]


def test_the_public_api_type_checks():
    """mypy on the public API's modules ([tool.mypy] in pyproject.toml)."""
    import subprocess
    import sys

    pytest.importorskip("mypy", reason="mypy is in the test extra")
    done = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_readme_links_into_the_site_resolve():
    """The README is not a page of the site (mkdocs checks those): its relative links must
    name files that exist, and it stays a front door (~150 lines at most)."""
    readme = (ROOT / "README.md").read_text()
    links = [link.split("#")[0] for link in re.findall(r"\]\(([^)\s]+)\)", readme) if "://" not in link]
    assert len(links) >= 10 and [link for link in links if not (ROOT / link).exists()] == []
    assert len(readme.splitlines()) <= 150


def test_every_page_is_in_the_navigation():
    """mkdocs --strict fails on a page left out of the navigation (make docs); the suite says so first."""
    pages = set(nav_pages())
    omitted = sorted(
        p.relative_to(DOCS).as_posix()
        for p in DOCS.rglob("*.md")
        if "equations" not in p.parts and "_hooks" not in p.parts and p.relative_to(DOCS).as_posix() not in pages
    )
    assert omitted == [], f"pages not in mkdocs.yml's nav: {omitted}"


#: Documented classes and functions with no `Raises:` section, each because it raises
#: nothing of its own.
RAISES_NOTHING = {
    # Exceptions and a warning: raising them is what other entries document.
    "symdyn.model.URDFError",
    "symdyn.model.URDFWarning",
    "symdyn.ocp.OCPError",
    "symdyn.sweep.engine.SchedulerUnreachable",
    "symdyn.sweep.engine.SweepInterrupted",
    "symdyn.sweep.table.TableError",
    # Plain data holders (dataclasses without checks): what builds or reads them checks
    # (fit, solve, verify and run make them), and the members that can fail
    # (Identification.robot/predict/validate) say so.
    "symdyn.identify.Data",
    "symdyn.identify.Identification",
    "symdyn.ocp.Solution",
    "symdyn.ocp.Check",
    "symdyn.sweep.engine.Outcome",
    # Builds a tuple of what it is given; nothing is checked until a Link or Robot reads it.
    "symdyn.model.transl",
    # Formats an exception it is given into one line (reads its type, message and traceback).
    "symdyn.sweep.engine.describe_error",
}


def public_object(name: str):
    """The object a reference entry names (an attribute first: `symdyn.model.placement`
    is the function, though a module of that name exists)."""
    parts = name.split(".")
    obj = importlib.import_module(parts[0])
    for k, part in enumerate(parts[1:], 2):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            obj = importlib.import_module(".".join(parts[:k]))
    return obj


def test_every_public_callable_documents_its_errors():
    """Issue 27: each function's and class's entry says the errors it raises (a Google-style
    `Raises:` section; a class's in its class docstring, for its constructor), unless it
    raises none of its own (`RAISES_NOTHING`)."""
    import inspect

    checked, missing = [], []
    for name in sorted(reference_entries() & expected_entries()):
        obj = public_object(name)
        target = inspect.unwrap(obj) if callable(obj) and not inspect.isclass(obj) else obj
        if not (inspect.isclass(target) or inspect.isfunction(target)):
            continue  # a module or a constant
        if not getattr(target, "__module__", "").startswith("symdyn"):
            continue
        checked.append(name)
        if name in RAISES_NOTHING:
            continue
        if not re.search(r"^\s*Raises:\s*\n\s+\w[\w.]*:", target.__doc__ or "", re.M):
            missing.append(name)
    assert len(checked) > 50
    assert not missing, f"public functions and classes without a Raises: section: {missing}"
    assert RAISES_NOTHING <= set(checked), sorted(RAISES_NOTHING - set(checked))


def test_the_public_api_is_annotated():
    """Every documented function, and every public method (and `__init__`) of every
    documented class defined in symdyn, annotates its parameters (bar self, cls, *args and
    **kwargs) and its return (bar `__init__`): the type hints the reference renders."""
    import inspect

    def callables(name: str, obj):
        if inspect.isfunction(obj):
            yield name, obj
            return
        for attr, member in vars(obj).items():
            if attr.startswith("_") and attr != "__init__":
                continue
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            elif isinstance(member, property):
                member = member.fget
            if inspect.isfunction(member) and member.__module__.startswith("symdyn"):
                yield f"{name}.{attr}", member

    checked, missing = [], []
    for name in sorted(reference_entries() & expected_entries()):
        obj = public_object(name)
        target = inspect.unwrap(obj) if callable(obj) and not inspect.isclass(obj) else obj
        if not (inspect.isclass(target) or inspect.isfunction(target)):
            continue  # a module or a constant
        if not getattr(target, "__module__", "").startswith("symdyn"):
            continue
        for where, function in callables(name, target):
            checked.append(where)
            signature = inspect.signature(inspect.unwrap(function))
            for parameter in signature.parameters.values():
                if parameter.name in ("self", "cls") or parameter.kind in (
                    parameter.VAR_POSITIONAL,
                    parameter.VAR_KEYWORD,
                ):
                    continue
                if parameter.annotation is parameter.empty:
                    missing.append(f"{where}({parameter.name})")
            if function.__name__ != "__init__" and signature.return_annotation is signature.empty:
                missing.append(f"{where} (return)")
    assert len(checked) > 80
    assert not missing, f"public functions and methods without annotations: {missing}"
