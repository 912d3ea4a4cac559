"""Map a sweep's task over many inputs on a Dask cluster and write each result as it arrives.

Where it sits: above the apps (a task is a pure function of a small input —
an arm's name, two poses, a parameter draw — that calls the OCP, the
simulator, the generated code); the cluster engine is `dask.distributed`
(the optional extra `symdyn[sweep]`).  With no scheduler address, an
embedded `LocalCluster` of worker processes on this machine; with
`scheduler=` (the CLI's `--scheduler`) or `DASK_SCHEDULER_ADDRESS`, an
existing cluster of any size.  A worker builds or finds the model code in
its own cache (`symdyn.derivation.cache.cache_dir()`): nothing but the input
travels, no disk is shared.

The driver (`run`) submits every task not yet in the table, then takes the
results in the order they finish (`as_completed`) and appends each as one
CSV line (`symdyn.sweep.table`): a Ctrl-C or a kill leaves every finished row
on disk, and `resume=True` runs only what is missing.  A task that raises is
a row with its error and its input, not the end of the sweep; a task that
raised is run again on a resume.  A worker that dies has its tasks re-run
elsewhere by the scheduler; the table keys rows by task id, so none is
written twice.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import numbers
import os
import signal
import socket
import sys
import threading
import time
import traceback
import uuid
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence
from urllib.parse import urlsplit

from ..derivation.cache import write_atomic
from .table import Table, TableError

if TYPE_CHECKING:  # Dask is the optional sweep extra: imported only where a sweep runs
    from distributed import Client

__all__ = [
    "Sweep",
    "Outcome",
    "SchedulerUnreachable",
    "SweepInterrupted",
    "META",
    "run",
    "task_id",
    "execute",
    "connect",
    "describe_error",
    "CONNECT_TIMEOUT_S",
]

#: Columns every table ends with: the error (empty when the task succeeded), where and how long it ran,
#: and whether its process had run this task function before (warm = 0 marks a first task: its import
#: and model-loading cost); cpu_s, the task's CPU time, is what a loaded machine does not stretch.
#: They describe the run, not the result: they differ between runs.
META = ("error", "worker", "wall_s", "cpu_s", "warm")
#: Seconds to wait for a scheduler before saying that none answers.
CONNECT_TIMEOUT_S = 5.0
TABLE = "results.csv"


class SchedulerUnreachable(RuntimeError):
    """No Dask scheduler answers at the given address."""


class SweepInterrupted(RuntimeError):
    """Ctrl-C during a sweep; the finished rows are on disk."""


@dataclass(frozen=True)
class Sweep:
    """A sweep: `task(input) -> row` (a module-level function: workers import it by name),
    `inputs(n, **options) -> [input, …]` (each a small dict of numbers, text and lists,
    deterministic in (n, options) and extended, not reshuffled, by a larger n),
    the table's input and result columns, and `report(rows, out_dir) -> lines` (the
    summary below the run's header, figures written into out_dir; rows as read back from
    the table, all cells strings).

    Raises:
        ValueError: a column named twice (an input and a result of the same name would
            share one cell), or named as one of the table's own (task_id and META).
    """

    name: str
    summary: str
    task: Callable[[dict], dict]
    inputs: Callable[..., list[dict]]
    input_columns: tuple[str, ...]
    result_columns: tuple[str, ...]
    report: Callable[[list[dict], Path], list[str]] | None = None
    options: dict = field(default_factory=dict)  # option name -> (default, help) for the CLI

    def __post_init__(self) -> None:
        names = [*self.input_columns, *self.result_columns]
        twice = sorted({c for c in names if names.count(c) > 1})
        if twice:
            raise ValueError(
                f"sweep {self.name}: column(s) {twice} named more than once among its input columns "
                f"{list(self.input_columns)} and result columns {list(self.result_columns)}"
            )
        own = sorted(set(names) & {"task_id", *META})
        if own:
            raise ValueError(f"sweep {self.name}: column(s) {own} are the table's own (task_id, {', '.join(META)})")

    @property
    def columns(self) -> tuple[str, ...]:
        return ("task_id",) + self.input_columns + self.result_columns + META


@dataclass
class Outcome:
    """What a run left: every row of the table (this run's and earlier ones'), how many tasks
    ran now, how many rows record an error, the wall time, and where things are."""

    rows: list[dict[str, str]]
    ran: int
    errors: int
    wall_s: float
    out: Path
    engine: str

    @property
    def table(self) -> Path:
        return self.out / TABLE


def task_id(item: dict) -> str:
    """A stable id of one input: its index (if it has one) and a hash of its canonical JSON,
    so a resume recognises the task across runs and machines.

    Raises:
        TypeError: an input holding something other than numbers, text, lists, dicts
            and NumPy values.
        TypeError: an `index` that is not an integer (a bool, float or text included:
            3.7 would silently become task 3).
    """
    if "index" in item:
        index = item["index"]
        if isinstance(index, bool) or not isinstance(index, numbers.Integral):  # NumPy integers too
            raise TypeError(f"a sweep input's index must be an integer, got {type(index).__name__} {index!r}")
    text = json.dumps(item, sort_keys=True, separators=(",", ":"), default=_jsonable)
    digest = hashlib.sha256(text.encode()).hexdigest()[:10]
    return f"{int(item['index']):06d}-{digest}" if "index" in item else digest


def _jsonable(value):
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"a sweep input must be numbers, text and lists; got {type(value).__name__} {value!r}")


def describe_error(exc: BaseException) -> str:
    """One line: the exception's type and message, and the innermost frame it came from."""
    frames = traceback.extract_tb(exc.__traceback__)
    where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno} in {frames[-1].name})" if frames else ""
    text = " ".join(str(exc).split()) or repr(exc)
    return f"{type(exc).__name__}: {text}{where}"


#: Task functions this process has run (`execute`'s warm flag).
_RAN: set[str] = set()


def execute(task: Callable[[dict], dict], tid: str, item: dict, result_columns: Sequence[str] | None = None) -> dict:
    """Run one task (on a worker, or in the driver for a serial run) and return its whole row:
    the id, the input, the result or the error, and META.  Given `result_columns`, a result
    with any other key is the task's error (recorded, not written over the input's cells).

    Raises:
        KeyboardInterrupt: a Ctrl-C during the task (any `BaseException` that is not
            an `Exception` passes through); an `Exception` of the task is not
            raised but recorded in the row's `error` (`describe_error`).
    """
    name = f"{task.__module__}.{task.__qualname__}"
    warm = name in _RAN
    start, cpu = time.perf_counter(), time.process_time()
    try:
        result, error = dict(task(item)), ""
        extra = sorted(set(result) - set(result_columns)) if result_columns is not None else []
        if extra:
            raise ValueError(
                f"the task returned {extra}, which are not among the sweep's result columns "
                f"{list(result_columns or ())}"
            )
    except Exception as exc:  # recorded in the row; the sweep goes on
        result, error = {}, describe_error(exc)
    _RAN.add(name)
    return {
        "task_id": tid,
        **item,
        **result,
        "error": error,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "wall_s": round(time.perf_counter() - start, 6),
        "cpu_s": round(time.process_time() - cpu, 6),
        "warm": warm,
    }


# --------------------------------------------------------------------------- the cluster


def scheduler_address(scheduler: str | None) -> str | None:
    """The address to use: `scheduler`, else $DASK_SCHEDULER_ADDRESS, else None (a local cluster)."""
    return scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


def _probe(address: str) -> None:
    """Fail at once, naming the address, when nothing listens at a tcp:// or tls:// address."""
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme not in ("tcp", "tls"):
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if not host or not port:
        raise SchedulerUnreachable(
            f"cannot read a host and port in the scheduler address {address!r} (expected e.g. tcp://10.0.0.5:8786)"
        )
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise SchedulerUnreachable(
            f"no Dask scheduler answers at {address}: "
            f"{exc.strerror or exc} (start one with `dask scheduler`, or leave "
            "--scheduler and DASK_SCHEDULER_ADDRESS unset for a local cluster)"
        ) from None


def connect(scheduler: str | None = None, workers: int | None = None) -> tuple[Client, str]:
    """(client, description): a `distributed.Client` of the scheduler at `scheduler` (or
    $DASK_SCHEDULER_ADDRESS), else of a new local cluster of `workers` processes (default:
    one per CPU), one thread each.  Closing the client closes a local cluster too.

    Raises:
        RuntimeError: Dask (`distributed`) is not installed.
        ValueError: `workers` with a scheduler address, or fewer than 1 worker.
        SchedulerUnreachable: an address without host and port, or where no
            scheduler answers within `CONNECT_TIMEOUT_S`.
    """
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        raise RuntimeError(
            "symdyn sweeps need Dask: pip install 'symdyn[sweep]' (or pip install 'dask[distributed]')"
        ) from None
    address = scheduler_address(scheduler)
    if address and workers is not None:
        raise ValueError(
            f"--workers sizes a local cluster; the cluster at {address} has its own workers "
            "(leave --workers out, or unset --scheduler and DASK_SCHEDULER_ADDRESS)"
        )
    if address:
        _probe(address)
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachable(
                f"no Dask scheduler answers at {address}: {' '.join(str(exc).split())}"
            ) from None
        n = len(client.scheduler_info()["workers"])
        return client, f"Dask scheduler {address} ({n} workers at the start)"
    workers = workers or os.cpu_count() or 1
    if workers < 1:
        raise ValueError(f"--workers must be at least 1 (or 0 for a serial run here), got {workers}")
    # a Ctrl-C in the terminal reaches the whole process group: the worker processes are started
    # ignoring it (they inherit that), and this process closes them in order, instead of each
    # printing a page of tracebacks as it dies
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    # Two of Dask's defaults cost sub-second solves CPU (measured on the library's Puma motions):
    # the workers' statistical profiler, sampling every thread each 10 ms (~11 %, for a dashboard
    # we do not open), and MALLOC_TRIM_THRESHOLD_=65536 in the workers' environment (~15 %: glibc
    # hands freed memory back to the system and maps it again at every solve); BLAS and OpenMP
    # stay at one thread, as Dask sets them
    environ = {
        k: v
        for k, v in dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
        if k != "MALLOC_TRIM_THRESHOLD_"
    }
    try:
        with dask.config.set(
            {"distributed.worker.profile.enabled": False, "distributed.nanny.pre-spawn-environ": environ}
        ):
            cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
    client = Client(cluster)
    _LOCAL_CLUSTERS[client] = cluster  # closed with the client (see _close)
    return client, f"local Dask cluster, {workers} worker process{'es' * (workers != 1)}, 1 thread each"


#: The local cluster `connect` started for a client, closed with it by `_close` (weak keys:
#: a client dropped unclosed takes its entry along).
_LOCAL_CLUSTERS: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()


def _close(client: Client) -> None:
    cluster = _LOCAL_CLUSTERS.pop(client, None)
    client.close()
    if cluster is not None:
        cluster.close()


# --------------------------------------------------------------------------- progress


class Progress:
    """One line on stderr: done/total, errors, rate, time left (redrawn in place on a
    terminal, a line per 10 % otherwise)."""

    def __init__(self, label: str, total: int, done: int, enabled: bool = True):
        self.label, self.total, self.done, self.errors = label, total, done, 0
        self.start, self.ran, self.enabled = time.perf_counter(), 0, enabled
        self.tty, self.last, self.step = sys.stderr.isatty(), 0.0, -1

    def __call__(self, error: bool) -> None:
        self.done, self.ran, self.errors = self.done + 1, self.ran + 1, self.errors + bool(error)
        if not self.enabled:
            return
        now = time.perf_counter()
        step = 10 * self.done // max(self.total, 1)
        if (self.tty and now - self.last < 0.2 and self.done < self.total) or (not self.tty and step == self.step):
            return
        self.last, self.step = now, step
        rate = self.ran / max(now - self.start, 1e-9)
        left = (self.total - self.done) / rate if rate > 0 else float("nan")
        line = (
            f"{self.label}: {self.done}/{self.total} done, {self.errors} error{'s' * (self.errors != 1)}, "
            f"{rate:.2f} tasks/s, {left:.0f} s left"
        )
        print(("\r" + line + "   ") if self.tty else line, end="" if self.tty else "\n", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self.tty and self.ran:
            print(file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- the driver


def _check(sweep: Sweep, inputs: Sequence[dict]) -> list[tuple[str, dict]]:
    items: list[tuple[str, dict]] = []
    seen: dict[str, int] = {}
    allowed = set(sweep.input_columns)
    for k, item in enumerate(inputs):
        extra = set(item) - allowed
        if extra:
            raise ValueError(
                f"input {k} of sweep {sweep.name} has keys {sorted(extra)} that are not its input "
                f"columns {list(sweep.input_columns)}"
            )
        tid = task_id(item)
        if tid in seen:
            raise ValueError(f"inputs {seen[tid]} and {k} of sweep {sweep.name} are the same task ({tid})")
        seen[tid] = k
        items.append((tid, dict(item)))
    return items


@functools.lru_cache(maxsize=1)
def _version() -> str:
    from .. import __version__

    return __version__


def run(
    sweep: Sweep,
    inputs: Iterable[dict],
    out: Path | str,
    *,
    resume: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Client | None = None,
    progress: bool = True,
    on_row: Callable[[dict], None] | None = None,
    options: dict | None = None,
) -> Outcome:
    """Run `sweep.task` over `inputs`, writing `out/results.csv` row by row and
    `out/summary.txt` (and the sweep's figures) at the end — also after a Ctrl-C,
    which then raises SweepInterrupted.

    Where: `client` (a `distributed.Client` the caller owns), else the scheduler
    at `scheduler` / $DASK_SCHEDULER_ADDRESS, else a local cluster of `workers`
    processes; workers=0 runs the tasks here, one after the other, through the
    same code (the serial baseline).  resume=True keeps the rows of an earlier
    run of the same inputs and runs the rest (and the tasks that raised);
    without it an `out` that holds results is an error.  on_row(row) is called
    after each row is on disk (tests use it to kill a worker mid-sweep).

    Returns:
        The `Outcome`: every row of the table, how many tasks ran now and how many
        rows record an error, the wall time, the engine used.

    Raises:
        ValueError: an input with keys that are not the sweep's input columns, two
            inputs that are the same task, or a task returning columns the sweep
            does not declare.
        TypeError: an input or a result value that cannot be written (not numbers,
            text, lists, dicts or NumPy values).
        TableError: `out` already holds results (without resume=True), or (with it)
            results of other columns or other inputs, or a damaged table.
        SweepInterrupted: a Ctrl-C; the finished rows and the summary are on disk.
        SchedulerUnreachable: no scheduler answers at `scheduler`.
        RuntimeError: Dask is needed (workers ≠ 0) but not installed.
        OSError: `out` cannot be written.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    items = _check(sweep, list(inputs))
    ids = {tid for tid, _ in items}
    table = Table.open(out / TABLE, sweep.columns, resume=resume)
    try:
        foreign = sorted(table.ids - ids)
        if foreign:
            raise TableError(
                f"{table.path} holds {len(foreign)} result(s) of other inputs (e.g. task {foreign[0]}): "
                f"resume with the options of {out / 'sweep.json'}, or choose another --out"
            )
        table.drop({r["task_id"] for r in table.rows if r["error"]})
        todo = [(tid, item) for tid, item in items if tid not in table.ids]
        write_atomic(
            out / "sweep.json",
            json.dumps(
                {"sweep": sweep.name, "tasks": len(items), "options": options or {}, "symdyn": _version()},
                indent=1,
                default=_jsonable,
            )
            + "\n",
        )
        start = time.perf_counter()
        bar = Progress(sweep.name, len(items), len(items) - len(todo), progress)
        engine = "serial, in this process" if todo else "nothing left to run"
        interrupted = False
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.default_int_handler) if main else None

        def write(row: dict) -> None:
            cells = table.append(row)
            if cells is not None:
                bar(bool(cells["error"]))
                if on_row is not None:
                    on_row(cells)

        try:
            if todo and workers == 0 and client is None:
                for tid, item in todo:
                    write(execute(sweep.task, tid, item, sweep.result_columns))
            elif todo:
                own = client is None
                if client is None:
                    client, engine = connect(scheduler, workers)
                else:
                    engine = f"Dask client {client.scheduler.address}"
                try:
                    _drive(client, sweep, todo, write)
                finally:
                    if own:
                        _close(client)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)
            bar.close()
        wall = time.perf_counter() - start
    finally:
        table.close()
    outcome = Outcome(table.rows, bar.ran, sum(1 for r in table.rows if r["error"]), wall, out, engine)
    _summarise(sweep, outcome, len(items), interrupted)
    if interrupted:
        raise SweepInterrupted(
            f"interrupted: {len(table.rows)} of {len(items)} results are on disk in "
            f"{table.path}; run the same command with --resume to finish"
        )
    return outcome


def _drive(client, sweep: Sweep, todo: list[tuple[str, dict]], write: Callable[[dict], None]) -> None:
    """Submit the tasks, then write their rows in the order they finish.  A future that fails
    without a row (its worker died more often than the scheduler's allowed-failures, the task
    could not be unpickled there) becomes an error row with its input."""
    from distributed import as_completed

    ids = [tid for tid, _ in todo]
    run_token = uuid.uuid4().hex[:8]  # a resume's keys never meet the cancelled keys of the run it resumes
    futures = client.map(
        functools.partial(execute, sweep.task, result_columns=sweep.result_columns),
        ids,
        [item for _, item in todo],
        key=[f"{sweep.name}-{tid}-{run_token}" for tid in ids],
        pure=False,
    )
    pending = {f.key: pair for f, pair in zip(futures, todo)}
    try:
        for future in as_completed(futures):
            tid, item = pending.pop(future.key)
            try:
                row = future.result()
            except Exception as exc:
                row = {
                    "task_id": tid,
                    **item,
                    "error": describe_error(exc),
                    "worker": "",
                    "wall_s": None,
                    "cpu_s": None,
                    "warm": None,
                }
            future.release()
            write(row)
    finally:
        client.cancel([f for f in futures if f.key in pending])


def _summarise(sweep: Sweep, outcome: Outcome, total: int, interrupted: bool) -> None:
    rows = outcome.rows
    head = [
        f"sweep {sweep.name}: {sweep.summary}",
        f"  {len(rows)} of {total} tasks in {outcome.table}"
        + (" (interrupted: --resume finishes it)" if interrupted or len(rows) < total else ""),
        f"  this run: {outcome.ran} tasks on {outcome.engine} in {outcome.wall_s:.1f} s; "
        f"{outcome.errors} row(s) record an error",
    ]
    for r in [r for r in rows if r["error"]][:10]:
        head.append(f"    task {r['task_id']}: {r['error']}")
    body = sweep.report(rows, outcome.out) if sweep.report is not None and rows else []
    write_atomic(outcome.out / "summary.txt", "\n".join(head + [""] + list(body)) + "\n")
