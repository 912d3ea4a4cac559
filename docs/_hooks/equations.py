"""mkdocs hook: the shipped arms' equations, printed by `symdyn print` while the site builds.

For every model of `symdyn.models.NAMES` (or those named in `$SYMDYN_DOCS_ARMS`, comma-
separated, e.g. `twolink` for a quick build), the page `equations/<name>.md` is what
`scripts/print_docs.py` makes of the `symdyn print … --format latex` output now — rendered
here by MathJax — and `equations/README.md` (the section's index) lists them. The Markdown
committed under docs/equations/ (the same pages for GitHub) is never read: each is replaced
by the printer's output under the same name, so links between pages hold on GitHub and on
the site alike, and the arms not rendered are left out. Derivations are cached on disk, so a
second build with the same symdyn is quicker. The arms are printed side by side, one worker
process per core (`$SYMDYN_DOCS_JOBS` sets how many). The Equations section of the
navigation gets one entry per page.
"""

from __future__ import annotations

import concurrent.futures
import importlib.util
import logging
import multiprocessing
import os
import sys
import time
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
log = logging.getLogger("mkdocs.hooks.equations")
SECTION = "Equations"


def _print_docs():
    """scripts/print_docs.py as a module, registered so forked workers can unpickle its functions."""
    if "symdyn_print_docs" not in sys.modules:
        spec = importlib.util.spec_from_file_location("symdyn_print_docs", ROOT / "scripts" / "print_docs.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules["symdyn_print_docs"] = module
    return sys.modules["symdyn_print_docs"]


def jobs(n: int) -> int:
    """Worker processes for `n` arms: `$SYMDYN_DOCS_JOBS`, else one per core (at most n)."""
    return max(1, min(n, int(os.environ.get("SYMDYN_DOCS_JOBS") or os.cpu_count() or 1)))


def arms() -> list[str]:
    """The arms this build renders: `$SYMDYN_DOCS_ARMS` (comma-separated) or every shipped one."""
    sys.path.insert(0, str(ROOT))
    from symdyn.models import NAMES

    chosen = [a.strip() for a in os.environ.get("SYMDYN_DOCS_ARMS", "").split(",") if a.strip()]
    unknown = [a for a in chosen if a not in NAMES]
    if unknown:
        raise ValueError(f"SYMDYN_DOCS_ARMS names unknown model(s) {', '.join(unknown)}; shipped: {', '.join(NAMES)}")
    return chosen or list(NAMES)


def on_config(config):
    """One navigation entry per rendered arm under the section titled `SECTION`."""
    names = arms()
    for i, item in enumerate(config.nav or []):
        if isinstance(item, dict) and SECTION in item:
            config.nav[i] = {SECTION: ["equations/README.md", *({n: f"equations/{n}.md"} for n in names)]}
    return config


def index(names: list[str], sizes: dict[str, int]) -> str:
    rows = "\n".join(f"| [{n}]({n}.md) | {sizes[n] / 1000:.0f} kB |" for n in names)
    pdfs = [p.stem for p in sorted((ROOT / "docs" / "equations").glob("*.pdf"))]
    pdf_line = (
        "\n\nThe same LaTeX compiled by pdflatex: "
        + ", ".join(f"[{p}.pdf]({p}.pdf) ([source]({p}.tex))" for p in pdfs)
        + "."
        if pdfs
        else ""
    )
    return f"""# Equations of the shipped arms

What `symdyn print` writes for each shipped arm: M, C, G, F and τ as the command prints
them by default (closed form; a 7-joint arm's M, C and τ in the derivation's named
intermediates), then the named-constant form (`--constants`, Armstrong, Khatib & Burdick
1986) where it is offered. These pages are printed while the site is built
(`docs/_hooks/equations.py` runs the printer through `scripts/print_docs.py`), so they are
the equations of the symdyn you are reading about; the mathematics is rendered by MathJax.
How the forms are made: [Printing closed forms](../printing.md).

| model | LaTeX printed |
|---|---:|
{rows}{pdf_line}

The same pages are committed under `docs/equations/` as Markdown GitHub renders
(`python scripts/print_docs.py` writes them; `tests/test_print_docs.py` checks the
two-link arm's is current).
"""


def on_files(files, config):
    from symdyn.models import NAMES

    _print_docs()  # loaded before the workers fork
    for stale in ["equations/README.md", *(f"equations/{n}.md" for n in NAMES)]:
        if (file := files.get_file_from_path(stale)) is not None:
            files.remove(file)
    names, sizes = arms(), {}
    start = time.perf_counter()
    if jobs(len(names)) > 1:  # the arms side by side: forked workers, the derivation cache's lock between them
        context = multiprocessing.get_context("fork")
        with concurrent.futures.ProcessPoolExecutor(jobs(len(names)), mp_context=context) as pool:
            pages = dict(zip(names, pool.map(_print_docs().model_markdown, names)))
    else:
        pages = {name: _print_docs().model_markdown(name) for name in names}
    for name in names:
        text, _ = pages[name]
        text = text.replace(
            "Generated by `python scripts/print_docs.py` from", "Printed while this site was built, from", 1
        )
        sizes[name] = len(text.encode())
        files.append(File.generated(config, f"equations/{name}.md", content=text))
        log.info("equations/%s.md: %d bytes", name, sizes[name])
    files.append(File.generated(config, "equations/README.md", content=index(names, sizes)))
    log.info("%d arms printed in %.1f s by %d processes", len(names), time.perf_counter() - start, jobs(len(names)))
    return files
