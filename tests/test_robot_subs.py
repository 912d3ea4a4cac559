"""`Robot.subs` reaches every field that can hold a symbol (issue 44, defect 1): after substituting
every free symbol, none is left — the links', gravity's, the base's, the tool's and a floating
base's body's — and the values land where the symbols were."""

import dataclasses

import numpy as np
import pytest
import sympy as sp

from symdyn.model import Link
from symdyn.model.random_robots import random_tree_robot


def _symbolic(seed: int, base_joint):
    """A random tree whose every numeric parameter of one link, of the base body, of gravity
    and of the tool's offset is a symbol; (robot, {symbol: value})."""
    robot = random_tree_robot(seed, n=3, base_joint=base_joint)
    values = {}

    def sym(name, value):
        s = sp.Symbol(name, real=True)
        values[s] = value
        return s

    link = robot.links[0]
    links = (dataclasses.replace(link, m=sym("m1", float(link.m)), B=sym("B1", 0.1)),) + robot.links[1:]
    tool = tuple(tuple(row) for row in robot.tool)
    tool = tool[:2] + ((*tool[2][:3], sym("d_tool", 0.05)),) + tool[3:]
    gravity = (0, 0, sym("g", 9.81))
    changes = dict(links=links, tool=tool, gravity=gravity)
    if base_joint is not None:
        body = robot.base_body
        changes["base_body"] = Link(m=sym("m0", float(body.m)), r=(sym("x0", 0.01), 0, 0), I=body.I)
    return dataclasses.replace(robot, **changes), values


@pytest.mark.parametrize("base_joint", [None, "free", "planar"])
@pytest.mark.parametrize("seed", range(4))
def test_substituting_every_free_symbol_leaves_none(seed, base_joint):
    robot, values = _symbolic(seed, base_joint)
    assert robot.free_symbols == frozenset(values)
    numeric = robot.subs(values)
    assert not numeric.is_symbolic, numeric.free_symbols
    assert numeric.tool[2][3] == pytest.approx(0.05) and numeric.gravity[2] == pytest.approx(9.81)
    if base_joint is not None:
        assert float(numeric.base_body.m) == pytest.approx(values[sp.Symbol("m0", real=True)])
        assert float(numeric.base_body.r[0]) == pytest.approx(0.01)
    numeric.require_numeric()  # what every numeric consumer asks first
    assert np.isfinite(float(numeric.links[0].m))


def test_substituting_the_base_bodys_mass_by_name():
    robot, values = _symbolic(1, "free")
    partial = robot.subs({"m0": 2.0})
    assert float(partial.base_body.m) == 2.0
    assert sp.Symbol("m0", real=True) not in partial.free_symbols
