"""`generate` and `load`: model code for NumPy, C, CasADi and the array API (JAX, PyTorch), from files.

The end of model → derive → simplify → program → emit.  `generate(robot,
target, out_dir)` derives (both methods, cached), builds one program per
function and writes `<name>.py`, `<name>.c`/`<name>.h` and `<name>.casadi`,
`<name>_xp.py` (array API), each headed with the symdyn version, the model fingerprint and the sha256 of
its content.  `load(name_or_robot, target)` returns the functions tau, M, C,
Cqd, G, F, fdyn, Y, tau_derivatives, fdyn_derivatives and Minv as attributes,
every target's taking the same arguments (docs/functions.md): from the checked-in `generated/<name>/` for
the shipped models (a stale or edited file is an error that says how to
regenerate), else generated once into the cache (again if a file there was
edited; into a temporary folder if the cache cannot be written).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import re
import shlex
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from .. import __version__
from ..derivation import progress
from ..derivation.cache import build_lock, writable
from ..model import Robot, arms
from .emit import Bundle, identifier, is_intact, read_header, write_atomic
from .shipped import SHIPPED, is_shipped

__all__ = [
    "generate",
    "load",
    "generate_all",
    "bundle",
    "GeneratedModel",
    "TARGETS",
    "LOADS",
    "SHIPPED",
    "GENERATED",
    "configure_parser",
]

TARGETS = ("numpy", "c", "casadi", "array-api", "cuda")
#: What `--target all` writes and generated/ holds: the CUDA target is written when asked for (its
#: arithmetic is the C target's, tested as C++ by tests/test_cuda.py).
ALL = ("numpy", "c", "casadi", "array-api")
#: What `load` takes: the targets, and the array-API module's functions on JAX or PyTorch arrays.
LOADS = (*TARGETS, "jax", "torch")
#: The target whose files a loadable name reads.
_WRITTEN = {"jax": "array-api", "torch": "array-api"}
#: The shipped models' code: generated/ of a source checkout (symdyn/generated links to it), or the
#: copy an installed wheel carries as package data (read only: its C is compiled into the cache).
GENERATED = (Path(__file__).resolve().parents[1] / "generated").resolve()


def _robot(name_or_robot) -> Robot:
    if isinstance(name_or_robot, Robot):
        return name_or_robot
    if isinstance(name_or_robot, str):
        return arms.load(name_or_robot)
    raise ValueError(f"expected a model name or a symdyn Robot, got {type(name_or_robot).__name__}")


def _targets(target: str) -> tuple[str, ...]:
    if target == "all":
        return ALL
    if target not in TARGETS:
        raise ValueError(f"unknown target {target!r}: expected one of {', '.join(TARGETS)} or 'all'")
    return (target,)


def files(name: str, target: str) -> tuple[str, ...]:
    """The file names one target writes (or a loadable name reads) for model `name`."""
    return {
        "numpy": (f"{name}.py",),
        "c": (f"{name}.c", f"{name}.h"),
        "casadi": (f"{name}.casadi",),
        "array-api": (f"{name}_xp.py",),
        "cuda": (f"{name}.cu", f"{name}_cuda.h"),
    }[_WRITTEN.get(target, target)]


def bundle(robot: Robot) -> Bundle:
    """Derive `robot` (`derivations`) and build every function's program, each from the
    derivation with fewer operations."""
    from ..derivation.regressor import regressor
    from .choice import derivations, programs

    dyns, origins = derivations(robot)
    reg = regressor(robot)
    try:
        progs, absent = programs(dyns, reg, origins, f"symdyn: programs of {robot.name}")
    except ValueError as exc:
        raise ValueError(f"cannot generate code for {robot.name!r}: {exc}") from None
    used = sorted({p.origin for p in progs}, key=str)
    source, notes, command = _provenance_lines(robot)
    if absent:  # M(q) singular (a robot read for its kinematics): said in the files and now
        why = f"not generated: {', '.join(absent)}: {next(iter(absent.values()))}"
        notes += (why,)
        warnings.warn(f"{robot.name}: {why}", stacklevel=2)
    return Bundle(
        name=identifier(robot.name),
        n=robot.n,
        version=__version__,
        nq=robot.nq,
        nv=robot.nv,
        fingerprint=robot.fingerprint(),
        programs=tuple(progs),
        derivation="; ".join(used),
        source=source,
        notes=notes,
        command=command,
    )


def _provenance_lines(robot: Robot) -> tuple[str, tuple, str]:
    """(model source, further lines, regenerate arguments) of the files' headers.  A robot read
    from a URDF, xacro or MJCF file (`robot.urdf`, `robot.mjcf`; not a shipped arm) names the file
    and its sha256 — never its folder, which is the reader's, not the model's —, lists what was
    locked, excluded and snapped, and rebuilds by `symdyn generate FILE --tip … [--name NAME]
    [--frames …]`, run beside the file."""
    record = getattr(robot, "urdf", None) or getattr(robot, "mjcf", None)
    frames = " --frames " + shlex.join(robot.frames) if robot.frames else ""
    if is_shipped(robot):
        return robot.source, (), robot.name
    if not robot.contacts and is_shipped(dataclasses.replace(robot, frames=())):  # a shipped arm's frames
        return robot.source, (), robot.name + frames
    if record is None:  # built in Python: no name or file the command line knows rebuilds it
        return robot.source, (), ""
    if not record.describes(robot) or robot.contacts:  # changed after reading (a payload, new
        # parameters) or a contact set (not on the command line): no command rebuilds it
        why = "a contact set chosen" if record.describes(robot) else "changed after reading"
        return (f"{robot.source}, {why} (the file alone does not rebuild it)", tuple(record.lines()[1:]), "")
    lines = list(record.lines())
    command = record.command_args()
    if command.split(" ", 1)[0] != shlex.quote(record.file):
        command = f"{shlex.quote(record.file)} {command}"
    if identifier(robot.name) != identifier(Path(record.file).stem):
        command += f" --name {shlex.quote(robot.name)}"
    command += frames
    in_folder = re.compile(r"[^\s'\"(\[]*[/\\]" + re.escape(record.file))

    def local(line: str) -> str:  # a warning that quotes the file by its path names it alone
        return in_folder.sub(lambda _: record.file, line)

    return local(lines[0]), tuple(local(line) for line in lines[1:]), command


def in_checkout() -> bool:
    """Whether symdyn runs from a source checkout, whose generated/ `generate` may
    rewrite; an installed wheel reads the copy it carries and never writes beside
    its package (without that copy, `load` generates the code into the cache, once)."""
    return (GENERATED.parent / "pyproject.toml").is_file()


def generate(robot, target: str = "all", out_dir=None, *, casadi_c: bool = False) -> list[Path]:
    """Write the model code of `robot` (a Robot or a model's name) for
    `target` ("numpy", "c", "casadi", "array-api", "cuda" or "all": all but "cuda") into `out_dir` (default, for
    the shipped models only: generated/<name>); `casadi_c` also writes
    CasADi's own C code.  Returns the paths written."""
    from .emit import array_api as xp_emit, c as c_emit, casadi as ca_emit, cuda as cu_emit, numpy as np_emit

    robot = _robot(robot)
    targets = _targets(target)
    name = identifier(robot.name)
    if out_dir is None and not is_shipped(robot):
        raise ValueError(
            f"generate({robot.name!r}) needs out_dir: generated/ holds only the shipped "
            f"models ({', '.join(SHIPPED)}) with their shipped parameters"
        )
    if out_dir is None and not in_checkout():
        raise ValueError(
            f"generate({robot.name!r}) needs out_dir: this symdyn is an installed package, and "
            "generated/ belongs to a source checkout (load() keeps the shipped models' code "
            "in the cache)"
        )
    b = bundle(robot)
    out = Path(out_dir) if out_dir is not None else GENERATED / name

    def write(folder: Path) -> list[Path]:
        written = []
        for t in targets:
            if t == "numpy":
                written.append(write_atomic(folder / f"{b.name}.py", np_emit.module_source(b)))
            elif t == "array-api":
                written.append(write_atomic(folder / f"{b.name}{xp_emit.SUFFIX}", xp_emit.module_source(b)))
            elif t == "c":
                written.append(write_atomic(folder / f"{b.name}.h", c_emit.h_source(b)))
                written.append(write_atomic(folder / f"{b.name}.c", c_emit.c_source(b)))
            elif t == "cuda":
                written.append(write_atomic(folder / f"{b.name}{cu_emit.HEADER_SUFFIX}", cu_emit.h_source(b)))
                written.append(write_atomic(folder / f"{b.name}.cu", cu_emit.cu_source(b)))
            else:
                written.append(ca_emit.serialize(b, folder / f"{b.name}.casadi"))
                if casadi_c:
                    written.append(ca_emit.generate_c(ca_emit.functions(b), b.name, folder))
        return written

    return publish(out, write)


def publish(out: Path, write) -> list[Path]:
    """Write a set of files into the folder `out` as one: `write(staging)`
    fills a fresh sibling folder, which gets copies of whatever else `out`
    holds and then takes its place by two renames — a reader sees the old
    set or the new one, never a mix.  Leftovers of a run that was killed
    (staging folders, a set moved aside) are cleaned up or restored first."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    for left in out.parent.glob(f".{out.name}.staging-*"):
        shutil.rmtree(left, ignore_errors=True)
    for old in out.parent.glob(f".{out.name}.old-*"):
        if out.exists():
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(old, out)  # killed between the two renames: the old set comes back
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.staging-", dir=out.parent))
    try:
        os.chmod(staging, 0o755)
        written = write(staging)
        if out.exists():
            for entry in out.iterdir():
                if not (staging / entry.name).exists():
                    copy = shutil.copytree if entry.is_dir() else shutil.copy2
                    copy(entry, staging / entry.name)
            old = out.parent / f".{out.name}.old-{os.getpid()}"
            os.rename(out, old)
            os.rename(staging, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return [out / p.name for p in written]


def generate_all(root=None) -> list[Path]:
    """Regenerate every target of the shipped models into root/<name>/ (default generated/)."""
    if root is None and not in_checkout():
        raise ValueError(
            "generate --all needs --out: this symdyn is an installed package, and generated/ "
            "belongs to a source checkout"
        )
    root = Path(root) if root is not None else GENERATED
    return [p for name in SHIPPED for p in generate(name, "all", root / name)]


# --------------------------------------------------------------------------- loading


class GeneratedModel:
    """Generated functions of one model as attributes (tau, M, C, Cqd, G, F,
    fdyn, Y, tau_derivatives, fdyn_derivatives, Minv), with `name`, `n`, `nq`, `nv` (the sizes of q and of
    q̇, q̈, τ: n but on a floating base), `target`, `fingerprint`, `folder` and `functions` (name → callable)."""

    def __init__(
        self, name: str, n: int, target: str, fingerprint: str, folder: Path, functions: dict, library=None
    ) -> None:
        self.name, self.n, self.target, self.fingerprint, self.folder = name, n, target, fingerprint, folder
        self.nq = self.nv = n  # sizes of q and of v (qd, qdd, tau): a floating base's differ (`_sized`)
        self.functions = dict(functions)
        self._library = library  # the C target's `clib.CLibrary`
        self.__dict__.update(self.functions)  # plain attributes, and no __getattr__: it slows every call ~0.1 µs

    def build(self, functions: list[str] | None = None, batch: bool = True) -> None:
        """C target: compile ahead, on every core, what the first calls would (each function's
        code, and with `batch` its SIMD kernel), so that no later call waits; a function not
        yet generated is generated first, the next one while the last compiles.

        Raises:
            ValueError: not the C target.
            KeyError: a name that is not one of the model's functions.
            RuntimeError: a function does not compile (the message names it).
        """
        if self._library is None:
            raise ValueError(f"build() compiles the C target; this is the {self.target} target of {self.name}")
        self._library.build(functions, batch)

    def __repr__(self) -> str:
        return f"<{self.name} model code ({self.target}): {', '.join(self.functions)}>"

    def __getattr__(self, name: str):
        """Only for a name that is not a function of the model (those are plain attributes)."""
        if name.startswith("_") or "functions" not in self.__dict__:
            raise AttributeError(name)
        absent = "fdyn" not in self.functions  # M(q) singular: the header says which are not generated and why
        why = " (M(q) is singular: its files' header says which functions are not generated)" if absent else ""
        raise AttributeError(
            f"{self.name}'s {self.target} code has no function {name!r}{why}; it has {', '.join(self.functions)}"
        )


def _sized(model: GeneratedModel, robot: Robot) -> GeneratedModel:
    """model with robot's nq and nv (a floating base's differ from n)."""
    model.nq, model.nv = robot.nq, robot.nv
    return model


class CasadiModel(GeneratedModel):
    """The CasADi target: `functions` are the casadi.Functions, for symbolic
    use; the attributes are the same Functions following the contract of every
    target when called with numbers (`emit.casadi.Numeric`); Jacobians by
    CasADi's AD."""

    def __init__(self, name: str, n: int, target: str, fingerprint: str, folder: Path, functions: dict):
        super().__init__(name, n, target, fingerprint, folder, functions)
        self.functions = {f: numeric.function for f, numeric in functions.items()}

    def jacobian(self, function: str, wrt: str, output: str | None = None):
        """casadi.Function of ∂output/∂wrt of `function` (same inputs), e.g.
        jacobian("tau", "q") for ∂τ/∂q, jacobian("fdyn", "tau") for ∂q̈/∂τ."""
        if function not in self.functions:
            raise ValueError(f"{self.name} has no function {function!r}: it has {', '.join(self.functions)}")
        f = self.functions[function]
        output = output or f.name_out(0)
        if wrt not in f.name_in():
            raise ValueError(f"{function} has no input {wrt!r}: its inputs are {', '.join(f.name_in())}")
        if output not in f.name_out():
            raise ValueError(f"{function} has no output {output!r}: its outputs are {', '.join(f.name_out())}")
        return f.factory(f"d{output}_d{wrt}", f.name_in(), [f"jac:{output}:{wrt}"])


def _stale(path: Path, found: dict, robot: Robot, name: str) -> str | None:
    """Why the file at `path` does not belong to this robot and symdyn, or None."""
    version, fp = found.get("symdyn-version"), found.get("model-fingerprint")
    if version == __version__ and fp == robot.fingerprint():
        return None
    return (
        f"{path} is stale: it was generated by symdyn {version} for model fingerprint "
        f"{(fp or '?')[:12]}…, but this is symdyn {__version__} and {robot.name!r} has fingerprint "
        f"{robot.fingerprint()[:12]}…. {_regenerate(name)}"
    )


def _regenerate(name: str) -> str:
    return f"Regenerate it: symdyn generate {name} (or symdyn generate --all)"


def _provenance(path: Path, target: str) -> tuple[dict, str]:
    """The header fields of a generated file and its sealed content (see `is_intact`)."""
    if target == "casadi":
        from .emit.casadi import read

        return read(path)
    text = path.read_text()
    return read_header(text), text


def _intact(folder: Path, name: str, target: str) -> bool:
    """Whether every file of `target` is in `folder`, as generated."""
    try:
        return all(
            (folder / f).is_file() and is_intact(_provenance(folder / f, target)[1]) for f in files(name, target)
        )
    except (OSError, ValueError):
        return False


def _load_folder(folder: Path, name: str, target: str, robot: Robot, options, jit=True) -> GeneratedModel:
    paths = [folder / f for f in files(name, target)]
    for path in paths:
        found, content = _provenance(path, target)
        if not is_intact(content):
            raise RuntimeError(
                f"{path} was modified after symdyn generated it (its content does not match "
                f"the content-sha256 in its header). {_regenerate(name)}"
            )
        reason = _stale(path, found, robot, name)
        if reason:
            raise RuntimeError(reason)
    if target == "numpy":
        module = _import_module(paths[0], f"_symdyn_generated_{name}_{robot.fingerprint()[:12]}")
        funcs = {f: getattr(module, f) for f in module.FUNCTIONS}
        return _sized(GeneratedModel(name, robot.n, target, robot.fingerprint(), folder, funcs), robot)
    if target in ("array-api", "jax", "torch"):
        from .emit import array_api

        module = _import_module(paths[0], f"_symdyn_generated_{name}_xp_{robot.fingerprint()[:12]}")
        sys.modules.setdefault(module.__name__, module)  # torch.compile imports the globals' module by name
        funcs = (
            array_api.jax_functions(module, jit)
            if target == "jax"
            else array_api.torch_functions(module)
            if target == "torch"
            else {f: getattr(module, f) for f in module.FUNCTIONS}
        )
        return _sized(GeneratedModel(name, robot.n, target, robot.fingerprint(), folder, funcs), robot)
    if target == "c":
        from .emit.clib import CompileOptions, load_library

        with progress.reported(
            f"symdyn: loading {name}'s C code (each function compiled into the cache when first called)"
        ):
            lib = load_library(paths[0], paths[1], options or CompileOptions())
        return _sized(GeneratedModel(name, robot.n, target, robot.fingerprint(), folder, lib.functions, lib), robot)
    if target == "cuda":
        from .emit import cudalib

        cupy, arch = cudalib.device()
        with progress.reported(f"symdyn: compiling {name}'s CUDA code for sm_{arch} (once; cached)"):
            funcs = cudalib.load(writable(folder), name, cupy, arch)
        return _sized(GeneratedModel(name, robot.n, target, robot.fingerprint(), folder, funcs), robot)
    from .emit.casadi import deserialize

    funcs = {f.name(): f for f in deserialize(paths[0])[1]}
    return _sized(CasadiModel(name, robot.n, target, robot.fingerprint(), folder, funcs), robot)


def _import_module(path: Path, module: str):
    spec = importlib.util.spec_from_file_location(module, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


#: The functions `load(..., "casadi", compiled=True)` compiles: those optimal control evaluates.
COMPILED = ("tau", "fdyn")


def load(name_or_robot, target: str = "c", *, options=None, folder=None, compiled=False, jit=None) -> GeneratedModel:
    """The generated functions of a model for `target` ("c", "numpy", "casadi", "jax", "torch"
    or "array-api").

    A shipped model's name loads generated/<name>/ (an error if stale); a
    Robot loads it too when it is that model, else its code is generated once
    into the cache.  `folder`: load the files `generate` wrote there instead
    (an error if they are missing, stale or edited).  `options`: a
    `symdyn.codegen.emit.clib.CompileOptions` for C.  `compiled` (CasADi
    only): True for tau and fdyn (COMPILED), or a list of function names,
    evaluated by compiled code — `casadi.external`s with their Jacobians and
    the Hessians of λᵀf compiled too, built once into the cache
    (`emit.casadi.compiled`) — for Opti and nlpsol; the other functions stay
    CasADi's SX.  "array-api": the functions of `<name>_xp.py`, on the arrays of any
    library that follows the array API standard; "jax" and "torch": the same on JAX
    arrays (each function `jax.jit`-compiled unless `jit=False`) or PyTorch tensors
    (needs array-api-compat), other arguments converted to them (docs/functions.md).  "cuda":
    the kernels of `<name>.cu` on CuPy arrays, PyTorch CUDA tensors or JAX GPU arrays (NumPy
    arrays copied to the GPU and back), compiled once for this GPU (docs/cuda.md); without CuPy
    or a GPU a RuntimeError that says which is missing, before anything is generated.
    """
    if target not in LOADS:
        raise ValueError(f"unknown target {target!r}: load() takes one of {', '.join(LOADS)}")
    if target == "cuda":
        from .emit import cudalib

        cudalib.device()
    if jit is not None and target != "jax":
        raise ValueError(f"jit= is an option of the JAX target, not of {target!r}")
    if compiled is not False and target != "casadi":
        raise ValueError(
            f"compiled= is an option of the CasADi target, not of {target!r} (the C target is always compiled)"
        )
    model = _load(name_or_robot, target, options, folder, True if jit is None else bool(jit))
    if compiled is False:
        return model
    return _compile_casadi(model, COMPILED if compiled is True else tuple(compiled))


def _compile_casadi(model: "CasadiModel", names: tuple) -> "CasadiModel":
    """A copy of the CasADi model with the functions `names` on compiled code."""
    from .emit.casadi import Numeric, compiled

    unknown = [f for f in names if f not in model.functions]
    if unknown:
        raise ValueError(
            f"{model.name} has no function {', '.join(map(repr, unknown))} to compile: it has "
            f"{', '.join(model.functions)}"
        )
    numeric = {f: getattr(model, f) for f in model.functions}
    numeric.update({f: Numeric(compiled(numeric[f].function), numeric[f].shapes, numeric[f].quaternion) for f in names})
    out = CasadiModel(model.name, model.n, model.target, model.fingerprint, model.folder, numeric)
    out.nq, out.nv = model.nq, model.nv
    return out


def _load(name_or_robot, target: str, options, folder, jit=True) -> GeneratedModel:
    robot = _robot(name_or_robot)
    name = identifier(robot.name)
    if folder is not None:
        missing = [f for f in files(name, target) if not (Path(folder) / f).is_file()]
        if missing:
            raise FileNotFoundError(
                f"{folder} has no {', '.join(missing)}: generate it with "
                f"symdyn generate {name} --target {_WRITTEN.get(target, target)} "
                f"--out {folder}"
            )
        return _load_folder(Path(folder), name, target, robot, options, jit)
    shipped = GENERATED / name
    if all((shipped / f).exists() for f in files(name, target)):
        if isinstance(name_or_robot, str):
            return _load_folder(shipped, name, target, robot, options, jit)
        found = _provenance(shipped / files(name, target)[0], target)[0]
        if _stale(shipped, found, robot, name) is None:
            return _load_folder(shipped, name, target, robot, options, jit)
    from . import lazy

    folder = lazy.model_folder(robot)
    if target == "c" and not robot.is_symbolic and not (name in SHIPPED and not in_checkout()):
        from .emit.clib import CompileOptions

        lib = lazy.load(robot, name, writable(folder), options or CompileOptions())
        return _sized(GeneratedModel(name, robot.n, target, robot.fingerprint(), folder, lib.functions, lib), robot)
    if not _intact(folder, name, target):
        with build_lock(folder):  # processes that want the same code (a cluster's workers) write it once
            if not _intact(folder, name, target):
                if name in SHIPPED and not in_checkout():
                    print(
                        f"symdyn: generating the code of {name} ({target}) into the cache, once: an "
                        "installed symdyn carries no generated/",
                        file=sys.stderr,
                    )
                folder = writable(folder)
                with progress.reported(f"symdyn: generating the {target} code of {name}"):
                    generate(robot, _WRITTEN.get(target, target), folder)
    return _load_folder(folder, name, target, robot, options, jit)


# --------------------------------------------------------------------------- command line


def configure_parser(p: argparse.ArgumentParser) -> None:
    """Arguments of `symdyn generate MODEL --target T [--out DIR]` / `symdyn generate --all`; MODEL
    is a shipped model's name or a URDF file with its options (`symdyn.model.command_line`)."""
    from ..model import command_line

    command_line.add_arguments(p, nargs="?")
    p.add_argument("--target", default="all", choices=(*TARGETS, "all"), help="default: all")
    p.add_argument(
        "--out",
        help="output folder (default: generated/MODEL for the shipped models, "
        "out/MODEL for the others, out/STEM for a URDF file STEM.urdf)",
    )
    p.add_argument("--all", action="store_true", help=f"regenerate generated/ ({', '.join(SHIPPED)})")
    p.add_argument("--casadi-c", action="store_true", help="also write CasADi's own C code")
    p.set_defaults(func=run_cli)


def run_cli(args: argparse.Namespace) -> int:
    """`symdyn generate`: write the files and list them."""
    if args.all == bool(args.model):
        raise ValueError("give a model name or --all (not both)")
    from ..model import command_line

    if args.all:
        paths = generate_all(args.out)
    else:
        robot = command_line.from_args(args)
        shipped = args.model in SHIPPED and not args.frames  # other frames: another model than generated/'s
        out = args.out or (None if shipped else Path("out") / identifier(robot.name))
        paths = generate(robot, args.target, out, casadi_c=args.casadi_c)
    for p in paths:
        print(p)
    print(f"{len(paths)} files written", file=sys.stderr)
    return 0
