"""The array-API target on PyTorch: every function against the NumPy target and the reference,
float32, the tensors' device kept, autograd and torch.func (jacrev, vmap) against the generated
derivatives, torch.compile, bad shapes (docs/functions.md, "JAX, PyTorch and the array API").

Marked `torch`: the main suite deselects these (pyproject.toml's addopts) and `make test-torch`
installs the torch extra and runs them.  torch is imported by a fixture, so that collecting this
file without it is no error.
"""

import functools

import numpy as np
import pytest

import symdyn
from symdyn.codegen import entry as codegen
from symdyn.derivation.regressor import parameter_values
from symdyn.model import arms
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref
from tests.codegen_cases import assert_close
from tests.conftest import random_states

pytestmark = pytest.mark.torch

ARMS = {name: functools.partial(arms.load, name) for name in codegen.SHIPPED}
ARMS["random-101"] = functools.partial(random_arm, 101, ArmOptions(n_max=4))
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "F", "fdyn", "Y", "tau_derivatives", "fdyn_derivatives", "Minv")
STATES = 200


@pytest.fixture(scope="module")
def torch():
    import torch

    return torch


@functools.lru_cache(maxsize=None)
def robot(name):
    return ARMS[name]()


@functools.lru_cache(maxsize=None)
def states(name):
    r = robot(name)
    q, qd, qdd = random_states(r, STATES, seed=26)
    qd[:5] = 0.0
    return q, qd, qdd, ref.rne(r, q, qd, qdd)


def arguments(f, q, qd, qdd, tau):
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


@pytest.mark.parametrize("name", ARMS)
def test_every_function_on_torch_float64_matches_numpy_and_the_reference(torch, name):
    r = robot(name)
    q, qd, qdd, tau = states(name)
    f, numpy = symdyn.load(r, "torch"), symdyn.load(r, "numpy")
    worst32 = {}
    for fn in FUNCTIONS:
        args = arguments(fn, q, qd, qdd, tau)
        got = outputs(getattr(f, fn)(*(torch.from_numpy(a) for a in args)))
        single = outputs(getattr(f, fn)(*(torch.from_numpy(a.astype(np.float32)) for a in args)))
        for k, (g, s, e) in enumerate(zip(got, single, outputs(getattr(numpy, fn)(*args)))):
            assert isinstance(g, torch.Tensor) and g.dtype == torch.float64 and s.dtype == torch.float32
            assert_close(g.numpy(), e, f"{name} {fn}[{k}] vs NumPy")
            worst32[fn] = max(worst32.get(fn, 0.0), float(np.max(np.abs(s.numpy() - e)) / max(1.0, np.max(np.abs(e)))))
    print(f"{name} torch float32 vs float64: " + ", ".join(f"{k} {v:.1e}" for k, v in worst32.items()))
    assert_close(f.tau(*map(torch.from_numpy, (q, qd, qdd))).numpy(), tau, f"{name} tau vs reference")
    assert_close(f.fdyn(*map(torch.from_numpy, (q, qd, tau))).numpy(), qdd, f"{name} fdyn vs reference")
    pi = np.array([float(v) for v in parameter_values(r)])
    assert_close(f.Y(q, qd, qdd).numpy() @ pi, tau, f"{name} Y pi")


@pytest.mark.parametrize("name", ("twolink", "puma560", "random-101"))
def test_autograd_and_jacrev_equal_the_generated_derivatives(torch, name):
    from torch.func import jacrev, vmap

    q, qd, qdd, tau = (torch.from_numpy(a) for a in states(name))
    f = symdyn.load(robot(name), "torch")
    _, dq, dqd = f.tau_derivatives(q, qd, qdd)
    jac = vmap(jacrev(f.tau, argnums=(0, 1, 2)))(q, qd, qdd)
    for got, auto, what in ((dq, jac[0], "dtau_dq"), (dqd, jac[1], "dtau_dqd"), (f.M(q), jac[2], "M")):
        assert_close(got.numpy(), auto.numpy(), f"{name} {what} vs jacrev", rtol=1e-10)
    _, dq, dqd, Minv = f.fdyn_derivatives(q, qd, tau)
    jac = vmap(jacrev(f.fdyn, argnums=(0, 1, 2)))(q, qd, tau)
    for got, auto, what in ((dq, jac[0], "dqdd_dq"), (dqd, jac[1], "dqdd_dqd"), (Minv, jac[2], "Minv")):
        assert_close(got.numpy(), auto.numpy(), f"{name} {what} vs jacrev", rtol=1e-10)
    q = q.clone().requires_grad_(True)
    w = torch.randn(q.shape, dtype=q.dtype, generator=torch.Generator().manual_seed(0))
    (f.tau(q, qd, qdd) * w).sum().backward()
    assert_close(
        q.grad.numpy(),
        torch.einsum("ni,nij->nj", w, f.tau_derivatives(q.detach(), qd, qdd)[1]).numpy(),
        f"{name} autograd tau wrt q",
        rtol=1e-10,
    )


def test_vmap_of_every_function_equals_the_batch(torch):
    from torch.func import vmap

    q, qd, qdd, tau = (torch.from_numpy(a[:20]) for a in states("twolink"))
    f = symdyn.load("twolink", "torch")
    for fn in FUNCTIONS:
        args = arguments(fn, q, qd, qdd, tau)
        for g, e in zip(outputs(vmap(getattr(f, fn))(*args)), outputs(getattr(f, fn)(*args))):
            assert_close(g.numpy(), e.numpy(), f"vmap {fn}", rtol=1e-14)


def test_torch_compile_gives_the_eager_values(torch):
    q, qd, qdd, tau = (torch.from_numpy(a[:50]) for a in states("twolink"))
    f = symdyn.load("twolink", "torch")
    compiled = torch.compile(f.fdyn_derivatives)
    for g, e in zip(compiled(q, qd, tau), f.fdyn_derivatives(q, qd, tau)):
        assert_close(g.numpy(), e.numpy(), "torch.compile fdyn_derivatives", rtol=1e-13)


def test_device_and_dtype_are_kept(torch):
    """On the `meta` device (shapes, no data): the outputs stay there; on CUDA when it is seen."""
    f = symdyn.load("puma560", "torch")
    devices = ["meta"] + (["cuda"] if torch.cuda.is_available() else [])
    for device in devices:
        for dtype in (torch.float32, torch.float64):
            q = torch.zeros((5, 6), dtype=dtype, device=device)
            for out in f.fdyn_derivatives(q, q, q) + (f.Y(q, q, q), f.F(q)):
                assert out.device.type == device and out.dtype == dtype


def test_bad_shapes_are_value_errors_naming_the_argument(torch):
    f = symdyn.load("puma560", "torch")
    with pytest.raises(ValueError, match=r"M\(\): q must have shape \(\.\.\., 6\), got \(5,\)"):
        f.M(torch.zeros(5))
    with pytest.raises(ValueError, match=r"tau\(\): the leading shapes .* q \(3,\), qd \(4,\)"):
        f.tau(torch.zeros(3, 6), torch.zeros(4, 6), torch.zeros(6))
    with pytest.raises(ValueError, match=r"Cqd\(\): qd is complex"):
        f.Cqd(torch.zeros(6), torch.zeros(6, dtype=torch.complex128))
    assert np.isnan(f.tau(torch.full((6,), float("nan")), torch.zeros(6), torch.zeros(6)).numpy()).all()


def test_numpy_arrays_beside_tensors_become_tensors_and_other_libraries_are_refused(torch):
    import jax.numpy as jnp

    xp = symdyn.load("puma560", "array-api")
    q, qd, qdd, tau = (a[:4] for a in states("puma560"))
    got = xp.tau(torch.from_numpy(q), qd, qdd)
    assert isinstance(got, torch.Tensor)
    assert_close(got.numpy(), tau, "tensor with NumPy arrays beside it")
    with pytest.raises(ValueError, match=r"tau\(\): the arguments are arrays of different libraries: q torch"):
        xp.tau(torch.from_numpy(q), jnp.asarray(qd), qdd)
