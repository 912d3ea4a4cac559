"""Optimal control on CasADi dynamics: small instances of each study, re-simulated
open-loop with the reference; transcriptions agree; infeasible requests fail clearly."""

import dataclasses

import numpy as np
import pytest

from symdyn import models
from symdyn.apps import ocp
from symdyn.apps.ocp import transcription
from symdyn.apps.studies import ocp as S
from symdyn.numeric import reference as ref

HANG, UP = np.array(S.TWOLINK_HANG), np.array(S.TWOLINK_UP)


@pytest.fixture(scope="module")
def arm2():
    return models.load("twolink")


@pytest.fixture(scope="module")
def puma_nc():
    return S.puma()


# --------------------------------------------------------------------------- problem set-up


def test_motor_torque_limits_are_motor_limits_times_gear_ratio(puma):
    lim = ocp.motor_torque_limits(puma, [1, 2, 3, 4, 5, 6])
    G = [-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686]
    assert np.allclose(lim, np.abs(G) * np.arange(1, 7), rtol=1e-12)
    with pytest.raises(ValueError, match="6 positive numbers"):
        ocp.motor_torque_limits(puma, [1, 2])


def test_urdf_effort_and_velocity_limits_are_the_default_limits():
    panda = models.load("panda")
    lim = ocp.Limits.for_robot(panda)
    assert lim.tau.tolist() == [87, 87, 87, 87, 12, 12, 12]  # <limit effort> of panda.urdf
    assert lim.qd.tolist() == [2.175] * 4 + [2.61] * 3  # <limit velocity>
    assert np.array_equal(lim.q, panda.qlim)
    assert ocp.Limits.for_robot(panda.nofriction()).tau.tolist() == lim.tau.tolist()
    # explicit limits still win, each on its own
    mine = ocp.Limits.for_robot(panda, tau=np.full(7, 5.0))
    assert mine.tau.tolist() == [5.0] * 7 and mine.qd.tolist() == lim.qd.tolist()
    assert ocp.Limits.for_robot(panda, qd=np.ones(7)).qd.tolist() == [1.0] * 7
    motor = ocp.Limits.for_robot(panda, motor_tau=np.full(7, 2.0))
    assert np.allclose(motor.tau, 2.0 * np.abs([float(link.G) for link in panda.links]))


def test_a_dh_model_without_effort_or_velocity_limits_keeps_them_unbounded(puma):
    lim = ocp.Limits.for_robot(puma)
    assert lim.tau is None and lim.qd is None and np.array_equal(lim.q, puma.qlim)
    assert S.puma_limits(S.puma()).tau == pytest.approx(
        np.array(S.PUMA_MOTOR_TAU) * np.abs([float(link.G) for link in puma.links]), rel=1e-12
    )


def test_joints_without_a_urdf_limit_are_unbounded_where_others_have_one(arm2):
    import dataclasses

    links = (dataclasses.replace(arm2.links[0], effort_limit=30.0), arm2.links[1])
    lim = ocp.Limits.for_robot(dataclasses.replace(arm2, links=links))
    assert lim.tau.tolist() == [30.0, np.inf] and lim.qd is None


@pytest.mark.parametrize("method", ocp.METHODS)
def test_an_infinite_limit_leaves_that_joint_unbounded(arm2, method):
    bounded = ocp.Limits(tau=np.array([30.0, 10.0]), qd=np.array([3.0, 3.0]))
    open_tau = ocp.Limits(tau=np.array([30.0, np.inf]), qd=np.array([3.0, 3.0]))
    arm = ocp.dynamics(arm2, "plain", compiled=False)
    T = {}
    for name, lim in (("bounded", bounded), ("open", open_tau)):
        problem = ocp.Problem(
            HANG, np.array([0.0, 0.5]), N=20, method=method, limits=lim, cost=ocp.Cost(time=1.0, smoothness=1e-6)
        )
        sol = ocp.solve(problem, arm)
        tol = dict(tol_q=0.1, tol_qd=0.2) if method == "trapezoidal" else {}
        check = ocp.verify(arm2, problem, sol, **tol)
        assert check.ok, (name, check.describe())  # the dynamics still hold on the free joint
        T[name] = sol.T
    assert np.abs(sol.tau[:, 1]).max() > 10.0  # the elbow uses more than the old limit
    assert T["open"] < T["bounded"]


def test_minimum_time_without_torque_or_speed_limits_is_refused(arm2):
    q0, qf = HANG, np.array([0.0, 0.5])
    min_time = ocp.Cost(time=1.0)
    for lim in (
        ocp.Limits(),
        ocp.Limits.for_robot(arm2),
        ocp.Limits(q=arm2.qlim),
        ocp.Limits(tau=np.full(2, np.inf), qd=np.full(2, np.inf)),
    ):
        with pytest.raises(
            ValueError,
            match=r"minimum-time problem has no torque or speed limit.*"
            r"Limits\(tau=.*Limits\.for_robot\(robot, tau=.*effort",
        ):
            ocp.Problem(q0, qf, T=None, cost=min_time, limits=lim)
    ocp.Problem(q0, qf, T=None, cost=min_time, limits=ocp.Limits(qd=np.array([3.0, np.inf])))
    ocp.Problem(q0, qf, T=1.0, cost=ocp.Cost(effort=1.0))  # a fixed time needs no limit


def test_bad_problems_are_refused_by_name():
    q = np.zeros(2)
    with pytest.raises(ValueError, match="unknown transcription 'euler'"):
        ocp.Problem(q, q, T=1.0, method="euler")
    with pytest.raises(ValueError, match="N must be"):
        ocp.Problem(q, q, T=1.0, N=1)
    with pytest.raises(ValueError, match="qf must have shape"):
        ocp.Problem(q, np.zeros(3), T=1.0)
    with pytest.raises(ValueError, match="unknown dynamics source"):
        ocp.dynamics(models.load("twolink"), "numpy")


def test_free_final_time_needs_a_time_cost_and_limits_must_fit_the_arm():
    q = np.zeros(2)
    with pytest.raises(ValueError, match="free final time"):
        ocp.Problem(q, q, T=None, cost=ocp.Cost(effort=1.0))
    with pytest.raises(ValueError, match="tau limits must be 2 positive numbers"):
        ocp.Problem(q, q, T=1.0, limits=ocp.Limits(tau=np.array([1.0, 0.0])))
    with pytest.raises(ValueError, match=r"joint limits must have shape \(2, 2\)"):
        ocp.Problem(q, q, T=1.0, limits=ocp.Limits(q=np.zeros((3, 2))))


def test_nan_limits_non_finite_boundary_states_and_bad_cost_weights_are_refused_by_name(puma):
    """NaN compares false with everything, so a NaN limit bounded nothing and reached IPOPT;
    inf stays legitimate (that joint unbounded)."""
    with pytest.raises(ValueError, match=r"6 positive numbers, got \[1, 2, 3, nan, 5, 6\]: joint 4 has nan"):
        ocp.motor_torque_limits(puma, [1, 2, 3, np.nan, 5, 6])
    with pytest.raises(ValueError, match=r"Limits.qd of joint 2 is NaN"):
        ocp.Limits(qd=np.array([3.0, np.nan]))
    with pytest.raises(ValueError, match=r"Limits.tau of joint 1 is NaN"):
        ocp.Limits(tau=[np.nan, 1.0])
    with pytest.raises(ValueError, match=r"Limits.q of joint 2 is NaN"):
        ocp.Limits(q=np.array([[-1.0, 1.0], [np.nan, 1.0]]))
    assert np.array_equal(ocp.Limits(tau=[np.inf, 2.0]).tau, [np.inf, 2.0])
    for field, value in (("time", np.nan), ("effort", -1.0), ("smoothness", np.inf)):
        with pytest.raises(ValueError, match=rf"the cost weight {field} must be a finite number ≥ 0, got {value}"):
            ocp.Cost(**{field: value})
    with pytest.raises(ValueError, match=r"joint 2 has -2.0 in \(1.0, -2.0\)"):
        ocp.Cost(effort=1.0, weights=(1.0, -2.0))
    q = np.zeros(2)
    with pytest.raises(
        ValueError, match=r"the cost weights must be 2 numbers \(one per joint\), got \(1.0, 1.0, 1.0\)"
    ):
        ocp.Problem(q, q, T=1.0, cost=ocp.Cost(effort=1.0, weights=(1.0, 1.0, 1.0)))
    with pytest.raises(ValueError, match=r"q0 must be finite: joint 2 has nan"):
        ocp.Problem(np.array([0.0, np.nan]), q, T=1.0)
    with pytest.raises(ValueError, match=r"qf must be finite: joint 1 has inf"):
        ocp.Problem(q, np.array([np.inf, 0.0]), T=1.0)


def test_limit_violation_refuses_a_solution_of_another_arm():
    problem = ocp.Problem(np.zeros(2), np.zeros(2), T=1.0, limits=ocp.Limits(tau=np.array([1.0, 1.0])))
    t = np.linspace(0, 1, 3)
    three = ocp.Solution("trapezoidal", t, np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)), 0.0, {})
    with pytest.raises(ValueError, match=r"the solution's q has shape \(3, 3\), not \(·, 2\)"):
        ocp.limit_violation(problem, three)
    two = ocp.Solution("trapezoidal", t, np.zeros((3, 2)), np.zeros((3, 2)), np.full((3, 2), 1.5), 0.0, {})
    assert ocp.limit_violation(problem, two) == 0.5


def test_a_transcription_without_its_function_is_refused(arm2):
    only_fdyn = ocp.ArmFunctions(tau=None, fdyn=ocp.dynamics(arm2, "plain").fdyn)
    problem = ocp.Problem(HANG, HANG + 0.2, T=1.0, N=4, method="trapezoidal")
    with pytest.raises(ValueError, match="trapezoidal needs the tau function"):
        ocp.solve(problem, only_fdyn)
    sol = ocp.solve(ocp.Problem(HANG, HANG + 0.2, T=1.0, N=4, method="multiple-shooting"), only_fdyn)
    assert np.allclose(sol.q[-1], HANG + 0.2)
    with pytest.raises(ValueError, match="needs tau"):
        ocp.ArmFunctions(tau=None, fdyn=None)


def test_hermite_simpson_smoothness_is_the_exact_integral_of_the_quadratic():
    a, b, c, h = 1.0, -2.0, 0.5, 0.3
    x = np.linspace(0, h, 200001)
    p = np.polyfit([0, h / 2, h], [a, b, c], 2)
    exact = np.trapezoid(np.polyval(np.polyder(p), x) ** 2, x)
    assert transcription._quadratic_smoothness(a, b, c, h) == pytest.approx(exact, rel=1e-9)


def test_twolink_hangs_at_minus_half_pi_and_is_upright_at_plus_half_pi(arm2):
    G, stable = S.hanging_check(arm2)
    assert np.abs(G).max() < 1e-12 and stable
    _, pot = ref.energy(arm2, np.array([HANG, UP]), np.zeros((2, 2)))
    assert pot[1] - pot[0] == pytest.approx(2 * 9.81 * (0.5 + 1.5))  # both masses lifted by 2·COM height


# --------------------------------------------------------------------------- the studies, coarse


# make test-all: multiple shooting on the two-link arm, solved and re-simulated, is in the main suite at
# N=8 (test_multiple_shooting_re_simulated_with_its_own_rk4_reproduces_the_nodes), the compiled symdyn
# dynamics in tests/test_ocp_compiled.py
@pytest.mark.slow
def test_swing_up_reaches_upright_open_loop_within_limits(arm2):
    sol, check = S.solve_checked(arm2, S.swing_up_problem(N=30), "symdyn")
    assert check.ok, check.describe()
    # the shoulder cannot hold the arm horizontal, so the elbow torque limit binds
    assert np.abs(sol.tau[:, 1]).max() >= S.ACTIVE * S.TWOLINK_TAU[1]


def test_puma_minimum_time_is_bang_bang_and_re_simulates(puma_nc):
    problem = S.min_time_problem(puma_nc, puma_nc.qz, puma_nc.qr, N=10)
    sol, check = S.solve_checked(puma_nc, problem, "plain", compiled=False)  # compiled = SX: test_ocp_compiled
    assert check.ok, check.describe()
    # joint 2 turns π/2 at ≤ 4 rad/s, so T > π/8; a torque limit must bind
    assert np.pi / 8 < sol.T < 1.0
    lim = problem.limits.tau
    assert np.abs(sol.tau[:, 1]).max() >= S.ACTIVE * lim[1]
    assert sol.tau[0, 1] >= S.ACTIVE * lim[1] and sol.tau[-1, 1] <= -S.ACTIVE * lim[1]


def test_puma_minimum_effort_with_payload_costs_more_and_beats_minimum_jerk(puma_nc):
    costs = []
    for robot in (puma_nc, puma_nc.payload(*S.PUMA_PAYLOAD)):
        problem = S.min_effort_problem(robot, N=10)
        sol, check = S.solve_checked(robot, problem, "plain", compiled=False)  # as above
        assert check.ok, check.describe()
        assert sol.cost <= S._min_jerk_effort(robot, problem)
        costs.append(sol.cost)
    assert costs[1] > 1.2 * costs[0]


# make test-all: test_an_infinite_limit_leaves_that_joint_unbounded solves and verifies this same
# minimum-time problem with each transcription in the main suite (on the uncompiled dynamics)
@pytest.mark.slow
def test_transcriptions_agree_on_the_two_link_minimum_time(arm2):
    lim = ocp.Limits(tau=np.array([30.0, 10.0]), qd=np.array([3.0, 3.0]))
    arm = ocp.dynamics(arm2, "plain")
    T = {}
    for method in ocp.METHODS:
        problem = ocp.Problem(
            HANG, np.array([0.0, 0.5]), N=20, method=method, limits=lim, cost=ocp.Cost(time=1.0, smoothness=1e-6)
        )
        sol = ocp.solve(problem, arm)
        # trapezoidal collocation is second order: a looser goal tolerance on this grid
        tol = dict(tol_q=0.1, tol_qd=0.2) if method == "trapezoidal" else {}
        check = ocp.verify(arm2, problem, sol, **tol)
        assert check.ok, (method, check.describe())
        T[method] = sol.T
    assert max(T.values()) / min(T.values()) < 1.005, T


def test_multiple_shooting_re_simulated_with_its_own_rk4_reproduces_the_nodes(arm2):
    problem = ocp.Problem(HANG, np.array([-1.0, 0.3]), T=1.0, N=8, method="multiple-shooting")
    sol = ocp.solve(problem, ocp.dynamics(arm2, "plain"))
    _, q, qd = ocp.resimulate(arm2, sol, substeps=problem.substeps)
    assert np.abs(q - sol.q).max() < 1e-8 and np.abs(qd - sol.qd).max() < 1e-8


def test_interval_replay_starts_each_interval_at_its_node(arm2):
    """replay="intervals" re-simulates interval k from node k: a node moved by 0.1 rad shows as a
    gap of 0.1 at that node and the next (the interval into it misses it, the one out of it starts
    there), while the open-loop replay, which never reads a node after the first, is unchanged."""
    problem = ocp.Problem(HANG, np.array([-1.0, 0.3]), T=1.0, N=8, method="multiple-shooting")
    sol = ocp.solve(problem, ocp.dynamics(arm2, "plain"))
    _, q_open, _ = ocp.resimulate(arm2, sol, substeps=problem.substeps)
    check = ocp.verify(arm2, problem, sol, replay="intervals", substeps=problem.substeps, tol_q=1e-6, tol_qd=1e-6)
    assert check.ok and check.path_q_error < 1e-8 and check.path_qd_error < 1e-8, check.describe()
    q_moved = sol.q.copy()
    q_moved[4, 0] += 0.1
    moved = dataclasses.replace(sol, q=q_moved)
    _, q, _ = ocp.resimulate(arm2, moved, substeps=problem.substeps, restart=True)
    gap = np.abs(q - moved.q).max(1)
    assert gap[4] == pytest.approx(0.1, abs=1e-8) and gap[5] > 0.05
    assert np.all(np.delete(gap, [4, 5]) < 1e-8)  # every other interval starts at its own node
    bad = ocp.verify(arm2, problem, moved, replay="intervals", substeps=problem.substeps)
    assert not bad.ok and "interval by interval" in bad.describe() and bad.path_q_error >= 0.1 - 1e-8
    assert np.array_equal(ocp.resimulate(arm2, moved, substeps=problem.substeps)[1], q_open)
    with pytest.raises(ValueError, match="unknown replay 'closed'"):
        ocp.verify(arm2, problem, sol, replay="closed")


def test_hermite_simpson_torque_passes_through_nodes_and_midpoints(arm2):
    problem = ocp.Problem(HANG, np.array([-1.0, 0.3]), T=1.0, N=6, method="hermite-simpson")
    sol = ocp.solve(problem, ocp.dynamics(arm2, "symdyn"))
    h = sol.T / sol.N
    assert np.allclose(sol.torque(sol.t[:-1]), sol.tau[:-1], atol=1e-12)
    assert np.allclose(sol.torque(sol.t[:-1] + h / 2), sol.tau_mid, atol=1e-12)
    # collocation: τ = ID(q, q̇, q̈) at the nodes, against the reference
    assert np.allclose(ref.rne(arm2, sol.q, sol.qd, sol.qdd), sol.tau, atol=1e-6)


# --------------------------------------------------------------------------- failure


def test_torque_too_small_to_hold_the_arm_fails_with_status_and_hint(arm2):
    problem = ocp.Problem(
        HANG, np.array([0.0, 0.0]), T=1.0, N=10, method="trapezoidal", limits=ocp.Limits(tau=np.array([2.0, 2.0]))
    )
    with pytest.raises(ocp.OCPError) as err:
        ocp.solve(problem, ocp.dynamics(arm2, "plain"), max_iter=200)
    e = err.value
    assert e.status and e.status in str(e)
    assert "joint 1 needs 19.6 N·m to hold the arm at qf but its torque limit is 2 N·m" in str(e)
    assert e.__cause__ is None and e.__suppress_context__


# --------------------------------------------------------------------------- comparison harness


def test_comparison_harness_plain_against_itself_and_against_symdyn(arm2):
    problem = ocp.Problem(HANG, np.array([-1.0, 0.3]), T=1.0, N=6)
    case = [("two-link", arm2, problem)]
    same = S.compare((("plain", False), ("plain", False)), case)
    sx = ocp.dynamics(arm2, "plain", compiled=False)
    assert [r["tau_instructions"] for r in same] == [sx.tau.n_instructions()] * 2
    assert same[0]["iterations"] == same[1]["iterations"]
    table = S.format_table(same)
    assert "| IPOPT iterations |" in table and "plain SX / plain SX" in table
    for r in same:  # IPOPT's own work and the function evaluations both take time
        assert 0 < r["outside_per_iteration"] < r["per_iteration"]
        assert 0 < r["free_evaluations"] < r["total"]
    assert f"would still take {same[0]['free_evaluations']:.2f} s" in table
    rows = S.compare((("symdyn", True), ("plain", True)), case)
    assert [r["source"] for r in rows] == ["symdyn compiled", "plain compiled"]
    assert rows[0]["tau_instructions"] < rows[1]["tau_instructions"]
    assert rows[0]["fdyn_instructions"] < rows[1]["fdyn_instructions"]
