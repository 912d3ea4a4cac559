"""A legged robot's optimal control through contact phases: Solo 12 jumps forward.

Solo 12 read from example-robot-data's URDF (`pip install 'symdyn[robots]'`) on a free base, its
four feet as point contacts; the schedule stance (0.3 s) → flight (0.16 s) → landing with an
inelastic impact → stance (0.3 s), from standing at rest to standing at rest 15 cm further
forward, minimum effort, friction pyramids μ = 0.7 (`symdyn.apps.ocp_legged`, CasADi + IPOPT
from a standing guess).  The optimum is then replayed open loop on the generated C contact
dynamics (`contact_fdyn` per stance node, `fdyn` in flight, `contact_impulse` at the
touchdown, the transcription's semi-implicit Euler steps): the replay's states against the
optimum's measure how exactly the transcription's constraints hold.  Writes
`legged_solo_jump.png`, `solo_jump.npz` (t, q, v, τ, forces: animation-ready) and `summary.txt`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...codegen.entry import load
from ...model import Robot
from .. import ocp_legged
from ._plot import finish, pyplot, save

FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")
STAND = {"FL_HFE": 0.8, "FL_KFE": -1.6, "FR_HFE": 0.8, "FR_KFE": -1.6}
STAND |= {"HL_HFE": -0.8, "HL_KFE": 1.6, "HR_HFE": -0.8, "HR_KFE": 1.6}


def solo12() -> Robot:
    """Solo 12 on a free base with its feet as frames (example-robot-data's URDF, no friction)."""
    from ...model.example_robots import robots_folder

    path = robots_folder() / "solo_description" / "robots" / "solo12.urdf"
    robot = Robot.from_urdf(str(path), tips="all", base_joint="free")
    return robot.nofriction(all=True).with_frames(FEET)


def jump_problem(robot: Robot) -> ocp_legged.LeggedProblem:
    q0 = ocp_legged.standing(robot, STAND)
    phases = (
        ocp_legged.Phase(FEET, 10, 0.3),
        ocp_legged.Phase((), 6, 0.16),
        ocp_legged.Phase(FEET, 10, 0.3),
    )
    return ocp_legged.LeggedProblem(robot, phases, q0, displacement=(0.15, 0.0, 0.0), mu=0.7)


def replay(robot: Robot, problem: ocp_legged.LeggedProblem, sol: ocp_legged.LeggedSolution) -> np.ndarray:
    """The optimum's torques replayed open loop on the generated C (see the module): q (N+1, nq)."""
    models = {}
    for phase in problem.phases:
        if phase.contacts not in models:
            model = robot.with_contacts({f: "point" for f in phase.contacts}) if phase.contacts else robot
            models[phase.contacts] = load(model, "c")
    q, v = problem.q0.copy(), np.zeros(robot.nv)
    out, k, previous = [q.copy()], 0, None
    nb = robot.nv - robot.n
    for phase in problem.phases:
        f = models[phase.contacts]
        for j in range(phase.nodes):
            if j == 0 and previous is not None and set(phase.contacts) - set(previous):
                v = f.contact_impulse(q, v)[0]
            tau = np.concatenate([np.zeros(nb), sol.tau[k]])
            a = f.contact_fdyn(q, v, tau)[0] if phase.contacts else f.fdyn(q, v, tau)
            v = v + phase.step * a
            q = robot.integrate(q, v, phase.step)
            out.append(q.copy())
            k += 1
        previous = phase.contacts
    return np.array(out)


def solo_jump(out_dir: Path, quick: bool = False) -> str:
    """Solo 12 jumps 15 cm forward: stance, flight, impact, stance (CasADi + IPOPT on the generated functions)."""
    robot = solo12()
    problem = jump_problem(robot)
    sol = ocp_legged.solve(problem)
    sol.save(Path(out_dir) / "solo_jump.npz")
    replayed = replay(robot, problem, sol)
    drift = np.abs(replayed[:, :3] - sol.q[:, :3]).max()
    joints = np.abs(replayed[:, 7:] - sol.q[:, 7:]).max()
    feet = load(robot, "c").frame_pose(sol.q)[:, :, 2, 3]
    plt = pyplot()
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(13, 3.8))
    a1.plot(sol.t, sol.q[:, 0], label="base x")
    a1.plot(sol.t, sol.q[:, 2], label="base z")
    a1.plot(sol.t, feet.min(axis=1), "k:", lw=1, label="lowest foot z")
    a1.set_xlabel("time (s)")
    a1.set_ylabel("m")
    a1.legend(fontsize=8)
    a1.grid(True)
    a1.set_title("Solo 12 jump: base and feet")
    mid = 0.5 * (sol.t[1:] + sol.t[:-1])
    for i, foot in enumerate(FEET):
        fz = [f[3 * i + 2] if len(f) else np.nan for f in sol.forces]
        a2.step(mid, fz, where="mid", label=foot)
    a2.set_xlabel("time (s)")
    a2.set_ylabel("normal force (N)")
    a2.legend(fontsize=8)
    a2.grid(True)
    a2.set_title("contact forces (flight: none)")
    a3.step(mid, sol.tau, where="mid", lw=1)
    a3.set_xlabel("time (s)")
    a3.set_ylabel("joint torque (N m)")
    a3.grid(True)
    a3.set_title("minimum-effort torques")
    save(fig, out_dir, "legged_solo_jump")
    cone = max(
        (max(abs(f[3 * c]), abs(f[3 * c + 1])) - problem.mu * f[3 * c + 2])
        for f in sol.forces
        if len(f)
        for c in range(4)
    )
    lines = [
        "Solo 12 (example-robot-data, free base, no friction) jumps 15 cm forward: stance 0.3 s, flight 0.16 s, "
        "inelastic landing, stance 0.3 s; minimum effort, friction pyramids mu = 0.7; the inverse transcription "
        "(symdyn.apps.ocp_legged) on the generated CasADi tau, feet Jacobians, drifts, poses and contact_impulse.",
        f"  IPOPT {sol.status} in {sol.iterations} iterations, {sol.seconds:.1f} s (building the problem "
        f"{sol.build_seconds:.1f} s), from a standing guess",
        f"  apex of the base {sol.q[:, 2].max() - problem.q0[2]:.3f} m above standing; largest torque "
        f"{np.abs(sol.tau).max():.2f} N m; largest cone excess {cone:.1e} N (<= 0: inside)",
        f"  replayed open loop on the generated C contact dynamics: base position within {drift * 1e6:.2f} µm, "
        f"joints within {joints:.1e} rad of the optimum at every node (IPOPT's 1e-6 on the constraints, open loop)",
        "  trajectory: solo_jump.npz (t, q, v, tau, forces)",
    ]
    return finish(out_dir, lines)


STUDIES = {
    "legged-solo-jump": ("Solo 12 jumps forward: stance, flight, impact, stance (CasADi + IPOPT)", solo_jump),
}
