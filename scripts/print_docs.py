"""Write the `symdyn print` output of every shipped arm under docs/equations/ (issue 14, item 5).

For each model in `symdyn.models.NAMES`, docs/equations/<model>.md holds what
`symdyn print MODEL --term T --format latex` prints for T = M, C, G, F, tau
(the default terms), then `symdyn print MODEL --constants --format latex`
where the named-constant form is offered, each element in a `$$ … $$`
display (the printing module's `align*` rows become an `aligned` block, so
its line breaking is kept).  A term the print command lays out in named
intermediates (a 7-joint arm's M, C, tau) is given as `--format text` prints
it, in a code block; a term whose Markdown would pass `TERM_LIMIT` characters
is not pasted: the file says how large it is and gives the command.  The
notes the command prints (layout, op counts) follow each term as text.

docs/equations/README.md indexes the files; with pdflatex on the PATH the
LaTeX of `PDF_MODELS` is compiled into docs/equations/<model>.pdf (its
source beside it).  The output depends only on the derivation, never on the
time or the machine, so tests/test_print_docs.py can regenerate the
two-link arm and compare.

    python scripts/print_docs.py            # every model, index, PDFs
    python scripts/print_docs.py twolink    # some models only (no index, no PDF)
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "equations"
TERMS = ("M", "C", "G", "F", "tau")
#: Largest Markdown pasted for one term (characters); beyond, the file gives the command.
TERM_LIMIT = 200_000
PDF_MODELS = ("twolink", "puma560")
TITLES = {
    "M": "Inertia M (upper triangle)",
    "C": "Coriolis and centripetal matrix C",
    "G": "Gravity G",
    "F": "Friction F",
    "tau": "Joint torques τ",
}


def symdyn(*argv: str) -> tuple[int, str, str]:
    """`symdyn ARGV` in this process: exit code, stdout, stderr (as the command prints them)."""
    from symdyn.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(list(argv))
    return rc, out.getvalue(), err.getvalue()


def _rows_to_displays(body: str) -> list[str]:
    """The rows of one `align*` body as `$$ \\begin{aligned} … $$` blocks, one per
    element (an element's continuation rows start with `&\\quad`)."""
    rows = [r.strip() for r in re.split(r"\s*\\\\\n", body.strip()) if r.strip()]
    groups: list[list[str]] = []
    for row in rows:
        if row.startswith(r"&\quad") and groups:
            groups[-1].append(row)
        else:
            groups.append([row])
    return ["$$\n\\begin{aligned}\n" + " \\\\\n".join(g) + "\n\\end{aligned}\n$$" for g in groups]


def latex_to_markdown(tex: str, level: str = "####") -> str:
    """The print command's LaTeX output as Markdown: `%` notes as text (before
    the math) or a code block (after it), `\\section*` as headings, each
    element of every `align*` as a display."""
    before, after, parts = [], [], []
    body = tex
    if "\\begin{document}" in tex:
        head, rest = tex.split("\\begin{document}", 1)
        body, tail = rest.split("\\end{document}", 1)
        before = [line[1:].strip() for line in head.splitlines() if line.startswith("%")]
        after = [line[1:].rstrip() for line in tail.splitlines() if line.startswith("%")]
    for chunk in re.split(r"(\\section\*\{[^}]*\}|\\begin\{align\*\}.*?\\end\{align\*\})", body, flags=re.S):
        if chunk.startswith("\\section*"):
            parts.append(f"{level} " + re.fullmatch(r"\\section\*\{(.*)\}", chunk).group(1))
        elif chunk.startswith("\\begin{align*}"):
            parts += _rows_to_displays(chunk[len("\\begin{align*}") : -len("\\end{align*}")])
    text = "".join(f"{line}\n\n" for line in before) + "\n\n".join(parts)
    if after:
        text += "\n\n```text\n" + "\n".join(f"%{line}" for line in after) + "\n```"
    return text


def _text_block(text: str) -> str:
    return "```text\n" + text.rstrip("\n") + "\n```"


def _too_large(cmd: str, size: int, lines: int) -> str:
    return (
        f"*Not pasted here: {size / 1000:.0f} kB of Markdown ({lines} lines), more than a page "
        f"anyone reads.* Print it with\n\n```sh\n{cmd}\n```"
    )


def _fail(cmd: str, err: str) -> str:
    return f"`{cmd}` is refused:\n\n> {err.strip().removeprefix('symdyn: error: ')}"


def model_markdown(name: str) -> tuple[str, dict]:
    """docs/equations/<name>.md and {"plain": {term: tex}, "constants": tex} of the LaTeX printed."""
    from symdyn.cli import _load_model
    from symdyn.derivation.entry import derive
    from symdyn.presentation.printing import plan

    robot = _load_model(name, False)
    dyn = derive(robot, "newton-euler", cache=True)
    layouts = {lay.term: lay.layout for lay in plan(dyn, TERMS)}
    kind = "symbolic parameters" if robot.is_symbolic else "numeric parameters"
    out = [
        f"# {name}: closed-form dynamics",
        f"{robot.n} joints, {robot.convention} DH, {kind}; Newton–Euler derivation. Generated by "
        f"`python scripts/print_docs.py` from the `symdyn print` commands named under each heading "
        f"(see [docs/printing.md](../printing.md) for the layouts); do not edit by hand.",
        "- [Terms](#terms): " + ", ".join(TERMS) + "\n- [Named-constant form](#named-constant-form)",
    ]
    tex: dict = {"plain": {}, "constants": None}
    out.append("## Terms")
    for t in TERMS:
        fmt = "latex" if layouts[t] == "closed" else "text"
        cmd = f"symdyn print {name} --term {t} --format {fmt}"
        rc, stdout, stderr = symdyn("print", name, "--term", t, "--format", fmt)
        if rc:
            body = _fail(cmd, stderr)
        elif fmt == "latex":
            tex["plain"][t] = stdout
            body = latex_to_markdown(stdout)
        else:
            body = (
                "Printed in the derivation's named intermediates (each defined once before its first "
                "use, then the elements in them), as the command prints it:\n\n" + _text_block(stdout)
            )
        if len(body) > TERM_LIMIT:
            body = _too_large(cmd, len(body), body.count("\n") + 1)
        out += [f"### {TITLES[t]}", f"`{cmd}`", body]
    out.append("## Named-constant form")
    cmd = f"symdyn print {name} --constants --format latex"
    rc, stdout, stderr = symdyn("print", name, "--constants", "--format", "latex")
    if rc:
        out += [f"`{cmd}`", _fail(cmd, stderr)]
    else:
        tex["constants"] = stdout
        body = latex_to_markdown(stdout)
        if len(body) > TERM_LIMIT:
            body = _too_large(cmd, len(body), body.count("\n") + 1)
        out += [f"`{cmd}`", body]
    return "\n\n".join(out) + "\n", tex


def latex_source(name: str, tex: dict) -> str:
    """One LaTeX document of a model: every closed-form term, then the named-constant form."""
    from symdyn.presentation.printing import latex_document

    def inner(doc: str) -> str:
        body = doc.split("\\begin{document}", 1)[1].split("\\end{document}", 1)[0]
        return body.replace("\\small\n", "", 1).strip()

    parts = [f"\\section*{{{name}: closed-form dynamics (\\texttt{{symdyn print}})}}"]
    for t, doc in tex["plain"].items():
        title = TITLES[t].replace("τ", "$\\tau$")
        parts += [f"\\subsection*{{{title}}}", inner(doc)]
    if tex["constants"]:
        parts += ["\\section*{Named-constant form}", inner(tex["constants"]).replace("\\section*", "\\subsection*")]
    return latex_document("\n".join(parts))


def compile_pdf(name: str, source: str) -> tuple[Path, int]:
    """docs/equations/<name>.tex and .pdf (pdflatex, reproducible dates); the PDF and its overfull boxes."""
    (OUT / f"{name}.tex").write_text(source)
    env = dict(os.environ, SOURCE_DATE_EPOCH="0", FORCE_SOURCE_DATE="1")
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / f"{name}.tex").write_text(source)
        run = subprocess.run(
            ["pdflatex", "-interaction=nonstopmode", "-halt-on-error", f"{name}.tex"],
            cwd=tmp,
            env=env,
            capture_output=True,
            text=True,
        )
        if run.returncode:
            raise RuntimeError(f"pdflatex failed on {name}:\n{run.stdout[-2000:]}")
        log = (Path(tmp) / f"{name}.log").read_text(errors="replace")
        shutil.copy(Path(tmp) / f"{name}.pdf", OUT / f"{name}.pdf")
    return OUT / f"{name}.pdf", log.count("Overfull \\hbox")


def index(sizes: dict, pdfs: dict, tex_present: bool) -> str:
    lines = [
        "# Closed-form equations of the shipped arms",
        "What `symdyn print` writes for each shipped arm, so it can be read without installing "
        "anything: M, C, G, F and τ as the command prints them by default (closed form; a 7-joint "
        "arm's M, C and τ in the derivation's named intermediates), then the named-constant form "
        "(`--constants`, Armstrong, Khatib & Burdick 1986) where it is offered. Equations are LaTeX "
        "display math, rendered by GitHub. How the forms are made: [docs/printing.md](../printing.md).",
    ]
    table = ["| model | Markdown | PDF |", "|---|---|---|"]
    for name, size in sizes.items():
        pdf = f"[{name}.pdf]({name}.pdf) ([source]({name}.tex))" if name in pdfs else "—"
        table.append(f"| {name} | [{name}.md]({name}.md) ({size / 1000:.0f} kB) | {pdf} |")
    lines.append("\n".join(table))
    if tex_present:
        lines.append(
            f"The PDFs ({', '.join(pdfs)}) are compiled by pdflatex from the same LaTeX "
            "(every closed-form term, then the named-constant form)."
        )
    else:
        lines.append(
            "No PDF is committed: TeX (pdflatex) was not present where these files were generated. "
            "`symdyn print MODEL --format latex` writes a document pdflatex compiles."
        )
    lines.append(
        "Regenerate with `python scripts/print_docs.py` (a few minutes: the 7-joint arms); "
        "`tests/test_print_docs.py` checks that twolink.md is what the script writes now."
    )
    return "\n\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    from symdyn.models import NAMES

    names = argv or list(NAMES)
    unknown = [n for n in names if n not in NAMES]
    if unknown:
        print(f"unknown model(s): {', '.join(unknown)}; shipped: {', '.join(NAMES)}", file=sys.stderr)
        return 2
    OUT.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    sizes, sources = {}, {}
    for name in names:
        t0 = time.perf_counter()
        text, tex = model_markdown(name)
        path = OUT / f"{name}.md"
        path.write_text(text)
        sizes[name] = len(text.encode())
        sources[name] = tex
        print(f"{path.relative_to(ROOT)}: {sizes[name]} bytes in {time.perf_counter() - t0:.1f} s")
    if argv:
        return 0
    tex_present = shutil.which("pdflatex") is not None
    pdfs = {}
    if tex_present:
        for name in PDF_MODELS:
            pdf, overfull = compile_pdf(name, latex_source(name, sources[name]))
            pdfs[name] = pdf
            print(f"{pdf.relative_to(ROOT)}: {pdf.stat().st_size} bytes, {overfull} overfull boxes")
    (OUT / "README.md").write_text(index(sizes, pdfs, tex_present))
    print(f"all in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main(sys.argv[1:]))
