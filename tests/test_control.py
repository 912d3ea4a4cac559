"""Controllers of chapter 9: trajectories, the simulator, the model adapter and each controller's promise."""

import dataclasses
import functools

import numpy as np
import pytest

from symdyn import models
from symdyn.apps import control as C
from symdyn.apps.studies import control as S
from symdyn.apps.studies import registry
from symdyn.numeric import backend as B
from symdyn.numeric import reference as ref

from conftest import random_states


# --------------------------------------------------------------------------- trajectories


def test_lspb_reaches_goal_at_the_toolbox_cruise_speed():
    t = np.linspace(0, 1, 2001)
    q, qd, qdd = C.lspb(0.0, 0.5, 1.0, t)
    assert q[0, 0] == 0.0 and q[-1, 0] == pytest.approx(0.5, abs=1e-15)
    assert qd[1000, 0] == pytest.approx(1.5 * 0.5 / 1.0)  # Corke's default V
    assert np.allclose(np.gradient(q[:, 0], t), qd[:, 0], atol=1e-3)
    assert np.allclose(np.gradient(qd[:, 0], t)[5:-5], qdd[5:-5, 0], atol=1.2)  # jumps at the blend corners only
    assert abs(np.gradient(qd[:, 0], t)[5:-5] - qdd[5:-5, 0]).mean() < 0.01


def test_lspb_rejects_a_cruise_speed_that_cannot_reach_the_goal():
    with pytest.raises(ValueError, match="cruise speed"):
        C.lspb(0.0, 1.0, 1.0, 0.5, V=0.9)


def test_quintic_has_zero_boundary_velocity_and_acceleration_and_consistent_derivatives():
    q0, q1 = np.zeros(6), np.array([0, np.pi / 2, -np.pi / 2, 0, 0, 0])
    t = np.linspace(0, 2, 4001)
    q, qd, qdd = C.quintic(q0, q1, 2.0, t)
    assert np.allclose(q[0], q0) and np.allclose(q[-1], q1)
    assert np.allclose(qd[[0, -1]], 0) and np.allclose(qdd[[0, -1]], 0)
    assert np.allclose(np.gradient(q, t, axis=0)[1:-1], qd[1:-1], atol=1e-5)  # central differences
    assert np.allclose(np.gradient(qd, t, axis=0)[1:-1], qdd[1:-1], atol=1e-5)
    assert np.allclose(C.quintic(q0, q1, 2.0, 3.0)[0], q1)  # held after T


# --------------------------------------------------------------------------- simulator


def test_rk4_is_fourth_order_on_an_oscillator():
    w = 2.0
    accel = lambda t, q, qd, tau: -(w**2) * q  # noqa: E731
    zero = lambda t, q, qd: np.zeros_like(q)  # noqa: E731
    errs = [abs(C.simulate(accel, zero, 2.0, [1.0], dt=dt).q[-1, 0] - np.cos(w * 2.0)) for dt in (0.02, 0.01)]
    assert 14 < errs[0] / errs[1] < 18


def test_sampled_controller_is_held_and_applied_after_the_delay():
    accel = lambda t, q, qd, tau: tau  # noqa: E731
    clock = lambda t, q, qd: np.full_like(q, t)  # noqa: E731 (output = its own sample time)
    tr = C.simulate(accel, clock, 0.05, [0.0], dt=1e-3, period=5e-3, delay=2)
    k = np.arange(50)
    expected = np.where(k // 5 >= 2, (k // 5 - 2) * 5e-3, 0.0)
    assert np.allclose(tr.tau[:50, 0], expected)


def test_simulate_rejects_a_period_that_is_not_a_whole_number_of_steps():
    with pytest.raises(ValueError, match="whole number of steps"):
        C.simulate(lambda *a: 0.0, lambda *a: 0.0, 0.01, [0.0], dt=1e-3, period=1.5e-3)


# --------------------------------------------------------------------------- model adapter


@pytest.fixture(scope="module")
def puma_nf():
    return models.load("puma560").nofriction()


@pytest.fixture(scope="module")
def fast(puma_nf):
    return B.model(puma_nf)


@pytest.mark.parametrize("backend", ["reference", "casadi", "auto"])
@pytest.mark.parametrize("friction", ["full", "viscous only"])
def test_model_adapter_agrees_with_the_reference(backend, friction):
    puma = models.load("puma560") if friction == "full" else models.load("puma560").nofriction()
    m = B.model(puma, backend)
    q, qd, qdd = random_states(puma, 20, seed=3)
    tau = ref.rne(puma, q, qd, qdd)
    assert np.allclose(m.tau(q, qd, qdd), tau, rtol=0, atol=1e-10)
    assert np.allclose(m.fdyn(q, qd, tau), qdd, rtol=0, atol=1e-8)
    assert np.allclose(m.M(q), ref.inertia(puma, q), rtol=0, atol=1e-12)
    assert np.allclose(m.Cqd(q, qd) + m.G(q) + m.F(qd), ref.rne(puma, q, qd, 0 * qdd), rtol=0, atol=1e-10)
    assert m.M(q[0]).shape == (6, 6) and m.tau(q[0], qd[0], qdd[0]).shape == (6,)


def test_auto_model_uses_generated_code_if_shipped_else_the_fallback(twolink):
    assert B.model(models.load("puma560").nofriction()).source.startswith("generated c (puma560)")
    moon = dataclasses.replace(twolink, gravity=(0.0, 0.0, 1.62))
    assert B.model(moon, fallback="reference").source.startswith("symdyn.reference")
    assert B.model(moon).source.startswith("plain CasADi RNEA")
    assert B.model(moon) is B.model(moon)  # built once
    q = np.array([0.3, -0.7])
    assert np.allclose(B.model(moon).G(q), ref.gravload(moon, q), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, message",
    [({"backend": "fortran"}, "unknown backend 'fortran'"), ({"fallback": "c"}, "unknown fallback 'c'")],
)
def test_model_names_a_bad_backend(twolink, kwargs, message):
    with pytest.raises(ValueError, match=message):
        B.model(twolink, **kwargs)


def test_refriction_swaps_the_friction_and_nothing_else(puma):
    target = puma.nofriction()
    m = B.refriction(B.model(puma, "reference"), target)
    q, qd, qdd = random_states(puma, 5, seed=4)
    tau = ref.rne(target, q, qd, qdd)
    assert np.allclose(m.tau(q, qd, qdd), tau, atol=1e-10)
    assert np.allclose(m.fdyn(q, qd, tau), qdd, atol=1e-8)
    assert np.allclose(m.F(qd), ref.friction(target, qd)) and not np.allclose(m.F(qd), ref.friction(puma, qd))


def test_scaled_model_equals_the_model_of_the_scaled_robot(puma):
    base = B.model(puma, "reference")
    q, qd, qdd = random_states(puma, 2, seed=5)
    both = C.scaled(base, puma, np.array([1.1, 0.9]))  # one factor per row
    for row, f in enumerate((1.1, 0.9)):
        robot = C.scale_inertia(puma, f)
        tau = ref.rne(robot, q[row], qd[row], qdd[row])
        assert np.allclose(both.tau(q, qd, qdd)[row], tau, atol=1e-10)
        assert np.allclose(both.M(q)[row], ref.inertia(robot, q[row]), atol=1e-12)
        assert np.allclose(both.G(q)[row], ref.gravload(robot, q[row]), atol=1e-10)
        assert np.allclose(both.fdyn(q, qd, tau[None].repeat(2, 0))[row], qdd[row], atol=1e-8)
    assert not np.allclose(ref.gravload(C.scale_inertia(puma, 1.1), puma.qz), ref.gravload(puma, puma.qz))


# --------------------------------------------------------------------------- independent joint control

DEMAND = S.speed_demand(S.SPEED)


def _steady(trace):
    return S._plateau(trace, DEMAND, 1.2, 1.3)


def test_p_velocity_loop_keeps_the_error_of_the_formula_and_pi_removes_it():
    drive = C.JointDrive(tau_load=20.0)
    p = _steady(S.run_velocity_loop(drive, DEMAND, 1.3, Kv=0.6))
    pi = _steady(S.run_velocity_loop(drive, DEMAND, 1.3, Kv=1.0, Ki=10.0))
    # (Bm·50 + Tc⁺ + 20/G)/(Km·0.6 + Bm) = 2.5604 rad/s
    assert p == pytest.approx((817e-6 * 50 + 0.126 + 20 / 107.815) / (0.228 * 0.6 + 817e-6), rel=1e-3)
    assert p > 2.5 and abs(pi) < 1e-3


def test_torque_feedforward_cancels_the_loads_share_of_the_p_error():
    loaded = C.JointDrive(tau_load=20.0)
    with_ff = _steady(S.run_velocity_loop(loaded, DEMAND, 1.3, Kv=0.6, tau_ff=20.0 / loaded.G))
    no_load = _steady(S.run_velocity_loop(C.JointDrive(), DEMAND, 1.3, Kv=0.6))
    assert with_ff == pytest.approx(no_load, abs=1e-6)
    assert with_ff == pytest.approx((817e-6 * 50 + 0.126) / (0.228 * 0.6 + 817e-6), rel=1e-3)  # 1.2124 rad/s


def test_clamping_anti_windup_removes_the_overshoot_of_a_saturated_pi_loop():
    drive = C.JointDrive(tau_load=20.0)
    demand = S.speed_demand(S.STEEP)
    runs = [S.run_velocity_loop(drive, demand, 0.4, Kv=1.0, Ki=10.0, antiwindup=aw) for aw in (False, True)]
    assert np.abs(runs[0].tau).max() == pytest.approx(drive.tau_max)  # the drive saturates
    plain, clamped = (tr.qd[:, 0].max() - 100.0 for tr in runs)
    assert plain > 30.0 and clamped < 0.5  # measured 35.4 and -0.02 rad/s


def test_larger_link_inertia_raises_the_p_ramp_error_by_dJ_alpha():
    errors = [
        S._plateau(S.run_velocity_loop(C.JointDrive(Jl=Jl, tau_load=20.0), DEMAND, 0.3, Kv=0.6), DEMAND, 0.2, 0.3)
        for Jl in (3.66, 5.21)
    ]
    dJ = (5.21 - 3.66) / 107.815**2
    assert errors[1] - errors[0] == pytest.approx(dJ * 250.0 / (0.228 * 0.6 + 817e-6), rel=0.01)


def test_velocity_feedforward_reduces_the_position_tracking_error():
    drive = C.JointDrive(tau_load=20.0)
    traj = functools.partial(C.lspb, 0.0, 0.5, 1.0)
    worst = []
    for ff in (False, True):
        loop = C.PositionLoop(C.VelocityLoop(drive, 1.0, 10.0, period=1e-3), traj, 40.0, velocity_ff=ff)
        tr = C.simulate(drive.accel, loop, 1.0, [0.0], dt=1e-3, period=1e-3, delay=1)
        worst.append(np.abs(traj(tr.t)[0][:, 0] - tr.q[:, 0] / drive.G).max())
    assert worst[0] > 0.015 and worst[1] < 1e-3  # measured 18.7 and 0.30 mrad
    assert worst[0] / worst[1] > 20


# --------------------------------------------------------------------------- whole-arm control


def test_computed_torque_with_exact_model_has_decoupled_error_dynamics(puma_nf, fast):
    wn = 10.0
    traj = functools.partial(C.quintic, puma_nf.qz, puma_nf.qr, 1.0)
    e0 = 0.01
    q0 = np.stack([puma_nf.qz, puma_nf.qz + np.array([0, e0, 0, 0, 0, 0])])
    ct = C.ComputedTorque(fast, traj, wn**2, 2 * wn)
    tr = C.simulate(lambda t, q, qd, tau: fast.fdyn(q, qd, tau), ct, 0.6, q0, dt=2e-3)
    err = traj(tr.t)[0][:, None, :] - tr.q
    assert np.abs(err[:, 0]).max() < 1e-6  # integration noise (measured ~1e-10)
    analytic = -e0 * (1 + wn * tr.t) * np.exp(-wn * tr.t)  # ë + 2ωė + ω²e = 0
    assert np.allclose(err[:, 1, 1], analytic, atol=1e-6)
    assert np.abs(err[:, 1, [0, 2, 3, 4, 5]]).max() < 1e-6  # the other joints do not notice


def test_feedforward_and_computed_torque_errors_stay_bounded_with_perturbed_models(puma_nf, fast):
    wn = 10.0
    traj = functools.partial(C.quintic, puma_nf.qz, puma_nf.qr, 1.0)
    cm = C.scaled(fast, puma_nf, np.array([1.0, 1.1, 0.9]))
    Mqz = np.diag(ref.inertia(puma_nf, puma_nf.qz))
    ff = C.TorqueFeedforward(cm, traj, Mqz * wn**2, Mqz * 2 * wn, ff_period=0.05)
    ct = C.ComputedTorque(cm, traj, wn**2, 2 * wn)
    both = lambda t, q, qd: np.concatenate([ff(t, q[:3], qd[:3]), ct(t, q[3:], qd[3:])])  # noqa: E731
    tr = C.simulate(
        lambda t, q, qd, tau: fast.fdyn(q, qd, tau), both, 1.2, np.tile(puma_nf.qz, (6, 1)), dt=2e-3, period=2e-3
    )
    worst = np.abs(traj(tr.t)[0][:, None, :] - tr.q).max(axis=(0, 2))  # per run
    ff_exact, ff_plus, ff_minus, ct_exact, ct_plus, ct_minus = worst
    assert worst.max() < 0.03  # bound: 30 mrad for ±10 %
    assert ct_exact < 1e-3 and min(ct_plus, ct_minus) > 10 * ct_exact  # the model error dominates
    assert ff_exact < min(ff_plus, ff_minus)


def test_operational_space_control_presses_with_the_force_set_point():
    tr, poses, W, goal = S.run_opspace(1.2, dt=1e-2)
    assert W[:, 2].min() < -4.0 and W[0, 2] == 0.0  # starts free, makes contact
    assert W[-1, 2] == pytest.approx(-5.0, abs=0.05)  # force set-point within 0.05 N
    assert poses[-1, 2, 3] == pytest.approx(-0.25, abs=5e-4)  # 5 cm into the 100 N/m surface
    assert abs(poses[-1, 1, 3] - goal[1, 3]) < 2e-3  # y held
    tilt = np.abs(poses[:, :3, :3] - goal[:3, :3]).max(axis=(1, 2))
    assert tilt[-1] < 0.05 and tilt[-1] < 0.5 * tilt.max()  # orientation held, recovering


# --------------------------------------------------------------------------- series-elastic actuator


def test_sea_lqr_gain_solves_the_riccati_equation_and_stabilises():
    act = C.SEA()
    A, B = act.matrices()
    K = act.lqr()
    assert np.all(np.linalg.eigvals(A - B @ K[None]).real < 0)
    Q, R = np.diag([100.0, 10.0, 100.0, 10.0]), 0.01
    # K = R⁻¹BᵀP with P from the CARE: check the residual via P recovered from the Lyapunov form
    from scipy.linalg import solve_continuous_lyapunov

    Acl = A - B @ K[None]
    P = solve_continuous_lyapunov(Acl.T, -(Q + R * np.outer(K, K)))
    assert np.allclose(B.T @ P / R, K[None], rtol=1e-8)


def test_sea_step_reaches_the_goal_without_obstacle():
    act = C.SEA()
    tr = C.simulate(act.accel, act.controller(act.lqr()), 8.0, [0.0, 0.0], dt=5e-3)
    assert tr.q[-1, 1] == pytest.approx(1.0, abs=5e-3)
    assert np.abs(tr.tau[:, 0]).max() <= act.force_limit


def test_sea_obstacle_stops_the_load_and_bounds_the_spring_force():
    act = C.SEA(obstacle=0.8)
    K = act.lqr()
    tr = C.simulate(act.accel, act.controller(K), 5.0, [0.0, 0.0], dt=2e-3)
    fs = act.spring_force(tr.q)
    assert tr.q[:, 1].max() < 0.8 + 2e-3  # the wall stops the load
    assert tr.q[-1, 1] == pytest.approx(0.8, abs=1e-4)
    # at rest against the wall: K1(1 - x_m) + 0.2 K3 = k(x_m - 0.8)
    x_m = (K[0] + 0.2 * K[2] + 0.8 * act.k) / (K[0] + act.k)
    assert fs[-1] == pytest.approx(act.k * (x_m - 0.8), abs=1e-3)  # 0.840 N
    assert np.abs(fs).max() < 2.5


# --------------------------------------------------------------------------- studies


def test_control_studies_are_registered_and_write_figures(tmp_path):
    names = {n for n in registry() if n.startswith("control-")}
    assert names == set(S.STUDIES)
    text = S.windup(tmp_path)
    assert (tmp_path / "control_windup.png").stat().st_size > 1000
    assert "overshoot" in (tmp_path / "summary.txt").read_text() and text
