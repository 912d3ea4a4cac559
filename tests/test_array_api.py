"""The array-API target on JAX (CPU, float64 and float32): every function against the reference
and the NumPy target, jit / vmap / grad, the generated derivatives against JAX's own autodiff,
dtype, broadcasting, bad shapes and NaN (docs/functions.md, "JAX, PyTorch and the array API").

JAX comes with the test extra.  The big checks run every function un-jitted (each XLA compile
of a large straight-line program costs seconds); jit compiles are few: every function of the
two-link arm, τ of every other arm.
"""

import functools
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import symdyn
from symdyn.codegen import entry as codegen
from symdyn.model import arms
from symdyn.derivation.regressor import parameter_values
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref
from tests.codegen_cases import assert_close
from tests.conftest import random_states, tiered

jax.config.update("jax_enable_x64", True)

ARMS = {name: functools.partial(arms.load, name) for name in codegen.SHIPPED}
ARMS["random-101"] = functools.partial(random_arm, 101, ArmOptions(n_max=4))  # test_derivatives' arm
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "F", "fdyn", "Y", "tau_derivatives", "fdyn_derivatives", "Minv")
STATES = 200
#: The arms, the main suite's two first: the shipped arms but the two-link one on JAX are make test-all's
MAIN_FIRST = sorted(ARMS, key=lambda name: name not in ("twolink", "random-101"))


@functools.lru_cache(maxsize=None)
def robot(name):
    return ARMS[name]()


@functools.lru_cache(maxsize=None)
def states(name):
    """(q, qd, qdd, tau) at STATES random states within the joint limits, qd = 0 in the first five."""
    r = robot(name)
    q, qd, qdd = random_states(r, STATES, seed=25)
    qd[:5] = 0.0  # Coulomb friction at rest is 0: sign(0)
    return q, qd, qdd, ref.rne(r, q, qd, qdd)


def arguments(f, q, qd, qdd, tau):
    """The arguments of function f at a state."""
    return {
        "M": (q,),
        "G": (q,),
        "Minv": (q,),
        "F": (qd,),
        "C": (q, qd),
        "Cqd": (q, qd),
        "fdyn": (q, qd, tau),
        "fdyn_derivatives": (q, qd, tau),
    }.get(f, (q, qd, qdd))


def outputs(value):
    return value if isinstance(value, tuple) else (value,)


@functools.lru_cache(maxsize=None)
def jax_model(name, jit=False):
    return symdyn.load(robot(name), "jax", jit=jit)


@pytest.mark.parametrize("name", tiered(MAIN_FIRST, 2))
def test_every_function_on_jax_float64_matches_the_reference_and_numpy(name):
    r = robot(name)
    q, qd, qdd, tau = states(name)
    f, numpy = jax_model(name), symdyn.load(r, "numpy")
    C = ref.coriolis(r, q, qd)
    expected = {
        "tau": tau,
        "M": ref.inertia(r, q),
        "C": C,
        "Cqd": np.einsum("nij,nj->ni", C, qd),
        "G": ref.gravload(r, q),
        "F": ref.friction(r, qd),
        "fdyn": qdd,
    }
    for fn in FUNCTIONS:
        args = arguments(fn, q, qd, qdd, tau)
        got = outputs(getattr(f, fn)(*map(jnp.asarray, args)))
        assert all(isinstance(g, jax.Array) and g.dtype == jnp.float64 for g in got), fn
        for k, (g, e) in enumerate(zip(got, outputs(getattr(numpy, fn)(*args)))):
            assert_close(np.asarray(g), e, f"{name} {fn}[{k}] vs NumPy")
        if fn in expected:
            assert_close(np.asarray(got[0]), expected[fn], f"{name} {fn} vs reference")
    pi = np.array([float(v) for v in parameter_values(r)])
    assert_close(np.asarray(f.Y(q, qd, qdd)) @ pi, tau, f"{name} Y pi")
    assert_close(
        np.einsum("nij,njk->nik", np.asarray(f.Minv(q)), expected["M"]),
        np.broadcast_to(np.eye(r.n), (STATES, r.n, r.n)),
        f"{name} Minv M",
        rtol=1e-10,
    )


@pytest.mark.parametrize("name", ARMS)
def test_float32_in_float32_out_within_its_rounding(name):
    """Every function on float32 (the array-API module on NumPy float32: the same arithmetic as
    on JAX, ~50x cheaper op by op) against float64, in error relative to each output's largest
    entry (printed; docs/functions.md lists them).  JAX float32: test_dtype_follows_the_arguments."""
    q, qd, qdd, tau = states(name)
    xp = symdyn.load(robot(name), "array-api")
    worst = {}
    for fn in FUNCTIONS:
        args = arguments(fn, q, qd, qdd, tau)
        single = outputs(getattr(xp, fn)(*(a.astype(np.float32) for a in args)))
        double = outputs(getattr(xp, fn)(*args))
        assert all(s.dtype == np.float32 for s in single), fn
        worst[fn] = max(
            float(np.max(np.abs(s - d)) / max(1.0, float(np.max(np.abs(d))))) for s, d in zip(single, double)
        )
    print(f"{name} float32 vs float64, worst relative error: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    for fn, err in worst.items():
        assert err < (1e-2 if "fdyn" in fn or fn == "Minv" else 1e-4), f"{name} {fn} float32 error {err:.1e}"


@pytest.mark.parametrize("name", tiered(MAIN_FIRST, 2))
def test_jitted_tau_matches_the_reference(name):
    q, qd, qdd, tau = states(name)
    f = symdyn.load(robot(name), "jax")  # jitted by default
    assert_close(np.asarray(f.tau(q, qd, qdd)), tau, f"{name} jitted tau")


def test_every_function_jits_on_the_two_link_arm():
    """Every function inside one jax.jit (one compile; the loader's own jit: τ of every arm)."""
    q, qd, qdd, tau = (a[:20] for a in states("twolink"))
    f, numpy = jax_model("twolink"), symdyn.load("twolink", "numpy")
    inside = jax.jit(lambda *a: {fn: getattr(f, fn)(*arguments(fn, *a)) for fn in FUNCTIONS})(q, qd, qdd, tau)
    for fn in FUNCTIONS:
        for got, e in zip(outputs(inside[fn]), outputs(getattr(numpy, fn)(*arguments(fn, q, qd, qdd, tau)))):
            assert_close(np.asarray(got), e, f"{fn} in a jit")


SMALL = tiered(["twolink", "random-101"], 1)  # the random arm: make test-all


def jit(function):
    """jax.jit with XLA's own options, as a caller writes it: on these small arms it compiles
    faster with XLA's fusion (the two-link arm's derivatives vs jacfwd: 1.2 s, 3.1 s without).
    One jit per test: op by op, JAX would compile each primitive's shapes."""
    return jax.jit(function)


@pytest.mark.parametrize("name", SMALL)
def test_vmap_of_every_function_equals_the_numpy_batch(name):
    q, qd, qdd, tau = (a[:20] for a in states(name))
    f, numpy = jax_model(name), symdyn.load(robot(name), "numpy")
    mapped = jit(lambda *a: {fn: jax.vmap(getattr(f, fn))(*arguments(fn, *a)) for fn in FUNCTIONS})(q, qd, qdd, tau)
    for fn in FUNCTIONS:
        for g, e in zip(outputs(mapped[fn]), outputs(getattr(numpy, fn)(*arguments(fn, q, qd, qdd, tau)))):
            assert_close(np.asarray(g), e, f"{name} vmap {fn}")


@pytest.mark.parametrize("name", SMALL)
def test_grad_of_every_function_equals_central_differences(name):
    """jax.grad (reverse mode) of a weighted sum of each function's outputs, every argument,
    against central differences of the NumPy target (1e-6: the differences' own error); and of τ
    against the generated derivatives and M (1e-10).  All grads in one jit."""
    q, qd, qdd, tau = (a[5] for a in states(name))  # one state with qd != 0
    f, numpy = jax_model(name), symdyn.load(robot(name), "numpy")
    rng = np.random.default_rng(3)
    cases = {}
    for fn in FUNCTIONS:
        args = arguments(fn, q, qd, qdd, tau)
        cases[fn] = (args, [rng.normal(size=o.shape) for o in outputs(getattr(numpy, fn)(*args))])

    def grads(cases):
        def scalar(fn, weights, *a):
            return sum(jnp.sum(w * o) for w, o in zip(weights, outputs(getattr(f, fn)(*a))))

        return {
            fn: jax.grad(functools.partial(scalar, fn, w), argnums=tuple(range(len(a))))(*a)
            for fn, (a, w) in cases.items()
        }

    got = jit(grads)(cases)
    h = 1e-6
    for fn, (args, weights) in cases.items():

        def value(*a):
            return sum(float(np.sum(w * o)) for w, o in zip(weights, outputs(getattr(numpy, fn)(*a))))

        for k, x in enumerate(args):

            def at(step, k=k):
                return value(*args[:k], args[k] + step, *args[k + 1 :])

            central = np.array([(at(h * e) - at(-h * e)) / (2 * h) for e in np.eye(len(x))])
            assert_close(np.asarray(got[fn][k]), central, f"{name} grad {fn} argument {k}", rtol=1e-6)
    (_, (w,)) = cases["tau"]
    _, dq, dqd = numpy.tau_derivatives(q, qd, qdd)
    for g, jac, what in zip(got["tau"], (dq, dqd, ref.inertia(robot(name), q)), ("q", "qd", "qdd")):
        assert_close(np.asarray(g), w @ jac, f"{name} grad tau wrt {what}", rtol=1e-10)


@pytest.mark.parametrize("name", SMALL)
def test_generated_derivatives_equal_jacfwd(name):
    q, qd, qdd, tau = (jnp.asarray(a) for a in states(name))
    f = jax_model(name)

    def both(q, qd, qdd, tau):
        return (
            (f.tau_derivatives(q, qd, qdd)[1:] + (f.M(q),), jax.vmap(jax.jacfwd(f.tau, (0, 1, 2)))(q, qd, qdd)),
            (f.fdyn_derivatives(q, qd, tau)[1:], jax.vmap(jax.jacfwd(f.fdyn, (0, 1, 2)))(q, qd, tau)),
        )

    for generated, auto in jit(both)(q, qd, qdd, tau):
        for g, a, what in zip(generated, auto, ("q", "qd", "qdd or tau")):
            assert_close(np.asarray(g), np.asarray(a), f"{name} derivative wrt {what} vs jacfwd", rtol=1e-10)


def test_jit_of_vmap_of_jacfwd_of_tau_runs():
    """The issue's 'done means', jax.jit(jax.vmap(jax.jacfwd(f.tau))), with XLA's own options
    (the Panda's compiled in 11 s that way on this machine, docs/functions.md; the two-link arm's here)."""
    f = symdyn.load("twolink", "jax")
    q, qd, qdd, _ = (jnp.asarray(a[:8]) for a in states("twolink"))
    jac = jax.jit(jax.vmap(jax.jacfwd(f.tau)))(q, qd, qdd)
    assert jac.shape == (8, 2, 2)
    assert_close(
        np.asarray(jac), symdyn.load("twolink", "numpy").tau_derivatives(q, qd, qdd)[1], "jit vmap jacfwd", rtol=1e-10
    )


def test_dtype_follows_the_arguments():
    f = jax_model("twolink")
    q32 = jnp.asarray([[0.3, -0.2]], dtype=jnp.float32)
    assert f.M(q32).dtype == jnp.float32
    assert f.tau(q32, q32, q32.astype(jnp.float64)).dtype == jnp.float64  # promoted as the library does
    assert f.M(jnp.asarray([1, 2])).dtype == jnp.float64  # integers: the default float
    np.testing.assert_allclose(
        np.asarray(f.M(jnp.asarray([1, 2]))), ref.inertia(robot("twolink"), [1.0, 2.0]), rtol=1e-14
    )
    xp = symdyn.load("twolink", "array-api")
    out = xp.fdyn_derivatives(*(np.full((3, 2), 0.5, dtype=np.float32),) * 3)
    assert all(isinstance(o, np.ndarray) and o.dtype == np.float32 for o in out)


def test_leading_shapes_broadcast_and_empty_batches_give_empty_outputs():
    f, numpy = symdyn.load("twolink", "jax"), symdyn.load("twolink", "numpy")  # jitted: op by op, new shapes compile
    q, qd, qdd, _ = states("twolink")
    q4 = q[:12].reshape(3, 4, 2)
    got = f.tau(q4, qd[0], qdd[:4])
    assert got.shape == (3, 4, 2)
    assert_close(np.asarray(got), numpy.tau(q4, qd[0], qdd[:4]), "broadcast tau")
    assert f.M(np.zeros((0, 2))).shape == (0, 2, 2)
    assert [o.shape for o in f.fdyn_derivatives(np.zeros((0, 2)), qd[0], qdd[0])] == [
        (0, 2),
        (0, 2, 2),
        (0, 2, 2),
        (0, 2, 2),
    ]
    assert f.G(q[0].tolist()).shape == (2,)  # a list: converted by jax.numpy.asarray


@pytest.mark.parametrize("target", ("jax", "jax-eager", "array-api"))
def test_bad_shapes_and_types_are_value_errors_naming_the_argument(target):
    f = jax_model("twolink") if target == "jax-eager" else symdyn.load("twolink", target)
    q = np.zeros(2)
    with pytest.raises(ValueError, match=r"M\(\): q must have shape \(\.\.\., 2\), got \(3,\)"):
        f.M(np.zeros(3))
    with pytest.raises(ValueError, match=r"G\(\): q must have shape \(\.\.\., 2\), got \(\)"):
        f.G(np.float64(1.0))
    with pytest.raises(ValueError, match=r"tau\(\): the leading shapes .* q \(3,\), qd \(4,\)"):
        f.tau(np.zeros((3, 2)), np.zeros((4, 2)), q)
    with pytest.raises(ValueError, match=r"Cqd\(\): qd is complex"):
        f.Cqd(q, q + 1j)
    with pytest.raises(ValueError, match=r"F\(\): qd must be real numbers"):
        f.F([None] * 2)
    with pytest.raises(TypeError, match="qdd"):
        f.tau(q, q)
    assert_close(np.asarray(f.tau(qdd=q, qd=q, q=q)), ref.rne(robot("twolink"), q, q, q), "tau by name")


def test_nan_in_gives_nan_out_where_the_output_depends_on_it():
    """A traced function cannot raise on values (docs/functions.md): NaN propagates."""
    f = symdyn.load("twolink", "jax")
    q = jnp.asarray([0.3, np.nan])
    assert np.isnan(np.asarray(f.tau(q, jnp.zeros(2), jnp.zeros(2)))).all()
    assert (np.asarray(f.F(jnp.asarray([np.nan, np.nan]))) == 0).all()  # no friction: F is the constant 0
    assert np.isnan(np.asarray(jax_model("puma560").F(jnp.full(6, np.nan)))).all()  # Coulomb: sign(NaN) is NaN
    assert np.isfinite(np.asarray(f.M(jnp.asarray([np.nan, 0.3])))).all()  # M depends on q2 only
    assert np.isnan(np.asarray(f.M(q))[[0, 0, 1], [0, 1, 0]]).all()


def test_the_jit_option_belongs_to_jax():
    with pytest.raises(ValueError, match="jit= is an option of the JAX target"):
        symdyn.load("twolink", "numpy", jit=True)
    assert "jax" in codegen.LOADS and "torch" in codegen.LOADS and "array-api" in codegen.TARGETS
    with pytest.raises(ValueError, match="unknown target 'tensorflow'.*jax, torch"):
        symdyn.load("twolink", "tensorflow")


@pytest.mark.parametrize("name", codegen.SHIPPED)
def test_the_array_api_files_are_headed_and_import_no_array_library(name):
    path = codegen.GENERATED / name / f"{name}_xp.py"
    text = path.read_text()
    assert f"regenerate: symdyn generate {name} --target array-api" in text and "operation counts" in text
    top = [line for line in text.splitlines() if line.startswith(("import ", "from "))]
    assert top == [], "the module imports nothing at its top: its namespace comes from the arguments"


def test_the_core_imports_neither_jax_nor_torch():
    """Only the array-API loaders and the CUDA binding (handing outputs back as the caller's
    arrays) import them, inside functions (extras, never core dependencies)."""
    package = codegen.GENERATED.parent / "symdyn"
    found = {
        path.relative_to(package).as_posix(): re.findall(
            r"^( *)(?:import|from) (jax|torch|array_api_compat)\b", path.read_text(), re.M
        )
        for path in package.rglob("*.py")
    }
    found = {path: imports for path, imports in found.items() if imports}
    assert sorted(found) == ["codegen/emit/array_api.py", "codegen/emit/cudalib.py"], found
    assert all(indent for imports in found.values() for indent, _ in imports), "imported at the module's top"


def test_without_array_api_compat_the_arrays_own_namespace_serves(monkeypatch):
    """JAX arrays and NumPy ≥ 2 arrays carry __array_namespace__: array-api-compat is needed for PyTorch only."""
    import sys

    monkeypatch.setitem(sys.modules, "array_api_compat", None)  # import array_api_compat → ImportError
    xp = symdyn.load("twolink", "array-api")
    q, qd, qdd, tau = (a[:3] for a in states("twolink"))
    assert_close(xp.tau(q, qd, qdd), tau, "NumPy's own namespace")
    assert_close(np.asarray(xp.tau(jnp.asarray(q), qd, qdd)), tau, "jax.numpy's own namespace, NumPy beside it")


@pytest.mark.parametrize("target", ("array-api", "jax"))
def test_an_edited_array_api_file_is_an_error_that_says_how_to_regenerate(tmp_path, target):
    text = (codegen.GENERATED / "twolink" / "twolink_xp.py").read_text()
    (tmp_path / "twolink_xp.py").write_text(text.replace("0.25", "0.26", 1))
    with pytest.raises(RuntimeError, match=r"twolink_xp.py was modified.*symdyn generate twolink"):
        symdyn.load("twolink", target, folder=tmp_path)
    with pytest.raises(FileNotFoundError, match="--target array-api"):
        symdyn.load("twolink", target, folder=tmp_path / "none")


def test_a_symbolic_model_takes_its_parameters_last():
    """The two-link arm with symbolic parameters: p = its free symbols, sorted by name, last."""
    arm = arms.load("twolink", symbolic=True)
    xp = symdyn.load(arm, "array-api")
    values = {"a1": 1.0, "a2": 0.8, "c1": -0.5, "c2": -0.3, "g": 9.81, "m1": 1.2, "m2": 0.7}
    p = np.array([values[str(s)] for s in sorted(arm.free_symbols, key=str)])
    q = np.array([[0.3, -0.7], [1.1, 0.4]])
    assert_close(xp.tau(q, -q, 2 * q, p), ref.rne(arm.subs(values), q, -q, 2 * q), "symbolic twolink tau")
    assert_close(xp.fdyn(q, -q, xp.tau(q, -q, 2 * q, p), p), 2 * q, "symbolic twolink fdyn")
