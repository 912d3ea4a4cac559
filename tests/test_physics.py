"""Physics and conventions the reference must obey (rung 4 of the ladder in DESIGN.md).

Identities that hold for any arm (M symmetric positive definite, Ṁ − 2C
skew-symmetric, τ(q, 0, 0) = G(q), energy conserved without friction and
torque, dissipated by viscous friction) and the Toolbox conventions (friction
law with negative gear ratios, rotor inertia, gravity, payload), checked
against numbers computed here from the published parameter table.
"""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from conftest import random_states
from symdyn import models
from symdyn.model import rotx
from symdyn.numeric import reference as ref

ROBOTS = ["puma560", "puma560_mdh", "twolink", "rrp"]
PUMA_TABLE = json.loads((Path(__file__).parents[1] / "symdyn/model/arms/data/puma560_params.json").read_text())


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    return models.load(request.param)


# --------------------------------------------------------------------------- identities


def test_mass_matrix_is_symmetric_positive_definite(robot):
    q, _, _ = random_states(robot, 200, seed=1)
    M = ref.inertia(robot, q)
    assert np.abs(M - np.swapaxes(M, -1, -2)).max() <= 1e-13 * np.abs(M).max()
    assert np.linalg.eigvalsh(M).min() > 0


def test_mdot_minus_2c_is_skew_symmetric(robot):
    """Ṁ by central differences along q̇: Ṁ ≈ (M(q + hq̇) − M(q − hq̇)) / 2h."""
    q, qd, _ = random_states(robot, 200, seed=2)
    h = 1e-5
    Mdot = (ref.inertia(robot, q + h * qd) - ref.inertia(robot, q - h * qd)) / (2 * h)
    S = Mdot - 2 * ref.coriolis(robot, q, qd)
    assert np.abs(S + np.swapaxes(S, -1, -2)).max() <= 1e-7 * np.abs(Mdot).max()
    assert np.abs(S).max() > 1e-3 * np.abs(Mdot).max()  # the identity is not vacuous


def test_inverse_dynamics_at_rest_is_gravity_load(robot):
    q, _, _ = random_states(robot, 200, seed=3)
    zero = np.zeros_like(q)
    G = ref.gravload(robot, q)
    assert np.abs(ref.rne(robot, q, zero, zero) - G).max() <= 1e-13 * np.abs(G).max()
    assert np.abs(G).max() > 1.0


def _energy(robot, q, qd):
    kinetic, potential = ref.energy(robot, q, qd)
    return kinetic + potential


@pytest.mark.parametrize(
    "name, q0, qd0, tol",
    [
        ("puma560", [0.0, 0.8, -2.5, 0.0, 0.5, 0.0], [0.2, -0.2, 0.2, 0.5, -0.5, 0.5], 1e-8),
        ("twolink", [-1.2, 0.3], [0.3, -0.2], 1e-7),  # drifts ~1e-9 at this tolerance
    ],
)
def test_energy_is_conserved_without_friction_or_torque(name, q0, qd0, tol):
    robot = models.load(name).nofriction(all=True)
    t, q, qd = ref.fdyn(robot, 2.0, q0, qd0, t_eval=np.linspace(0, 2, 41), rtol=tol, atol=tol)
    E = _energy(robot, q, qd)
    kinetic = ref.energy(robot, q, qd)[0]
    assert t[-1] == 2.0 and kinetic.max() > 1.0  # the arm really moves
    assert np.abs(E - E[0]).max() <= 1e-6 * np.abs(E).max()


def test_viscous_friction_dissipates_energy_monotonically():
    """Puma with viscous friction only (Coulomb removed): dE/dt = −q̇ᵀ G²B q̇ ≤ 0."""
    robot = models.load("puma560").nofriction()
    t, q, qd = ref.fdyn(
        robot,
        1.0,
        [0.0, 0.8, -2.5, 0.0, 0.5, 0.0],
        [0.2, -0.2, 0.2, 0.5, -0.5, 0.5],
        t_eval=np.linspace(0, 1, 21),
        rtol=1e-8,
        atol=1e-8,
    )
    E = _energy(robot, q, qd)
    assert np.all(np.diff(E) <= 1e-9 * np.abs(E).max())
    assert E[0] - E[-1] > 1.0


# --------------------------------------------------------------------------- conventions


def _table_friction(qd):
    """Friction of the Puma from the JSON table: G²·B·q̇ + |G|·Tc⁺ / |G|·Tc⁻ / 0."""
    out = []
    for link, v in zip(PUMA_TABLE["links"], qd):
        G = link["G"]
        coulomb = link["Tc_plus"] if v > 0 else link["Tc_minus"] if v < 0 else 0.0
        out.append(G * G * link["B"] * v + abs(G) * coulomb)
    return np.array(out)


@pytest.mark.parametrize(
    "qd",
    [
        [0.7, -0.7, 0.3, -0.2, 0.0, 1.1],
        [-0.7, 0.7, -0.3, 0.2, 1e-9, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ],
)
def test_friction_law_with_negative_gear_ratios(puma, qd):
    qd = np.array(qd)
    assert puma.links[0].G == -62.6111 and puma.links[2].G < 0
    expected = _table_friction(qd)
    assert np.allclose(ref.friction(puma, qd), expected, rtol=1e-14, atol=0)
    q, zero = puma.qn, np.zeros(6)
    assert np.allclose(
        ref.rne(puma, q, qd, zero) - ref.rne(puma.nofriction(all=True), q, qd, zero), expected, rtol=1e-9, atol=1e-12
    )
    assert np.all(ref.friction(puma, qd)[qd == 0] == 0.0)


def test_joint_one_friction_values(puma):
    """Joint 1 (G = −62.6111): +0.5 rad/s gives G²B·0.5 + |G|·0.395; −0.5 gives −G²B·0.5 − |G|·0.435."""
    G, B = 62.6111, 0.00148
    F = ref.friction(puma, np.array([[0.5, 0, 0, 0, 0, 0], [-0.5, 0, 0, 0, 0, 0]]))[:, 0]
    assert F[0] == pytest.approx(G * G * B * 0.5 + G * 0.395, rel=1e-14)
    assert F[1] == pytest.approx(-G * G * B * 0.5 - G * 0.435, rel=1e-14)


def test_nofriction_removes_coulomb_then_viscous(puma):
    qd = np.array([0.7, -0.7, 0.3, -0.2, 0.5, -1.1])
    viscous = np.array([l["G"] ** 2 * l["B"] for l in PUMA_TABLE["links"]]) * qd
    assert np.allclose(ref.friction(puma.nofriction(), qd), viscous, rtol=1e-14, atol=0)
    assert np.all(ref.friction(puma.nofriction(all=True), qd) == 0.0)
    assert np.abs(ref.friction(puma, qd) - viscous).min() > 1e-3  # Coulomb was there


def test_rotor_inertia_is_on_the_diagonal_of_M(puma):
    no_rotor = dataclasses.replace(puma, links=tuple(dataclasses.replace(l, Jm=0) for l in puma.links))
    q, _, _ = random_states(puma, 50, seed=4)
    diff = ref.inertia(puma, q) - ref.inertia(no_rotor, q)
    rotor = np.array([l["G"] ** 2 * l["Jm"] for l in PUMA_TABLE["links"]])
    assert np.allclose(diff, np.diag(rotor), rtol=1e-12, atol=1e-13)


def test_puma_total_mass_and_base_wrench_at_rest_carries_its_weight(puma):
    mass = sum(l.m for l in puma.links)
    assert mass == pytest.approx(PUMA_TABLE["total_mass"]) and mass == pytest.approx(23.45)
    q, _, _ = random_states(puma, 20, seed=5)
    zero = np.zeros_like(q)
    _, wrench = ref.rne(puma, q, zero, zero, base_wrench=True)
    assert np.allclose(wrench[:, :3], [0, 0, 23.45 * 9.81], rtol=1e-12, atol=1e-9)
    upside = dataclasses.replace(puma, base=rotx(math.pi))
    _, wrench = ref.rne(upside, q, zero, zero, base_wrench=True)
    assert np.allclose(wrench[:, :3], [0, 0, -23.45 * 9.81], rtol=1e-12, atol=1e-9)


def test_puma_mdh_has_the_same_dynamics_as_standard(puma):
    mdh = models.load("puma560_mdh")
    assert mdh.convention == "modified"
    q, qd, qdd = random_states(puma, 200, seed=6)
    for f, args in ((ref.rne, (q, qd, qdd)), (ref.inertia, (q,)), (ref.gravload, (q,))):
        a, b = f(puma, *args), f(mdh, *args)
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max(), f.__name__
    assert np.allclose(ref.fkine(puma, q), ref.fkine(mdh, q), rtol=0, atol=1e-14)


def test_puma_gravity_load_at_qz_is_the_textbook_value(puma):
    """MATLAB RTB `p560.gravload(qz)` = [0 37.4837 0.2489 0 0 0] N·m (Pinocchio agrees to 1e-14)."""
    G = ref.gravload(puma, puma.qz)
    assert np.allclose(G, [0, 37.4837, 0.2489, 0, 0, 0], rtol=0, atol=5e-5)


def test_upside_down_base_flips_the_gravity_load(puma):
    q, _, _ = random_states(puma, 50, seed=7)
    upside = dataclasses.replace(puma, base=rotx(math.pi))
    G = ref.gravload(puma, q)
    assert np.allclose(ref.gravload(upside, q), -G, rtol=0, atol=1e-13 * np.abs(G).max())
    moon = dataclasses.replace(upside, gravity=(0, 0, 1.62))
    assert np.allclose(ref.gravload(moon, q), -G * 1.62 / 9.81, rtol=0, atol=1e-13 * np.abs(G).max())
