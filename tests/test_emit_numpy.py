"""The NumPy target: a plain module per model, batched, equal to the reference."""

import numpy as np
import pytest

import symdyn.codegen as codegen
from tests.codegen_cases import MODELS, assert_close, cases, parameters


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return codegen.load(request.param, target="numpy")


@pytest.mark.parametrize("function", ["tau", "M", "C", "Cqd", "G", "F", "fdyn"])
def test_every_function_agrees_with_the_reference(model, function):
    args, expected = cases(model.name)[function]
    assert_close(getattr(model, function)(*args), expected, f"{model.name} {function}")


def test_regressor_times_parameters_is_tau(model):
    (q, qd, qdd), tau = cases(model.name)["tau"]
    assert_close(model.Y(q, qd, qdd) @ parameters(model.name), tau, f"{model.name} Y·π")


def test_fdyn_inverts_its_own_tau(model):
    (q, qd, qdd), _ = cases(model.name)["tau"]
    assert_close(model.fdyn(q, qd, model.tau(q, qd, qdd)), qdd, f"{model.name} fdyn∘tau")


@pytest.mark.parametrize("function", ["tau", "M", "C", "fdyn", "Y"])
def test_batched_equals_single_state(model, function):
    args, _ = cases(model.name)["tau" if function == "Y" else function]
    f = getattr(model, function)
    batch = f(*args)
    for k in range(4):
        np.testing.assert_allclose(f(*(a[k] for a in args)), batch[k], rtol=1e-14, atol=1e-14)


def test_any_leading_shape_and_broadcasting(model):
    (q, qd, qdd), tau = cases(model.name)["tau"]
    n = model.n
    got = model.tau(q[:6].reshape(2, 3, n), qd[:6].reshape(2, 3, n), qdd[:6].reshape(2, 3, n))
    assert got.shape == (2, 3, n)
    np.testing.assert_allclose(got.reshape(6, n), tau[:6], rtol=1e-14, atol=1e-14)
    assert model.M(q[:6].reshape(2, 3, n)).shape == (2, 3, n, n)
    broadcast = model.tau(q[:6], qd[0], qdd[0])  # one velocity for six poses
    np.testing.assert_allclose(broadcast[2], model.tau(q[2], qd[0], qdd[0]), rtol=1e-14)


def test_wrong_shape_is_a_clear_error(model):
    with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., %d\)" % model.n):
        model.M(np.zeros(model.n + 1))
    with pytest.raises(ValueError, match="qd must have shape"):
        model.C(np.zeros(model.n), 1.0)


def test_module_imports_only_numpy():
    text = (codegen.GENERATED / "puma560" / "puma560.py").read_text()
    imports = {line.split()[1] for line in text.splitlines() if line.startswith(("import ", "from "))}
    assert imports == {"numpy"}
