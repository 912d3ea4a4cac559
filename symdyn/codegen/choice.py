"""Which derivation each function of a model's code comes from, and the list of its programs.

Each term (τ, M, C, C·q̇, G, F, the bias) takes the derivation whose program
has the fewest operations (Lagrange's trigonometric polynomials give a
compact M, Newton–Euler's recursion a compact τ); forward dynamics, the
derivatives and M⁻¹ are built from the chosen M, bias and τ.
"""

from __future__ import annotations

from typing import Sequence

from ..derivation.dynamics import Dynamics
from ..derivation.program import Program, dag_size
from .derivatives import christoffel_spec, fdyn_derivatives_program, minv_spec, tau_derivatives_spec
from .functions import FunctionSpec, candidates, fdyn_spec, regressor_spec

__all__ = ["programs"]


def _cheapest(specs: Sequence[FunctionSpec]) -> tuple[FunctionSpec, Program]:
    """The spec whose program has the fewest operations (the first on ties).

    Specs are built smallest first, by the nodes of their expression DAG; one
    with more than twice as many nodes as the best program so far has
    operations is not built (CSE leaves 0.9–1.7 operations per node here):
    a generic 7-joint arm's expanded Lagrange C would take minutes to CSE
    only to lose to the Newton–Euler recursion.
    """
    sizes = [dag_size(s.outputs, s.definitions) for s in specs]
    best = None
    for k in sorted(range(len(specs)), key=lambda k: (sizes[k], k)):
        if best is not None and sizes[k] > 2 * best[0]:
            continue
        program = specs[k].program()
        candidate = (program.op_count()["total"], k, specs[k], program)
        best = candidate if best is None else min(best, candidate, key=lambda c: c[:2])
    return best[2], best[3]


def programs(dyns: Sequence[Dynamics], regressor=None, origins: Sequence[str] | None = None) -> list[Program]:
    """The programs of tau, M, C, Cqd, G, F, fdyn (and Y when `regressor` is
    given), tau_derivatives, fdyn_derivatives and Minv: each term from the
    derivation giving the fewest operations (the first on ties), the others
    from the cheapest M, bias and τ.  `origins`: a label per
    derivation for the generated files (default: their methods)."""
    if not dyns:
        raise ValueError("programs() needs at least one derivation")
    origins = origins or [None] * len(dyns)
    cands = [candidates(d, o) for d, o in zip(dyns, origins)]
    chosen: dict[str, tuple[FunctionSpec, Program]] = {}
    for term in ("tau", "M", "C", "Cqd", "G", "F", "bias"):
        extra = [christoffel_spec(c["Cqd"]) for c in cands] if term == "C" else []
        chosen[term] = _cheapest([c[term] for c in cands if term in c] + extra)
    out = [chosen[t][1] for t in ("tau", "M", "C", "Cqd", "G", "F")]
    fdyn = fdyn_spec(chosen["M"][0], chosen["bias"][0]).program()
    out.append(fdyn)
    if regressor is not None:
        out.append(regressor_spec(regressor, dyns[0]).program())
    tau_derivatives = tau_derivatives_spec(chosen["tau"][0]).program()
    minv = minv_spec(chosen["M"][0]).program()
    return out + [tau_derivatives, fdyn_derivatives_program(fdyn, tau_derivatives, minv), minv]
