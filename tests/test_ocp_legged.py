"""Optimal control of a legged robot through contact phases (issue 43, item 3): the free base's
step on its manifold in CasADi, and the Solo 12 jump converging from a standing guess (slow)."""

import numpy as np
import pytest

from symdyn.apps import ocp_legged
from symdyn.model.random_robots import random_tree_robot


def test_the_casadi_step_is_robot_integrate():
    """q ⊕ w in CasADi (the exponential's series) against Robot.integrate (closed forms), turns up
    to 1 rad, and its Jacobian finite at a zero turn (where the closed forms are 0/0)."""
    import casadi as ca

    robot = random_tree_robot(2, n=3, base_joint="free")
    step = ocp_legged.integrate_function(robot)
    rng = np.random.default_rng(0)
    for scale in (0.0, 1e-9, 1e-3, 0.1, 0.5):
        q = robot.normalize(rng.normal(size=robot.nq))
        w = rng.normal(size=robot.nv)
        w[3:6] *= scale / max(np.linalg.norm(w[3:6]), 1e-300) if scale else 0.0
        np.testing.assert_allclose(step(q, w).full().ravel(), robot.integrate(q, w), rtol=0, atol=1e-12)
    q_sym, w_sym = ca.SX.sym("q", robot.nq), ca.SX.sym("w", robot.nv)
    jac = ca.Function("J", [q_sym, w_sym], [ca.jacobian(step(q_sym, w_sym), w_sym)])
    assert np.all(np.isfinite(jac(robot.neutral(), np.zeros(robot.nv)).full()))
    with pytest.raises(ValueError, match="not free"):
        ocp_legged.integrate_function(random_tree_robot(2, n=3))


@pytest.mark.slow
def test_solo12_jumps_from_a_standing_guess_and_the_generated_contact_dynamics_replay_it(tmp_path):
    """The study's jump converges; its torques, replayed on the generated C contact dynamics
    (contact_fdyn, fdyn, contact_impulse), give the optimum's motion: each node's step, and the
    base's open loop (the joints' open loop grows the steps' residuals ~3× a node in the landing's
    stance, ~1e-4 rad at the end: not a bound on the transcription); every force in its
    friction pyramid, the feet on the ground in stance and above it in flight."""
    from symdyn.apps.studies import legged
    from tests.test_task_space import _solo_file

    _solo_file()  # skips without example-robot-data
    from symdyn.codegen.entry import load

    robot = legged.solo12()
    problem = legged.jump_problem(robot)
    sol = ocp_legged.solve(problem)
    assert sol.status == "Solve_Succeeded"
    stepped = legged.replay(robot, problem, sol, each_step=True)
    assert np.abs(stepped - sol.q).max() < 1e-7  # each node's step (IPOPT's 1e-6 on the constraints; 5e-9)
    replayed = legged.replay(robot, problem, sol)
    assert np.abs(replayed[:, :3] - sol.q[:, :3]).max() < 1e-6  # the base open loop, m
    np.testing.assert_allclose(sol.q[-1, :3] - problem.q0[:3], [0.15, 0.0, 0.0], atol=1e-6)
    for f in sol.forces:
        for c in range(len(f) // 3):
            assert f[3 * c + 2] >= -1e-6 and max(abs(f[3 * c]), abs(f[3 * c + 1])) <= 0.7 * f[3 * c + 2] + 1e-6
    assert problem.hold == legged.HOLD  # each foot in contact within 1 mm of its anchor, each axis
    assert legged.slip(problem, sol, load(robot, "c").frame_pose(sol.q)[:, :, :3, 3]) <= 3**0.5 * problem.hold + 1e-6
    feet = load(robot, "c").frame_pose(sol.q)[:, :, 2, 3]
    flight = [k for k, p in enumerate(sol.phase_of_node) if p == 1][1:]
    assert feet[flight].min() > 0.0  # in the air
    assert feet.min() >= -problem.hold - 1e-6  # no foot into the ground by more than the hold
    assert np.abs(feet[sol.phase_of_node.index(2)]).max() < 1e-6  # the touchdown on the ground
    sol.save(tmp_path / "jump.npz")
    saved = np.load(tmp_path / "jump.npz")
    assert saved["q"].shape == sol.q.shape and saved["forces"].shape == (len(sol.forces), 12)


@pytest.mark.slow
def test_solo12_trots_two_steps_onto_its_footholds(tmp_path):
    """The study's trot converges: each foot lands once, on its foothold (where it stood, 10 cm
    forward), clears the ground by 3 cm at mid-swing, pushes only inside its friction pyramid, and
    the generated C contact dynamics replay the motion: each node's step, and the base open loop."""
    from symdyn.apps.studies import legged
    from symdyn.codegen.entry import load
    from tests.test_task_space import _solo_file

    _solo_file()  # skips without example-robot-data
    robot = legged.solo12()
    problem = legged.trot_problem(robot)
    sol = ocp_legged.solve(problem)
    assert sol.status == "Solve_Succeeded"
    feet = load(robot, "c").frame_pose(sol.q)[:, :, :3, 3]
    start = feet[0].copy()
    for phase in (2, 4):  # the touchdowns: the feet that were in the air land on their footholds
        k = sol.phase_of_node.index(phase)
        landing = [i for i, f in enumerate(legged.FEET) if f not in problem.phases[phase - 1].contacts]
        np.testing.assert_allclose(feet[k, landing, 0], start[landing, 0] + 0.1, atol=1e-6)
        np.testing.assert_allclose(feet[k, landing, 1:], start[landing, 1:], atol=1e-6)
        swing = [j for j, p in enumerate(sol.phase_of_node) if p == phase - 1]
        assert feet[swing[len(swing) // 2], landing, 2].min() >= 0.03 - 1e-6  # clearance at mid-swing
    for f in sol.forces:
        for c in range(len(f) // 3):
            assert f[3 * c + 2] >= -1e-6 and max(abs(f[3 * c]), abs(f[3 * c + 1])) <= 0.7 * f[3 * c + 2] + 1e-6
    stepped = legged.replay(robot, problem, sol, each_step=True)
    assert np.abs(stepped - sol.q).max() < 1e-7  # each node's step on the generated C
    replayed = legged.replay(robot, problem, sol)
    assert np.abs(replayed[:, :3] - sol.q[:, :3]).max() < 1e-6  # the base open loop, m
    np.testing.assert_allclose(sol.q[-1, :3] - problem.q0[:3], [0.1, 0.0, 0.0], atol=1e-6)
    assert legged.slip(problem, sol, feet) < 1.5e-3  # the Baumgarte gains hold the feet in stance (8.3 mm without)


# ---------------------------------------------------------------- flat soles (surface contacts)

BIPED = "tests/urdf/sole_biped.urdf"
SOLES = ("left_sole", "right_sole")


def _biped():
    from symdyn.model import Robot

    robot = Robot.from_urdf(BIPED, tips="all", base_joint="free").nofriction(all=True).with_frames(SOLES)
    bent = {
        f"{s}_{j}": a for s in ("left", "right") for j, a in (("hip_pitch", -0.3), ("knee", 0.6), ("ankle_pitch", -0.3))
    }
    return robot, ocp_legged.standing(robot, bent)


def test_a_soles_anchor_error_is_pinocchios_corrector_error():
    """A surface's error from its anchor in the transcription is −R·log₆(M⁻¹M_anchor) (world axes),
    what `with_contacts(kp=…)` and Pinocchio's corrector measure, at turns up to ~1 rad."""
    import casadi as ca

    pin = pytest.importorskip("pinocchio", reason="the peer (the test extra)")
    rng = np.random.default_rng(3)
    for scale in (0.0, 1e-6, 0.1, 0.5):
        M = pin.SE3.Random()
        anchor = M * pin.exp6(pin.Motion(rng.normal(size=6) * scale))
        got = ocp_legged._anchor_error(ca.DM(M.homogeneous[:3, :]), ca.DM(anchor.homogeneous[:3, :]), 6)
        log = pin.log6(M.inverse() * anchor).vector
        want = -np.concatenate([M.rotation @ log[:3], M.rotation @ log[3:]])
        np.testing.assert_allclose(ca.evalf(got).full().ravel(), want, rtol=0, atol=1e-12)


def test_soles_are_checked_before_anything_is_built():
    robot, q0 = _biped()
    phases = (ocp_legged.Phase(SOLES, 2, 0.1),)
    for soles, match in (
        ({"left_foot": (0.1, 0.05)}, "'left_foot' is not among the feet"),
        ({"left_sole": (0.1, 0)}, r"soles\['left_sole'\]: \(half-length, half-width\)"),
    ):
        with pytest.raises(ValueError, match=match):
            ocp_legged.solve(ocp_legged.LeggedProblem(robot, phases, q0, soles=soles))
    problem = ocp_legged.LeggedProblem(robot, phases, q0, soles={"left_sole": (0.1, 0.05)}, baumgarte=(100.0, 20.0))
    with pytest.raises(ValueError, match="point feet only"):
        ocp_legged.solve(problem, source="plain")
    with pytest.raises(ValueError, match="inverse transcription"):
        ocp_legged.solve(problem, transcription="forward")


@pytest.mark.slow
def test_a_biped_steps_on_flat_soles_within_their_wrench_cones():
    """Double support, the right foot swinging 2 cm clear for 0.25 s, double support again (an impact
    at its touchdown): IPOPT converges; every sole's wrench lies in its rectangle's contact wrench
    cone (in the sole's axes); the stance sole holds its place and stays flat (Baumgarte gains on
    its 6-D error); the swinging sole lands flat on the ground."""
    from symdyn import load
    from symdyn.apps import wrench_cone

    robot, q0 = _biped()
    phases = (
        ocp_legged.Phase(SOLES, 3, 0.06),
        ocp_legged.Phase(("left_sole",), 10, 0.25),
        ocp_legged.Phase(SOLES, 3, 0.06),
    )
    size = (0.1, 0.05)
    problem = ocp_legged.LeggedProblem(
        robot,
        phases,
        q0,
        displacement=(0.04, 0.0, 0.0),
        clearance=0.02,
        baumgarte=(400.0, 40.0),
        soles={foot: size for foot in SOLES},
    )
    sol = ocp_legged.solve(problem)
    assert sol.status == "Solve_Succeeded", sol.status
    pose = load(robot, "c").frame_pose(sol.q)
    k, worst = 0, -np.inf
    for phase in phases:
        for _ in range(phase.nodes):
            force = sol.forces[k]
            assert force.shape == (6 * len(phase.contacts),)
            for c, foot in enumerate(phase.contacts):
                R = pose[k, SOLES.index(foot), :3, :3]
                rows = wrench_cone.rows(R.T @ force[6 * c : 6 * c + 3], R.T @ force[6 * c + 3 : 6 * c + 6], *size, 0.7)
                worst = max(worst, max(rows))
            k += 1
    assert worst <= 1e-6
    left, right = pose[:, 0], pose[:, 1]
    assert np.abs(left[:, :3, 3] - left[0, :3, 3]).max() < 5e-3 and np.abs(left[:, :2, 2]).max() < 5e-3
    landed = phases[0].nodes + phases[1].nodes
    assert np.abs(right[landed, 2, 3]) < 1e-6 and np.abs(right[landed, :2, 2]).max() < 1e-6
    assert right[landed, 0, 3] - right[0, 0, 3] > 0.02  # it stepped forward
