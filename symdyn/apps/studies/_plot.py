"""Figure and summary helpers shared by the studies: matplotlib on the Agg
backend, small PNGs, summary.txt.  Private (the registry skips modules whose
names start with "_"), so it defines no studies."""

from __future__ import annotations

from pathlib import Path


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (a clear error if matplotlib is missing)."""
    try:
        import matplotlib
    except ImportError:
        raise RuntimeError("studies draw figures with matplotlib: pip install 'symdyn[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, out_dir: Path, name: str) -> Path:
    """Write fig as out_dir/name.png (small: dpi 80) and close it."""
    path = Path(out_dir) / f"{name}.png"
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    pyplot().close(fig)
    return path


def finish(out_dir: Path, lines: list[str]) -> str:
    """Write the summary lines to out_dir/summary.txt and return them as text."""
    text = "\n".join(lines)
    (Path(out_dir) / "summary.txt").write_text(text + "\n")
    return text
