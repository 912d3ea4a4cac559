"""Forward mode in vectors (`symdyn.codegen.tangents`): the C the plan emits gives sympy's Jacobian of
a small branched program exactly as its partials are evaluated, with the vector types and with the
plain-C lane loop; the pattern is the Jacobian's structure."""

import ctypes
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from symdyn.codegen.tangents import LANES, plan

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")


def _program():
    """Two branches on a shared root, as a tree's legs on a base: a and b move the root, x1, x2 the
    first branch, y1 the second; more than one vector of directions."""
    a, b, x1, x2, y1 = sp.symbols("a b x1 x2 y1", real=True)
    s1, s2, s3, s4, s5 = sp.symbols("s1:6", real=True)
    defs = [
        (s1, sp.sin(a) * b),
        (s2, s1 * x1 + sp.cos(x2)),
        (s3, s2 * s2 - 3 * x2),
        (s4, s1 + y1**2),
        (s5, s3 * s4),
    ]
    outputs = [s3 + s1, s4, s5 / 2, x1 - 7]
    groups = [[a, b], [x1, x2], [y1]]
    return defs, outputs, groups


def _compiled(tmp_path, source: str, name: str):
    c = tmp_path / f"{name}.c"
    c.write_text("#include <string.h>\n" + source)
    so = tmp_path / f"{name}.so"
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(so), str(c)], check=True)
    return getattr(ctypes.CDLL(str(so)), name.split("__")[0])


@pytest.mark.parametrize("vectors", [True, False], ids=["vector types", "lane loop"])
def test_the_plans_c_gives_the_jacobian(tmp_path, vectors):
    defs, outputs, groups = _program()
    wrt = [x for g in groups for x in g]
    p = plan(defs, outputs, groups)
    assert max(p.lanes.values()) >= LANES  # the branches start vectors of their own
    columns = {x: k for k, x in enumerate(wrt)}
    source = p.c_source("tangents", columns, len(wrt)).replace("static void", "void")
    if not vectors:  # what a compiler without GCC's vector types runs
        source = source.replace("defined(__GNUC__)", "defined(SYMDYN_NO_VECTORS_)")
    f = _compiled(tmp_path, source, "tangents")
    point = dict(zip(wrt, np.random.default_rng(3).uniform(-1, 1, len(wrt))))
    values = dict(point)
    for s, e in defs:
        values[s] = float(e.xreplace(values))
    partials = np.array([float(sp.sympify(v).xreplace(values)) for v in p.values] or [0.0])
    R = np.full(len(outputs) * len(wrt), np.nan)
    f(partials.ctypes.data_as(ctypes.c_void_p), R.ctypes.data_as(ctypes.c_void_p))
    full = dict(defs)
    expanded = [sp.sympify(o) for o in outputs]
    for _ in defs:
        expanded = [e.xreplace(full) for e in expanded]
    want = np.array([[float(sp.diff(e, x).xreplace(point)) for x in wrt] for e in expanded])
    got = R.reshape(len(outputs), len(wrt))
    pattern = p.pattern(columns)
    for i in range(len(outputs)):
        for k in range(len(wrt)):
            if (i, k) in pattern:
                assert got[i, k] == pytest.approx(want[i, k], rel=1e-13, abs=1e-13)
            else:  # structurally zero: left untouched or an exact zero of its vector
                assert (np.isnan(got[i, k]) or got[i, k] == 0.0) and want[i, k] == 0
    assert (3, columns[wrt[2]]) in pattern and (1, columns[wrt[2]]) not in pattern  # x1 reaches s5, not s4
