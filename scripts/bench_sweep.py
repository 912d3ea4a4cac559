"""Benchmark of `symdyn sweep`: the trajectory library serially, then on local Dask clusters.

    .venv/bin/python scripts/bench_sweep.py --n 200 --workers 1,2 [--cold-cache] [--markdown FILE]
    .venv/bin/python scripts/bench_sweep.py --probe 400 --probe-ms 50 --workers 1,2   # the engine alone
    .venv/bin/python scripts/bench_sweep.py --fuzz 40 --workers 1,2                   # the random-arm fuzz

One run, same tasks: the library of n minimum-time Puma motions (--arm, N = 40,
Hermite–Simpson on compiled CasADi dynamics; no re-simulation unless
--verify) first in this process one after the other (`workers=0`: the
baseline, same task code), then on a local cluster of 1 and 2 worker
processes (one thread each).  Reported per run: wall time, per-task time (the
mean time inside a warm task), first-task cost (a fresh process's first task
minus a warm one: imports and loading the compiled functions from the disk
cache), scheduler overhead per task (worker time outside tasks: k·wall − Σ
task time, per task; includes the start-up of the workers' first tasks and
the idle tail), speed-up and parallel efficiency against the serial run, and
whether every run's results equal the serial run's exactly; then the machine's
ceiling: the same motions split over k independent processes without Dask
(what the cores give side by side bounds any engine's efficiency).  --cold-cache also
times one task in a fresh process with an empty symdyn cache (a new host of a
cluster: derive, generate and compile the CasADi functions).  BLAS/OpenMP are
held to one thread everywhere (Dask's workers do this by default).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from symdyn.sweep import engine, library  # noqa: E402


def _results(rows) -> dict:
    """Rows by task id without the run's columns (and, for the fuzz, without its per-stage seconds)."""
    out = {}
    for r in rows:
        row = {k: v for k, v in r.items() if k not in engine.META or k == "error"}
        if row.get("per_stage"):
            row["per_stage"] = [s[:3] for s in json.loads(row["per_stage"])]
        out[r["task_id"]] = row
    return out


def fuzz_sweep(arms: int):
    """The random-arm fuzz as a sweep (scripts/fuzz_arms.py's task), and its first `arms` inputs."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import fuzz_arms

    columns = ("index", "seed", "n_min", "n_max", "general", "states", "stages", "tol")
    sweep = engine.Sweep(
        "fuzz-arms",
        "random-arm differential check",
        fuzz_arms.check_one,
        inputs=None,
        input_columns=columns,
        result_columns=("name", "n", "joints", "per_stage", "bad", "code"),
    )
    items = [
        {
            "index": k,
            "seed": 1000 + k,
            "n_min": 1,
            "n_max": 7,
            "general": 0.0,
            "states": 12,
            "stages": list(fuzz_arms.STAGES),
            "tol": 1e-10,
        }
        for k in range(arms)
    ]
    return sweep, items


def measure(label: str, rows, wall: float, workers: int, serial_wall: float | None) -> dict:
    done = [r for r in rows if r["wall_s"]]
    warm = [float(r["wall_s"]) for r in done if r["warm"] == "1"]
    cold = [float(r["wall_s"]) for r in done if r["warm"] == "0"]
    per_task = statistics.mean(warm) if warm else float("nan")
    cpu = statistics.mean(float(r["cpu_s"]) for r in done if r["warm"] == "1") if warm else float("nan")
    busy = sum(float(r["wall_s"]) for r in done)
    out = {
        "run": label,
        "workers": workers,
        "wall_s": wall,
        "per_task_s": per_task,
        "cpu_per_task_s": cpu,
        "first_task_extra_s": (statistics.mean(cold) - per_task) if cold else float("nan"),
        "overhead_per_task_s": (max(workers, 1) * wall - busy) / len(done),
        "tasks_per_s": len(done) / wall,
    }
    if serial_wall is not None:
        out["speedup"] = serial_wall / wall
        out["efficiency"] = serial_wall / (workers * wall)
    return out


def idle(item: dict) -> dict:
    """The probe's task: sleep for item["s"] seconds (no CPU: what remains of a run's wall time beyond
    the sleeps is the engine's own cost, and a loaded machine hardly stretches it)."""
    time.sleep(item["s"])
    return {"slept": item["s"]}


def probe(tasks: int, seconds: float, sizes: list[int], out: Path) -> list[str]:
    """Scheduler overhead per task on tasks that only sleep, serially and on local clusters."""
    sweep = engine.Sweep(
        "probe", "sleeping tasks", idle, inputs=None, input_columns=("index", "s"), result_columns=("slept",)
    )
    items = [{"index": k, "s": seconds} for k in range(tasks)]
    lines = [
        f"engine overhead: {tasks} tasks that sleep {seconds * 1e3:.0f} ms each",
        "| run | wall (s) | ideal (s) | overhead per task (ms) | efficiency |",
        "|---|---|---|---|---|",
    ]
    runs = [("serial (this process)", 0)] + [(f"local cluster, {k} worker{'s' * (k != 1)}", k) for k in sizes]
    for label, k in runs:
        if k:
            client, _ = engine.connect(None, k)
            client.run(time.sleep, 0)  # workers up and answering
            got = engine.run(sweep, items, out / f"probe{k}", client=client, progress=False)
            engine._close(client)
        else:
            got = engine.run(sweep, items, out / "probe0", workers=0, progress=False)
        ideal = tasks * seconds / max(k, 1)
        busy = sum(float(r["wall_s"]) for r in got.rows)
        lines.append(
            f"| {label} | {got.wall_s:.2f} | {ideal:.2f} | "
            f"{(max(k, 1) * got.wall_s - busy) / tasks * 1e3:.1f} | {ideal / got.wall_s:.2f} |"
        )
    return lines


def independent(items: list[dict], k: int) -> float:
    """The machine's ceiling for k workers: k independent processes (no Dask, no driver), each
    running its share of the tasks one after the other once warm; the wall time of the slowest.
    What the cores give side by side (shared caches, memory, clocks) bounds any engine."""
    code = (
        "import json, sys, time; from symdyn.sweep import library; items = json.loads(sys.stdin.read()); "
        "library.motion(items[0]); t = time.perf_counter(); [library.motion(i) for i in items]; "
        "print(time.perf_counter() - t)"
    )
    shares = [items[j::k] for j in range(k)]
    procs = [
        subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        for _ in shares
    ]
    for proc, share in zip(procs, shares):
        proc.stdin.write(json.dumps(share))
        proc.stdin.close()
    walls = [float(proc.stdout.read().split()[-1]) for proc in procs]
    if any(proc.wait() for proc in procs):
        raise RuntimeError("an independent process failed")
    return max(walls)


def cold_cache_first_task(item: dict) -> float:
    """Seconds of one task in a fresh process whose symdyn cache is empty (a new host)."""
    with tempfile.TemporaryDirectory(prefix="symdyn-cold-") as cache:
        code = (
            "import time; t = time.perf_counter(); from symdyn.sweep import library; "
            f"library.motion({item!r}); print(time.perf_counter() - t)"
        )
        env = dict(os.environ, SYMDYN_CACHE_DIR=cache)
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        return float(run.stdout.split()[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=200, help="motions (default 200)")
    p.add_argument("--arm", default="puma560", choices=library.ARMS)
    p.add_argument("--N", type=int, default=None, help="collocation intervals (default: the arm's, Puma 40)")
    p.add_argument("--workers", default="1,2", help="local cluster sizes to run, comma-separated (default 1,2)")
    p.add_argument("--verify", action="store_true", help="re-simulate every motion with the reference (slower)")
    p.add_argument(
        "--no-ceiling",
        dest="ceiling",
        action="store_false",
        help="skip the machine's ceiling (the motions in independent processes, no Dask)",
    )
    p.add_argument("--cold-cache", action="store_true", help="also time a first task with an empty cache")
    p.add_argument("--out", default=None, help="folder for the runs' tables (default: a temporary folder)")
    p.add_argument("--markdown", default=None, help="also write the table as markdown to this file")
    p.add_argument(
        "--probe",
        type=int,
        default=0,
        metavar="TASKS",
        help="only the engine's overhead: TASKS tasks that sleep --probe-ms each (no solves)",
    )
    p.add_argument("--probe-ms", type=float, default=50.0, help="sleep of a probe task, ms (default 50)")
    p.add_argument(
        "--fuzz",
        type=int,
        default=0,
        metavar="ARMS",
        help="the random-arm fuzz of ARMS arms instead of the library (scripts/fuzz_arms.py's task)",
    )
    args = p.parse_args(argv)
    sizes = [int(k) for k in args.workers.split(",") if k]
    out = Path(args.out or tempfile.mkdtemp(prefix="bench-sweep-"))
    if args.probe:
        text = "\n".join(probe(args.probe, args.probe_ms / 1e3, sizes, out))
        print(text)
        if args.markdown:
            Path(args.markdown).write_text(text + "\n")
        return 0
    load = os.getloadavg()[0]
    if args.fuzz:
        sweep, items = fuzz_sweep(args.fuzz)
        what = f"the random-arm fuzz of {args.fuzz} arms (seeds 1000…, 1 to 7 joints)"
    else:
        sweep, items = library.SWEEP, library.inputs(args.n, arm=args.arm, N=args.N, verify=args.verify)
        what = f"{args.n} minimum-time {args.arm} motions (N = {items[0]['N']}, verify {args.verify})"
        t = time.perf_counter()
        library.motion(items[0])  # fills the cache (derive, generate, compile) if need be: not timed below
        print(f"  warm-up task (cache fill if the cache is cold): {time.perf_counter() - t:.1f} s", flush=True)
    print(
        f"bench_sweep: {what}, {os.cpu_count()} CPUs, load average {load:.1f} at the start; tables in {out}", flush=True
    )
    if args.fuzz:  # every run derives and compiles its arms afresh, as a first fuzz of those seeds does
        os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-cache-serial-")
    serial = engine.run(sweep, items, out / "serial", workers=0, progress=False)
    serial_wall = serial.wall_s  # the tasks and the writing of their rows; not the summary and figure
    rows = [measure("serial (this process)", serial.rows, serial_wall, 1, None)]
    reference = _results(serial.rows)
    equal = {}
    for k in sizes:
        if args.fuzz:
            os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix=f"symdyn-cache-workers{k}-")
        t = time.perf_counter()
        client, _ = engine.connect(None, k)  # the local cluster `symdyn sweep --workers k` starts
        startup = time.perf_counter() - t
        got = engine.run(sweep, items, out / f"workers{k}", client=client, progress=False)
        wall = got.wall_s
        engine._close(client)
        row = measure(f"local cluster, {k} worker{'s' * (k != 1)}", got.rows, wall, k, serial_wall)
        row["cluster_start_s"] = startup
        rows.append(row)
        equal[k] = _results(got.rows) == reference
        print(f"  {row['run']}: {wall:.1f} s (cluster start {startup:.1f} s, not included)", flush=True)
    done = sum(1 for r in serial.rows if not r["error"] and (args.fuzz or r["T"]))
    lines = [
        f"{what}: {done} {'checked' if args.fuzz else 'solved'}; load average {load:.1f} -> "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs",
        "| run | wall (s) | per task (s) | CPU per task (s) | first-task extra (s) | overhead per task (s) | tasks/s | speed-up "
        "| efficiency |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['run']} | {r['wall_s']:.1f} | {r['per_task_s']:.3f} | {r['cpu_per_task_s']:.3f} | "
            f"{r['first_task_extra_s']:.2f} | "
            f"{r['overhead_per_task_s']:.4f} | {r['tasks_per_s']:.2f} | "
            f"{r.get('speedup', 1.0):.2f} | {r.get('efficiency', 1.0):.2f} |"
        )
    if not args.fuzz and args.ceiling:
        ceiling = {k: independent(items, k) for k in sizes if k > 1}
        lines.append(
            "the machine's ceiling (k independent processes, no Dask, each warm, its share of the "
            "motions one after the other): "
            + ", ".join(
                f"{k}: {w:.1f} s, speed-up {serial_wall / w:.2f}, efficiency {serial_wall / (k * w):.2f}"
                for k, w in ceiling.items()
            )
        )
    lines.append(
        "results equal the serial run exactly: "
        + ", ".join(f"{k} worker(s) {'yes' if v else 'NO'}" for k, v in equal.items())
    )
    if args.cold_cache and not args.fuzz:
        lines.append(
            f"first task in a fresh process with an empty cache (derive, generate, compile): "
            f"{cold_cache_first_task(items[0]):.1f} s"
        )
    text = "\n".join(lines)
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text + "\n")
    return 0 if all(equal.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
