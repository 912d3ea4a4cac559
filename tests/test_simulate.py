"""Forward-dynamics simulation: energy bookkeeping, integrator agreement, smoothed Coulomb friction."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import simpson

from symdyn.apps import simulate as S
from symdyn.numeric import reference as ref


def kinetic(robot, traj):
    return ref.energy(robot, traj.q, traj.qd)[0]


def test_frictionless_collapse_conserves_energy(puma):
    robot = puma.nofriction(all=True)
    traj = S.simulate(robot, 0.3, robot.qz, integrator=S.Adaptive(rtol=1e-10, atol=1e-10))
    E = S.total_energy(robot, traj)
    K = kinetic(robot, traj)
    assert K.max() > 5  # the arm really falls: joules change form
    assert np.abs(E - E[0]).max() <= 1e-6 * K.max()


def test_viscous_collapse_loses_exactly_the_friction_work(puma):
    robot = puma.nofriction()  # viscous friction only
    traj = S.simulate(robot, 0.3, robot.qz, integrator=S.Adaptive(rtol=1e-10, atol=1e-10, sample=1e-3))
    E = S.total_energy(robot, traj)
    assert np.all(np.diff(E) <= 1e-9 * np.abs(E).max())  # monotone (to integration noise)
    power = np.einsum("ni,ni->n", traj.qd, ref.friction(robot, traj.qd))
    dissipated = simpson(power, x=traj.t)
    assert dissipated > 1.0
    assert E[0] - E[-1] == pytest.approx(dissipated, rel=1e-6)


def test_fixed_step_rk4_agrees_with_adaptive(puma):
    robot = puma.nofriction()
    dt = 1e-2
    fixed = S.simulate(robot, 0.2, robot.qz, integrator=S.RK4(dt=dt))
    adaptive = S.simulate(robot, 0.2, robot.qz, integrator=S.Adaptive(rtol=1e-10, atol=1e-10, sample=dt))
    np.testing.assert_allclose(fixed.t, adaptive.t, atol=1e-12)
    assert np.abs(fixed.q - adaptive.q).max() < 1e-7
    assert np.abs(fixed.q[-1] - robot.qz).max() > 0.1  # and the motion is not trivial


@pytest.mark.parametrize("robot_name", ["puma560", "pendulum"])
def test_generated_or_casadi_right_hand_side_agrees_with_the_reference(puma, twolink, robot_name):
    robot = puma if robot_name == "puma560" else sticky_pendulum(twolink, level=1.0)
    q0 = robot.qz if robot_name == "puma560" else np.array([0.3])
    fast = S.simulate(robot, 0.05, q0, integrator=S.RK4(dt=5e-3))
    slow = S.simulate(robot, 0.05, q0, integrator=S.RK4(dt=5e-3), backend="reference")
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.qd, slow.qd, rtol=0, atol=1e-10)
    assert np.abs(fast.q[-1] - q0).max() > 1e-3  # and the arm moved


def test_rk4_converges_at_fourth_order(twolink):
    robot = twolink
    q0 = np.array([0.2, 0.4])
    exact = S.simulate(robot, 0.3, q0, integrator=S.Adaptive(rtol=1e-12, atol=1e-12))
    errors = [
        np.abs(S.simulate(robot, 0.3, q0, integrator=S.RK4(dt)).q[-1] - exact.q[-1]).max() for dt in (0.03, 0.015)
    ]
    assert 12 < errors[0] / errors[1] < 20  # 2⁴ = 16


def test_gravity_compensation_holds_the_arm_still(puma):
    robot = puma.nofriction(all=True)
    q0 = np.array([0.1, 0.6, -0.8, 0.2, 0.5, 0.3])
    traj = S.simulate(robot, 0.2, q0, torque=lambda t, q, qd: ref.gravload(robot, q), integrator=S.RK4(dt=0.05))
    assert np.abs(traj.q - q0).max() < 1e-12


def test_smooth_friction_matches_the_exact_law_away_from_rest(puma):
    qd = np.array([[1.0, -0.5, 0.3, -2.0, 0.8, -1.5], [0.0] * 6])
    exact = ref.friction(puma, qd)
    smooth = S.smooth_friction(puma, qd, width=1e-3)
    np.testing.assert_allclose(smooth[0], exact[0], rtol=1e-12)
    np.testing.assert_array_equal(smooth[1], 0.0)
    np.testing.assert_array_equal(S.smooth_friction(puma, qd, width=0), exact)
    # at |q̇| = width: viscous + tanh(1) of the Coulomb level
    link = puma.links[1]
    w = 0.01
    value = S.smooth_friction(puma, np.array([0, w, 0, 0, 0, 0]), width=w)[1]
    assert value == pytest.approx(link.G**2 * link.B * w + abs(link.G) * link.Tc[0] * np.tanh(1.0), rel=1e-12)


def sticky_pendulum(twolink, level=10.0):
    """Link 1 of the two-link arm alone (1 kg at 0.5 m, I_zz = 0.75 kg·m² about the COM, so M = 1 kg·m²)
    with a unit gear ratio and Coulomb friction `level` N·m above its largest gravity load (4.9 N·m)."""
    link = dataclasses.replace(
        twolink.links[0], I=((0.375, 0, 0), (0, 0.375, 0), (0, 0, 0.75)), G=1, Tc=(level, -level)
    )
    return dataclasses.replace(twolink, name="pendulum", links=(link,), poses={})


def test_coulomb_friction_holds_a_pendulum_to_a_creep_of_width_times_atanh(twolink):
    robot, width, level = sticky_pendulum(twolink), 0.05, 10.0
    q0 = np.array([0.3])
    fixed = S.simulate(robot, 0.1, q0, integrator=S.RK4(dt=2e-3), coulomb_width=width)
    adaptive = S.simulate(
        robot, 0.1, q0, integrator=S.Adaptive(rtol=1e-10, atol=1e-10, sample=2e-3), coulomb_width=width
    )
    assert np.abs(fixed.q - adaptive.q).max() < 1e-7
    # quasi-static: tanh(|q̇|/w)·Tc balances the gravity load, so q̇ = −w·atanh(G(q)/Tc)
    creep = -width * np.arctanh(ref.gravload(robot, fixed.q[-1]) / level)
    np.testing.assert_allclose(fixed.qd[-1], creep, rtol=1e-2)
    free = S.simulate(robot.nofriction(), 0.1, q0, integrator=S.RK4(dt=1e-2))
    assert np.abs(free.qd[-1]).max() > 10 * np.abs(creep).max()


def test_progress_reports_every_tenth(puma, capsys):
    S.simulate(puma.nofriction(), 0.05, puma.qz, integrator=S.RK4(dt=0.01), progress=S.StderrProgress("fall"))
    lines = capsys.readouterr().err.strip().splitlines()
    assert [line.split()[1] for line in lines[:10]] == [f"{k}/10" for k in range(1, 11)]
    assert lines[-1].startswith("fall: done in")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"T": -1.0}, "positive finite time"),
        ({"q0": np.zeros(5)}, "shape"),
        ({"integrator": S.RK4(dt=2.0)}, "RK4 step"),
        ({"coulomb_width": -0.1}, "width"),
        ({"integrator": "euler"}, "integrator"),
        ({"backend": "matlab"}, "unknown backend"),
    ],
)
def test_simulate_names_bad_arguments(twolink, kwargs, message):
    args = {"T": 1.0, "q0": np.zeros(2)} | kwargs
    with pytest.raises(ValueError, match=message):
        S.simulate(twolink, args.pop("T"), args.pop("q0"), **args)


@pytest.mark.parametrize("name", ["collapse", "integrators"])
def test_simulation_study_writes_its_figures_and_summary(name, tmp_path):
    from symdyn.apps.studies import registry, simulation

    assert registry()[name][1] is simulation.STUDIES[name][1]
    text = simulation.STUDIES[name][1](tmp_path, quick=True)
    figures = sorted(tmp_path.glob("sim_*.png"))
    assert figures and all(f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for f in figures)
    assert (tmp_path / "summary.txt").read_text() == text + "\n"
    if name == "integrators":
        order = float(text.split("observed order ")[1].split()[0])
        assert 3.5 < order < 4.5
