"""Trajectory optimisation for any arm on CasADi dynamics functions (Opti + IPOPT).

The third use of symdyn: the emitted CasADi functions feed optimal control.
A `Problem` (boundary states, fixed or free final time, grid, transcription,
`Limits`, `Cost`) is posed with `casadi.Opti` as direct multiple shooting
(piecewise-constant torque, RK4 on fdyn(q, q̇, τ)) or direct collocation
(trapezoidal or Hermite–Simpson, q̈ a decision variable and τ = ID(q, q̇, q̈)
imposed: no mass-matrix inverse).  `solve` returns a `Solution`; `verify`
re-simulates its torque open-loop with the numeric reference and checks the
goal and the limits, so every optimum is checked against `symdyn.reference`.

By concern: `functions` (the dynamics posed on), `problem` (what is asked), `transcription`
(posing and solving), `check` (re-simulation against the reference), `tracking` (receding horizon).
"""

from __future__ import annotations

from .functions import ArmFunctions, SOURCES, dynamics, planar_rates
from .problem import Cost, Limits, METHODS, Problem, Solution, motor_torque_limits
from .transcription import OCPError, solve
from .check import Check, limit_violation, resimulate, verify
from .tracking import RTITracker, Tracker

__all__ = [
    "METHODS",
    "SOURCES",
    "OCPError",
    "ArmFunctions",
    "Limits",
    "Cost",
    "Problem",
    "Solution",
    "Check",
    "Tracker",
    "RTITracker",
    "dynamics",
    "planar_rates",
    "motor_torque_limits",
    "solve",
    "resimulate",
    "verify",
    "limit_violation",
]
