"""The task-space functions of a model's code: frames, centre of mass, centroidal momentum.

Between derive and program, beside `functions` (the joint space): each function of
`symdyn.derivation.task_space.OUTPUTS` as a `FunctionSpec` over the task-space derivation's
named intermediates, its output shaped per state as `TaskSpace.shape` says ((m, 4, 4) poses,
(m, 6, nv) Jacobians, …); the drifts are the accelerations at a = 0, their definitions
substituted (as the bias is τ at q̈ = 0).
"""

from __future__ import annotations

import sympy as sp

from ..derivation.program import Program, make_programs
from ..derivation import engine
from ..derivation.task_space import (
    DRIFTS,
    OUTPUTS,
    TOGETHER,
    TaskSpace,
    arguments,
    derive_task_space,
    functions,
    parts,
)
from ..model import Robot
from .functions import FunctionSpec
from .shipped import is_shipped

__all__ = ["TASK_NAMES", "task_names", "task_spec", "task_doc", "TaskPrograms"]

#: Every task-space function, in the order of a model's list (the centroidal ones need mass).
TASK_NAMES = (*OUTPUTS, *TOGETHER)

_DOCS = {
    "frame_pose": "World pose of each frame ({m}, 4, 4) (Pinocchio's data.oMf)",
    "frame_jacobian": "Jacobian of each frame in its own axes, LOCAL ({m}, 6, {nv}), rows [linear; angular]",
    "frame_jacobian_aligned": "Jacobian of each frame at its origin in world axes, LOCAL_WORLD_ALIGNED ({m}, 6, {nv})",
    "frame_velocity": "Spatial velocity of each frame in its own axes, LOCAL ({m}, 6): J(q) v",
    "frame_acceleration": "Classical acceleration of each frame, LOCAL_WORLD_ALIGNED ({m}, 6): "
    "J_aligned(q) a + dJ/dt v (getFrameClassicalAcceleration)",
    "frame_drift": "dJ/dt v of each frame, LOCAL_WORLD_ALIGNED ({m}, 6): the classical acceleration at a = 0",
    "com": "Centre of mass (3,) in the world, every body counted",
    "com_jacobian": "Jacobian of the centre of mass (3, {nv})",
    "com_drift": "Acceleration of the centre of mass at a = 0 (3,): dJcom/dt v",
    "centroidal_map": "Centroidal momentum matrix A_G (6, {nv}) about the centre of mass, world axes, rows "
    "[linear; angular] (computeCentroidalMap)",
    "centroidal_drift": "dA_G/dt v (6,): the rate of the centroidal momentum at a = 0 "
    "(computeCentroidalMomentumTimeVariation at a = 0)",
    "frame_kinematics": "(pose, J, drift) of each frame from one pass: frame_pose, frame_jacobian_aligned and "
    "frame_drift together, what they share computed once",
    "centroidal": "(com, Jcom, Ag) from one pass: com, com_jacobian and centroidal_map together, what they share "
    "computed once",
}


def task_names(ts: TaskSpace) -> tuple[str, ...]:
    """The task-space functions the derivation gives (no centroidal ones for a massless robot)."""
    return tuple(name for name in TASK_NAMES if all(part in ts.outputs for part in parts(name)))


def task_doc(ts: TaskSpace, name: str, params=()) -> str:
    """A function's docstring: what it returns, for which frames, and what q, v, a hold."""
    doc = _DOCS[name].format(m=len(ts.frames), nv=len(ts.v)) + "."
    if parts(name)[0].startswith("frame_"):
        doc += f" Frames: {', '.join(f.name for f in ts.frames)}."
    if ts.robot.base_joint is not None:
        doc += f" q: ({len(ts.q)},), the {ts.robot.base_joint} base's coordinates first; v, a: ({len(ts.v)},), its body-frame velocity first."
    return doc + (f" p = ({', '.join(map(str, params))})." if params else "")


def task_spec(ts: TaskSpace, name: str, params=()) -> FunctionSpec:
    """The spec of one task-space function (of `OUTPUTS`, or several of them `TOGETHER`); `params`
    the symbols of a symbolic model (argument p)."""
    zero = ts.at_rest()
    drifts = any(part in DRIFTS for part in parts(name))
    outputs, shapes = [], []
    for part in parts(name):
        expr = ts.outputs[part]
        outputs.append((OUTPUTS[part][0], expr.xreplace(zero) if part in DRIFTS else expr))
        shapes.append((OUTPUTS[part][0], ts.shape(part)))
    defs = tuple((s, sp.sympify(e).xreplace(zero)) for s, e in ts.definitions) if drifts else ts.definitions
    inputs = ts.inputs(name) + ((("p", tuple(params)),) if params else ())
    return FunctionSpec(
        name,
        inputs,
        tuple(outputs),
        defs,
        task_doc(ts, name, params),
        "task space",
        tuple(out for out, shape in shapes if len(shape) > 1),
        tuple(shapes),
    )


class TaskPrograms:
    """The task-space functions' programs of one robot, each built when first asked for from one
    task-space derivation (made once): no joint-space derivation is needed for them.
    `params`: a symbolic model's parameters (argument p)."""

    def __init__(self, robot: Robot, params=()) -> None:
        self.robot, self.params = robot, tuple(params)
        self.names = functions(robot)
        self._derived: TaskSpace | None = None
        self._built: dict[str, Program] = {}

    def derivation(self) -> TaskSpace:
        if self._derived is None:
            self._derived = derive_task_space(self.robot)
        return self._derived

    def program(self, name: str) -> Program:
        """A function's program, its CSE by the engine of the model's code (`choice`: sympy for
        the shipped models, pinned byte for byte in generated/, SymEngine for any other).  Any
        other model's is made with every function of its group (`_groups`) by one CSE over all
        their outputs (the Panda's thirteen: 0.25 → 0.15 s, the same operations ±2 in 30 000 on
        Talos), by SymEngine alone (sympy's CSE of the small group, frame_acceleration, tried as
        for any small program, gave the same operations on the Panda, Solo 12, Talos and five
        arms, in 0.03-0.1 s more); a shipped model's by a CSE of its own, as people read it
        (sympy's CSE over a group names terms another function shares, x2 = −c1)."""
        if name not in self._built:
            if name not in self.names:
                raise KeyError(f"{self.robot.name} has no task-space function {name!r}")
            if is_shipped(self.robot):
                with engine.use("sympy"):
                    self._built[name] = task_spec(self.derivation(), name, self.params).program()
                return self._built[name]
            group = next(g for g in _groups(self.names) if name in g)
            specs = [task_spec(self.derivation(), n, self.params) for n in group]
            # the group's definitions: at a = 0 where it has a drift (the others there do not read a)
            defs = next((s.definitions for s in specs if set(parts(s.name)) & set(DRIFTS)), specs[0].definitions)
            with engine.use("symengine"):  # sympy's CSE of a small group is no leaner: not tried
                self._built.update(zip(group, make_programs([s.fields() for s in specs], defs, choose=False)))
        return self._built[name]


def _groups(names) -> tuple[tuple[str, ...], ...]:
    """The functions that share one CSE: those that read the accelerations a (their definitions
    as derived), and all the others (the definitions at a = 0, which none of them but the drifts
    depend on)."""
    reads = tuple(n for n in names if "a" in arguments(n))
    return tuple(g for g in (reads, tuple(n for n in names if n not in reads)) if g)
