"""Progress lines on stderr for long derivations and simulations."""

from __future__ import annotations

import sys
import time


class Progress:
    """Counts steps of a long job and reports them on one stderr line.

    Silent unless `enabled`; a finished job prints its total time.  On a
    terminal every step rewrites the line; elsewhere (a log, CI) at most
    `lines` evenly spread steps are printed (the quarters by default), so a
    long job leaves a handful of lines.
    """

    def __init__(self, label: str, total: int, enabled: bool = True, lines: int = 4) -> None:
        self.label, self.total, self.enabled, self.lines = label, total, enabled, lines
        self.count, self.start = 0, time.perf_counter()

    def step(self, what: str = "") -> None:
        self.count += 1
        if not self.enabled:
            return
        if sys.stderr.isatty():
            print(f"{self.label}: {self.count}/{self.total} {what}".ljust(60), end="\r", file=sys.stderr, flush=True)
        elif self.lines * self.count // max(self.total, 1) > self.lines * (self.count - 1) // max(self.total, 1):
            print(f"{self.label}: {self.count}/{self.total} {what}", file=sys.stderr, flush=True)

    def done(self) -> float:
        elapsed = time.perf_counter() - self.start
        if self.enabled:
            print(f"{self.label}: done in {elapsed:.2f} s".ljust(60), file=sys.stderr, flush=True)
        return elapsed


def silent(label: str = "", total: int = 0) -> Progress:
    return Progress(label, total, enabled=False)
