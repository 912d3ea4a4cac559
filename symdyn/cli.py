"""`symdyn …`: the command line.

Subcommands: run (the main job), print (closed forms), generate (model
code), bench (speed against peers), identify (excite, simulate, fit),
study (the chapter's studies), sweep (many tasks on a Dask cluster).  Each
delegates to the module that owns the work; this file only parses.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np


#: The largest disagreement `symdyn run` accepts between the code it wrote and the reference.
RUN_TOLERANCE = 1e-10


def _cmd_run(args: argparse.Namespace) -> int:
    """The main job: derive the Puma 560 both ways, generate its code into
    args.out, check it against the reference, and summarise."""
    import time

    from .codegen.entry import generate, load
    from .derivation.entry import derive
    from .derivation.simplify import op_counts
    from .model import arms
    from .numeric import reference as ref

    robot = arms.load("puma560")
    print(
        f"{robot.name}: {robot.n} joints, {robot.convention} DH, "
        f"total mass {sum(float(l.m) for l in robot.links):.2f} kg  [{robot.source}]"
    )
    for method in ("newton-euler", "lagrange"):
        start = time.perf_counter()
        dyn = derive(robot, method, progress=True)
        how = "from cache" if dyn.stats.get("from_cache") else "derived"
        print(f"{method:13s} {how} in {time.perf_counter() - start:.2f} s")
    dyn = derive(robot, "newton-euler", regroup=True, progress=True)
    counts = {t: op_counts(dyn, t, ("cse",))["cse"] for t in ("tau", "M", "G", "Cqd")}
    print(
        f"derivation's operations after one joint CSE, mul + add (Newton–Euler on regrouped base parameters, "
        f"{friction_variant(robot)}; the generated files' headers count sin/cos/sign calls too): "
        + ", ".join(f"{t} {c['mul'] + c['add']} ({c['mul']} mul + {c['add']} add)" for t, c in counts.items())
    )
    paths = generate(robot, "all", args.out)
    print(f"generated {len(paths)} files in {paths[0].parent}")
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    written = {target: load(robot, target, folder=paths[0].parent) for target in ("c", "numpy", "casadi")}
    worst = 0.0
    for pose in ("qz", "qr", "qs", "qn"):
        q = getattr(robot, pose)
        G, M = ref.gravload(robot, q), ref.inertia(robot, q)
        for f in written.values():
            worst = max(
                worst,
                float(np.abs(np.asarray(f.G(q), dtype=float).reshape(G.shape) - G).max()),
                float(np.abs(np.asarray(f.M(q), dtype=float).reshape(M.shape) - M).max()),
            )
        print(f"\n{pose} = {q}")
        print(f"  G(q)      = {G}  N·m")
        print(f"  diag M(q) = {np.diag(M)}  kg·m²")
    print(
        f"\ngenerated code (C, NumPy, CasADi) in {paths[0].parent} vs reference at the book poses: "
        f"max |error| {worst:.1e}"
    )
    if not worst <= RUN_TOLERANCE:
        print(
            f"symdyn: error: the generated code disagrees with the reference by {worst:.1e} "
            f"(more than {RUN_TOLERANCE:.0e})",
            file=sys.stderr,
        )
        return 1
    return 0


def _cmd_print(args: argparse.Namespace) -> int:
    """Print the closed-form dynamics of a model, with op counts per stage."""
    from .derivation.entry import derive
    from .presentation.printing import closed_form, plan
    from .derivation.simplify import op_counts
    from .model import command_line

    # a shipped model or a robot file; one whose moving links carry no mass is printed, with a warning
    robot = command_line.from_args(args, symbolic=not args.numeric, massless=True)
    if not 1 <= args.digits <= 17:
        raise ValueError(f"--digits must be between 1 and 17, got {args.digits}")
    if args.frames is not None:  # refused before a derivation that may take minutes
        joint_space = [f"--{k}" for k, v in (("term", args.term != "all"), ("layout", args.layout != "auto")) if v]
        joint_space += ["--prune"] if args.prune is not None else []
        if joint_space:
            verb = "applies" if len(joint_space) == 1 else "apply"
            raise ValueError(f"{' and '.join(joint_space)} {verb} to the joint-space equations, not to --frames")
    dyn = derive(robot, args.method, cache=not args.no_cache, progress=True)
    if args.frames is not None:  # the task space: each frame's forward kinematics and Jacobian
        from .presentation.task_space import frames_constant_form, frames_form

        if args.constants:
            print(frames_constant_form(dyn, args.format, digits=args.digits))
        else:
            print(frames_form(dyn, args.format, digits=args.digits, form=args.form))
        return 0
    if args.constants:
        return _print_constants(dyn, args)
    terms = ("M", "C", "G", "F", "tau") if args.term == "all" else (args.term,)
    layouts = plan(dyn, terms, args.layout)
    print(closed_form(dyn, terms, args.format, args.prune, args.form, digits=args.digits, layouts=layouts))
    comment = "%" if args.format == "latex" else "#"
    closed = ("raw", "cse", "folded") + (("pruned",) if args.prune and not robot.is_symbolic else ())
    print(
        f"{comment} {robot.name} by {dyn.method}; operations (mul + add) at each stage, full inertial "
        f"parameters (not regrouped), {friction_variant(robot)}"
        + (
            "; terms in named intermediates: raw and cse only, folding is what they avoid:"
            if any(lay.layout == "named" for lay in layouts)
            else ":"
        )
    )
    for lay in layouts:
        t = lay.term
        stages = closed if lay.layout == "closed" else ("raw", "cse")
        counts = op_counts(dyn, t, stages, prune_tol=args.prune or 1e-3)
        row = "  ".join(f"{s} {c['mul'] + c['add']}" for s, c in counts.items() if c)
        print(f"{comment}   {t:4s} {row}")
    # a URDF, xacro or MJCF file's chain: what was locked, excluded, snapped
    record = getattr(robot, "urdf", None) or getattr(robot, "mjcf", None)
    for line in record.lines() if record is not None and command_line.is_urdf(args.model) else ():
        print(f"{comment} {line}")
    return 0


def _cmd_show(args: argparse.Namespace) -> int:
    """Draw a model as read (`symdyn.presentation.picture`) into --out, and say what it shows; a file
    whose moving bodies have impossible inertias is drawn with them repaired, with the warning."""
    from .model import URDFError, command_line

    try:
        robot = command_line.from_args(args, massless=True)  # a file without mass is still worth a look
    except URDFError as exc:  # impossible inertias: drawn as the nearest physical ones, said so
        if "no physical body" not in str(exc) and "impossible" not in str(exc):
            raise
        print(
            f"symdyn: warning: {exc}\nsymdyn: drawn with those inertias repaired (--balance-inertia)", file=sys.stderr
        )
        args.balance_inertia = True
        robot = command_line.from_args(args, massless=True)
    fig = robot.plot()
    out = Path(args.picture)
    if out.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise ValueError(f"--out {out}: expected a .png, .pdf or .svg file")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=args.dpi)
    print(robot)
    print(f"wrote {out}")
    return 0


def _cmd_expand(args: argparse.Namespace) -> int:
    """`symdyn expand FILE.xacro`: the expanded URDF on stdout."""
    from .model import command_line, expand_xacro

    text = expand_xacro(
        args.file, xacro_args=command_line.parse_xacro_args(args.xacro_arg), package_paths=args.package_path
    )
    sys.stdout.write(text if text.endswith("\n") else text + "\n")
    return 0


def _print_constants(dyn, args: argparse.Namespace) -> int:
    """The named-constant form, then its term and op counts beside the generated code's."""
    from .codegen.entry import bundle
    from .presentation.constants import constant_form, render_form

    form = constant_form(dyn)
    print(render_form(form, args.format, digits=args.digits))
    comment = "%" if args.format == "latex" else "#"
    kinds = {k: sum(1 for c in form.constants if str(c.symbol).startswith(k)) for k in ("I", "g", "F")}
    terms = {k: form.term_count(k) for k in "MbcGF"}
    print(
        f"{comment} {len(form.constants)} named constants ({kinds['I']} inertial, {kinds['g']} gravity, "
        f"{kinds['F']} friction); constant x abbreviation terms: "
        + ", ".join(f"{k} {v}" for k, v in terms.items())
        + f" ({sum(terms.values())} in all)"
    )
    generated = {p.name: p for p in bundle(dyn.robot).programs}
    how = "constants from their definitions" if dyn.robot.is_symbolic else "constants as numbers"
    print(
        f"{comment} operations (mul + add, sin/cos calls) of evaluating this form ({how}, one joint CSE, "
        f"{friction_variant(dyn.robot)}) "
        f"vs the generated code (the program every emitter prints):"
    )
    for kind in ("M", "Cqd", "G", "tau"):
        ours, theirs = form.op_count(kind), generated[kind].op_count()
        print(
            f"{comment}   {kind:4s} named constants {ours['mul'] + ours['add']:5d} + {ours['fun']:2d} fun   "
            f"generated ({generated[kind].origin}) {theirs['mul'] + theirs['add']:5d} + {theirs['fun']:2d} fun"
        )
    return 0


def friction_variant(robot) -> str:
    """'with friction' or 'without friction': τ's op count differs by the friction terms, so every
    printed count says which model it counts."""
    rough = any(link.B != 0 or any(t != 0 for t in link.Tc) for link in robot.links)
    return "with friction" if rough else "without friction"


def _load_model(name: str, numeric: bool):
    """A shipped model: its symbolic variant where it has one, unless numeric (scripts/print_docs.py)."""
    from .model import command_line

    return command_line.load(name, symbolic=not numeric)


def _cmd_study(args: argparse.Namespace) -> int:
    from .apps import studies
    from .identify import study as identify_studies

    found = {**studies.registry(), **identify_studies.STUDIES}
    if args.list or not args.name:
        for name, (summary, _) in sorted(found.items()):
            print(f"{name:28s} {summary}")
        return 0
    if args.name in identify_studies.STUDIES:
        text = identify_studies.run(args.name, Path(args.out))
    else:
        text = studies.run(args.name, Path(args.out))
    print(text)
    print(f"\nfigures and summary written to {Path(args.out) / args.name}")
    return 0


DESCRIPTION = (
    "symdyn: symbolic rigid-body dynamics of robot arms, by Lagrange's energy method and the "
    "recursive Newton-Euler method, closed forms printed like a textbook, and fast generated model "
    "code (NumPy, C, CasADi) checked against a numeric reference."
)


def build_parser() -> argparse.ArgumentParser:
    from . import __version__
    from .model import command_line

    parser = argparse.ArgumentParser(prog="symdyn", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"symdyn {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("run", help="the main job: derive the Puma 560, generate its code, summarise")
    p.add_argument("--out", default="out/puma560", help="where the generated code goes (default: out/puma560)")
    p.set_defaults(func=_cmd_run)

    from .bench import compare
    from .codegen import entry
    from .presentation.printing import CLOSED_LIMIT

    entry.configure_parser(sub.add_parser("generate", help="write generated model code (NumPy, C, CasADi)"))
    compare.configure_parser(sub.add_parser("bench", help="generated code vs Pinocchio and the Robotics Toolbox"))

    p = sub.add_parser("print", help="print closed-form M, C, G, F, tau of a model")
    command_line.add_arguments(p)
    p.add_argument(
        "--term",
        default="all",
        choices=("M", "C", "Cqd", "G", "F", "tau", "all"),
        help="which term to print (default: all)",
    )
    p.add_argument(
        "--method",
        default="newton-euler",
        choices=("newton-euler", "lagrange"),
        help="which derivation (default: newton-euler)",
    )
    p.add_argument(
        "--format", default="text", choices=("text", "pretty", "latex"), help="output format (default: text)"
    )
    p.add_argument(
        "--form",
        default="book",
        choices=("book", "folded"),
        help="book: products of sines/cosines of natural angles (S23*C4*S5); folded: sines/cosines of angle sums",
    )
    p.add_argument(
        "--layout",
        default="auto",
        choices=("auto", "closed", "named"),
        help="closed: every element in closed form; named: the derivation's named intermediates, "
        f"then the elements in them; auto (default): closed up to {CLOSED_LIMIT} terms, "
        "named beyond (a 7-joint arm's M, C, tau)",
    )
    p.add_argument(
        "--constants",
        action="store_true",
        help="named-constant form (Armstrong, Khatib & Burdick 1986): M, b, c, G, F, tau in named "
        "inertial constants with their definitions, values and units, and C2, S23 abbreviations",
    )
    p.add_argument("--digits", type=int, default=5, help="significant digits of printed numbers (default: 5)")
    p.add_argument(
        "--prune", type=float, default=None, metavar="TOL", help="drop terms below TOL relative to each element's scale"
    )
    p.add_argument("--numeric", action="store_true", help="numeric parameters even where a symbolic variant exists")
    p.add_argument("--no-cache", action="store_true", help="derive afresh, bypassing the cache")
    p.set_defaults(func=_cmd_print)

    p = sub.add_parser(
        "show",
        help="draw a model as read: chain, joint axes, centres of mass, inertia ellipsoids, locked and excluded parts",
    )
    command_line.add_arguments(p)
    p.add_argument(
        "--out", dest="picture", default="robot.png", help="the picture (.png, .pdf, .svg; default robot.png)"
    )
    p.add_argument("--dpi", type=int, default=120, help="resolution of a .png (default 120)")
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("expand", help="print the URDF a xacro file expands to (what symdyn reads), for other tools")
    p.add_argument("file", metavar="FILE", help="a .xacro file")
    p.add_argument(
        "--xacro-arg", metavar="NAME:=VALUE", action="append", default=[], help="a xacro argument; repeatable"
    )
    p.add_argument(
        "--package-path", metavar="DIR", action="append", default=[], help="a folder holding ROS packages; repeatable"
    )
    p.set_defaults(func=_cmd_expand)

    from .identify import command as identify_command

    identify_command.configure_parser(
        sub.add_parser(
            "identify", help="identification: excite, simulate, fit (base parameters, a consistent model, a report)"
        )
    )

    from .sweep import command as sweep_command

    sweep_command.configure_parser(
        sub.add_parser(
            "sweep", help="many tasks on a Dask cluster: trajectory library, Monte-Carlo (--list to see them)"
        )
    )

    p = sub.add_parser("study", help="run one of the chapter's studies (--list to see them)")
    p.add_argument("name", nargs="?", help="the study to run (see --list)")
    p.add_argument("--list", action="store_true", help="list the studies")
    p.add_argument("--out", default="out", help="output folder (default: ./out)")
    p.set_defaults(func=_cmd_study)
    return parser


def writable_folder(path: Path) -> Path:
    """`path` created if needed and proven writable (a probe file), before any
    work is done; else a ValueError that names it and says why."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".symdyn-probe-"):
            pass
    except OSError as exc:
        raise ValueError(f"cannot write to {path}: {exc.strerror or exc}") from None
    return path


def _interrupted(signum, frame) -> None:
    """Ctrl-C: one line and exit 130 at once (a KeyboardInterrupt could be
    swallowed deep inside a library and come out as a traceback or not at all)."""
    print("\nsymdyn: interrupted", file=sys.stderr, flush=True)
    os._exit(130)


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """A warning about a robot file (URDFWarning, MJCFWarning) printed as the errors are, without
    the Python file and source line that `warnings` adds (`command_line.py:298: … return …`)."""
    from .model import MJCFWarning, URDFWarning

    if issubclass(category, (URDFWarning, MJCFWarning)):
        return f"symdyn: warning: {message}\n"
    return _python_format_warning(message, category, filename, lineno, line)


_python_format_warning = warnings.formatwarning


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, _interrupted) if main_thread else None
    formatting, warnings.formatwarning = warnings.formatwarning, _format_warning
    try:
        if getattr(args, "out", None):
            writable_folder(Path(args.out))
        return args.func(args)
    except (KeyError, ValueError, RuntimeError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"symdyn: error: {msg}", file=sys.stderr)
        return 2
    finally:
        warnings.formatwarning = formatting
        if main_thread:
            signal.signal(signal.SIGINT, previous)


if __name__ == "__main__":
    sys.exit(main())
