"""What every compiled target (C and NumPy) must do: agree with the reference
at 200 states, satisfy τ = Y·π and fdyn∘tau = id, and batch like single states."""

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from tests.codegen_cases import MODELS, assert_close, cases, parameters


@pytest.fixture(scope="module", params=[(m, t) for m in MODELS for t in ("c", "numpy")], ids=lambda p: f"{p[0]}-{p[1]}")
def model(request):
    name, target = request.param
    return codegen.load(name, target=target)


@pytest.mark.parametrize("function", ["tau", "M", "C", "Cqd", "G", "F", "fdyn"])
def test_every_function_agrees_with_the_reference(model, function):
    args, expected = cases(model.name)[function]
    assert_close(getattr(model, function)(*args), expected, f"{model.name} {model.target} {function}")


def test_regressor_times_parameters_is_tau(model):
    (q, qd, qdd), tau = cases(model.name)["tau"]
    assert_close(model.Y(q, qd, qdd) @ parameters(model.name), tau, f"{model.name} Y·π")


def test_fdyn_inverts_its_own_tau(model):
    (q, qd, qdd), _ = cases(model.name)["tau"]
    assert_close(model.fdyn(q, qd, model.tau(q, qd, qdd)), qdd, f"{model.name} fdyn∘tau")


@pytest.mark.parametrize("function", ["tau", "M", "C", "fdyn", "Y"])
def test_batched_equals_single_state(model, function):
    """To 1e-14: for NumPy math.sin for one state, a kernel batched; for C the SIMD kernel,
    the scalar function's arithmetic lane by lane, where the compiler may fuse a
    multiply-add differently (tests/test_batch_simd.py: state by state, any N, any threads)."""
    args, _ = cases(model.name)["tau" if function == "Y" else function]
    f = getattr(model, function)
    batch = f(*args)
    for k in range(4):
        single = f(*(a[k] for a in args))
        np.testing.assert_allclose(single, batch[k], rtol=1e-14, atol=1e-14 * np.max(np.abs(single)))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_input_is_an_error(model, bad):
    (q, qd, qdd), _ = cases(model.name)["tau"]
    broken = q[:3].copy()
    broken[1, 0] = bad
    with pytest.raises(ValueError, match="NaN or infinity"):
        model.tau(broken, qd[:3], qdd[:3])
    with pytest.raises(ValueError, match="NaN or infinity"):
        model.M(broken[1])
