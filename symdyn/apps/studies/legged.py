"""A legged robot's optimal control through contact phases: Solo 12 jumps forward, and trots.

Solo 12 read from example-robot-data's URDF (`pip install 'symdyn[robots]'`) on a free base, its
four feet as point contacts; the schedule stance (0.3 s) → flight (0.16 s) → landing with an
inelastic impact → stance (0.3 s), from standing at rest to standing at rest 15 cm further
forward, minimum effort, friction pyramids μ = 0.7 (`symdyn.apps.ocp_legged`, CasADi + IPOPT
from a standing guess).  The optimum is then replayed open loop on the generated C contact
dynamics (`contact_fdyn` per stance node, `fdyn` in flight, `contact_impulse` at the
touchdown, the transcription's semi-implicit Euler steps): the replay's states against the
optimum's measure how exactly the transcription's constraints hold.  Writes
`legged_solo_jump.png`, `solo_jump.npz` (t, q, v, τ, forces: animation-ready) and `summary.txt`.
The trot (`legged-solo-trot`): two steps of the diagonal pairs, each foot landing once on its
foothold, written and checked alike (`legged_solo_trot.png`, `solo_trot.npz`).
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
#: The feet's Baumgarte gains (kp, kd): ω = 20 rad/s, critically damped.  Without them the feet in
#: stance slid up to 68 mm (the jump) and 8.3 mm (the trot); with them 3.9 mm and 0.8 mm, and IPOPT
#: converged in fewer iterations; stiffer gains (ω = 30, 40) slid more (ω h ≥ 0.75 per step).
GAINS = (400.0, 40.0)
#: The jump's feet held within 1 mm of their anchors (`LeggedProblem.hold`): with the gains alone a
#: landing's first step moves a foot by h²·γ, and which optimum IPOPT reaches decides how far (3.9
#: to 9.5 mm, a foot 7.8 mm into the ground, between runs whose functions differ by 1e-14).
HOLD = 1e-3


def solo12() -> Robot:
    """Solo 12 on a free base with its feet as frames (example-robot-data's URDF, no friction)."""
    from ...model.example_robots import robots_folder

    path = robots_folder() / "solo_description" / "robots" / "solo12.urdf"
    robot = Robot.from_urdf(str(path), tips="all", base_joint="free")
    return robot.nofriction(all=True).with_frames(FEET)


def jump_problem(robot: Robot, gains: tuple = GAINS, hold: float | None = HOLD) -> ocp_legged.LeggedProblem:
    """The jump (`solo_jump`); `gains`: the feet's Baumgarte (kp, kd), (0, 0) for none; `hold`: how
    far a foot in contact may move (`LeggedProblem.hold`), None for no bound."""
    q0 = ocp_legged.standing(robot, STAND)
    phases = (
        ocp_legged.Phase(FEET, 10, 0.3),
        ocp_legged.Phase((), 6, 0.16),
        ocp_legged.Phase(FEET, 10, 0.3),
    )
    return ocp_legged.LeggedProblem(
        robot, phases, q0, displacement=(0.15, 0.0, 0.0), mu=0.7, baumgarte=gains, hold=hold
    )


def replay(
    robot: Robot, problem: ocp_legged.LeggedProblem, sol: ocp_legged.LeggedSolution, each_step: bool = False
) -> np.ndarray:
    """The optimum's torques replayed open loop on the generated C (see the module): q (N+1, nq).
    With Baumgarte gains each foot's anchor is where the replay's own stance began.  `each_step`:
    every step starts from the optimum's own node (q, v; its anchors the optimum's stance starts),
    so row k + 1 is one step of the generated dynamics from node k — what the transcription's
    constraints hold, without the open loop's growth of their residuals."""
    kp, kd = problem.baumgarte
    models = {}
    for phase in problem.phases:
        if phase.contacts not in models:
            model = robot.with_contacts({f: "point" for f in phase.contacts}, kp=kp, kd=kd) if phase.contacts else robot
            models[phase.contacts] = load(model, "c")
    pose = load(robot, "c").frame_pose
    q, v = problem.q0.copy(), np.zeros(robot.nv)
    out, k, previous, anchors = [q.copy()], 0, (), {}
    nb = robot.nv - robot.n
    for phase in problem.phases:
        f = models[phase.contacts]
        for j in range(phase.nodes):
            if each_step:
                q, v = robot.normalize(sol.q[k]), sol.v[k].copy()  # IPOPT's quaternion: unit to its 1e-6
            for foot in phase.contacts:
                if j == 0 and foot not in previous or k == 0:
                    anchors[foot] = pose(q)[FEET.index(foot), :3, 3]
            if j == 0 and k > 0 and set(phase.contacts) - set(previous):
                v = f.contact_impulse(q, v)[0]
            tau = np.concatenate([np.zeros(nb), sol.tau[k]])
            if phase.contacts:
                anchor = (np.concatenate([anchors[foot] for foot in phase.contacts]),) if kp else ()
                a = f.contact_fdyn(q, v, tau, *anchor)[0]
            else:
                a = f.fdyn(q, v, tau)
            v = v + phase.step * a
            q = robot.integrate(q, v, phase.step)
            out.append(q.copy())
            k += 1
        previous = phase.contacts
    return np.array(out)


def _report(
    robot: Robot, problem: ocp_legged.LeggedProblem, sol: ocp_legged.LeggedSolution, out_dir, name: str, title: str
):
    """The figure (base and feet, normal forces, torques) saved as `name`.png, and the checks every
    legged study states: ((each node's step against the optimum, the open loop's base drift, its
    joints' drift), the largest friction-cone excess)."""
    replayed = replay(robot, problem, sol)
    drift = (
        np.abs(replay(robot, problem, sol, each_step=True) - sol.q).max(),
        np.abs(replayed[:, :3] - sol.q[:, :3]).max(),
        np.abs(replayed[:, 7:] - sol.q[:, 7:]).max(),
    )
    feet = load(robot, "c").frame_pose(sol.q)[:, :, 2, 3]
    plt = pyplot()
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(13, 3.8))
    a1.plot(sol.t, sol.q[:, 0], label="base x")
    a1.plot(sol.t, sol.q[:, 2], label="base z")
    for i, foot in enumerate(FEET):
        a1.plot(sol.t, feet[:, i], ":", lw=1, label=f"{foot} z")
    a1.set_xlabel("time (s)")
    a1.set_ylabel("m")
    a1.legend(fontsize=7)
    a1.grid(True)
    a1.set_title(f"{title}: base and feet")
    mid = 0.5 * (sol.t[1:] + sol.t[:-1])
    for i, foot in enumerate(FEET):
        fz = [_normal(f, problem.phases[p].contacts, foot) for f, p in zip(sol.forces, sol.phase_of_node)]
        a2.step(mid, fz, where="mid", label=foot)
    a2.set_xlabel("time (s)")
    a2.set_ylabel("normal force (N)")
    a2.legend(fontsize=8)
    a2.grid(True)
    a2.set_title("contact forces (a foot in the air: none)")
    a3.step(mid, sol.tau, where="mid", lw=1)
    a3.set_xlabel("time (s)")
    a3.set_ylabel("joint torque (N m)")
    a3.grid(True)
    a3.set_title("minimum-effort torques")
    save(fig, out_dir, name)
    cone = max(
        max(abs(f[3 * c]), abs(f[3 * c + 1])) - problem.mu * f[3 * c + 2]
        for f in sol.forces
        for c in range(len(f) // 3)
    )
    return drift, cone


def _normal(force: np.ndarray, contacts: tuple, foot: str) -> float:
    """The foot's normal force in a node's forces (ordered as its phase's contacts), NaN in the air."""
    return force[3 * contacts.index(foot) + 2] if foot in contacts else np.nan


def _solved(sol: ocp_legged.LeggedSolution) -> str:
    return (
        f"  IPOPT {sol.status} in {sol.iterations} iterations, {sol.seconds:.1f} s (building the problem "
        f"{sol.build_seconds:.1f} s), from a standing guess"
    )


def _replayed(drift: tuple) -> str:
    step, base, joints = drift
    return (
        f"  replayed on the generated C contact dynamics: each node's step within {step:.1e} of the optimum's next "
        f"node (IPOPT's 1e-6 on the constraints); open loop, the base position within {base * 1e6:.2f} µm and the "
        f"joints within {joints:.1e} rad at every node (the steps' residuals grown along the motion)"
    )


def _solved_study(robot: Robot, problem: ocp_legged.LeggedProblem, out_dir, name: str, title: str):
    """Solve, save the trajectory (`<name>.npz`) and report (`legged_<name>.png`): (sol, drift, cone)."""
    sol = ocp_legged.solve(problem)
    sol.save(Path(out_dir) / f"{name}.npz")
    return (sol, *_report(robot, problem, sol, out_dir, f"legged_{name}", title))


def solo_jump(out_dir: Path, quick: bool = False) -> str:
    """Solo 12 jumps 15 cm forward: stance, flight, impact, stance (CasADi + IPOPT on the generated functions)."""
    robot = solo12()
    problem = jump_problem(robot)
    sol, drift, cone = _solved_study(robot, problem, out_dir, "solo_jump", "Solo 12 jump")
    lines = [
        "Solo 12 (example-robot-data, free base, no friction) jumps 15 cm forward: stance 0.3 s, flight 0.16 s, "
        "inelastic landing, stance 0.3 s; minimum effort, friction pyramids mu = 0.7; the inverse transcription "
        "(symdyn.apps.ocp_legged) on the generated CasADi tau, feet Jacobians, drifts, poses and contact_impulse.",
        _solved(sol),
        f"  apex of the base {sol.q[:, 2].max() - problem.q0[2]:.3f} m above standing; largest torque "
        f"{np.abs(sol.tau).max():.2f} N m; largest cone excess {cone:.1e} N (<= 0: inside)",
        _slid(problem, sol, robot),
        _replayed(drift),
        "  trajectory: solo_jump.npz (t, q, v, tau, forces)",
    ]
    return finish(out_dir, lines)


def slip(problem: ocp_legged.LeggedProblem, sol: ocp_legged.LeggedSolution, feet: np.ndarray) -> float:
    """The largest distance (m) a foot in contact moves from where its phase began, over every phase."""
    worst, k = 0.0, 0
    for phase in problem.phases:
        held = [FEET.index(f) for f in phase.contacts]
        if held:
            span = feet[k : k + phase.nodes + 1, held]
            worst = max(worst, float(np.linalg.norm(span - span[0], axis=-1).max()))
        k += phase.nodes
    return worst


def _slid(problem: ocp_legged.LeggedProblem, sol: ocp_legged.LeggedSolution, robot: Robot) -> str:
    feet = load(robot, "c").frame_pose(sol.q)[:, :, :3, 3]
    return (
        f"  a foot in contact moves at most {1e3 * slip(problem, sol, feet):.2f} mm within its phase, the lowest "
        f"foot {1e3 * feet[:, :, 2].min():+.2f} mm (Baumgarte gains kp, kd = {problem.baumgarte}: the contacts "
        "hold J a + gamma = -kd J v - kp (p - anchor), semi-implicit Euler steps the positions"
        + ("" if problem.hold is None else f"; each foot held within {1e3 * problem.hold:g} mm of its anchor")
        + ")"
    )


def trot_problem(robot: Robot, gains: tuple = GAINS, hold: float | None = None) -> ocp_legged.LeggedProblem:
    """Two trot steps, 10 cm forward: the diagonal pairs swing in turn, each foot landing once on
    its foothold (where it stood, moved 10 cm), 3 cm above the ground at mid-swing; `gains` and
    `hold` as `jump_problem`'s (the trot's landings are gentle: its feet move 0.8 mm without a
    bound, and IPOPT did not converge in 1000 iterations with a 1 mm one)."""
    fl, fr, hl, hr = FEET
    phases = (
        ocp_legged.Phase(FEET, 4, 0.08),
        ocp_legged.Phase((fl, hr), 8, 0.2),
        ocp_legged.Phase(FEET, 3, 0.06),
        ocp_legged.Phase((fr, hl), 8, 0.2),
        ocp_legged.Phase(FEET, 4, 0.08),
    )
    q0 = ocp_legged.standing(robot, STAND)
    return ocp_legged.LeggedProblem(
        robot,
        phases,
        q0,
        displacement=(0.1, 0.0, 0.0),
        mu=0.7,
        clearance=0.03,
        footholds=True,
        baumgarte=gains,
        hold=hold,
    )


def solo_trot(out_dir: Path, quick: bool = False) -> str:
    """Solo 12 trots two steps, 10 cm forward (CasADi + IPOPT on the generated functions)."""
    robot = solo12()
    problem = trot_problem(robot)
    sol, drift, cone = _solved_study(robot, problem, out_dir, "solo_trot", "Solo 12 trot")
    feet = load(robot, "c").frame_pose(sol.q)[:, :, :3, 3]
    lines = [
        "Solo 12 (example-robot-data, free base, no friction) trots two steps 10 cm forward: four feet 0.08 s, "
        "FR and HL swing 0.2 s, an inelastic touchdown, four feet 0.06 s, FL and HR swing 0.2 s, a touchdown, "
        "four feet 0.08 s; each foot lands on its foothold, 3 cm clearance at mid-swing; minimum effort, "
        "friction pyramids mu = 0.7, Baumgarte gains on the feet (symdyn.apps.ocp_legged, inverse transcription).",
        _solved(sol),
        "  feet moved (x, m): "
        + ", ".join(f"{f} {d:+.4f}" for f, d in zip(FEET, feet[-1, :, 0] - feet[0, :, 0]))
        + f"; highest foot {feet[:, :, 2].max():.3f} m; largest torque {np.abs(sol.tau).max():.2f} N m; "
        f"largest cone excess {cone:.1e} N (<= 0: inside)",
        _slid(problem, sol, robot),
        _replayed(drift),
        "  trajectory: solo_trot.npz (t, q, v, tau, forces)",
    ]
    return finish(out_dir, lines)


STUDIES = {
    "legged-solo-jump": ("Solo 12 jumps forward: stance, flight, impact, stance (CasADi + IPOPT)", solo_jump),
    "legged-solo-trot": ("Solo 12 trots two steps: diagonal pairs swing in turn (CasADi + IPOPT)", solo_trot),
}
