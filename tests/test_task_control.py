"""Task-space control on the generated functions: inverse kinematics and operational-space control."""

import numpy as np
import pytest

from symdyn.apps.task_control import OperationalSpaceController, inverse_kinematics, pose_error
from symdyn.codegen.entry import load
from symdyn.model import arms
from symdyn.model.random_robots import random_tree_robot


@pytest.fixture(scope="module")
def panda():
    robot = arms.load("panda")
    return robot, load(robot, "c")


def test_inverse_kinematics_reaches_poses_the_arm_can_reach(panda):
    """Targets made by the forward kinematics of random configurations, reached from qr to 1e-10
    (pose and position only); the answer's own pose is the target."""
    robot, f = panda
    rng = np.random.default_rng(0)
    lo, hi = robot.qlim.T
    for _ in range(5):
        q = robot.qr + rng.uniform(-0.4, 0.4, robot.n)
        target = f.frame_pose(np.clip(q, lo, hi))[0]
        ik = inverse_kinematics(f, robot, target, robot.qr)
        assert ik.converged and ik.error < 1e-10, ik
        assert np.abs(pose_error(target, f.frame_pose(ik.q)[0])).max() < 1e-10
        assert np.all(ik.q >= lo) and np.all(ik.q <= hi)
    only = inverse_kinematics(f, robot, target, np.clip(robot.qr + 0.3, lo, hi), axes=(True,) * 3 + (False,) * 3)
    assert only.converged and np.abs(f.frame_pose(only.q)[0][:3, 3] - target[:3, 3]).max() < 1e-10


def test_inverse_kinematics_moves_a_free_base_on_its_manifold():
    robot = random_tree_robot(4, n=3, base_joint="free").with_frames(["link3"])
    f = load(robot, "numpy")
    q = robot.integrate(robot.neutral(), np.r_[0.1, -0.2, 0.3, 0.4, -0.1, 0.2, 0.5, -0.3, 0.2])
    target = f.frame_pose(q)[0]
    ik = inverse_kinematics(f, robot, target, robot.neutral())
    assert ik.converged
    assert abs(np.linalg.norm(ik.q[3:7]) - 1) < 1e-12


def bad_poses():
    """(pose, what the error says): a sheared, a scaled and a reflected rotation, a wrong last
    row, NaN, the wrong shape."""
    sheared, scaled, mirrored, row, nan = (np.eye(4) for _ in range(5))
    sheared[0, 1] = 0.5
    scaled[:3, :3] *= 0.2
    mirrored[2, 2] = -1
    row[3] = (1, 2, 3, 4)
    nan[0, 3] = np.nan
    return [
        (sheared, "not orthonormal"),
        (scaled, "not orthonormal"),
        (mirrored, "reflection"),
        (row, r"last row .* \[0 0 0 1\]"),
        (nan, "NaN"),
        (np.eye(3), "4x4"),
    ]


def test_inverse_kinematics_refuses_bad_input(panda):
    """A target that is no pose would be read as another one (SciPy takes the nearest rotation) or
    never met: refused by name, as are an unknown frame and a q0 of the wrong size or not finite."""
    robot, f = panda
    for pose, why in bad_poses():
        with pytest.raises(ValueError, match=f"target.*{why}"):
            inverse_kinematics(f, robot, pose, robot.qr)
    with pytest.raises(ValueError, match="frame 3 out of range"):
        inverse_kinematics(f, robot, np.eye(4), robot.qr, frame=3)
    with pytest.raises(ValueError, match="serves no frame 'panda_hand'; it serves tool"):
        inverse_kinematics(f, robot, np.eye(4), robot.qr, frame="panda_hand")
    with pytest.raises(ValueError, match=r"q0 must have shape \(7,\)"):
        inverse_kinematics(f, robot, np.eye(4), robot.qr[:6])
    with pytest.raises(ValueError, match="q0 must be finite"):
        inverse_kinematics(f, robot, np.eye(4), robot.qr * np.nan)


def test_inverse_kinematics_and_the_controller_take_frames_by_name():
    robot = arms.load("panda").with_frames(["panda_link5", "panda_hand_tcp"])
    f = load(robot, "c")
    target = f.frame_pose(robot.qr + 0.1)[1]
    ik = inverse_kinematics(f, robot, target, robot.qr, frame="panda_hand_tcp")
    assert ik.converged and np.abs(pose_error(target, f.frame_pose(ik.q)[1])).max() < 1e-10
    path = lambda t: (target[:3, 3], np.zeros(3), np.zeros(3))  # noqa: E731
    assert OperationalSpaceController(f, robot, path, target[:3, :3], frame="panda_hand_tcp").frame == 1
    with pytest.raises(ValueError, match="R_goal.*not orthonormal"):
        OperationalSpaceController(f, robot, path, 2 * target[:3, :3], frame=1)


def test_operational_space_control_gives_the_commanded_task_acceleration_whatever_the_posture(panda):
    """With the exact model, the closed loop's task acceleration J q̈ + J̇ v equals a* exactly, the
    null-space posture term changing q̈ but not the task: the controller's Λ, J̄ and N are right."""
    robot, f = panda
    rng = np.random.default_rng(1)
    goal = f.frame_pose(robot.qr)[0]

    def path(t):
        return goal[:3, 3] + [0.05, 0.0, -0.02], np.array([0.1, 0.2, 0.0]), np.array([0.3, -0.1, 0.2])

    q, v = robot.qr + rng.uniform(-0.2, 0.2, 7), rng.uniform(-0.5, 0.5, 7)
    results = []
    for posture in (robot.qr, robot.qz):
        osc = OperationalSpaceController(f, robot, path, goal[:3, :3], posture=posture)
        qdd = f.fdyn(q, v, osc(0.0, q, v))
        J, drift = f.frame_jacobian_aligned(q)[0], f.frame_drift(q, v)[0]
        p, pd, pdd = path(0.0)
        target = np.r_[goal[:3, 3] * 0 + p, 0, 0, 0]
        T = f.frame_pose(q)[0]
        e = pose_error(np.block([[goal[:3, :3], target[:3, None]], [np.zeros((1, 3)), 1.0]]), T)
        a_star = np.r_[pdd, 0, 0, 0] + osc.Kv * (np.r_[pd, 0, 0, 0] - J @ v) + osc.Kp * e
        np.testing.assert_allclose(J @ qdd + drift, a_star, atol=1e-8 * np.abs(a_star).max())
        results.append(qdd)
    assert np.abs(results[0] - results[1]).max() > 1e-3  # the posture does move the joints


def test_the_panda_study_tracks_its_circle_to_a_micrometre(tmp_path):
    from symdyn.apps.studies.task_space import osc_panda

    text = osc_panda(tmp_path, quick=True)
    assert (tmp_path / "task_osc_panda.png").is_file()
    largest = float(text.split("largest position error ")[1].split(" mm")[0])
    assert largest < 0.01, text


@pytest.mark.slow
def test_the_panda_reaches_a_pose_around_a_sphere_its_links_clear(tmp_path):
    """The OCP on the generated CasADi frame_pose: IPOPT converges, the re-simulation (reference
    dynamics, interval by interval) passes, the end pose is the goal's and every ball clears."""
    pytest.importorskip("matplotlib", reason="the study draws its figure (the test extra)")
    from symdyn.apps.studies.task_space import ocp_panda_obstacle

    text = ocp_panda_obstacle(tmp_path, quick=True)
    assert "Solve_Succeeded" in text and "PASS" in text, text
    position = float(text.split("end pose of the re-simulation: position ")[1].split(" mm")[0])
    clear = float(text.split("smallest clearance along the re-simulated nodes ")[1].split(" mm")[0])
    line = float(text.split("the joint-space line to the IK answer: ")[1].split(" mm")[0])
    assert position < 5.0 and clear > -1.0 and line < 0, text  # the naive motion would hit the sphere
