"""The chapter's exercises (issue 16): each number a study's summary reports,
checked against an independent calculation on a short horizon."""

import functools
import math

import numpy as np
import pytest

from symdyn import cli
from symdyn.apps import air_puck as P
from symdyn.apps import analysis
from symdyn.apps import control as C
from symdyn.apps import exercises_arm as XA
from symdyn.apps import exercises_motor as XM
from symdyn.apps.studies import exercises_arm as SA
from symdyn.apps.studies import exercises_motor as SM
from symdyn.model import arms
from symdyn.numeric import backend
from symdyn.numeric import reference as ref

EXERCISES = (
    "ex-root-locus",
    "ex-voltage-motor",
    "ex-puma-joints",
    "ex-air-puck",
    "ex-ellipsoids",
    "ex-slow-feedforward",
    "ex-opspace-incline",
    "ex-sea",
)


def test_study_list_names_all_eight_exercises(capsys):
    assert cli.main(["study", "--list"]) == 0
    listed = {line.split()[0] for line in capsys.readouterr().out.splitlines() if line.strip()}
    assert set(EXERCISES) <= listed


# --------------------------------------------------------------------------- ex. 1b


def _max_pole(coefficients) -> float:
    return float(np.abs(np.roots(coefficients)).max())


def test_root_locus_max_gain_is_where_the_characteristic_roots_leave_the_unit_circle():
    drive = C.JointDrive(Tc=(0.0, 0.0))
    T = 1e-3
    a = math.exp(-drive.Bm * T / drive.J)
    b = drive.Km * (1 - a) / drive.Bm
    loop = XM.SampledVelocityLoop(drive, T)
    k_p = loop.max_gain()
    assert _max_pole([1, -a, 0.999 * k_p * b]) < 1 < _max_pole([1, -a, 1.001 * k_p * b])
    k_pi = loop.max_gain(10.0)

    def pi(K):  # (z-1)z(z-a) + b((Kv + Ki T)z - Kv)
        return [1, -(1 + a), a + b * (K + 10 * K * T), -b * K]

    assert _max_pole(pi(0.999 * k_pi)) < 1 < _max_pole(pi(1.001 * k_pi))


def test_simulated_velocity_loop_grows_per_sample_as_its_largest_pole():
    linear = C.JointDrive(Tc=(0.0, 0.0), tau_max=np.inf)
    loop = XM.SampledVelocityLoop(linear)
    for factor in (0.8, 1.2):
        tr = SM.velocity_step(linear, factor * loop.max_gain(), 0.04)
        rate = SM.decay_per_sample(tr.t, tr.qd[:, 0])
        assert rate == pytest.approx(math.sqrt(factor), rel=2e-3)  # |z|² = b·Kv = factor at the limit 1/b


# --------------------------------------------------------------------------- ex. 1c


def test_voltage_loop_bandwidth_matches_the_analytic_transfer_function():
    drive, L, R, Kv = C.JointDrive(), 1e-3, 1.6, 0.96
    Km = drive.Km
    # |H(jw)|² = c²/((a0 - a2 w²)² + a1² w²) = c²/(2 a0²): a quadratic in x = w²
    a2, a1, a0 = L * drive.J, L * drive.Bm + R * drive.J, R * drive.Bm + Km * Km + Kv * Km
    x = max(np.roots([a2**2, a1**2 - 2 * a0 * a2, -(a0**2)]).real)
    assert XM.bandwidth(*XM.VoltageDrive(drive, L, R).closed_loop(Kv)) == pytest.approx(math.sqrt(x), rel=1e-8)
    assert XM.bandwidth(*XM.current_loop(drive, 0.6)) == pytest.approx((drive.Bm + 0.6 * Km) / drive.J, rel=1e-8)
    assert XM.VoltageDrive(drive).damping == pytest.approx(drive.Bm + Km**2 / R)


# --------------------------------------------------------------------------- ex. 12


def test_sea_touches_an_unknown_object_and_settles_at_5_newtons():
    sea = C.SEA(obstacle=0.2, force_limit=10.0)
    tr, guard = SM.touch(sea, 5.0)
    assert guard.contact_time is not None and 1.0 < guard.contact_time < 2.5
    assert sea.spring_force(tr.q[-1]) == pytest.approx(5.0, abs=1e-4)
    assert float(sea.wall_force(tr.q[-1], tr.qd[-1])) == pytest.approx(
        -5.0, abs=1e-3
    )  # the load at rest: wall = -spring
    assert tr.q[-1, 1] == pytest.approx(0.2 + 5.0 / sea.wall_k, abs=1e-7)  # Hooke in the wall


def test_sea_frequency_response_peak_and_collision_rest_state():
    k, m, zeta = 5.0, 1.0, 0.05
    H = XM.sea_frequency_response(k, m, [math.sqrt(k / m)], zeta)[0]
    assert abs(H) == pytest.approx(math.sqrt(1 + 4 * zeta**2) / (2 * zeta), rel=1e-12)
    sea = C.SEA()
    K = sea.lqr()
    A, B = sea.matrices()
    E = np.array([0, 0, 0, 1 / sea.m_load])
    goal = np.array([1.0, 0, 1.0, 0])
    x = np.linalg.solve(A - B @ K[None, :], -B[:, 0] * (K @ goal) - E * -1.0)  # (A - BK)x + BKx* + E d = 0
    np.testing.assert_allclose(XM.collision_steady_state(sea, K, -1.0), x[[0, 2]], rtol=1e-12)


# --------------------------------------------------------------------------- ex. 1e


def test_puma_wrist_joint_alone_follows_the_single_joint_drive_model():
    """Joint 6 moving alone sees a constant inertia and no coupling: the arm run equals the one-joint
    motor model of control.JointDrive under control.VelocityLoop/PositionLoop."""
    tr, demand, (Kv, Ki, J), _ = SA.independent_joint_runs(T=0.3, horizon=0.3, joints=[5])
    puma = arms.load("puma560")
    link = puma.links[5]
    drive = C.JointDrive(Km=1.0, Jm=J[5], Bm=link.B, Tc=link.Tc, G=link.G, tau_max=np.inf, qd_max=np.inf, Jl=0.0)
    q0 = puma.qn[5]
    traj = functools.partial(C.quintic, 0.0, SA.JOINT_MOVE[5], 0.3)
    loop = C.PositionLoop(C.VelocityLoop(drive, Kv[5], Ki[5]), traj, 40.0, velocity_ff=True)
    one = C.simulate(drive.accel, loop, 0.3, [0.0], dt=1e-3, period=1e-3, delay=1)
    arm_error = demand[:, 1, 5] - tr.q[:, 1, 5]
    one_error = traj(one.t)[0][:, 0] - one.q[:, 0] / drive.G
    assert np.abs(arm_error).max() > 1e-5
    np.testing.assert_allclose(arm_error, one_error, atol=1e-3 * np.abs(one_error).max())
    assert q0 + SA.JOINT_MOVE[5] == pytest.approx(demand[-1, 1, 5])


# --------------------------------------------------------------------------- ex. 10


def test_ellipsoid_radii_are_the_singular_values_of_J_and_J_inv_M():
    puma = arms.load("puma560")
    q = np.array(SA.ELLIPSOID_POSES["qn"])
    J = ref.jacob0(puma, q)[:3]
    force = XA.force_ellipsoid(puma, q)
    np.testing.assert_allclose(force.radii, np.sort(1 / np.linalg.svd(J, compute_uv=False)), rtol=1e-10)
    acc = np.sort(np.linalg.svd(J @ np.linalg.inv(ref.inertia(puma, q)), compute_uv=False))
    np.testing.assert_allclose(analysis.acceleration_ellipsoid(puma, q).radii, acc, rtol=1e-8)
    assert XA.major_axis_angle([1, 0, 0], [-1, 1e-12, 0]) == pytest.approx(0, abs=1e-6)


# --------------------------------------------------------------------------- ex. 11b


def test_slow_feedforward_error_grows_as_the_update_period():
    tr, demand = SA.feedforward_runs(rates=(20, 10), T=0.5, horizon=0.5)
    worst = np.abs(demand[:, None, :] - tr.q).max(axis=(0, 2))
    assert worst[1] / worst[0] == pytest.approx(2.0, rel=0.1)
    puma = arms.load("puma560").nofriction()
    ff = C.TorqueFeedforward(
        backend.model(puma), functools.partial(C.quintic, puma.qz, puma.qr, 0.5), 0.0, 0.0, ff_period=0.1
    )
    held = ff(0.17, puma.qz, np.zeros(6))  # the model part sampled at t = 0.1 s
    np.testing.assert_allclose(held, ref.rne(puma, *C.quintic(puma.qz, puma.qr, 0.5, 0.1)), rtol=1e-9, atol=1e-9)


# --------------------------------------------------------------------------- ex. 11d


def test_incline_contact_settles_at_the_set_force_and_hookes_depth():
    surface = XA.InclinedSurface(point=(0.6, -0.15, -0.06), slope=math.radians(10.0))
    tr, poses, W, surface, _ = SA.incline_scene(1.5, dt=5e-3, start=10.0, surface=surface)
    p = poses[-1, :3, 3]
    assert W[-1, 2] == pytest.approx(-5.0, rel=0.02)
    n = surface.normal
    depth = (np.asarray(surface.point) - p) @ n
    assert depth == pytest.approx(-W[-1, 2] / (surface.k * n[2]), rel=1e-9)  # force along the normal, Hooke
    np.testing.assert_allclose(W[-1, :3] / np.linalg.norm(W[-1, :3]), -n, atol=1e-12)


# --------------------------------------------------------------------------- ex. 9


def test_air_puck_conserves_momentum_and_keeps_its_centre_of_mass():
    robot = P.puck_robot()
    model = backend.model(robot, "casadi")
    start = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])
    traj = functools.partial(C.quintic, start, start + np.array([1.0, 0.3, -0.5, 0, 0, 0]), 0.3)
    tr = C.simulate(
        lambda t, q, qd, tau: model.fdyn(q, qd, tau),
        P.PassiveBase(model, traj),
        0.3,
        np.concatenate([np.zeros(3), start]),
        dt=3e-3,
    )
    assert np.abs(tr.tau[:, :3]).max() == 0 and np.abs(tr.q[-1, :3]).max() > 1e-3  # passive base, yet it moves
    M = ref.inertia(robot, tr.q)
    arm_share = np.abs(np.einsum("kij,kj->ki", M[:, :3, 3:], tr.qd[:, 3:])).max()  # what the base must cancel
    mom = P.momentum(M, tr.q, tr.qd)
    assert arm_share > 1.0 and np.abs(mom).max() < 1e-6 * arm_share  # RK4 error only
    com = P.centre_of_mass(robot, tr.q)
    assert np.ptp(com[:, :2], axis=0).max() < 1e-8 < np.abs(tr.q[:, :2]).max() * 1e-3
    # the base velocity at zero momentum, from the arm's: the planner's kinematics
    np.testing.assert_allclose(P.base_rate(model, tr.q[-5], tr.qd[-5, 3:]), tr.qd[-5, :3], rtol=1e-5)
