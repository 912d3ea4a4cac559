"""The NumPy target: a plain module per model, batched, equal to the reference."""

import importlib.util

import numpy as np
import pytest
import sympy as sp

from symdyn import models
from symdyn.codegen import entry as codegen
from symdyn.codegen.emit import Bundle, numpy as numpy_emit
from symdyn.derivation.program import make_program
from symdyn.numeric import reference as ref
from tests.codegen_cases import MODELS, assert_close, cases


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return codegen.load(request.param, target="numpy")


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


def test_module_imports_only_numpy_and_math():
    text = (codegen.GENERATED / "puma560" / "puma560.py").read_text()
    imports = {line.split()[1] for line in text.splitlines() if line.startswith(("import ", "from "))}
    assert imports == {"numpy", "math"}


def _module(path):
    spec = importlib.util.spec_from_file_location(f"_test_numpy_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_sincos_kernel_is_libm_to_rounding():
    m = _module(codegen.GENERATED / "puma560" / "puma560.py")
    table = np.arange(-2048, 2049) / 256.0
    xs = np.concatenate(
        [
            np.random.default_rng(0).uniform(-8, 8, 100_000),
            table,
            table[:-1] + 1 / 512,
            np.arange(-8, 9) * np.pi / 3,
            [0.0, 1e-300, -1e-9],
        ]
    )
    s, c = m._sincos(xs[None], np.empty((6, xs.size)))
    for got, exact in ((s[0], np.sin(xs)), (c[0], np.cos(xs))):
        err = np.abs(got - exact)
        assert err.max() <= 1.2e-16
        assert np.mean(err <= np.spacing(np.abs(exact))) > 0.999


def test_sincos_beyond_the_table_or_not_finite_is_numpys():
    m = _module(codegen.GENERATED / "puma560" / "puma560.py")
    xs = np.array([[8.5, -100.0, 1e6, np.nan, np.inf]])
    with np.errstate(invalid="ignore"):
        s, c = m._sincos(xs, np.empty((6, xs.shape[1])))
        np.testing.assert_array_equal(s, np.sin(xs))
        np.testing.assert_array_equal(c, np.cos(xs))


@pytest.mark.parametrize("function", ["tau", "C", "fdyn", "Y"])
def test_few_states_by_the_scalar_body_equal_the_batched_body(model, function):
    args, _ = cases(model.name)["tau" if function == "Y" else function]
    f = getattr(model, function)
    batch = f(*args)
    for count in (2, numpy_emit.FEW, numpy_emit.FEW + 1):
        np.testing.assert_allclose(f(*(a[:count] for a in args)), batch[:count], rtol=1e-14, atol=1e-14)


def test_batches_longer_than_a_chunk_and_empty_batches(model):
    (q, qd, qdd), tau = cases(model.name)["tau"]
    count = numpy_emit.CHUNK + 7
    reps = -(-count // len(q))
    big = [np.tile(a, (reps, 1))[:count] for a in (q, qd, qdd)]
    assert_close(model.tau(*big), np.tile(tau, (reps, 1))[:count], f"{model.name} tau, {count} states")
    assert model.tau(q[:0], qd[:0], qdd[:0]).shape == (0, model.n)
    assert model.M(q[:0]).shape == (0, model.n, model.n)


def test_angles_beyond_the_sine_table_agree_with_the_reference(model):
    robot = models.load(model.name)
    (q, qd, qdd), _ = cases(model.name)["tau"]
    far = q + np.array([4 * np.pi, -6 * np.pi] * model.n)[: model.n]
    assert_close(model.tau(far, qd, qdd), ref.rne(robot, far, qd, qdd), f"{model.name} tau at |q| > 8")
    assert_close(model.M(far[0]), ref.inertia(robot, far[0]), f"{model.name} M, one state at |q| > 8")


@pytest.mark.parametrize("count", [None, 8, numpy_emit.FEW + 8])  # one state, scalar body, batched body
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_state_is_an_error_naming_the_argument(model, count, bad):
    (q, qd, qdd), _ = cases(model.name)["tau"]
    states = slice(None, count) if count else 0
    broken = qd[states].copy()
    broken[..., 1] = bad
    with pytest.raises(ValueError, match="qd contains NaN or infinity"):
        model.tau(q[states], broken, qdd[states])


def test_every_primitive_in_the_scalar_and_the_batched_body(tmp_path):
    x1, x2, x3 = sp.symbols("x1 x2 x3", real=True)
    exprs = [
        3 * sp.sign(x1) * x2 + sp.sign(x2 - x3),
        sp.Abs(x1 - x2) * x3,
        sp.sqrt(x3**2 + 1),
        (x3**2 + 2) ** sp.Rational(5, 2),
        x1 / x3 - 1 / (x2**2 + 1),
        sp.tan(x1 * x2),
        sp.sin(x1 - 2 * x3) * sp.cos(x2) + sp.sin(x1 * x3),
        -(x1**3) + x2**4,
        sp.Integer(0),
    ]
    second = sp.Matrix([[x1 * x2, 1], [sp.cos(x2) ** 2, x3]])
    program = make_program("f", [("x", (x1, x2, x3))], [("y", sp.Matrix(exprs)), ("z", second)])
    path = tmp_path / "prims.py"
    path.write_text(numpy_emit.module_source(Bundle("prims", 3, "test", "none", (program,))))
    f = _module(path).f
    x = np.random.default_rng(1).uniform(-2, 2, (50, 3))
    x[:3, 0] = [0.0, -0.0, 1.5]
    x[2, 1] = 0.0
    want_y = np.stack(np.broadcast_arrays(*sp.lambdify([x1, x2, x3], exprs, "numpy")(*x.T)), axis=-1)
    want_z = np.moveaxis(np.array(np.broadcast_arrays(*sp.lambdify([x1, x2, x3], list(second), "numpy")(*x.T))), 0, -1)
    for states in (slice(None), slice(3), 0, 1, 2, 3):  # batched body, scalar body for few and for one
        y, z = f(x[states])
        np.testing.assert_allclose(y, want_y[states], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(z, want_z[states].reshape(z.shape), rtol=1e-13, atol=1e-13)
        assert z.shape == np.shape(x[states])[:-1] + (2, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        at_zero = f(np.array([1.0, 2.0, 0.0]))[0]  # 1/0 raises in Python: NumPy's inf instead
        assert at_zero[4] == np.inf


def test_emitter_names_cannot_clash():
    x = sp.Symbol("q1", real=True)
    t = sp.Symbol("_t", real=True)
    program = make_program("f", [("q", (x,))], [("y", sp.Matrix([t * t]))], definitions=[(t, sp.sin(x) + x)])
    with pytest.raises(ValueError, match="_t"):
        numpy_emit.batched_source(program)
