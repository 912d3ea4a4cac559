"""Sweeps: one study's task mapped over many inputs on a Dask cluster, results in one table.

Where it sits: after the apps and identification (a task calls the OCP, the
simulator, generated code), before the command line.  `engine` maps a task
over inputs (a local cluster by default, any Dask scheduler by address) and
writes rows as they arrive; `table` is the CSV those rows go to; each sweep
is a module with a `SWEEP` (`library`: minimum-time trajectory library;
`montecarlo`: the computed-torque controller under parameter draws);
`command` is `symdyn sweep`.  A new sweep is a module with a task function,
an inputs function and a `Sweep`, listed in `MODULES` (docs/sweeps.md).
"""

from __future__ import annotations

import importlib

#: name -> module holding its SWEEP, in the order `symdyn sweep --list` shows them.
MODULES = {"trajectory-library": "library", "monte-carlo": "montecarlo"}


def get(name: str):
    """The `Sweep` called `name` (a ValueError naming the known ones otherwise)."""
    if name not in MODULES:
        raise ValueError(f"unknown sweep {name!r}: expected one of {', '.join(MODULES)}")
    return importlib.import_module(f".{MODULES[name]}", __name__).SWEEP
