"""The CasADi target: named casadi.Functions, serialised, with AD Jacobians."""

import casadi as ca
import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import casadi as ca_emit
from tests.codegen_cases import MODELS, assert_close, cases, parameters


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return codegen.load(request.param, target="casadi")


def _mapped(f, args):
    """f over a batch (N, …) of states with CasADi's map: outputs (N, rows) or (N, rows, cols)."""
    count = len(args[0])
    out = np.array(f.map(count)(*(a.T for a in args)))  # (rows, N·cols)
    rows, cols = f.size_out(0)
    blocks = out.reshape(rows, count, cols).transpose(1, 0, 2)
    return blocks[..., 0] if cols == 1 else blocks


@pytest.mark.parametrize("function", ["tau", "M", "C", "Cqd", "G", "F", "fdyn"])
def test_every_function_agrees_with_the_reference(model, function):
    args, expected = cases(model.name)[function]
    assert_close(_mapped(getattr(model, function), args), expected, f"{model.name} {function}")


def test_named_inputs_and_outputs(model):
    assert model.tau.name_in() == ["q", "qd", "qdd"] and model.tau.name_out() == ["tau"]
    assert model.fdyn.name_in() == ["q", "qd", "tau"] and model.fdyn.name_out() == ["qdd"]
    assert model.M.size_out(0) == (model.n, model.n)


def test_regressor_times_parameters_is_tau(model):
    args, tau = cases(model.name)["tau"]
    Y = _mapped(model.Y, args)
    assert_close(Y @ parameters(model.name), tau, f"{model.name} Y·π")


def test_single_state_equals_mapped(model):
    args, _ = cases(model.name)["fdyn"]
    batch = _mapped(model.fdyn, args)
    for k in range(4):
        single = np.array(model.fdyn(*(a[k] for a in args))).ravel()
        np.testing.assert_allclose(single, batch[k], rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize(
    "function, wrt", [("tau", "q"), ("tau", "qd"), ("tau", "qdd"), ("fdyn", "q"), ("fdyn", "tau"), ("G", "q")]
)
def test_jacobians_match_finite_differences(model, function, wrt):
    f = getattr(model, function)
    J = model.jacobian(function, wrt)
    args, _ = cases(model.name)[function]
    k_in = f.name_in().index(wrt)
    h = 1e-6
    for k in (5, 9):  # moving states: friction's sign is locally constant
        x = [np.asarray(a[k], float) for a in args]
        jac = np.array(J(*x))
        fd = np.empty_like(jac)
        for j in range(len(x[k_in])):
            up = [v.copy() for v in x]
            dn = [v.copy() for v in x]
            up[k_in][j] += h
            dn[k_in][j] -= h
            fd[:, j] = (np.array(f(*up)) - np.array(f(*dn))).ravel() / (2 * h)
        scale = max(1.0, np.max(np.abs(jac)))
        assert np.max(np.abs(jac - fd)) / scale < 1e-6, f"{function} d/d{wrt} at state {k}"


def test_mass_matrix_times_forward_dynamics_jacobian_is_identity(model):
    (q, qd, tau), _ = cases(model.name)["fdyn"]
    dqdd_dtau = np.array(model.jacobian("fdyn", "tau")(q[7], qd[7], tau[7]))
    np.testing.assert_allclose(np.array(model.M(q[7])) @ dqdd_dtau, np.eye(model.n), atol=1e-12)


def test_unknown_jacobian_is_a_clear_error(model):
    with pytest.raises(ValueError, match="tau has no input 'x'"):
        model.jacobian("tau", "x")


def test_casadi_c_code_generation(tmp_path):
    m = codegen.load("twolink", target="casadi")
    path = ca_emit.generate_c(list(m.functions.values()), "twolink", tmp_path)
    text = path.read_text()
    assert all("twolink_casadi" in p.name for p in tmp_path.iterdir())
    for name in m.functions:
        assert f"int {name}(const casadi_real** arg" in text


def test_not_a_symdyn_file_is_a_clear_error(tmp_path):
    path = tmp_path / "f.casadi"
    x = ca.SX.sym("x")
    s = ca.FileSerializer(str(path))
    s.pack(ca.Function("f", [x], [x]))
    del s
    with pytest.raises(ValueError, match="not a symdyn CasADi file"):
        ca_emit.deserialize(path)
