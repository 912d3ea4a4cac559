"""One input contract for every target (docs/functions.md): NumPy, C through
the CPython extension and through ctypes, and CasADi called with numbers."""

import numpy as np
import pytest

from symdyn.codegen import entry as codegen
from symdyn.codegen.emit.clib import CompileOptions
from tests.codegen_cases import assert_close, cases

TARGETS = [("numpy", None), ("c", "extension"), ("c", "ctypes"), ("casadi", None)]


@pytest.fixture(scope="module", params=TARGETS, ids=lambda t: t[1] or t[0])
def model(request):
    target, binding = request.param
    options = CompileOptions(binding=binding) if binding else None
    return codegen.load("puma560", target, options=options)


def _states(count=200):
    (q, qd, qdd), tau = cases("puma560")["tau"]
    return q[:count], qd[:count], qdd[:count], tau[:count]


def test_single_and_batched_states_agree_with_the_reference(model):
    q, qd, qdd, tau = _states()
    assert_close(model.tau(q, qd, qdd), tau, f"{model.target} tau (N, n)")
    assert_close(model.tau(q[7], qd[7], qdd[7]), tau[7], f"{model.target} tau (n,)")
    (M_args,), M = cases("puma560")["M"]
    assert_close(model.M(M_args), M, f"{model.target} M (N, n, n)")
    assert_close(model.M(M_args[3]), M[3], f"{model.target} M (n, n)")


def test_any_leading_shape_lists_and_empty_batches(model):
    q, qd, qdd, tau = _states(6)
    assert_close(model.M(q.tolist()), model.M(q), "M of lists")
    assert_close(model.G([0] * 6), model.G(np.zeros(6)), "G of integers")
    got = model.tau(q.reshape(2, 3, 6), qd.reshape(2, 3, 6), qdd.reshape(2, 3, 6))
    assert got.shape == (2, 3, 6)
    assert_close(got.reshape(6, 6), tau, "tau (2, 3, n)")
    assert model.M(q.reshape(3, 2, 6)).shape == (3, 2, 6, 6)
    assert model.M(q[:0]).shape == (0, 6, 6)
    assert model.tau(q[:0], qd[0], qdd[0]).shape == (0, 6)


def test_leading_shapes_broadcast(model):
    q, qd, qdd, _ = _states(5)
    expected = np.array([model.tau(q[k], qd[0], qdd[1]) for k in range(5)])
    assert_close(model.tau(q, qd[0], qdd[1:2]), expected, "tau (N, n), (n,), (1, n)")
    grid = model.tau(q[:, None], qd[None, :3], qdd[0])
    assert grid.shape == (5, 3, 6)
    assert_close(grid[4, 2], model.tau(q[4], qd[2], qdd[0]), "tau (N, 1, n), (1, K, n), (n,)")


def test_keyword_arguments_by_their_documented_names(model):
    """Wrong calls raise Python's own TypeErrors, as a Python function's would."""
    q, qd, qdd, tau = _states(4)
    assert_close(model.tau(qdd=qdd, q=q, qd=qd), tau, "tau(qdd=, q=, qd=)")
    assert_close(model.fdyn(q, qd, tau=tau), qdd, "fdyn(q, qd, tau=)")
    """Wrong calls raise Python's own TypeErrors, as a Python function's would."""
    with pytest.raises(TypeError, match=r"^fdyn\(\) got an unexpected keyword argument 'qdd'"):
        model.fdyn(q, qd, qdd=tau)
    with pytest.raises(TypeError, match=r"^M\(\) got multiple values for argument 'q'"):
        model.M(q, q=q)
    with pytest.raises(TypeError, match=r"^tau\(\) missing 1 required positional argument: 'qdd'"):
        model.tau(q, qd)
    with pytest.raises(TypeError, match=r"^M\(\) takes 1 positional argument but 2 were given"):
        model.M(q, q)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("count", [1, 200])
def test_nan_and_infinity_are_errors_naming_the_argument(model, bad, count):
    q, qd, qdd, tau = _states(count)
    for name in ("q", "qd", "tau"):
        args = {"q": q.copy(), "qd": qd.copy(), "tau": tau.copy()}
        args[name][-1, 0] = bad
        with pytest.raises(ValueError, match=rf"^fdyn\(\): {name} contains NaN or infinity"):
            model.fdyn(**args)
        with pytest.raises(ValueError, match=rf"^fdyn\(\): {name} contains NaN or infinity"):
            model.fdyn(args["q"][-1], args["qd"][-1], args["tau"][-1])


@pytest.mark.parametrize("count", [1, 200])
def test_complex_input_is_an_error_naming_the_argument(model, count):
    q, qd, qdd, _ = _states(count)
    with pytest.raises(ValueError, match=r"^tau\(\): qd is complex"):
        model.tau(q, qd + 1e-3j, qdd)
    with pytest.raises(ValueError, match=r"^M\(\): q is complex"):
        model.M(q[0].astype(complex))  # even with a zero imaginary part
    with pytest.raises(ValueError, match=r"^G\(\): q is complex"):
        model.G([0.1, 0.2, 0.3, 0.4, 0.5, 1j])


@pytest.mark.parametrize(
    "bad, why",
    [
        (0.5, r"must have shape \(\.\.\., 6\), got \(\)"),
        (np.zeros(5), r"must have shape \(\.\.\., 6\), got \(5,\)"),
        (np.zeros((4, 7)), r"must have shape \(\.\.\., 6\), got \(4, 7\)"),
        (["a"] * 6, "must be real numbers"),
    ],
)
def test_wrong_shapes_and_non_numbers_are_errors_naming_the_argument(model, bad, why):
    q, qd, _, _ = _states(1)
    with pytest.raises(ValueError, match=rf"^C\(\): qd {why}"):
        model.C(q[0], bad)
    with pytest.raises(ValueError, match=rf"^M\(\): q {why}"):
        model.M(bad)


def test_leading_shapes_that_do_not_broadcast_are_an_error_naming_them(model):
    q, qd, qdd, _ = _states(6)
    with pytest.raises(ValueError, match=r"^tau\(\): the leading shapes .* q \(6,\), qd \(4,\), qdd \(6,\)"):
        model.tau(q, qd[:4], qdd)


@pytest.mark.parametrize("binding", ["extension", "ctypes"])
def test_an_out_array_sharing_memory_with_an_input_is_refused(binding):
    """The C stores a matrix's entries as it computes them, before it has read every input: an
    out= that overlaps an input is a ValueError naming that input (both bindings, one state and a
    batch), and an out= of its own is written."""
    model = codegen.load("puma560", "c", options=CompileOptions(binding=binding))
    q, qd, qdd, _ = _states(4)
    store = np.zeros(40)
    store[2:8] = q[0]
    with pytest.raises(ValueError, match=r"M\(\): out shares memory with the input q"):
        model.M(store[2:8], out=store[4:40].reshape(6, 6))
    batch = np.zeros(4 * 36)
    batch[100:124] = q.ravel()
    with pytest.raises(ValueError, match="shares memory with the input q"):
        model.M(batch[100:124].reshape(4, 6), out=batch.reshape(4, 6, 6))
    joint = np.zeros(36)
    joint[30:] = qd[0]
    with pytest.raises(ValueError, match=r"C\(\): out shares memory with the input qd"):
        model.C(q[0], joint[30:], out=joint.reshape(6, 6))
    apart = np.zeros(42)  # side by side, not overlapping: accepted
    apart[:6] = q[0]
    assert_close(model.M(apart[:6], out=apart[6:].reshape(6, 6)), model.M(q[0]), "M beside q")
    own = np.full((6, 6), np.nan)
    assert model.M(q[0], out=own) is own
    assert_close(own, model.M(q[0]), "M into out=")


@pytest.mark.parametrize("binding", ["extension", "ctypes"])
def test_out_arrays_sharing_memory_with_each_other_are_refused(binding):
    """Two outputs of one call in one piece of memory would overwrite each other's entries: refused
    by position (both bindings, one state and a batch); side by side in one buffer, accepted."""
    model = codegen.load("puma560", "c", options=CompileOptions(binding=binding))
    q, qd, qdd, _ = _states(3)
    store = np.zeros(6 + 36 + 36)
    tau, dq, dv = store[:6], store[6:42].reshape(6, 6), store[42:].reshape(6, 6)
    with pytest.raises(ValueError, match=r"tau_derivatives\(\): out\[1\] and out\[2\] share memory"):
        model.tau_derivatives(q[0], qd[0], qdd[0], out=(tau, dq, store[36:72].reshape(6, 6)))
    batch = np.zeros(3 * 78)
    with pytest.raises(ValueError, match=r"out\[0\] and out\[1\] share memory"):
        model.tau_derivatives(
            q, qd, qdd, out=(batch[:18].reshape(3, 6), batch[:108].reshape(3, 6, 6), np.zeros((3, 6, 6)))
        )
    got = model.tau_derivatives(q[0], qd[0], qdd[0], out=(tau, dq, dv))
    assert got[0] is tau and got[2] is dv
    for a, b, name in zip(got, model.tau_derivatives(q[0], qd[0], qdd[0]), ("tau", "dtau_dq", "dtau_dqd")):
        assert_close(a, b, f"{name} side by side in one buffer")
