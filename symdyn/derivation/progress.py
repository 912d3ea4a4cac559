"""Progress lines on stderr for long derivations and simulations."""

from __future__ import annotations

import sys
import time


class Progress:
    """Counts steps of a long job and reports them on one stderr line.

    Silent unless `enabled`; a finished job prints its total time.
    """

    def __init__(self, label: str, total: int, enabled: bool = True) -> None:
        self.label, self.total, self.enabled = label, total, enabled
        self.count, self.start = 0, time.perf_counter()

    def step(self, what: str = "") -> None:
        self.count += 1
        if self.enabled:
            end = "\r" if sys.stderr.isatty() else "\n"
            print(f"{self.label}: {self.count}/{self.total} {what}".ljust(60), end=end, file=sys.stderr, flush=True)

    def done(self) -> float:
        elapsed = time.perf_counter() - self.start
        if self.enabled:
            print(f"{self.label}: done in {elapsed:.2f} s".ljust(60), file=sys.stderr, flush=True)
        return elapsed


def silent(label: str = "", total: int = 0) -> Progress:
    return Progress(label, total, enabled=False)
