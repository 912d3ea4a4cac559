"""The rows and tables of the speed comparisons: one comparison per row (paired samples of
symdyn and a peer, the speed-up and its range over rounds), grouped under titles, printed as
text or Markdown.  Shared by `symdyn bench`'s sections (`compare`, `task_bench`)."""

from __future__ import annotations

import statistics
from dataclasses import dataclass

__all__ = ["Row", "format_table", "markdown_table", "OPS_NOTE", "OPS_NOTE_ARM"]


@dataclass
class Row:
    """One comparison, under its group's title (`level`): paired samples (one per round or
    repetition) of ns per call (per state for batches) of symdyn and of the peer, the op count
    of the symdyn function and the speed-up (peer/symdyn) issue 4 asks for.  A peer that was
    not measured makes no row (the report says what to install instead)."""

    level: str
    function: str
    symdyn: tuple
    peer: str
    peer_samples: tuple
    ops: int | None = None
    target: float | None = None

    def __post_init__(self) -> None:
        if not self.symdyn or not self.peer_samples:
            raise ValueError(f"row {self.function!r} vs {self.peer!r}: both sides need at least one timing")

    @property
    def symdyn_ns(self) -> float:
        return statistics.median(self.symdyn)

    @property
    def peer_ns(self) -> float:
        return statistics.median(self.peer_samples)

    @property
    def ratio(self) -> float:
        """Speed-up: median peer time / median symdyn time."""
        return self.peer_ns / self.symdyn_ns

    @property
    def spread(self) -> tuple[float, float] | None:
        """(lowest, highest) speed-up of the paired samples: how much the machine's noise moves it."""
        if len(self.peer_samples) < 2:
            return None
        ratios = [p / s for s, p in zip(self.symdyn, self.peer_samples)]
        return min(ratios), max(ratios)

    @property
    def met(self) -> str:
        if self.target is None:
            return ""
        return "yes" if self.ratio >= self.target else "no"


COLUMNS = ("function", "symdyn ns", "peer", "peer ns", "speed-up", "range", "ops", "target", "met")
RIGHT = {1, 3, 4, 5, 6}
#: What the ops column counts, printed with every table (a count that does not say what it counts misleads).
OPS_NOTE = (
    "ops: the symdyn function's operations in its generated C (mul + add + div + sin/cos/sign calls, "
    "after one joint CSE; Newton–Euler on regrouped base parameters, C by Lagrange), without friction "
    "unless the function says +friction"
)
#: The same for an arm beyond six joints' reach of Lagrange, and the CasADi baseline's count beside it.
OPS_NOTE_ARM = (
    "ops: the symdyn function's operations in its generated C (mul + add + div + sin/cos/sign calls, "
    "after one joint CSE; Newton–Euler on regrouped base parameters, C = ∂(C q̇)/∂q̇ / 2 of it, as the "
    "generated file's header says), without friction; the CasADi baseline's ops: the arithmetic and "
    "sin/cos instructions of its SX algorithm, negation free"
)


def _cells(row: Row) -> list[str]:
    spread = row.spread
    return [
        row.function,
        f"{row.symdyn_ns:.1f}",
        row.peer,
        f"{row.peer_ns:.1f}",
        f"{row.ratio:.2f}×",
        f"{spread[0]:.2f}–{spread[1]:.2f}" if spread else "",
        "" if row.ops is None else str(row.ops),
        f"≥ {row.target}×" if row.target else "",
        row.met,
    ]


def _groups(rows: list[Row]) -> list[tuple[str, list[Row]]]:
    """Rows grouped by their level (the group's title), in order of first appearance."""
    groups: dict[str, list[Row]] = {}
    for row in rows:
        groups.setdefault(row.level, []).append(row)
    return list(groups.items())


def format_table(rows: list[Row], missing: list[str] = (), note: str = OPS_NOTE) -> str:
    """Plain-text tables, one per group of rows under its title, the ops legend, then one line
    per peer that was not measured (what to install)."""
    out = []
    for title, group in _groups(rows):
        cells = [list(COLUMNS)] + [_cells(r) for r in group]
        widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
        lines = [
            "  ".join(c.rjust(w) if i in RIGHT else c.ljust(w) for i, (c, w) in enumerate(zip(line, widths)))
            for line in cells
        ]
        lines.insert(1, "  ".join("-" * w for w in widths))
        out += ["", title, *(line.rstrip() for line in lines)]
    out += ["", note, *missing]
    return "\n".join(out).strip("\n")


def markdown_table(rows: list[Row], missing: list[str] = (), note: str = OPS_NOTE) -> str:
    """The same tables in Markdown: the title of each in bold above it."""
    out = []
    for title, group in _groups(rows):
        out += [
            "",
            f"**{title}**",
            "",
            "| " + " | ".join(COLUMNS) + " |",
            "|" + "|".join("---:" if i in RIGHT else "---" for i in range(len(COLUMNS))) + "|",
        ]
        out += ["| " + " | ".join(_cells(r)) + " |" for r in group]
    out += ["", note + ".", *(f"\n{m}" for m in missing)]
    return "\n".join(out).strip("\n")
