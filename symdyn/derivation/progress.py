"""Progress lines on stderr for long derivations, simulations and builds."""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import Iterator

#: A step wrapped in `reported` says something only once it has run this long (s):
#: a result read back from the cache comes well within it and stays silent.
REPORT_AFTER_S = 2.0


class Progress:
    """Counts steps of a long job and reports them on one stderr line, with an estimate of
    the time left (the mean step so far times the steps left).

    Silent unless `enabled`, and until the job has run `after` seconds (a short job says
    nothing); a finished job that said something prints its total time.  On a terminal
    every step rewrites the line; elsewhere (a log, CI) at most `lines` evenly spread steps
    are printed (the quarters by default), so a long job leaves a handful of lines.
    """

    def __init__(self, label: str, total: int, enabled: bool = True, lines: int = 4, after: float = 0.0) -> None:
        self.label, self.total, self.enabled, self.lines, self.after = label, total, enabled, lines, after
        self.count, self.start, self.said = 0, time.perf_counter(), False

    def step(self, what: str = "") -> None:
        self.count += 1
        elapsed = time.perf_counter() - self.start
        if not self.enabled or elapsed < self.after:
            return
        left = elapsed / self.count * (self.total - self.count)
        line = f"{self.label}: {self.count}/{self.total} {what}" + (
            f" (~{left:.0f} s left)" if self.count < self.total else ""
        )
        if sys.stderr.isatty():
            print(line.ljust(60), end="\r", file=sys.stderr, flush=True)
            self.said = True
        elif self.lines * self.count // max(self.total, 1) > self.lines * (self.count - 1) // max(self.total, 1):
            print(line, file=sys.stderr, flush=True)
            self.said = True

    def done(self) -> float:
        elapsed = time.perf_counter() - self.start
        if self.enabled and (self.said or elapsed >= self.after):
            print(f"{self.label}: done in {elapsed:.2f} s".ljust(60), file=sys.stderr, flush=True)
        return elapsed


def silent(label: str = "", total: int = 0) -> Progress:
    return Progress(label, total, enabled=False)


@contextlib.contextmanager
def reported(what: str, after: float | None = None) -> Iterator[None]:
    """Report one long, indivisible step (a C compile, a derivation) on stderr.

    Silent for a step that ends within `after` s (default REPORT_AFTER_S, read at
    the call); after that, the line "`what` ..." (on a terminal rewritten every
    second with the elapsed time) and, at the end, "`what`: done in 12.3 s".
    """
    after = REPORT_AFTER_S if after is None else after
    start = time.perf_counter()
    finished, shown = threading.Event(), threading.Event()

    def watch() -> None:
        if finished.wait(after):
            return
        shown.set()
        tty = sys.stderr.isatty()
        print(f"{what} ...".ljust(60 if tty else 0), end="\r" if tty else "\n", file=sys.stderr, flush=True)
        while tty and not finished.wait(1.0):
            print(f"{what} ... {time.perf_counter() - start:.0f} s".ljust(60), end="\r", file=sys.stderr, flush=True)

    watcher = threading.Thread(target=watch, name="symdyn-progress", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        finished.set()
        watcher.join()
        if shown.is_set():
            line = f"{what}: done in {time.perf_counter() - start:.1f} s"
            print(line.ljust(60 if sys.stderr.isatty() else 0), file=sys.stderr, flush=True)
