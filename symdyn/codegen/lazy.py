"""The C target of a model that is not shipped, generated function by function on first call.

`load(robot, "c")` for a robot built in Python or read from a file: a function's
program is built (`choice.Programs`: only what it needs), printed as a C file of
its own (`emit.c.function_file`, sealed, kept in the model's cache folder) and
compiled (`emit.cunits`, one translation unit per function and kind) when the
function is first called; the contact derivatives from their KKT parts and dense products
(`emit.ckkt`).  A first `tau` waits for τ's derivation, program and
compile only, not for fdyn_derivatives; a second process finds the files and the
compiled units in the cache and derives nothing.  `generate(robot, "c", folder)`
still writes the whole .c/.h pair, with every function's operation count.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping
from pathlib import Path

from .. import __version__
from ..derivation import progress, task_space
from ..derivation.cache import build_lock, cache_dir, fork_safe, package_fingerprint, writable, write_atomic
from ..model import Robot
from .emit import c as c_emit, ckkt, clib, cunits, format_ops, identifier, is_intact, read_header
from .contact_functions import CONTACT_NAMES, contact_names, contact_signatures
from .task_functions import TaskPrograms

__all__ = ["load", "signatures"]

#: The joint-space functions of a numeric model, in the order of the whole file (`choice.Programs.names`);
#: the task-space functions follow (`symdyn.derivation.task_space.functions`).
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "F", "fdyn", "Y", "tau_derivatives", "fdyn_derivatives", "Minv")


def signatures(robot: Robot) -> list[c_emit.Signature]:
    """The C signature of every function of a numeric robot (docs/functions.md); a floating base:
    q of size nq, v (q̇, q̈, τ) of size nv, and Y with the base body's ten parameters before the
    links' 14 each; its m task frames: poses (m, 4, 4), Jacobians (m, 6, nv), …"""
    n, nq, nv = robot.n, robot.nq, robot.nv
    floating = robot.base_joint is not None
    v, m = (nv,), (nv, nv)
    q, qd, qdd, tau = ("q", nq), ("qd", nv), ("qdd", nv), ("tau", nv)
    table = {
        "tau": ((q, qd, qdd), (("tau", v),)),
        "M": ((q,), (("M", m),)),
        "C": ((q, qd), (("C", m),)),
        "Cqd": ((q, qd), (("Cqd", v),)),
        "G": ((q,), (("G", v),)),
        "F": ((qd,), (("F", v),)),
        "fdyn": ((q, qd, tau), (("qdd", v),)),
        "Y": ((q, qd, qdd), (("Y", (nv, 14 * n + (10 if floating else 0))),)),
        "tau_derivatives": ((q, qd, qdd), (("tau", v), ("dtau_dq", m), ("dtau_dqd", m))),
        "fdyn_derivatives": ((q, qd, tau), (("qdd", v), ("dqdd_dq", m), ("dqdd_dqd", m), ("Minv", m))),
        "Minv": ((q,), (("Minv", m),)),
    }
    frames = len(robot.task_frames)
    sizes = {"q": nq, "v": nv, "a": nv}
    for name in task_space.functions(robot):
        outs = tuple((task_space.OUTPUTS[p][0], task_space.shape(p, frames, nv)) for p in task_space.parts(name))
        table[name] = (tuple((a, sizes[a]) for a in task_space.arguments(name)), outs)
    table.update(contact_signatures(robot) if robot.contacts else {})
    return [c_emit.Signature(f, *table[f]) for f in (*FUNCTIONS, *task_space.functions(robot), *contact_names(robot))]


class _Sources:
    """Each function's C file: read from the model's cache folder when it is there, intact and
    of this symdyn and model, else built from its program and written there (atomically,
    under a lock, so that processes wanting the same function build it once)."""

    def __init__(self, robot: Robot, name: str, folder: Path) -> None:
        self.robot, self.name, self.folder = robot, name, folder
        self.sigs = {s.name: s for s in signatures(robot)}
        self.task = TaskPrograms(robot)
        self._programs = None
        self._failure: BaseException | None = None  # the derivation's error, for every call that needs it
        self._lock = threading.RLock()
        fork_safe(self, "_lock")  # a forked child gets a lock of its own

    def programs(self):
        """The model's `choice.Programs`, its derivations made (or read from their cache) once; a
        derivation that failed (on the prefetch thread too) raises its error again, unchanged."""
        with self._lock:
            if self._failure is not None:
                raise self._failure
            if self._programs is None:
                from ..derivation.regressor import regressor
                from .choice import Programs, derivations

                try:
                    dyns, origins = derivations(self.robot)
                except Exception as exc:
                    self._failure = exc
                    raise
                self._programs = Programs(dyns, lambda: regressor(self.robot), origins)
            return self._programs

    def prefetch(self) -> None:
        """Start the derivations on a thread of their own when τ's C file is not in the cache:
        they run while the binding compiles (a cold machine's first model: 0.3 s) instead of
        after it.  A failure is kept (`programs`) and raised by the first call that needs it."""
        if self._current(self.folder / f"{self.name}.tau.c") is not None:
            return  # a second process: the files are there, nothing to derive

        def derive() -> None:
            try:
                self.programs()
            except Exception:  # noqa: BLE001 - kept by programs(), raised by the first call needing it
                pass

        threading.Thread(target=derive, name=f"symdyn-derive-{self.name}", daemon=True).start()

    def _current(self, path: Path) -> str | None:
        try:
            text = path.read_text()
        except OSError:
            return None
        found = read_header(text)
        fresh = (
            found.get("symdyn-version") == __version__ and found.get("model-fingerprint") == self.robot.fingerprint()
        )
        return text if fresh and is_intact(text) else None

    def __call__(self, function: str) -> str:
        path = self.folder / f"{self.name}.{function}.c"
        with self._lock:
            text = self._current(path)
            if text is not None:
                return text
            with build_lock(path):
                text = self._current(path)
                if text is None:
                    with progress.reported(f"symdyn: generating {self.robot.name}'s {function}"):
                        text = self._build(function)
                    write_atomic(path, text)
            return text

    def _build(self, function: str) -> str:
        kkt = function in CONTACT_NAMES and function.endswith("_derivatives")
        tangents = None
        try:
            if function in self.task.names:  # the task space needs no joint-space derivation
                program = self.task.program(function)
            elif kkt:  # the KKT parts, then dense products (`ckkt`); R in vectors where it can
                program = self.programs().parts(function)
                tangents = self.programs().tangents(function)
            else:
                program = self.programs().program(function)
        except ValueError as exc:
            raise ValueError(f"cannot generate {function} for {self.robot.name!r}: {exc}") from None
        if not kkt and c_emit.signature(program) != self.sigs[function]:
            raise RuntimeError(f"{function}'s program has the signature {c_emit.signature(program)}")
        ops = format_ops(program.op_count())
        comment = [
            f"{self.name}_{function} ({self.robot.name} dynamics, C), generated by symdyn - do not edit.",
            f"symdyn-version: {__version__}",
            f"model-fingerprint: {self.robot.fingerprint()}",
            "content-sha256:  (of this file without this value: an edited file is refused)",
            f"operations after one joint CSE: {ops}"
            + (f" + {ckkt.products(program, tangents)} multiply-adds in vector products" if kkt else "")
            + f" [{program.origin}]",
        ]
        if kkt:
            return ckkt.function_file(self.name, program, self.sigs[function], comment, tangents)
        return c_emit.function_file(self.name, program, comment)


class _Units(Mapping):
    """{(function, "scalar" or "simd"): translation unit}, each function's made from its C file
    when first read."""

    def __init__(self, sources: _Sources) -> None:
        self.sources = sources
        self.header = c_emit.prototypes(sources.name, list(sources.sigs.values()))
        self._made: dict = {}

    def __getitem__(self, key: tuple[str, str]) -> str:
        function, kind = key
        if function not in self.sources.sigs or kind not in cunits.KINDS:
            raise KeyError(key)
        if function not in self._made:
            text = self.sources(function)
            self._made[function] = cunits.function_units(self.sources.name, text, self.header, [function])
        return self._made[function][key]

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter([(f, kind) for f in self.sources.sigs for kind in cunits.KINDS])

    def __len__(self) -> int:
        return len(self.sources.sigs) * len(cunits.KINDS)


def model_folder(robot: Robot) -> Path:
    """The cache folder of a model's generated code: keyed by its name, fingerprint and this symdyn."""
    name = identifier(robot.name)
    return cache_dir() / "generated" / f"{name}-{robot.fingerprint()[:16]}-{package_fingerprint()[:12]}"


def scalar_units(robot: Robot, functions) -> dict[str, str]:
    """{function: its scalar C translation unit} of a numeric robot, each function's C generated
    (or read) in the model's cache folder as the lazy target does: to compile into a program
    of one's own (a benchmark's harness)."""
    name = identifier(robot.name)
    units = _Units(_Sources(robot, name, writable(model_folder(robot))))
    return {f: units[(f, "scalar")] for f in functions}


def load(robot: Robot, name: str, folder: Path, options: clib.CompileOptions) -> clib.CLibrary:
    """The C functions of a numeric `robot`, each generated and compiled into `folder` and the
    cache when first called (see the module docstring)."""
    sources = _Sources(robot, name, folder)
    sources.prefetch()
    return clib.load_units(name, list(sources.sigs.values()), _Units(sources), options)
