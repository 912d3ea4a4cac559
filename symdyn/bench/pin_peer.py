"""The Pinocchio C++ peer of `symdyn bench`: the arm it reads, its build, its run.

`pin_peer.cpp` (beside this file) times Pinocchio's algorithms in C++ with
the loop of symdyn's own C harness, on the same states file.  This module
writes the arm it is fed (`write_arm`: one line per joint — type, unit
axis, 3×4 placement in the parent joint's frame, mass, centre of mass,
inertia about it, armature — taken from `peers.pinocchio_model`, the very
model the reference is tested against, so DH arms of either convention and
general-joint arms reach the C++ alike; a tree, on a fixed base or a
FreeFlyer / Planar root carrying the base body, by `tree_joints` and
`write_arm(..., parents=, root=, base=)`, version 2 of the file, timed by
scripts/bench_whole.py), compiles it once into the cache
against the headers of the `pin` and `cmeel-eigen` wheels (`peer_binary`:
keyed by a hash of the source, flags, compiler and Pinocchio version;
rebuilt when stale or when the binary's recorded sha256 no longer matches),
and runs it (`run_peer`).  Missing pieces raise `PeerUnavailable`, whose
message says what to install.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from ..derivation.cache import cache_dir, writable

__all__ = [
    "SOURCE",
    "CXXFLAGS",
    "ALGORITHMS",
    "PeerUnavailable",
    "PeerJoint",
    "arm_joints",
    "tree_joints",
    "write_arm",
    "include_dirs",
    "cache_key",
    "peer_binary",
    "run_peer",
    "read_report",
    "central_jacobian",
    "check_peer",
]

SOURCE = Path(__file__).with_name("pin_peer.cpp")
#: The flags of symdyn's own harness (-O3 -march=native), so neither side is favoured; the Boost
#: defines are those Pinocchio's own build passes (its headers need the longer MPL lists).
CXXFLAGS = (
    "-std=c++17",
    "-O3",
    "-march=native",
    "-DNDEBUG",
    "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
    "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
    "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
    "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
)
#: What pin_peer.cpp times, in its order; see `check_peer` for what each is checked against.
ALGORITHMS = (
    "rnea",
    "crba",
    "crba_world",
    "aba",
    "computeGeneralizedGravity",
    "nonLinearEffects",
    "computeCoriolisMatrix",
    "crba_cholesky",
    "computeRNEADerivatives",
    "computeABADerivatives",
    "computeMinverse",
)
#: How to get every peer: the `bench` extra (pin, cmeel-eigen, roboticstoolbox-python).
HOW_TO_INSTALL = "run `make bench`, which installs the bench extra (pip install -e '.[bench]')"


class PeerUnavailable(RuntimeError):
    """The C++ peer cannot be built here; the message says what is missing and how to get it."""


@dataclass(frozen=True)
class PeerJoint:
    """One joint of a serial chain as pin_peer.cpp reads it.

    `placement` (3×4, [R | p]): the joint frame at q = 0 in the parent
    joint's frame; `axis`: unit vector in the joint frame, rotated about
    (`revolute`) or moved along; `com` (m) and `inertia` (kg·m², about the
    COM) in the joint frame after the motion; `armature`: G²·Jm (kg·m²).
    """

    revolute: bool
    axis: tuple
    placement: tuple
    mass: float
    com: tuple
    inertia: tuple
    armature: float

    def line(self) -> str:
        """The joint's line of the arm file (floats written to round-trip exactly)."""
        I = self.inertia
        numbers = [
            *self.axis,
            *np.ravel(self.placement),
            self.mass,
            *self.com,
            I[0][0],
            I[0][1],
            I[0][2],
            I[1][1],
            I[1][2],
            I[2][2],
            self.armature,
        ]
        return " ".join(["R" if self.revolute else "P", *(repr(float(x) + 0.0) for x in numbers)])


_ALIGNED = {"RX": (True, 0), "RY": (True, 1), "RZ": (True, 2), "PX": (False, 0), "PY": (False, 1), "PZ": (False, 2)}


def _peer_joint(model, j: int) -> PeerJoint:
    """Pinocchio joint j (one-DOF revolute or prismatic) as pin_peer.cpp reads it."""
    kind = model.joints[j].shortname().removeprefix("JointModel")
    if kind in _ALIGNED:
        revolute, k = _ALIGNED[kind]
        axis = tuple(np.eye(3)[k])
    elif kind in ("RevoluteUnaligned", "PrismaticUnaligned"):
        revolute, axis = kind == "RevoluteUnaligned", tuple(np.array(model.joints[j].extract().axis, float))
    else:
        raise ValueError(
            f"joint {j} ({model.names[j]}) is a Pinocchio {kind} joint: the C++ peer "
            "takes revolute and prismatic joints only"
        )
    Y = model.inertias[j]
    return PeerJoint(
        revolute,
        axis,
        tuple(map(tuple, model.jointPlacements[j].homogeneous[:3])),
        float(Y.mass),
        tuple(Y.lever),
        tuple(map(tuple, Y.inertia)),
        float(model.armature[model.idx_vs[j]]),
    )


def arm_joints(model) -> tuple[list[PeerJoint], np.ndarray]:
    """(joints, gravity) of a serial `pinocchio.Model` of one-DOF revolute or prismatic joints.

    gravity: the downward acceleration in the base frame (m/s²), as Pinocchio's `model.gravity`.
    """
    joints = []
    for j in range(1, model.njoints):
        if model.parents[j] != j - 1:
            raise ValueError(
                f"joint {j} ({model.names[j]}) hangs from joint {model.parents[j]}: "
                "the C++ peer takes a serial chain only"
            )
        joints.append(_peer_joint(model, j))
    return joints, np.array(model.gravity.linear, dtype=float)


_ROOTS = {"FreeFlyer": "free", "Planar": "planar"}


@dataclass(frozen=True)
class PeerTree:
    """A tree as pin_peer.cpp reads it (arm file version 2): `root` "none", "free" or "planar";
    `base` the floating root's body (mass, centre of mass, inertia about it; None on a fixed
    base); `parents[i]` the joint line that joint i hangs on (0: the root, k: joints[k - 1])."""

    root: str
    base: tuple | None
    joints: list
    parents: list
    gravity: np.ndarray


def tree_joints(model) -> PeerTree:
    """The tree of a `pinocchio.Model`: an optional FreeFlyer or Planar root joint (joint 1, on the
    universe), then one-DOF revolute or prismatic joints, each on the root or on an earlier joint."""
    root, base, first = "none", None, 1
    if model.njoints > 1:
        kind = model.joints[1].shortname().removeprefix("JointModel")
        if kind in _ROOTS:
            root, first = _ROOTS[kind], 2
            Y = model.inertias[1]
            base = (float(Y.mass), tuple(Y.lever), tuple(map(tuple, Y.inertia)))
    joints, parents = [], []
    for j in range(first, model.njoints):
        up = int(model.parents[j])
        if up != 0 and up < first:  # hangs on the floating root
            up = first - 1
        elif up == 0 and first == 2:
            raise ValueError(f"joint {j} ({model.names[j]}) hangs from the universe beside the floating root")
        parents.append(up - first + 1)
        joints.append(_peer_joint(model, j))
    return PeerTree(root, base, joints, parents, np.array(model.gravity.linear, dtype=float))


def _numbers(values) -> str:
    return " ".join(repr(float(x) + 0.0) for x in values)


def write_arm(path: str | Path, joints: list[PeerJoint], gravity, *, parents=None, root="none", base=None) -> Path:
    """Write the arm file pin_peer.cpp reads (format in its header comment); returns the path.

    A serial chain on a fixed base (no `parents`, no `root`): version 1, as it always was.  Else
    version 2: `parents` (one per joint: 0 the root, k the k-th joint), `root` "none", "free" or
    "planar" and, for a floating root, `base` = (mass, com, inertia) of its body (`tree_joints`).
    """
    if not joints and root == "none":
        raise ValueError("an arm on a fixed base needs at least one joint")
    g = _numbers(gravity)
    if parents is None and root == "none":
        text = f"symdyn-pin-arm 1\nn {len(joints)}\ngravity {g}\n" + "".join(j.line() + "\n" for j in joints)
    else:
        parents = list(range(len(joints))) if parents is None else [int(p) for p in parents]
        if len(parents) != len(joints) or any(not 0 <= p <= i for i, p in enumerate(parents)):
            raise ValueError(f"parents {parents}: one per joint, each 0 (the root) or an earlier joint's number")
        if root not in ("none", "free", "planar"):
            raise ValueError(f"root {root!r}: none, free or planar")
        head = f"root {root}"
        if root != "none":
            if base is None:
                raise ValueError(f"a {root} root needs its base body (mass, com, inertia)")
            m, c, I = base
            head += " " + _numbers([m, *c, I[0][0], I[0][1], I[0][2], I[1][1], I[1][2], I[2][2]])
        text = f"symdyn-pin-arm 2\n{head}\nn {len(joints)}\ngravity {g}\n" + "".join(
            f"{p} {j.line()}\n" for p, j in zip(parents, joints)
        )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def write_tree(path: str | Path, tree: PeerTree) -> Path:
    """Write the arm file of a `tree_joints` tree (version 2: root, parents, base body)."""
    return write_arm(path, tree.joints, tree.gravity, parents=tree.parents, root=tree.root, base=tree.base)


# --------------------------------------------------------------------------- build


def _compiler() -> str:
    cxx = os.environ.get("CXX") or next((c for c in ("c++", "g++", "clang++") if shutil.which(c)), None)
    if cxx is None or shutil.which(cxx) is None:
        raise PeerUnavailable(
            f"no C++ compiler found{f' (CXX={cxx})' if cxx else ''}: install g++ "
            "(Debian/Ubuntu: apt-get install g++) or set CXX"
        )
    return cxx


def include_dirs() -> list[Path]:
    """Pinocchio's and Eigen's header folders, from the `pin` and `cmeel-eigen` wheels
    (Eigen also from Debian's libeigen3-dev), else PeerUnavailable saying what to install."""
    try:
        import cmeel

        pin_version = metadata.version("pin")
    except (ImportError, metadata.PackageNotFoundError):
        raise PeerUnavailable(f"Pinocchio is not installed (pin): {HOW_TO_INSTALL}") from None
    prefix = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix" / "include"
    if not (prefix / "pinocchio" / "multibody.hpp").is_file():
        raise PeerUnavailable(
            f"Pinocchio's C++ headers are not in {prefix} (pin {pin_version}): "
            "reinstall the wheel (pip install --force-reinstall pin)"
        )
    eigen = next(
        (d for d in (prefix / "eigen3", Path("/usr/include/eigen3")) if (d / "Eigen" / "Core").is_file()), None
    )
    if eigen is None:
        raise PeerUnavailable(f"Eigen's C++ headers are missing (cmeel-eigen): {HOW_TO_INSTALL}")
    return [prefix, eigen]


def cache_key(source: str, cxx: str, flags: tuple, includes: list[Path]) -> str:
    """Hash of everything the binary depends on: the source, the compiler (and its version), the flags,
    the header folders, the Pinocchio version and, for -march=native, the host."""
    try:
        version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout
    except OSError:
        version = ""
    try:
        pin_version = metadata.version("pin")
    except metadata.PackageNotFoundError:
        pin_version = ""
    host = platform.node() if "-march=native" in flags else ""
    h = hashlib.sha256()
    for part in (source, cxx, version, *flags, *map(str, includes), pin_version, host):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def peer_binary(log=lambda msg: print(msg, file=sys.stderr, flush=True)) -> Path:
    """The compiled peer in the cache, built first if missing, stale or damaged (minutes on 2 cores).

    Intact: the sha256 recorded beside it when it was built still matches.
    PeerUnavailable if the headers or a C++ compiler are missing, or the build fails.
    """
    includes = include_dirs()
    cxx = _compiler()
    source = SOURCE.read_text()
    folder = writable(cache_dir() / "bench" / f"pin-peer-{cache_key(source, cxx, CXXFLAGS, includes)}")
    binary, recorded = folder / "pin_peer", folder / "pin_peer.sha256"
    try:
        if recorded.read_text() == _sha256(binary):
            return binary
    except OSError:
        pass
    cmd = [cxx, *CXXFLAGS, *(f"-I{d}" for d in includes), str(SOURCE)]
    log(f"building the Pinocchio C++ peer into {folder} (once; several minutes on 2 cores) ...")
    start = time.monotonic()
    fd, tmp = tempfile.mkstemp(prefix=".pin_peer.", dir=folder)
    os.close(fd)
    try:
        with tempfile.TemporaryFile(mode="w+") as err:
            proc = subprocess.Popen([*cmd, "-o", tmp], stdout=subprocess.DEVNULL, stderr=err, text=True)
            while True:  # its progress: a line every 30 s, so a long build is never silent
                try:
                    proc.wait(timeout=30)
                    break
                except subprocess.TimeoutExpired:
                    log(f"  ... still compiling the Pinocchio C++ peer ({time.monotonic() - start:.0f} s)")
            err.seek(0)
            stderr = err.read()
        if proc.returncode != 0:
            raise PeerUnavailable(f"compiling the Pinocchio C++ peer failed ({' '.join(cmd)}):\n{stderr[-3000:]}")
        os.replace(tmp, binary)
    finally:
        Path(tmp).unlink(missing_ok=True)
    recorded.write_text(_sha256(binary))
    log(f"built the Pinocchio C++ peer in {time.monotonic() - start:.0f} s")
    return binary


# --------------------------------------------------------------------------- run


def read_report(stdout: str) -> tuple[dict, dict]:
    """({name: ns per call}, {name: outputs at state 3}) from the "time NAME NS" and
    "check NAME v..." lines that harness.c and pin_peer.cpp print."""
    times, checks = {}, {}
    for line in stdout.splitlines():
        kind, _, rest = line.partition(" ")
        name, *values = rest.split()
        if kind == "time":
            times[name] = float(values[0])
        elif kind == "check":
            checks[name] = np.array(values, dtype=float)
    return times, checks


def run_peer(binary: Path, arm: Path, states: Path, ncalls: int, reps: int, algorithms=()) -> tuple[dict, dict]:
    """Time Pinocchio on the arm and states files: ({algorithm: ns per call}, {algorithm: outputs at state 3})."""
    run = subprocess.run(
        [str(binary), str(arm), str(states), str(int(ncalls)), str(int(reps)), *algorithms],
        capture_output=True,
        text=True,
    )
    if run.returncode != 0:
        raise RuntimeError(f"{binary} failed ({run.returncode}): {run.stderr.strip()}")
    return read_report(run.stdout)


def central_jacobian(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """∂f/∂x (rows: outputs of f, columns: entries of x) by central differences, error ~1e-9 relative:
    the reference has no derivatives, so timed derivatives are checked against this."""
    cols = [(np.asarray(f(x + h * e)) - np.asarray(f(x - h * e))) / (2 * h) for e in np.eye(len(x))]
    return np.stack(cols, axis=-1)


#: Tolerance of the outputs checked against central differences (the rest agree to rounding: 1e-9).
FD_RTOL = 1e-6


def check_peer(robot, checks: dict, q, qd, qdd, tau, k: int = 3, rtol: float = 1e-9) -> float:
    """Largest relative error of the peer's outputs at state k against symdyn's reference (frictionless
    `robot`); a RuntimeError naming the algorithm if above rtol (FD_RTOL for derivatives): a peer timed
    on a different arm or computing something else would make the comparison worthless."""
    from ..numeric import reference as ref

    q, qd, qdd, tau = q[k], qd[k], qdd[k], tau[k]
    M = lambda: ref.inertia(robot, q)  # noqa: E731  (each only when asked: a floating base has no C)
    C, G, n = lambda: ref.coriolis(robot, q, qd), lambda: ref.gravload(robot, q), robot.nv  # noqa: E731
    expected = {
        "rnea": lambda: ref.rne(robot, q, qd, qdd),
        "crba": M,
        "crba_world": M,
        "aba": lambda: ref.accel(robot, q, qd, tau),
        "computeGeneralizedGravity": G,
        "nonLinearEffects": lambda: C() @ qd + G(),
        "computeCoriolisMatrix": lambda: C() @ qd,  # Pinocchio's C need not be the Christoffel one; C q̇ is
        "crba_cholesky": lambda: ref.accel(robot, q, qd, tau),
        "computeRNEADerivatives": lambda: central_jacobian(lambda x: ref.rne(robot, x, qd, qdd), q),
        "computeABADerivatives": lambda: central_jacobian(lambda x: ref.accel(robot, x, qd, tau), q),
        "computeMinverse": lambda: np.linalg.inv(M()),
    }
    worst = 0.0
    for name, got in checks.items():
        if name == "computeCoriolisMatrix":
            got = got.reshape(n, n) @ qd
        want = np.ravel(expected[name]())
        err = float(np.abs(np.ravel(got) - want).max() / max(1.0, np.abs(want).max()))
        if not err <= (FD_RTOL if name.endswith("Derivatives") else rtol):
            raise RuntimeError(
                f"Pinocchio C++ peer: {name} at state {k} differs from symdyn's reference "
                f"by {err:.1e} (relative): not the same arm"
            )
        worst = max(worst, err)
    return worst
