"""The task space's speed at the C level, side by side with Pinocchio's C++ in one run.

The cases a legged or manipulation controller calls each step: Solo 12's four feet (pose,
world-aligned Jacobian and drift of each, by `frame_kinematics`'s one pass, and by the three
functions called in turn: Pinocchio's forwardKinematics(q, v, 0) + computeJointJacobians +
updateFramePlacements + getFrameJacobian and getFrameClassicalAcceleration per foot), the
Panda's hand (pose + LOCAL Jacobian: computeJointJacobians(q) + updateFramePlacements +
getFrameJacobian) and Talos' centre of mass (its Jacobian and A_G, by `centroidal` and by
com_jacobian + centroidal_map: jacobianCenterOfMass + computeCentroidalMap); and the contact
dynamics of Solo 12 on four feet and Talos on two soles (contact_fdyn: constraintDynamics;
contact_fdyn_derivatives: + computeConstraintDynamicsDerivatives; both without friction, which
Pinocchio's model has not).  symdyn's side is
its generated scalar C (the lazy target's translation units, compiled into a small harness
with the same loop as `harness.c`); Pinocchio's is `pin_peer.cpp` on the same model (its own
reading of the URDF, written as an arm file with the frames), on the same states, in
alternating rounds.  Both sides' outputs at one state are compared before any time is believed.
The batch rows time the generated SIMD kernels on every core over 10⁵ states, per state,
against Pinocchio's per-call time.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..derivation.cache import cache_dir, writable
from ..model import Robot
from ..model.example_robots import robots_folder
from . import pin_peer
from .harness import POOL, cached_program, write_states
from .rows import Row
from .task_space import file_model

__all__ = ["CASES", "Case", "bench_case"]


@dataclass(frozen=True)
class Case:
    """One comparison: the robot (file under example-robot-data's robots/, or a shipped arm's URDF),
    how it is read, its frames, symdyn's functions called per step and Pinocchio's algorithm."""

    name: str
    file: str
    options: dict
    frames: tuple
    functions: tuple
    algorithm: str
    contacts: tuple = ()  # the first frames' contact kinds ("point", "surface")
    target: float = 5.0  # the issue's per-call goal (×): 5 for the task space, 3 for the contacts


_SOLO = ("solo_description/robots/solo12.urdf", {"tips": "all", "base_joint": "free"})
_FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
_TALOS = (
    "talos_data/robots/talos_full_v2.urdf",
    {"tips": "all", "base_joint": "free", "locked": {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}},
)

CASES = {
    "solo12": Case("Solo 12, four feet", *_SOLO, _FEET, ("frame_kinematics",), "frames_drift"),
    "solo12-separate": Case(
        "Solo 12, four feet, three calls",
        *_SOLO,
        _FEET,
        ("frame_pose", "frame_jacobian_aligned", "frame_drift"),
        "frames_drift",
    ),
    "panda": Case(
        "Panda, hand",
        "",
        {},
        ("panda_hand",),
        ("frame_pose", "frame_jacobian"),
        "frames_jacobian",
    ),
    "talos": Case("Talos, centre of mass", *_TALOS, (), ("centroidal",), "com_centroidal"),
    "talos-separate": Case(
        "Talos, centre of mass, two calls", *_TALOS, (), ("com_jacobian", "centroidal_map"), "com_centroidal"
    ),
    "solo12-contacts": Case(
        "Solo 12, four feet in contact",
        *_SOLO,
        _FEET,
        ("contact_fdyn",),
        "contact_fdyn",
        ("point",) * 4,
        3.0,
    ),
    "solo12-contact-derivatives": Case(
        "Solo 12, four feet in contact, derivatives",
        *_SOLO,
        _FEET,
        ("contact_fdyn_derivatives",),
        "contact_fdyn_derivatives",
        ("point",) * 4,
        3.0,
    ),
    "talos-contacts": Case(
        "Talos, two soles in contact",
        *_TALOS,
        ("left_sole_link", "right_sole_link"),
        ("contact_fdyn",),
        "contact_fdyn",
        ("surface",) * 2,
        3.0,
    ),
    "talos-contact-derivatives": Case(
        "Talos, two soles in contact, derivatives",
        *_TALOS,
        ("left_sole_link", "right_sole_link"),
        ("contact_fdyn_derivatives",),
        "contact_fdyn_derivatives",
        ("surface",) * 2,
        3.0,
    ),
}

#: Where each input of a generated function lies in a state of the harness's file (q, v, a, τ).
_STATE = {"q": "Q", "v": "V", "a": "A", "tau": "T", "v_before": "V", "qd": "V", "qdd": "A"}


def case_robot(case: Case) -> tuple[Robot, Path]:
    """(the robot with the case's frames, the URDF it was read from)."""
    if case.file:
        path = robots_folder() / case.file
    else:
        from importlib.resources import files

        path = Path(str(files("symdyn.model.arms") / "data" / "panda.urdf"))
    robot = Robot.from_urdf(str(path), **case.options)
    robot = robot.with_frames(case.frames) if case.frames else robot
    if case.contacts:
        robot = robot.nofriction(all=True).with_contacts(dict(zip(case.frames, case.contacts)))
    return robot, path


def _peer_arm(robot: Robot, path: Path, folder: Path, contacts: tuple = ()) -> Path:
    """Pinocchio's model of the file with the robot's frames, as pin_peer.cpp reads it."""
    model, ids = file_model(robot, path)
    tree = pin_peer.tree_joints(model)
    arm = pin_peer.write_tree(folder / f"arm-{os.getpid()}.txt", tree)
    first = 1 if tree.root == "none" else 2
    lines = []
    for f in ids:
        frame = model.frames[f]
        joint = int(frame.parentJoint)
        line = 0 if joint < first else joint - first + 1
        numbers = np.ravel(frame.placement.homogeneous[:3])
        lines.append(f"{line} " + " ".join(repr(float(x) + 0.0) for x in numbers))
    if lines:
        kinds = " ".join("3" if kind == "point" else "6" for kind in contacts)
        section = f"frames {len(lines)}\n" + "".join(x + "\n" for x in lines)
        arm.write_text(arm.read_text() + section + (f"contacts {len(contacts)} {kinds}\n" if contacts else ""))
    return arm


def _check_lines(case: Case, sigs: dict, m: int) -> str:
    """The C that prints the case's outputs at one state in pin_peer.cpp's layout."""
    buf = {o: f"o_{f}_{o}" for f in case.functions for o, _ in sigs[f].outputs}  # output → its buffer
    if case.algorithm == "com_centroidal":
        check = f'for (i = 0; i < 3 * NV; ++i) printf(" %.17g", {buf["Jcom"]}[i]);\n'
        return check + f'    for (i = 0; i < 6 * NV; ++i) printf(" %.17g", {buf["Ag"]}[i]);\n'
    if case.algorithm == "contact_fdyn":
        return f'for (i = 0; i < NV; ++i) printf(" %.17g", {buf["a"]}[i]);\n' + (
            f'    for (i = 0; i < NC; ++i) printf(" %.17g", {buf["force"]}[i]);\n'
        )
    if case.algorithm == "contact_fdyn_derivatives":  # [da_dq da_dv da_dtau; dforce_dq dforce_dv dforce_dtau], by rows
        f = "o_contact_fdyn_derivatives_"
        return (
            "for (i = 0; i < NV; ++i) for (f = 0; f < 3 * NV; ++f)\n"
            f'        printf(" %.17g", (f < NV ? {f}da_dq : f < 2 * NV ? {f}da_dv : {f}da_dtau)[i * NV + f % NV]);\n'
            "    for (i = 0; i < NC; ++i) for (f = 0; f < 3 * NV; ++f)\n"
            f'        printf(" %.17g", (f < NV ? {f}dforce_dq : f < 2 * NV ? {f}dforce_dv : {f}dforce_dtau)[i * NV + f % NV]);\n'
        )
    check = f"for (f = 0; f < {m}; ++f) {{\n"
    check += f'        for (i = 0; i < 16; ++i) printf(" %.17g", {buf["pose"]}[16 * f + i]);\n'
    check += f'        for (i = 0; i < 6 * NV; ++i) printf(" %.17g", {buf["J"]}[6 * NV * f + i]);\n'
    if "drift" in buf:
        check += f'        for (i = 0; i < 6; ++i) printf(" %.17g", {buf["drift"]}[6 * f + i]);\n'
    return check + "    }\n"


def _harness_source(model: str, robot: Robot, case: Case, sigs: dict, check: bool = True) -> str:
    """A C harness timing one step of the case (its functions called in turn), then (`check`)
    printing its outputs at state 3 in pin_peer.cpp's layout (`_check_lines`)."""
    from ..codegen.contact_functions import contact_count

    nq, nv, m = robot.nq, robot.nv, len(robot.task_frames)
    buffers = "".join(
        f"static double o_{f}_{o}[{int(np.prod(shape))}];\n" for f in case.functions for o, shape in sigs[f].outputs
    )
    calls = " ".join(
        f"{model}_{f}({', '.join([_STATE[a] for a, _ in sigs[f].inputs] + [f'o_{f}_{o}' for o, _ in sigs[f].outputs])});"
        for f in case.functions
    )
    first = f"o_{case.functions[0]}_{sigs[case.functions[0]].outputs[0][0]}"
    protos = "".join(
        f"void {model}_{f}({', '.join(['const double *'] * len(sigs[f].inputs) + ['double *'] * len(sigs[f].outputs))});\n"
        for f in case.functions
    )
    return f"""/* symdyn's side of the task-space comparison (symdyn.bench.task_bench): generated, do not edit. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#define NQ {nq}
#define NV {nv}
#define NC {contact_count(robot) if robot.contacts else 0}
{protos}{buffers}
static double now_ns(void) {{ struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return 1e9 * t.tv_sec + t.tv_nsec; }}
static int by_value(const void *a, const void *b) {{ double x = *(const double *)a, y = *(const double *)b; return (x > y) - (x < y); }}
int main(int argc, char **argv)
{{
    enum {{ W = NQ + 3 * NV }};
    volatile double sink = 0.0;
    long K, ncalls = atol(argv[2]), i, k, size;
    int reps = atoi(argv[3]), r, f;
    double *S, *v = malloc(reps * sizeof *v);
    FILE *fh = fopen(argv[1], "rb");
    if (!fh) return 2;
    fseek(fh, 0, SEEK_END); size = ftell(fh) / (long)sizeof(double); rewind(fh);
    K = size / W; S = malloc(size * sizeof *S);
    if (fread(S, sizeof *S, size, fh) != (size_t)size) return 2;
    fclose(fh);
#define Q (S + k * W)
#define V (S + k * W + NQ)
#define A (S + k * W + NQ + NV)
#define T (S + k * W + NQ + 2 * NV)
    for (r = 0; r < reps; ++r) {{
        volatile char pad[1 + 64 * (r * 37 % 64)];  /* each repetition at another stack placement (harness.c) */
        double t0 = (pad[0] = 0, now_ns());
        for (i = 0; i < ncalls; ++i) {{ k = i & (K - 1); {calls} sink += {first}[0]; }}
        v[r] = (now_ns() - t0) / (double)ncalls;
    }}
    qsort(v, reps, sizeof *v, by_value);
    printf("time step %.3f\\n", v[reps / 2]);
    k = 3; {calls}
    printf("check step");
    {_check_lines(case, sigs, m) if check else ""}    printf("\\n");
    (void)f; (void)sink;
    return 0;
}}
"""


def _symdyn_harness(robot: Robot, case: Case, log, check: bool = True) -> Path:
    """The harness compiled with the generated scalar C of the case's functions (cached by
    content); `check`: it prints the outputs Pinocchio's are compared with."""
    from ..codegen import lazy
    from ..codegen.emit import identifier

    name = identifier(robot.name)
    sigs = {s.name: s for s in lazy.signatures(robot)}
    texts = {f"{f}.c": text for f, text in lazy.scalar_units(robot, case.functions).items()}
    texts["task_harness.c"] = _harness_source(name, robot, case, sigs, check)
    return cached_program(f"task-{name}", texts, log=log)


def _states(robot: Robot, count: int, seed: int = 0):
    """(q, v, a, τ): joints within their limits, a floating base moved along a random twist."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.qlim.T
    q = robot.neutral() + np.zeros((count, 1))
    q[:, robot.nq - robot.n :] = rng.uniform(lo, hi, (count, robot.n))
    if robot.base_joint is not None:
        twist = np.zeros((count, robot.nv))
        twist[:, : robot.nv - robot.n] = rng.normal(size=(count, robot.nv - robot.n))
        q = robot.integrate(q, twist)
    v = rng.uniform(-2, 2, (count, robot.nv))
    return q, v, rng.uniform(-5, 5, (count, robot.nv)), rng.uniform(-2, 2, (count, robot.nv))


def _agree(label: str, ours: np.ndarray, peer: np.ndarray, rtol: float = 1e-10) -> float:
    err = float(np.abs(ours - peer).max() / max(1.0, np.abs(peer).max()))
    if not ours.shape == peer.shape or not err <= rtol:
        raise RuntimeError(f"{label}: symdyn's and Pinocchio's outputs differ ({err:.1e} relative): not comparable")
    return err


def _batch_ns(robot: Robot, case: Case, count: int, threads: int | None) -> float:
    """ns per state of the case's step on `count` states through the generated SIMD kernels on
    every core (built ahead, then one warm-up call)."""
    from ..codegen.entry import load

    from ..codegen import lazy

    c = load(robot, "c")
    c.build(list(case.functions))  # every kernel ahead: a large one would otherwise compile in the background
    q, v, a, tau = _states(robot, count, seed=1)
    state = {"q": q, "v": v, "a": a, "tau": tau, "v_before": v}
    sigs = {s.name: s for s in lazy.signatures(robot)}
    calls = [(getattr(c, f), tuple(state[x] for x, _ in sigs[f].inputs)) for f in case.functions]
    outs = [f(*a) for f, a in calls]  # compiles the kernels, allocates the outputs
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for (f, a), out in zip(calls, outs):
            f(*a, out=out)
        best = min(best, time.perf_counter() - t0)
    return 1e9 * best / count


@contextlib.contextmanager
def _fresh(binary: Path, folder: Path):
    """A copy of a compiled program, removed after: each round runs from a new file, so from new
    pages of memory.  Where a program's pages land moves its time (Talos' two centroidal calls: 770
    ns from one file, 1 157 from another of the same bytes), so the rounds sample it, and the range
    shows it, for Pinocchio's side and symdyn's alike."""
    copy = folder / f"{binary.name}-{os.getpid()}-round"
    shutil.copy(binary, copy)
    try:
        yield copy
    finally:
        copy.unlink(missing_ok=True)


def bench_case(key: str, *, calls: int = 20000, reps: int = 7, rounds: int = 3, batch: int = 100_000, log=print):
    """Rows of one case (`CASES[key]`): per call, symdyn's generated C and Pinocchio's C++ on the
    same states in alternating rounds; per state over `batch` states on every core."""
    case = CASES[key]
    robot, path = case_robot(case)
    work = writable(cache_dir() / "bench")
    q, v, a, tau = _states(robot, POOL)
    states = write_states(work / f"task-states-{os.getpid()}.bin", q, v, a, tau)
    arm = _peer_arm(robot, path, work, case.contacts)
    try:
        ours = _symdyn_harness(robot, case, log)
        peer = pin_peer.peer_binary(log)
        symdyn_ns, peer_ns = [], []
        for r in range(rounds):
            with _fresh(peer, work) as peer_copy, _fresh(ours, work) as ours_copy:
                t, checks = pin_peer.run_peer(peer_copy, arm, states, calls, reps, [case.algorithm])
                run = subprocess.run(
                    [str(ours_copy), str(states), str(calls), str(reps)], capture_output=True, text=True
                )
            peer_ns.append(t[case.algorithm])
            if run.returncode != 0:
                raise RuntimeError(f"{ours} failed ({run.returncode}): {run.stderr.strip()}")
            t_ours, ours_checks = pin_peer.read_report(run.stdout)
            symdyn_ns.append(t_ours["step"])
            _agree(case.name, ours_checks["step"], checks[case.algorithm])
            log(f"{case.name}: round {r + 1}/{rounds}: symdyn {symdyn_ns[-1]:.0f} ns, Pinocchio {peer_ns[-1]:.0f} ns")
    finally:
        states.unlink(missing_ok=True)
        arm.unlink(missing_ok=True)
    title = f"task space, {case.name} ({robot.nv} velocities): {' + '.join(case.functions)}"
    rows = [Row(title, "per call", tuple(symdyn_ns), f"Pinocchio {case.algorithm}", tuple(peer_ns), target=case.target)]
    if batch:
        from .batched import ceilings
        from ..codegen import lazy

        try:
            per_state = _batch_ns(robot, case, batch, None)
        except RuntimeError as exc:  # a kernel the compiler cannot build (killed, out of memory)
            log(f"{case.name}: batch row not measured (the per-call rows stand): {str(exc).splitlines()[0]}")
            return rows
        sigs = {s.name: s for s in lazy.signatures(robot)}
        read = 8 * sum(k for f in case.functions for _, k in sigs[f].inputs)  # bytes a state's calls read
        written = 8 * sum(int(np.prod(x)) for f in case.functions for _, x in sigs[f].outputs)
        ceil = ceilings(os.cpu_count() or 1)
        # inputs at the copy bandwidth; outputs at the plain-store bandwidth, as the kernels write them
        # (each line read before it is written: 30-34 GB/s here, against a copy's 40-78)
        bound = (read / ceil.bandwidth[1] + written / ceil.store[1]) * 1e9
        where = (
            f"{read} B read at {ceil.bandwidth[1] / 1e9:.1f} GB/s, {written} B written at "
            f"{ceil.store[1] / 1e9:.1f} GB/s"
        )
        log(f"{case.name}: batch {per_state:.1f} ns per state; memory bound {bound:.1f} ns ({where})")
        rows.append(
            Row(
                title,
                f"batch of {batch:,} states, all cores, per state (memory bound {bound:.0f} ns: {where})",
                (per_state,),
                f"Pinocchio {case.algorithm} per call",
                (float(np.median(peer_ns)),),
                target=None if case.contacts else 30,  # the task-space issue's batch goal; the contacts' has none
            )
        )
    return rows
