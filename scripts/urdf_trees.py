"""Real robot trees from example-robot-data, read as they come (issue 22): the slow check.

Run: .venv/bin/python scripts/urdf_trees.py [--robots NAME ...] [--markdown PATH] [--cold]

Each robot's chain is read by `Robot.from_urdf` — every moving joint off the
chain locked (default 0, or the limit nearest 0; mimic joints following their
leader; chain joints named in `locked` made fixed) and merged into the link it
hangs from — and compared by `symdyn.bench.reduced.compare` with Pinocchio's
`buildReducedModel` of the whole file, the same joints locked at the same
values: the reference's τ, M, G, C·q̇, Christoffel symbols, forward dynamics
and tool pose, and the generated C code's τ, M, fdyn and derivatives.  Every
relative error must be ≤ 1e-10 (else FAIL and exit status 1).  Reports the
locks, snaps and warnings of each reading, the generated code's operation
counts per function, and the time to read the file and to derive + generate +
compile (the first `symdyn.load`, cold when the cache did not hold it; `--cold`
uses a fresh cache) against a cached load.  Progress goes to stderr; the
Markdown table to stdout and `--markdown PATH`.

Needs the `robots` extra (example-robot-data) and Pinocchio (`pin`, the
`test` or `bench` extra).  Too slow for the test suite: a 7–8 joint arm takes
10–60 s to derive and generate on a cold cache.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

TOL = 1e-10
FUNCTIONS = ("tau", "M", "C", "G", "fdyn", "tau_derivatives", "fdyn_derivatives")


@dataclass(frozen=True)
class Case:
    """One chain of one file: `from_urdf(file, **options)`, and what the reading must give."""

    name: str
    file: str  # relative to example-robot-data's robots/ folder
    what: str
    options: dict
    joints: tuple  # the chain's moving joints, in order
    seed: int
    warn: tuple = ()  # links the reading must warn about (and not refuse)
    tau_ops: int | None = None  # an expected τ operation count (± 10 %), where an issue names one


TALOS_LOCKS = {
    "torso_1_joint": 0.3,
    "torso_2_joint": 0.2,  # on the chain: made fixed
    "arm_right_1_joint": 0.5,
    "arm_right_2_joint": -0.6,
    "arm_right_4_joint": -1.0,
    "head_1_joint": 0.4,
    "head_2_joint": -0.5,
    "gripper_left_joint": -0.4,
    "gripper_right_joint": -0.6,
    "leg_left_4_joint": 1.0,
}
TIAGO_DUAL_LOCKS = {
    "arm_right_1_joint": 0.6,
    "arm_right_2_joint": -0.4,
    "arm_right_4_joint": 1.2,
    "arm_right_6_joint": 0.7,
    "head_1_joint": 0.3,
    "head_2_joint": -0.5,
    "hand_right_index_joint": 1.0,
    "hand_left_thumb_joint": 0.8,
}
BAXTER_LOCKS = {"r_gripper_l_finger_joint": 0.012, "left_s0": 0.4, "left_e1": 1.0, "head_pan": 0.3}

TIAGO_ARM = tuple(f"arm_{k}_joint" for k in range(1, 8))
CASES = (
    Case(
        "tiago",
        "tiago_description/robots/tiago.urdf",
        "TIAGo: torso lift + arm; wheels on the base, head and hand locked",
        dict(tip_link="arm_tool_link"),
        ("torso_lift_joint",) + TIAGO_ARM,
        seed=1,
        warn=("base_antenna_left_link", "base_antenna_right_link"),
    ),
    Case(
        "so101",
        "so_arm_description/urdf/so101.urdf",
        "SO-101 to the gripper frame, the moving jaw locked at 0",
        dict(tip_link="gripper_frame_link"),
        ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
        seed=2,
    ),
    Case(
        "so101_jaw",
        "so_arm_description/urdf/so101.urdf",
        "SO-101, the jaw locked open (gripper = 0.8)",
        dict(tip_link="gripper_frame_link", locked={"gripper": 0.8}),
        ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
        seed=3,
    ),
    Case(
        "talos_left_arm",
        "talos_data/robots/talos_full_v2.urdf",
        "Talos' left arm to the gripper base; torso locked on the chain, gripper (with its mimic "
        "joints), right arm, head and a leg at non-zero values",
        dict(tip_link="gripper_left_base_link", locked=TALOS_LOCKS),
        tuple(f"arm_left_{k}_joint" for k in range(1, 8)),
        seed=4,
    ),
    Case(
        "kinova",
        "kinova_description/robots/kinova.urdf",
        "Kinova Jaco2 (j2s6s200) to the end effector, snapped",
        dict(tip_link="j2s6s200_end_effector"),
        tuple(f"j2s6s200_joint_{k}" for k in range(1, 7)),
        seed=5,
        tau_ops=464,
    ),
    Case(
        "kinova_unsnapped",
        "kinova_description/robots/kinova.urdf",
        "the same Jaco2 with the file's numbers (snap=False), for the op counts",
        dict(tip_link="j2s6s200_end_effector", snap=False),
        tuple(f"j2s6s200_joint_{k}" for k in range(1, 7)),
        seed=6,
    ),
    Case(
        "tiago_dual_left",
        "tiago_description/robots/tiago_dual.urdf",
        "TIAGo++: torso lift + left arm; right arm, head and fingers locked at non-zero values",
        dict(tip_link="arm_left_tool_link", locked=TIAGO_DUAL_LOCKS),
        ("torso_lift_joint",) + tuple(f"arm_left_{k}_joint" for k in range(1, 8)),
        seed=7,
        warn=("base_antenna_left_link", "base_antenna_right_link"),
    ),
    Case(
        "baxter_right",
        "baxter_description/urdf/baxter.urdf",
        "Baxter's right arm to the gripper; a prismatic finger (and its mimic) open, the left arm and head locked",
        dict(tip_link="right_gripper", locked=BAXTER_LOCKS),
        ("right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"),
        seed=8,
    ),
)
BY_NAME = {c.name: c for c in CASES}


@dataclass
class Result:
    case: Case
    chain: str = ""
    n: int = 0
    locked: tuple = ()
    snaps: int = 0
    max_snap: float = 0.0
    warnings: tuple = ()
    read_s: float = math.nan
    first_s: float = math.nan
    cold: bool | None = None
    cached_s: float = math.nan
    compare_s: float = math.nan
    errors: dict = field(default_factory=dict)
    ops: dict = field(default_factory=dict)
    problems: list = field(default_factory=list)

    @property
    def worst(self) -> tuple[str, float]:
        if not self.errors:
            return ("", math.inf)
        key = max(self.errors, key=self.errors.get)
        return key, self.errors[key]

    @property
    def ok(self) -> bool:
        return not self.problems and bool(self.errors) and all(e <= TOL for e in self.errors.values())


def robots_folder(given: str | None) -> Path:
    """example-robot-data's robots/ folder (inside the wheel's cmeel.prefix), or `given`."""
    if given:
        folder = Path(given)
    else:
        try:
            dist = importlib.metadata.distribution("example-robot-data")
        except importlib.metadata.PackageNotFoundError:
            sys.exit(
                "urdf_trees: example-robot-data is not installed: pip install example-robot-data "
                "(or pip install -e '.[robots]'), or give its robots/ folder with --data"
            )
        folder = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
        if not folder.is_dir():  # another layout: find the folder among the wheel's files
            hits = [f for f in dist.files or () if "example-robot-data/robots/" in str(f)]
            if hits:
                text = str(dist.locate_file(hits[0]))
                folder = Path(text[: text.index("example-robot-data/robots/")]) / "example-robot-data" / "robots"
    if not folder.is_dir():
        sys.exit(f"urdf_trees: no example-robot-data robots/ folder at {folder}: pip install example-robot-data")
    return folder


def op_counts(functions) -> dict:
    """Function → total operations, from the comment line of each function's C file, which the
    C target of a model that is not shipped writes into the model's cache folder."""
    counts = {}
    for path in Path(functions.folder).glob(f"{functions.name}.*.c"):
        m = re.search(r"operations after one joint CSE: .*\((\d+) total\)", path.read_text()[:2000])
        if m:
            counts[path.name.split(".")[1]] = int(m.group(1))
    return counts


def log(message: str) -> None:
    print(f"[urdf_trees {time.strftime('%H:%M:%S')}] {message}", file=sys.stderr, flush=True)


def run(case: Case, folder: Path, count: int) -> Result:
    import symdyn
    from symdyn.bench.reduced import compare
    from symdyn.model import Robot
    from symdyn.model.urdf import URDFWarning

    out = Result(case)
    path = folder / case.file
    log(f"{case.name}: reading {case.file} ({case.what})")
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = Robot.from_urdf(path, name=case.name, **case.options)
    out.read_s = time.perf_counter() - start
    record = robot.urdf
    out.chain = f"{record.base_link} → {record.tip_link}"
    out.n, out.locked = robot.n, record.locked
    out.snaps, out.max_snap = len(record.snaps), record.max_snap
    out.warnings = record.warnings
    issued = [str(w.message) for w in caught if issubclass(w.category, URDFWarning)]
    if list(record.joints) != list(case.joints):
        out.problems.append(f"chain joints {list(record.joints)}, expected {list(case.joints)}")
    for link in case.warn:
        if not any(f"link {link!r}" in w for w in issued):
            out.problems.append(f"no URDFWarning about link {link!r} (warnings: {issued})")
    nonzero = [f"{lock.joint}={lock.value:g}" for lock in record.locked if lock.value != 0]
    log(
        f"{case.name}: read in {out.read_s:.2f} s: {robot.n} joints, {len(record.locked)} locked "
        f"({len(nonzero)} non-zero), {out.snaps} snaps (largest {out.max_snap:.1e}), "
        f"{len(record.warnings)} warnings"
    )

    log(f"{case.name}: derive + generate + compile every function (symdyn.load(robot, 'c').build())…")
    start, wall = time.perf_counter(), time.time()
    functions = symdyn.load(robot, "c")
    functions.build(batch=False)
    out.first_s = time.perf_counter() - start
    out.cold = (Path(functions.folder) / f"{functions.name}.tau.c").stat().st_mtime >= wall - 0.05
    out.cached_s = cached_load(case, folder)
    out.ops = op_counts(functions)
    log(
        f"{case.name}: first load {out.first_s:.1f} s ({'cold' if out.cold else 'from the cache'}), "
        f"cached (another process) {out.cached_s:.2f} s; ops " + ", ".join(f"{f} {out.ops.get(f)}" for f in FUNCTIONS)
    )
    if case.tau_ops and abs(out.ops.get("tau", 0) - case.tau_ops) > 0.1 * case.tau_ops:
        out.problems.append(f"tau takes {out.ops.get('tau')} operations, the issue expects about {case.tau_ops}")

    log(f"{case.name}: comparing with Pinocchio's reduced model at {count} states…")
    start = time.perf_counter()
    out.errors = compare(robot, path, count=count, seed=case.seed, functions=functions)
    out.compare_s = time.perf_counter() - start
    key, worst = out.worst
    log(f"{case.name}: {'ok' if out.ok else 'FAIL'}: worst relative error {worst:.1e} ({key}) in {out.compare_s:.1f} s")
    return out


def cached_load(case: Case, folder: Path) -> float:
    """Seconds of `symdyn.load(robot, "c")` in a fresh process, the cache now holding the robot's
    code and library (reads and checks the files, imports the compiled extension); NaN when that
    process generated or compiled anew after all — symdyn's source changed in between (the
    cache is keyed by it), as it does while someone edits the tree."""
    result = subprocess.run(
        [sys.executable, __file__, "--data", str(folder), "--time-cached-load", case.name],
        capture_output=True,
        text=True,
    )
    if result.returncode:
        log(f"{case.name}: the cached load in a new process failed:\n{result.stderr.strip()}")
        return math.nan
    seconds, hit = result.stdout.split()[-2:]
    if hit != "hit":
        log(
            f"{case.name}: the new process generated or compiled again ({float(seconds):.1f} s): symdyn's "
            "source changed since the first load; no cached time"
        )
        return math.nan
    return float(seconds)


def _time_cached_load(case: Case, folder: Path) -> None:
    """Print the seconds of one load and whether it found everything in the cache ("hit")."""
    import symdyn
    from symdyn.derivation.cache import cache_dir
    from symdyn.model import Robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = Robot.from_urdf(folder / case.file, name=case.name, **case.options)
    wall, start = time.time(), time.perf_counter()
    functions = symdyn.load(robot, "c")
    functions.build(batch=False)
    seconds = time.perf_counter() - start
    written = list(Path(functions.folder).glob(f"{functions.name}.*.c"))
    written += list((cache_dir() / "c" / "units").glob(f"{functions.name}_*"))
    fresh = any(f.stat().st_mtime >= wall - 0.05 for f in written if f.exists())
    print(seconds, "miss" if fresh else "hit")


# --------------------------------------------------------------------------- report


def _seconds(s: float) -> str:
    return "–" if not math.isfinite(s) else (f"{s:.2f} s" if s < 10 else f"{s:.0f} s")


def markdown(results: list, command: str, cold: bool) -> str:
    lines = [
        "# Robot trees from example-robot-data",
        "",
        "The slow check of issue 22 (`scripts/urdf_trees.py`): real URDF trees read by "
        "`Robot.from_urdf` (off-chain joints locked and merged, angles and axes snapped) against "
        "Pinocchio's `buildReducedModel` of the whole file with the same joints locked at the same "
        f"values (`symdyn.bench.reduced.compare`, generated C included; every relative error ≤ {TOL:g}).",
        "",
        "Produced by"
        + (" (`--cold`: a fresh cache, so the first load derives, generates and compiles)" if cold else "")
        + ":",
        "",
        "```",
        command,
        "```",
        "",
        'The first `symdyn.load(robot, "c")` with `build()` derives, generates and compiles unless the cache holds '
        "the robot's code (then marked *cache*); the cached load is the same call in a new process "
        "(– where that process found the cache outdated: symdyn's source changed in between).",
        "",
        "Where symdyn snapped the file's angles and axes (π/2 written 1.57079632679, 4.9e-12 rad off), "
        "Pinocchio reads a copy snapped by the same rule, so the errors measure the dynamics, not "
        "the snap; the `kinova_unsnapped` row reads the file's numbers on both sides (`snap=False`).",
        "",
        "| robot | chain base → tip | n | locked (non-zero) | snaps (largest change) | max error vs "
        "Pinocchio reduced | τ / M / G / fdyn ops | read | first load | cached load |",
        "|---|---|---:|---|---|---|---|---:|---:|---:|",
    ]
    for r in results:
        key, worst = r.worst
        nonzero = sum(1 for lock in r.locked if lock.value != 0)
        on_base = sum(1 for lock in r.locked if not lock.moves)
        ops = " / ".join(str(r.ops.get(f, "–")) for f in ("tau", "M", "G", "fdyn"))
        status = "" if r.ok else " **FAIL**"
        first = _seconds(r.first_s) + ("" if r.cold in (True, None) else " *cache*")
        lines.append(
            f"| {r.case.name}{status} | {r.chain} | {r.n} | {len(r.locked)} ({nonzero}), "
            f"{on_base} on the base | {r.snaps} ({r.max_snap:.1e}) | {worst:.1e} ({key}) | {ops} | "
            f"{_seconds(r.read_s)} | {first} | {_seconds(r.cached_s)} |"
        )
    lines += [
        "",
        "Operations of the generated functions (after one joint CSE, with the model's friction; "
        "a − b counts one add, negation is free):",
        "",
        "| robot | " + " | ".join(FUNCTIONS) + " |",
        "|---|" + "---:|" * len(FUNCTIONS),
    ]
    for r in results:
        lines.append(f"| {r.case.name} | " + " | ".join(str(r.ops.get(f, "–")) for f in FUNCTIONS) + " |")
    lines += ["", "## Each robot", ""]
    for r in results:
        lines.append(
            f"- **{r.case.name}** (`{r.case.file}`): {r.case.what}. Chain {r.chain}, joints {', '.join(r.case.joints)}."
        )
        nonzero = [
            f"{lock.joint} = {lock.value:g} ({lock.why}{', chain' if lock.on_chain else ''}"
            f"{'' if lock.moves else ', on the base'})"
            for lock in r.locked
            if lock.value != 0
        ]
        if nonzero:
            lines.append(f"  Non-zero locks: {'; '.join(nonzero)}.")
        if r.warnings:
            lines.append("  Warnings: " + "; ".join(_local(w) for w in r.warnings) + ".")
        if r.errors:
            lines.append("  Errors: " + ", ".join(f"{k} {v:.1e}" for k, v in r.errors.items()) + ".")
        for p in r.problems:
            lines.append(f"  **Problem**: {p}")
    return "\n".join(lines) + "\n"


def _local(text: str) -> str:
    """A message with the robots folder's path cut to the file's name."""
    return re.sub(r"\S*/([\w.-]+\.urdf)", r"\1", text)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--robots",
        nargs="+",
        choices=list(BY_NAME),
        metavar="NAME",
        help=f"a subset of {', '.join(BY_NAME)} (default: all)",
    )
    parser.add_argument("--markdown", metavar="PATH", help="also write the report (Markdown) there")
    parser.add_argument("--count", type=int, default=200, help="random states per robot (default 200)")
    parser.add_argument(
        "--cold",
        action="store_true",
        help="a fresh symdyn cache (SYMDYN_CACHE_DIR), so the first load derives, generates and compiles",
    )
    parser.add_argument(
        "--data", metavar="FOLDER", help="example-robot-data's robots/ folder (default: the installed wheel's)"
    )
    parser.add_argument("--time-cached-load", choices=list(BY_NAME), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    folder = robots_folder(args.data)
    if args.time_cached_load:
        _time_cached_load(BY_NAME[args.time_cached_load], folder)
        return 0
    fresh = None
    if args.cold:
        fresh = os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-urdf-trees-")
        log(f"fresh cache {fresh} (removed at the end)")
    try:
        return _run_all(args, folder, argv)
    finally:
        if fresh:
            shutil.rmtree(fresh, ignore_errors=True)


def _run_all(args, folder: Path, argv) -> int:
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        sys.exit("urdf_trees: Pinocchio is needed for the comparison: pip install pin")

    results = []
    for name in args.robots or list(BY_NAME):
        case = BY_NAME[name]
        try:
            results.append(run(case, folder, args.count))
        except Exception as exc:  # one robot's failure is reported, the others still run
            import traceback

            log(f"{name}: FAIL: {type(exc).__name__}: {exc}")
            traceback.print_exc()
            result = Result(case)
            result.problems.append(f"{type(exc).__name__}: {_local(str(exc))}")
            results.append(result)
    command = "python scripts/urdf_trees.py " + shlex.join(sys.argv[1:] if argv is None else argv)
    report = markdown(results, command.strip(), args.cold)
    print(report)
    if args.markdown:
        Path(args.markdown).write_text(report)
        log(f"wrote {args.markdown}")
    failed = [r.case.name for r in results if not r.ok]
    for r in results:
        if not r.ok:
            key, worst = r.worst
            print(f"FAIL {r.case.name}: worst {worst:.1e} ({key}); " + "; ".join(r.problems), file=sys.stderr)
    log(
        f"{len(results) - len(failed)} of {len(results)} robots pass"
        + (f"; FAIL: {', '.join(failed)}" if failed else "")
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
