"""Real robot descriptions nobody here wrote, through symdyn and against their peers (issue 34).

Run: .venv/bin/python scripts/real_descriptions.py FOLDER … [--states 200] [--no-compile]

Each FOLDER is searched for the descriptions below (extracted as they ship: the
ROS packages `ur_description` (Universal_Robots_ROS2_Description),
`franka_description` (franka_ros), `kortex_description` (ros2_kortex), and
MuJoCo Menagerie's arm folders, their XML files only: absent meshes are
stripped by symdyn and given stand-ins for MuJoCo itself).  A xacro file's
`--package-path` is the folder holding its package.  For each one found:

1. `symdyn generate FILE … --target c --out OUT` in a fresh process with an
   empty `SYMDYN_CACHE_DIR` (what a user runs): its wall time, return code and
   every line it writes to stderr;
2. `Robot.from_urdf` / `Robot.from_mjcf` with the same choices, timed
   in-process, with every warning, and what its record says changed the
   physics (snaps and their effect, friction, rotor inertia, locks, stripped
   files, repairs);
3. agreement with the peer at `--states` random states within the limits:
   URDF/xacro against Pinocchio (`rnea`, `crba`) built from the same expanded
   URDF text, the joints symdyn does not move locked at the same values
   (`symdyn.bench.reduced.reduced_model`); MJCF against MuJoCo (`mj_inverse`
   with contacts and constraints disabled, `mj_fullM`; `qfrc_inverse` includes
   the joints' damping, not their frictionloss, which is a constraint).  Two
   comparisons: symdyn's reference on the file's numbers (`snap=False`,
   friction the peer lacks removed), and the generated C the command wrote
   (loaded from OUT, compiled once: its friction subtracted by its own law,
   its snaps kept, so the error includes what the snaps change).

The errors are max|Δτ| / max|τ_peer| and max|ΔM| / max|M_peer| over all states.
Prints one markdown table, then the details (errors and warnings verbatim).
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SYMDYN = [sys.executable, "-m", "symdyn"]


@dataclass(frozen=True)
class Case:
    """One description: how a user would name it on the command line."""

    label: str
    file: str  # the path below the folder holding the package (or below the Menagerie folder)
    xacro_args: dict = field(default_factory=dict)
    tip: str | None = None
    kind: str = "urdf"  # "urdf" (URDF or xacro) or "mjcf"


CASES = [
    Case("UR5e, ROS 2 ur_description", "ur_description/urdf/ur.urdf.xacro", {"ur_type": "ur5e", "name": "ur"}, "tool0"),
    Case(
        "UR10e, ROS 2 ur_description", "ur_description/urdf/ur.urdf.xacro", {"ur_type": "ur10e", "name": "ur"}, "tool0"
    ),
    Case(
        "Panda + hand, franka_ros, gazebo:=true",
        "franka_description/robots/panda/panda.urdf.xacro",
        {"hand": "true", "gazebo": "true"},
        "panda_hand_tcp",
    ),
    Case(
        "Panda + hand, franka_ros, gazebo:=false",
        "franka_description/robots/panda/panda.urdf.xacro",
        {"hand": "true", "gazebo": "false"},
        "panda_hand_tcp",
    ),
    Case(
        "Panda arm, franka_ros (older layout)",
        "franka_description/robots/panda_arm.urdf.xacro",
        {"hand": "true", "gazebo": "true"},
        "panda_hand_tcp",
    ),
    Case(
        "FR3 + hand, franka_ros, gazebo:=true",
        "franka_description/robots/fr3/fr3.urdf.xacro",
        {"hand": "true", "gazebo": "true"},
        "fr3_hand_tcp",
    ),
    Case("Gen3 7-dof, ros2_kortex", "kortex_description/robots/gen3.xacro", {"dof": "7"}),
    Case(
        "Gen3 + Robotiq 2F-85, ros2_kortex",
        "kortex_description/robots/gen3_robotiq_2f_85.xacro",
        {},
        "end_effector_link",
    ),
    Case(
        "Gen3 + Robotiq 2F-85, ros2_kortex, gripper:=",
        "kortex_description/robots/gen3.xacro",
        {"dof": "7", "gripper": "robotiq_2f_85"},
        "end_effector_link",
    ),
    Case(
        "Gen3 + Robotiq 2F-85, ros2_kortex (URDF)",
        "kortex_description/robots/gen3_2f85.urdf",
        {},
        "gen3_end_effector_link",
    ),
    Case("UR5e, Menagerie", "universal_robots_ur5e/ur5e.xml", kind="mjcf"),
    Case("Panda + hand, Menagerie", "franka_emika_panda/panda.xml", tip="hand", kind="mjcf"),
    Case("Gen3, Menagerie", "kinova_gen3/gen3.xml", kind="mjcf"),
    Case("iiwa 14, Menagerie", "kuka_iiwa_14/iiwa14.xml", kind="mjcf"),
    Case("xArm7 + gripper, Menagerie", "ufactory_xarm7/xarm7.xml", tip="xarm_gripper_base_link", kind="mjcf"),
]


@dataclass
class Row:
    case: Case
    path: Path
    package_path: Path
    command: str = ""
    generate_s: float = float("nan")
    generate_rc: int | None = None
    generate_err: list = field(default_factory=list)
    read_s: float = float("nan")
    read_error: str = ""
    read_warnings: list = field(default_factory=list)
    chain: str = ""
    joints: int = 0
    physics: list = field(default_factory=list)
    printed: str = ""
    ref_tau: float = float("nan")
    ref_M: float = float("nan")
    gen_tau: float = float("nan")
    gen_M: float = float("nan")
    compile_s: float = float("nan")
    notes: list = field(default_factory=list)


def found(folders: list[Path]) -> list[Row]:
    """Each case whose file lies below one of `folders` (first match), with the folder holding its package."""
    rows = []
    for case in CASES:
        for folder in folders:
            hits = sorted(folder.rglob(Path(case.file).name))
            hits = [h for h in hits if h.as_posix().endswith(case.file)]
            if hits:
                path = hits[0]
                depth = len(Path(case.file).parts)
                rows.append(Row(case, path, path.parents[depth - 1]))
                break
    return rows


def cli_args(row: Row) -> list[str]:
    args = [str(row.path)]
    for name, value in row.case.xacro_args.items():
        args += ["--xacro-arg", f"{name}:={value}"]
    if row.path.suffix == ".xacro":
        args += ["--package-path", str(row.package_path)]
    if row.case.tip:
        args += ["--tip", row.case.tip]
    return args


def generate(row: Row, out: Path) -> None:
    """`symdyn generate … --target c` in a fresh process with an empty cache folder."""
    args = ["generate", *cli_args(row), "--target", "c", "--out", str(out)]
    row.command = "symdyn " + " ".join(a.replace(str(row.package_path), "$PKG") for a in args)
    with tempfile.TemporaryDirectory(prefix="symdyn-cache-") as cache:
        env = dict(os.environ, SYMDYN_CACHE_DIR=cache)
        start = time.perf_counter()
        done = subprocess.run([*SYMDYN, *args], capture_output=True, text=True, env=env, cwd=ROOT)
        row.generate_s = time.perf_counter() - start
    row.generate_rc = done.returncode
    row.generate_err = [line for line in done.stderr.splitlines() if line.strip()]


def read(row: Row, **kw):
    from symdyn.model import Robot

    case = row.case
    if case.kind == "mjcf":
        return Robot.from_mjcf(row.path, tip_body=case.tip, **kw)
    if row.path.suffix != ".xacro":
        return Robot.from_urdf(row.path, tip_link=case.tip, **kw)
    return Robot.from_urdf(
        row.path, tip_link=case.tip, xacro_args=case.xacro_args, package_paths=[row.package_path], **kw
    )


def physics(robot) -> list[str]:
    """What the record says changed the physics, in short."""
    record = robot.urdf if robot.urdf is not None else robot.mjcf
    out = []
    if record.snaps:
        effect = record.snapping.effect if record.snapping is not None else None
        size = (
            "no change"
            if effect is None or effect.tau == effect.M == (effect.qdd or 0) == 0
            else f"τ {effect.tau:.1e}, M {effect.M:.1e}, q̈ {effect.qdd:.1e}"
            if effect.qdd is not None
            else f"τ {effect.tau:.1e}, M {effect.M:.1e}"
        )
        out.append(f"{len(record.snaps)} snaps ({size})")
    if getattr(record, "rotor", ()):
        out.append(f"armature on {len(record.rotor)}")
    if record.viscous:
        out.append(f"viscous on {len(record.viscous)}")
    if record.coulomb:
        out.append(f"Coulomb on {len(record.coulomb)}")
    if record.locked:
        out.append(f"{len(record.locked)} locked")
    if record.excluded:
        out.append(f"{len(record.excluded)} excluded")
    if getattr(record, "repairs", ()):
        out.append(f"{len(record.repairs)} inertias repaired")
    if getattr(record, "stripped", ()):
        out.append(f"{len(record.stripped)} absent files stripped")
    if getattr(record, "left_out", ()):
        out.append(f"{len(record.left_out)} subtrees left out")
    return out or ["nothing"]


# --- the peers ---------------------------------------------------------------------------------


def pinocchio_peer(row: Row, robot, q, qd, qdd):
    """Pinocchio's τ and M of the chain `robot` moves, from the URDF text symdyn read (expanded)."""
    import pinocchio as pin

    from symdyn.bench.reduced import pin_configuration, reduced_model
    from symdyn.model.urdf.xacro import expand, is_xacro

    with tempfile.TemporaryDirectory() as folder:
        if is_xacro(row.path):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                text = expand(row.path, xacro_args=row.case.xacro_args, package_paths=[row.package_path]).text
            urdf = Path(folder) / "expanded.urdf"
            urdf.write_text(text)
        else:
            urdf = row.path
        model = reduced_model(urdf, robot)
    data = model.createData()
    x = pin_configuration(model, q)
    tau = np.array([pin.rnea(model, data, xi, v, a).copy() for xi, v, a in zip(x, qd, qdd)])
    M = []
    for xi in x:
        m = pin.crba(model, data, xi)
        M.append(np.triu(m) + np.triu(m, 1).T)
    return tau, np.array(M)


def _stand_ins(path: Path, folder: Path) -> Path:
    """A copy of the MJCF file at `path` in `folder`, with a tetrahedron for every absent mesh file
    and a 1×1 PNG for every absent texture, so that MuJoCo itself loads it."""
    root = ET.parse(path).getroot()
    compiler = root.find("compiler")
    meshdir = compiler.get("meshdir", compiler.get("assetdir", "")) if compiler is not None else ""
    texdir = compiler.get("texturedir", compiler.get("assetdir", "")) if compiler is not None else ""
    target = folder / path.name
    target.write_bytes(path.read_bytes())
    v = [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    for mesh in root.iter("mesh"):
        if not mesh.get("file") or (path.parent / meshdir / mesh.get("file")).exists():
            continue
        out = folder / meshdir / mesh.get("file")
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".stl":
            body = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
            out.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + body)
        else:
            out.write_text(
                "".join(f"v {x} {y} {z}\n" for x, y, z in v)
                + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)
            )
    for texture in root.iter("texture"):
        if texture.get("file") and not (path.parent / texdir / texture.get("file")).exists():
            import zlib

            def chunk(kind, data):
                return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

            out = folder / texdir / texture.get("file")
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_bytes(
                b"\x89PNG\r\n\x1a\n"
                + chunk(b"IHDR", struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(b"\0\xff\xff\xff"))
                + chunk(b"IEND", b"")
            )
    return target


def mujoco_peer(row: Row, robot, q, qd, qdd):
    """MuJoCo's τ (qfrc_inverse: includes damping, not frictionloss) and M of the chain's dofs,
    the locked joints at their values, contacts and constraints disabled."""
    import mujoco

    with tempfile.TemporaryDirectory() as folder:
        model = mujoco.MjModel.from_xml_path(str(_stand_ins(row.path, Path(folder))))
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(model)
    joint = {j: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in robot.mjcf.joints}
    dofs = [model.jnt_dofadr[joint[j]] for j in robot.mjcf.joints]
    qadr = [model.jnt_qposadr[joint[j]] for j in robot.mjcf.joints]
    tau, M = [], []
    full = np.zeros((model.nv, model.nv))
    for k in range(len(q)):
        data.qpos[:], data.qvel[:], data.qacc[:] = model.qpos0, 0, 0
        for lock in robot.mjcf.locked:
            data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, lock.joint)]] = lock.value
        data.qpos[qadr], data.qvel[dofs], data.qacc[dofs] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(model, data)
        tau.append(data.qfrc_inverse[dofs].copy())
        if hasattr(data, "qM"):
            mujoco.mj_fullM(model, full, data.qM)
        else:
            mujoco.mj_fullM(model, data, full)
        M.append(full[np.ix_(dofs, dofs)].copy())
    return np.array(tau), np.array(M)


def _rel(got, expected) -> float:
    return float(np.max(np.abs(got - expected)) / max(np.max(np.abs(expected)), 1e-12))


def check(row: Row, count: int, out: Path, compile_: bool) -> None:
    from symdyn import load
    from symdyn import reference as ref
    from symdyn.bench.differential import friction_law, states

    start = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            robot = read(row)
    except ValueError as exc:
        row.read_s = time.perf_counter() - start
        row.read_error = f"{type(exc).__name__}: {exc}"
        return
    row.read_s = time.perf_counter() - start
    row.read_warnings = [str(w.message) for w in caught]
    record = robot.urdf if robot.urdf is not None else robot.mjcf
    base = getattr(record, "base_link", None) or getattr(record, "base_body", "")
    tip = getattr(record, "tip_link", None) or getattr(record, "tip_body", "")
    row.chain, row.joints, row.physics, row.printed = f"{base} → {tip}", robot.n, physics(robot), str(robot)

    mjcf = row.case.kind == "mjcf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        literal = read(row, snap=False)
    q, qd, qdd, _ = states(robot, count, 0)
    peer = mujoco_peer if mjcf else pinocchio_peer
    tau_peer, M_peer = peer(row, literal, q, qd, qdd)
    # MuJoCo's qfrc_inverse has the damping (viscous) but not frictionloss; Pinocchio has neither
    bare = literal.nofriction() if mjcf else literal.nofriction(all=True)
    row.ref_tau = _rel(ref.rne(bare, q, qd, qdd), tau_peer)
    row.ref_M = _rel(ref.inertia(literal, q), M_peer)
    if not compile_ or row.generate_rc != 0:
        return
    start = time.perf_counter()
    functions = load(robot, "c", folder=out)
    functions.tau(q[:1], qd[:1], qdd[:1])
    functions.M(q[:1])
    row.compile_s = time.perf_counter() - start
    friction = friction_law(robot, qd)
    if mjcf:  # keep the viscous part: MuJoCo's τ has it
        friction -= np.array([float(link.G) ** 2 * float(link.B) for link in robot.links]) * qd
    row.gen_tau = _rel(functions.tau(q, qd, qdd) - friction, tau_peer)
    row.gen_M = _rel(functions.M(q), M_peer)


def _e(x: float) -> str:
    return "–" if x != x else f"{x:.1e}"


def table(rows: list[Row]) -> str:
    lines = [
        "| description | file | chain | joints | read (s) | generate (s) | τ ref | M ref | τ C | M C | compile C (s) "
        "| what changed the physics |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        peer = "MuJoCo" if r.case.kind == "mjcf" else "Pinocchio"
        args = " ".join(f"{k}:={v}" for k, v in r.case.xacro_args.items())
        file = f"{r.path.name}" + (f" ({args})" if args else "")
        chain = r.chain or ("refused" if r.read_error else "–")
        gen = f"{r.generate_s:.2f}" + ("" if r.generate_rc == 0 else f" (exit {r.generate_rc})")
        lines.append(
            f"| {r.case.label} (vs {peer}) | {file} | {chain} | {r.joints or '–'} | {r.read_s:.2f} | {gen} "
            f"| {_e(r.ref_tau)} | {_e(r.ref_M)} | {_e(r.gen_tau)} | {_e(r.gen_M)} | "
            f"{'–' if r.compile_s != r.compile_s else f'{r.compile_s:.1f}'} | "
            f"{'; '.join(r.physics) if r.physics else '–'} |"
        )
    return "\n".join(lines)


def details(rows: list[Row]) -> str:
    out = []
    for r in rows:
        out.append(f"\n### {r.case.label}\n\n    {r.command}\n")
        out.append(f"exit {r.generate_rc}, {r.generate_s:.2f} s; stderr:")
        out += [f"    {line}" for line in r.generate_err] or ["    (nothing)"]
        if r.read_error:
            out.append(f"from_{r.case.kind}: {r.read_error}")
        for w in dict.fromkeys(r.read_warnings):
            out.append(f"warning: {w}")
        out += r.notes
    return "\n".join(out)


def main(argv: list[str]) -> int:
    count, compile_, folders, args = 200, True, [], iter(argv)
    for item in args:
        if item == "--states":
            count = int(next(args))
        elif item == "--no-compile":
            compile_ = False
        else:
            folders.append(Path(item))
    if not folders:
        print(__doc__)
        return 2
    # the checker's own compiles (load(…, folder=OUT)) in an empty cache too: cold, as a user's first
    os.environ["SYMDYN_CACHE_DIR"] = tempfile.mkdtemp(prefix="symdyn-cache-")
    import symdyn.model  # noqa: F401  (the imports once, before the first timing)
    import symdyn.model.urdf.xacro  # noqa: F401

    rows = found(folders)
    if not rows:
        print("no known description below", ", ".join(map(str, folders)))
        return 1
    with tempfile.TemporaryDirectory(prefix="real-descriptions-") as outs:
        for i, row in enumerate(rows):
            out = Path(outs) / f"{i}"
            print(f"[{i + 1}/{len(rows)}] {row.case.label}: {row.path}", file=sys.stderr, flush=True)
            generate(row, out)
            try:
                check(row, count, out, compile_)
            except Exception as exc:  # a peer that cannot read the file is a result too
                row.notes.append(f"check failed: {type(exc).__name__}: {exc}")
    print(table(rows))
    print(details(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
