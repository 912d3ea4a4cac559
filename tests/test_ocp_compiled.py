"""Optimal control on compiled CasADi code (issue 13 items 2-4): the compiled functions
and their derivatives equal the SX ones, OCP optima on the compiled path equal those on
the SX path to the solver tolerance, and the NMPC tracker holds its limits.  Two-link
arm: compiles in about a second."""

import re
import time

import casadi as ca
import numpy as np
import pytest

import symdyn
from symdyn.apps import ocp
from symdyn.apps.ocp import functions
from symdyn.derivation import progress
from symdyn.apps.studies import mpc
from symdyn.codegen.emit.casadi import compiled
from tests.conftest import tiered

HANG, UP = np.array([-np.pi / 2, 0.0]), np.array([np.pi / 2, 0.0])


@pytest.fixture(scope="module")
def arm2():
    return symdyn.models.load("twolink").nofriction()


@pytest.fixture(scope="module")
def both(arm2):
    return ocp.dynamics(arm2, "symdyn", compiled=False), ocp.dynamics(arm2, "symdyn", compiled=True)


def _states(count=50, seed=1):
    rng = np.random.default_rng(seed)
    return [ca.DM(x) for x in rng.uniform(-2, 2, (3, 2, count))]


def test_compiled_functions_and_their_jacobians_and_hessians_equal_the_sx_ones(both):
    sx, cc = both
    assert cc.compiled and not sx.compiled and cc.label == "symdyn compiled"
    for name in ("tau", "fdyn"):
        f, g = getattr(sx, name), getattr(cc, name)
        assert isinstance(g, ca.Function) and g.class_name() == "External"
        args = _states()
        lam = ca.DM(np.random.default_rng(2).normal(size=(2, 50)))
        val = np.array(f.map(50)(*args))
        assert np.allclose(np.array(g.map(50)(*args)), val, rtol=1e-12, atol=1e-12)
        for k in range(3):  # Jacobian and Hessian of λᵀf, through CasADi's AD on each
            x = [ca.MX.sym(f.name_in(i), 2) for i in range(3)]
            jf = ca.Function("j", x, [ca.jacobian(f(*x), x[k])]).map(50)(*args)
            jg = ca.Function("j", x, [ca.jacobian(g(*x), x[k])]).map(50)(*args)
            assert np.allclose(np.array(jg), np.array(jf), rtol=1e-10, atol=1e-10)
            lm = ca.MX.sym("lam", 2)
            hf = ca.Function("h", [*x, lm], [ca.hessian(ca.dot(lm, f(*x)), x[k])[0]]).map(50)(*args, lam)
            hg = ca.Function("h", [*x, lm], [ca.hessian(ca.dot(lm, g(*x)), x[k])[0]]).map(50)(*args, lam)
            assert np.allclose(np.array(hg), np.array(hf), rtol=1e-9, atol=1e-9)


def test_the_compiled_jacobian_matches_central_differences(both):
    _, cc = both
    x0 = [np.array([0.3, -0.7]), np.array([1.1, -0.4]), np.array([2.0, 1.0])]
    x = [ca.MX.sym(n, 2) for n in ("q", "qd", "tau")]
    J = np.array(ca.Function("J", x, [ca.jacobian(cc.fdyn(*x), x[0])])(*x0))
    eps = 1e-6
    fd = np.column_stack(
        [
            (np.array(cc.fdyn(x0[0] + eps * e, *x0[1:])) - np.array(cc.fdyn(x0[0] - eps * e, *x0[1:]))).ravel()
            / (2 * eps)
            for e in np.eye(2)
        ]
    )
    assert np.allclose(J, fd, rtol=1e-6, atol=1e-6)


def test_the_library_is_cached_by_source_and_rebuilt_when_damaged(arm2, tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    f = ocp.dynamics(arm2, "symdyn", compiled=False).tau
    compiled(f)
    (lib,) = tmp_path.glob("casadi/tau-*/libtau.so")
    built = lib.stat().st_mtime_ns
    compiled(f)
    assert lib.stat().st_mtime_ns == built  # reused
    lib.write_bytes(lib.read_bytes()[:1000])  # truncated: would crash dlopen
    g = compiled(f)
    assert lib.stat().st_size > 1000
    assert np.allclose(
        np.array(g([0.1, 0.2], [0.3, 0.4], [0.5, 0.6])), np.array(f([0.1, 0.2], [0.3, 0.4], [0.5, 0.6])), rtol=1e-13
    )


def test_a_long_step_reports_what_it_builds_and_how_long_a_quick_one_says_nothing(capsys):
    with progress.reported("building X", after=0.05):
        time.sleep(0.3)
    err = capsys.readouterr().err.splitlines()
    assert err[0].strip() == "building X ..."
    assert re.fullmatch(r"building X: done in 0\.[3-9] s", err[-1].strip()), err
    with progress.reported("building Y"):  # the default threshold, REPORT_AFTER_S = 2 s
        pass
    assert capsys.readouterr().err == ""


def test_the_compiled_build_shows_progress_and_a_cached_one_is_silent(arm2, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(progress, "REPORT_AFTER_S", 0.0)  # the two-link arm builds in about a second
    arm = ocp.dynamics.__wrapped__(arm2, "symdyn", compiled=True)  # not the in-process lru_cache
    functions._compiled_step.__wrapped__(arm.fdyn_sx, 2, 1, arm.fdyn_derivatives_sx, arm.name)
    err = capsys.readouterr().err
    for what in (
        "compiling tau (symdyn) with its Jacobian and Hessian",
        "compiling fdyn (symdyn)",
        "compiling the multiple-shooting interval (1 RK4 step,",
    ):
        assert f"ocp {arm2.name}: {what}" in err, err
    assert len(re.findall(r": done in \d+\.\d s", err)) >= 3, err
    monkeypatch.setattr(progress, "REPORT_AFTER_S", 2.0)  # as shipped: a read from the cache is far quicker
    again = ocp.dynamics.__wrapped__(arm2, "symdyn", compiled=True)
    functions._compiled_step.__wrapped__(again.fdyn_sx, 2, 1, again.fdyn_derivatives_sx, again.name)
    assert capsys.readouterr().err == ""


def test_load_compiled_gives_externals_that_follow_the_contract(arm2):
    sx = symdyn.load(arm2, "casadi")
    cc = symdyn.load(arm2, "casadi", compiled=True)
    assert cc.functions["tau"].class_name() == "External" and cc.functions["M"].class_name() != "External"
    q, qd, qdd = np.random.default_rng(3).uniform(-1, 1, (3, 7, 2))
    assert cc.tau(q, qd, qdd).shape == (7, 2)
    assert np.allclose(cc.tau(q, qd, qdd), sx.tau(q, qd, qdd), rtol=1e-12)
    with pytest.raises(ValueError, match="no function 'nope'"):
        symdyn.load(arm2, "casadi", compiled=["nope"])
    with pytest.raises(ValueError, match="option of the CasADi target"):
        symdyn.load(arm2, "numpy", compiled=True)


@pytest.mark.parametrize("method", tiered(["trapezoidal", "multiple-shooting"], 1))
def test_ocp_optimum_on_the_compiled_path_equals_the_sx_one(both, method):
    problem = ocp.Problem(
        HANG,
        UP,
        T=2.0,
        N=20,
        method=method,
        limits=ocp.Limits(tau=np.array([15.0, 4.0]), qd=np.array([5.0, 5.0])),
        cost=ocp.Cost(effort=1.0, smoothness=1e-3),
    )
    a, b = (ocp.solve(problem, arm) for arm in both)
    assert a.stats["success"] and b.stats["success"]
    assert b.stats["compiled"] and not a.stats["compiled"]
    assert abs(a.cost - b.cost) <= 1e-7 * abs(a.cost)
    assert np.abs(a.tau - b.tau).max() <= 1e-4 * np.abs(a.tau).max()
    assert np.abs(a.q - b.q).max() <= 1e-5


def test_nmpc_tracker_reaches_a_goal_within_its_torque_limits():
    arm2 = symdyn.models.load("twolink").nofriction()
    lim = ocp.Limits(tau=np.array([40.0, 15.0]), qd=np.array([3.0, 3.0]))
    tracker = ocp.Tracker(ocp.dynamics(arm2, "symdyn"), lim, 0.02, 10)
    x = np.array([0.0, 0.0, 0.0, 0.0])
    goal = np.array([0.5, -0.3, 0.0, 0.0])
    taus = []
    for _ in range(40):
        tau, st = tracker.control(x, np.tile(goal, (11, 1)))
        assert st["success"]
        taus.append(tau)
        x = mpc._plant_step(arm2, x, tau, 0.02, 5)
    assert np.abs(np.array(taus)).max() <= 40.0 + 1e-6
    assert np.abs(x[:2] - goal[:2]).max() < 1e-2  # settled on the goal after 0.8 s


@pytest.mark.parametrize("integrator", ["euler", "rk4"])
def test_rti_iterated_converges_to_the_ipopt_tracker_solution_and_keeps_the_limits(arm2, integrator):
    """The real-time iteration is one Gauss–Newton SQP step per call; iterated at a fixed
    state and reference it converges to the NLP optimum the IPOPT tracker finds, with the
    torque and speed limits active and held.  With RK4 both run on the compiled interval,
    and the IPOPT tracker's optimum is the one it finds on the SX path."""
    lim = ocp.Limits(tau=np.array([30.0, 10.0]), qd=np.array([1.5, 1.5]))
    arm = ocp.dynamics(arm2, "symdyn")
    x = np.array([0.2, 0.1, 0.5, -0.3])
    ref = np.tile([0.8, -0.4, 0.0, 0.0], (9, 1))
    ipopt = ocp.Tracker(arm, lim, 0.02, 8, tol=1e-12, integrator=integrator)
    tau_ip, st = ipopt.control(x, ref)
    assert st["success"]
    if integrator == "rk4":
        tau_sx, _ = ocp.Tracker(
            ocp.dynamics(arm2, "symdyn", compiled=False), lim, 0.02, 8, tol=1e-12, integrator=integrator
        ).control(x, ref)
        assert np.abs(tau_sx - tau_ip).max() < 1e-8 * np.abs(tau_ip).max()
    rti = ocp.RTITracker(arm, lim, 0.02, 8, integrator=integrator)
    steps = []
    for _ in range(8):
        rti.prepare(ref)
        tau, st = rti.feedback(x)
        assert st["success"]
        steps.append(np.abs(tau - tau_ip).max())
    assert steps[0] > 1e-3  # the first QP is not yet the optimum
    assert steps[-1] < 1e-6 * np.abs(tau_ip).max()
    X, U = rti.prediction
    assert np.abs(U / lim.tau).max() <= 1 + 1e-9 and np.abs(U / lim.tau).max() > 0.999  # torque limit active
    assert np.abs(X[:, 2:] / lim.qd).max() <= 1 + 1e-6 and np.abs(X[:, 2:] / lim.qd).max() > 0.999
    _, st = rti.control(x, ref)
    assert st["wall"] == pytest.approx(st["prepare"] + st["feedback"]) and st["iterations"] == 1
