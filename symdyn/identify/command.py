"""`symdyn identify …`: the command line of identification.

`identify excite MODEL` designs an excitation trajectory (`excitation`'s own
parser), `identify simulate MODEL TRAJECTORY --out data.csv` makes
measurement-like data from a perturbed copy of the model, and `identify fit
MODEL DATA --validate DATA2 --out DIR` estimates the base parameters and
writes the report (summary.txt, parameters.json, identified.urdf for a URDF
model, figures).  MODEL is a shipped name or a URDF file with --tip/--base…
like every command's (`model.command_line`).  This module only parses and
delegates.
"""

from __future__ import annotations

import argparse
from importlib import import_module
from pathlib import Path

__all__ = ["configure_parser"]


def _excitation_module():
    try:
        return import_module(f"{__package__}.excitation")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__package__}.excitation":
            raise
        return None


def configure_parser(p: argparse.ArgumentParser) -> None:
    """The `identify` subcommands: excite, simulate, fit."""
    from ..model.command_line import add_arguments

    sub = p.add_subparsers(dest="identify_command", required=True, metavar="STEP")
    excite = sub.add_parser("excite", help="design an excitation trajectory (Fourier series, CasADi)")
    module = _excitation_module()
    if module is not None and hasattr(module, "configure_parser"):
        module.configure_parser(excite)
        excite.set_defaults(func=module.run_cli)
    else:
        excite.add_argument("rest", nargs="*", help=argparse.SUPPRESS)
        excite.set_defaults(func=_no_excitation)

    s = sub.add_parser("simulate", help="measurement-like data from a perturbed copy of the model")
    add_arguments(s)
    s.add_argument(
        "trajectory",
        metavar="TRAJECTORY",
        help="CSV or NPZ with t, q1…qn, qd1…qdn, qdd1…qddn (e.g. identify excite's excitation.csv; a "
        "floating base's base_x…, base_vx…, base_dvx… columns too)",
    )
    s.add_argument(
        "--out",
        dest="output",
        required=True,
        metavar="FILE.csv",
        help="the data file to write (CSV); the true parameters go beside it as FILE.truth.json",
    )
    s.add_argument(
        "--perturb",
        type=float,
        default=0.2,
        help="every inertial and friction parameter off by up to ± this fraction (default 0.2)",
    )
    s.add_argument(
        "--noise",
        type=float,
        nargs="+",
        default=[0.0],
        metavar="SIGMA",
        help="σ of the Gaussian torque noise in N·m (N): one, or one per joint (default 0)",
    )
    s.add_argument(
        "--quantisation",
        type=float,
        nargs="+",
        default=[0.0],
        metavar="RES",
        help="encoder resolution in rad (m): one, or one per joint (default 0: none)",
    )
    s.add_argument("--seed", type=int, default=0, help="seed of the perturbation and the noise (default 0)")
    s.add_argument(
        "--no-derivatives", action="store_true", help="write t, q, tau only (fit then low-passes and differentiates q)"
    )
    s.set_defaults(func=_simulate)

    f = sub.add_parser("fit", help="base parameters with error bars, a consistent model, a report")
    add_arguments(f)
    f.add_argument("data", metavar="DATA", help="CSV or NPZ: t, q1…qn, tau1…taun (qd…, qdd… or i… optional)")
    f.add_argument("--validate", metavar="DATA2", help="held-out data to validate the prediction on")
    f.add_argument("--out", required=True, help="folder for summary.txt, parameters.json, identified.urdf, figures")
    f.add_argument(
        "--method",
        choices=("wls", "ols"),
        default="wls",
        help="weighted (by each joint's noise, default) or ordinary least squares",
    )
    f.add_argument(
        "--no-consistent",
        action="store_true",
        help="skip the physically consistent standard parameters (least squares alone)",
    )
    f.add_argument(
        "--cutoff",
        type=float,
        default=None,
        metavar="HZ",
        help="low-pass cutoff of q before differentiation (default: 10 Hz where q̇, q̈ are computed)",
    )
    f.add_argument(
        "--decimate",
        type=int,
        default=1,
        metavar="K",
        help="decimate τ and the regressor by K through one filter (parallel filtering; default 1)",
    )
    f.add_argument(
        "--torque-constant",
        type=float,
        nargs="+",
        metavar="K",
        help="N·m/A: τ = K·i from motor current columns i1…in (one K, or one per joint)",
    )
    f.add_argument(
        "--target",
        choices=("c", "numpy", "casadi"),
        default="c",
        help="the generated code that evaluates the regressor (default c)",
    )
    f.add_argument("--no-figures", action="store_true", help="skip the figures")
    f.set_defaults(func=_fit)


def _no_excitation(args: argparse.Namespace) -> int:
    raise RuntimeError("excitation design (symdyn.identify.excitation) is not part of this installation")


def _simulate(args: argparse.Namespace) -> int:
    from ..model.command_line import from_args
    from .simulate import simulate, write

    robot = from_args(args)
    noise = args.noise[0] if len(args.noise) == 1 else args.noise
    res = args.quantisation[0] if len(args.quantisation) == 1 else args.quantisation
    data = simulate(robot, args.trajectory, perturb=args.perturb, noise=noise, quantisation=res, seed=args.seed)
    path = write(Path(args.output), data, derivatives=not args.no_derivatives, robot=robot)
    print(f"{data.N} samples of {robot.n} joints from {data.source}")
    print(f"wrote {path} and {path.with_suffix('.truth.json')}")
    return 0


def _fit(args: argparse.Namespace) -> int:
    from ..model.command_line import from_args
    from .data import load_data
    from .estimate import fit

    robot = from_args(args)
    K = (
        None
        if args.torque_constant is None
        else (args.torque_constant[0] if len(args.torque_constant) == 1 else args.torque_constant)
    )
    options = dict(joints=robot, torque_constant=K, cutoff=args.cutoff)
    data = load_data(args.data, decimate=args.decimate, **options)
    check = load_data(args.validate, **options) if args.validate else None
    result = fit(robot, data, args.method, consistent=not args.no_consistent, target=args.target)
    validation = result.validate(check) if check is not None else None
    from ..model.command_line import is_urdf

    result.write(
        args.out, validation, figures=not args.no_figures, urdf_source=args.model if is_urdf(args.model) else None
    )
    print(result.summary(validation))
    print(f"\nwritten to {args.out}")
    return 0
