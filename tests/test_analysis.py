"""The chapter-9 analyses agree with the reference, with hand formulas and with the model data."""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from symdyn.apps import analysis as A
from symdyn.model import transl
from symdyn.numeric import reference as ref

DATA = Path(__file__).resolve().parents[1] / "symdyn" / "model" / "arms" / "data"


def puma_json():
    return json.loads((DATA / "puma560_params.json").read_text())


# --------------------------------------------------------------------------- model functions


@pytest.mark.parametrize("backend", ["auto", "reference"])
def test_model_functions_bias_is_coriolis_plus_gravity_without_friction(puma, backend):
    from conftest import random_states

    q, qd, _ = random_states(puma, 5, seed=1)
    f = A.model_functions(puma, backend)
    expected = np.einsum("nij,nj->ni", ref.coriolis(puma, q, qd), qd) + ref.gravload(puma, q)
    np.testing.assert_allclose(f.Cqd(q, qd) + f.G(q), expected, atol=1e-10)


def test_model_functions_use_generated_code_for_the_puma_and_the_reference_for_a_variant(puma):
    assert A.model_functions(puma).source.startswith("generated c")
    assert A.model_functions(A.inverted(puma)).source.startswith("symdyn.reference")


def test_model_functions_refuses_a_symbolic_robot():
    from symdyn import models

    with pytest.raises(ValueError, match="symbolic"):
        A.model_functions(models.load("twolink", symbolic=True))


# --------------------------------------------------------------------------- gravity load


def test_gravity_map_grid_points_equal_reference_gravload(puma):
    sweep = A.gravity_load_map(puma, resolution=9)
    assert sweep.values.shape == (9, 9, 2) and sweep.labels == ("G2", "G3")
    for i, j in [(0, 0), (3, 7), (8, 2), (4, 4)]:
        q = np.zeros(6)
        q[1], q[2] = sweep.axes[0][i], sweep.axes[1][j]
        np.testing.assert_allclose(sweep.values[i, j], ref.gravload(puma, q)[[1, 2]], atol=1e-12)


def test_gravity_map_extremes_are_the_grid_extremes(puma):
    sweep = A.gravity_load_map(puma, resolution=15)
    g2 = sweep.extremes()[0]
    assert g2.max == sweep.values[..., 0].max() and g2.min == sweep.values[..., 0].min()
    q = np.zeros(6)
    q[1], q[2] = g2.argmax
    assert ref.gravload(puma, q)[1] == pytest.approx(g2.max, abs=1e-12)
    # joint 2 holds both arm links: the extreme is of the order (m2·|r2| + m3·a2)·g
    assert 30 < g2.max < 60


def test_lunar_gravity_scales_the_load_by_the_gravity_ratio(puma):
    earth = A.gravity_load_map(puma, resolution=7).values
    moon = A.gravity_load_map(A.with_gravity(puma, A.LUNAR_GRAVITY), resolution=7).values
    np.testing.assert_allclose(moon, earth * 1.62 / 9.81, rtol=1e-12, atol=1e-13)


def test_inverted_base_flips_the_sign_of_the_gravity_load(puma):
    upright = A.gravity_load_map(puma, resolution=7, loads=(1, 2, 3, 4)).values
    hanging = A.gravity_load_map(A.inverted(puma), resolution=7, loads=(1, 2, 3, 4)).values
    np.testing.assert_allclose(hanging, -upright, atol=1e-12)


def test_with_gravity_rejects_a_negative_magnitude(puma):
    with pytest.raises(ValueError, match="gravity magnitude"):
        A.with_gravity(puma, -1.0)


# --------------------------------------------------------------------------- inertia variation


def test_inertia_map_points_equal_reference_inertia(puma):
    sweep = A.inertia_map(puma, resolution=6)
    q = np.zeros(6)
    q[1], q[2] = sweep.axes[0][2], sweep.axes[1][5]
    M = ref.inertia(puma, q)
    np.testing.assert_allclose(sweep.values[2, 5], [M[0, 0], M[0, 1]], atol=1e-12)


def test_puma_M22_depends_on_q3_only(puma):
    sweep = A.inertia_map(puma, elements=((1, 1),), resolution=11)
    np.testing.assert_allclose(sweep.values, np.broadcast_to(sweep.values[:1], sweep.values.shape), atol=1e-12)
    curve = A.inertia_curve(puma, resolution=11)
    np.testing.assert_allclose(curve.values[:, 0], sweep.values[0, :, 0], atol=1e-12)


def test_extreme_ratio_is_max_over_min_and_nan_across_zero():
    sweep = A.Sweep((1,), (np.array([0.0, 1.0, 2.0]),), np.array([[2.0, -1.0], [5.0, 0.5], [4.0, 3.0]]), ("a", "b"))
    a, b = sweep.extremes()
    assert (a.min, a.argmin, a.max, a.argmax) == (2.0, (0.0,), 5.0, (1.0,))
    assert a.ratio == 2.5
    assert (b.min, b.max) == (-1.0, 3.0) and math.isnan(b.ratio)


# --------------------------------------------------------------------------- payload


def point_jacobian(robot, q, p):
    """Translational Jacobian (3, n) of a point p fixed in the last link (independent of payload code)."""
    return ref.jacob0(dataclasses.replace(robot, tool=transl(*p)), q)[:3]


@pytest.mark.parametrize("additive", [False, True])
def test_payload_changes_M_and_G_by_the_point_mass_terms(puma, additive):
    m, p, q = 2.5, (0.0, 0.0, 0.1), puma.qn
    effect = A.payload_effect(puma, m, p, q, additive=additive)
    Jp = point_jacobian(puma, q, p)
    dM = m * Jp.T @ Jp
    dG = m * Jp.T @ np.array([0, 0, 9.81])
    if not additive:  # the book's payload replaces the last link's mass m6 at r6 (its inertia tensor is kept)
        last = puma.links[-1]
        Jc = point_jacobian(puma, q, last.r)
        dM -= last.m * Jc.T @ Jc
        dG -= last.m * Jc.T @ np.array([0, 0, 9.81])
    np.testing.assert_allclose(effect.M1 - effect.M0, dM, atol=1e-12)
    np.testing.assert_allclose(effect.G1 - effect.G0, dG, atol=1e-12)
    np.testing.assert_allclose(effect.M0, ref.inertia(puma, q), atol=1e-14)


def test_payload_ratio_is_elementwise_and_nan_where_unloaded_is_zero(puma):
    effect = A.payload_effect(puma, 2.5, (0, 0, 0.1), puma.qn)
    G0 = ref.gravload(puma, puma.qn)
    assert effect.G_ratio[1] == pytest.approx(effect.G1[1] / G0[1], rel=1e-14)
    assert math.isnan(effect.G_ratio[0])  # no gravity load on joint 1
    assert effect.M_ratio[0, 0] == pytest.approx(effect.M1[0, 0] / effect.M0[0, 0], rel=1e-14)


# --------------------------------------------------------------------------- base wrench


def test_total_mass_matches_the_model_data(puma):
    assert A.total_mass(puma) == pytest.approx(puma_json()["total_mass"], abs=1e-9)


def test_static_base_wrench_is_the_weight_and_its_moment(puma):
    q = np.array([0.3, 0.7, -1.2, 0.4, 0.9, -0.5])
    W = A.base_wrench(puma, q)
    weight = np.array([0, 0, 9.81])
    moment = np.zeros(3)
    for i, link in enumerate(puma.links):  # COM of link i from forward kinematics of the chain up to it
        arm = dataclasses.replace(puma, links=puma.links[: i + 1], tool=transl(*link.r), poses={})
        moment += np.cross(ref.fkine(arm, q[: i + 1])[:3, 3], link.m * weight)
    np.testing.assert_allclose(W[:3], A.total_mass(puma) * weight, atol=1e-10)
    np.testing.assert_allclose(W[3:], moment, atol=1e-10)


# --------------------------------------------------------------------------- manipulability


def test_asada_measure_of_the_twolink_arm_by_hand(twolink):
    q = np.array([0.0, math.pi / 2])
    # point masses 1 kg at 0.5 m from each joint, links 1 m: M at q2 = 90°
    M = np.array([[0.25 + 1.0 + 0.25, 0.25], [0.25, 0.25]])
    # tip velocity in the world x–z plane: x = c1 + c12, z = s1 + s12
    J = np.array([[-1.0, -1.0], [1.0, 0.0]])
    Ji = np.linalg.inv(J)
    eig = np.linalg.eigvalsh(Ji.T @ M @ Ji)
    assert A.dynamic_manipulability(twolink, q, axes=(0, 2)) == pytest.approx(eig[0] / eig[1], rel=1e-12)
    radii = np.sqrt(np.linalg.eigvalsh(J @ np.linalg.inv(M) @ np.linalg.inv(M).T @ J.T))
    np.testing.assert_allclose(A.acceleration_ellipsoid(twolink, q, axes=(0, 2)).radii, radii, rtol=1e-12)


def test_full_axis_cartesian_inertia_inverts_the_operational_mobility(puma):
    q = puma.qn
    J = ref.jacob0(puma, q)
    mobility = J @ np.linalg.solve(ref.inertia(puma, q), J.T)
    np.testing.assert_allclose(A.cartesian_inertia(puma, q, "all") @ mobility, np.eye(6), atol=1e-8)


def test_manipulability_is_batched_and_in_unit_interval(puma):
    from conftest import random_states

    q = random_states(puma, 4, seed=3)[0]
    values = A.dynamic_manipulability(puma, q)
    assert values.shape == (4,) and np.all((values > 0) & (values <= 1))
    assert values[2] == pytest.approx(A.dynamic_manipulability(puma, q[2]), rel=1e-12)


def test_ellipsoid_radius_is_the_largest_acceleration_along_its_axis(puma):
    q = puma.qn
    e = A.acceleration_ellipsoid(puma, q)
    JMi = ref.jacob0(puma, q)[:3] @ np.linalg.inv(ref.inertia(puma, q))
    for k in range(3):
        # max over unit τ of axisᵀ J M⁻¹ τ is ‖axisᵀ J M⁻¹‖
        assert e.radii[k] == pytest.approx(np.linalg.norm(e.axes[:, k] @ JMi), rel=1e-10)
    x, y, z = e.surface(points=8)
    assert x.shape == (8, 8)


def test_unknown_axes_are_named(puma):
    with pytest.raises(ValueError, match="sideways"):
        A.dynamic_manipulability(puma, puma.qn, axes="sideways")


# --------------------------------------------------------------------------- joint dynamics


def test_joint_transfer_function_counts_the_rotor_once(puma):
    data = puma_json()["links"]
    q = puma.qn
    tf = A.joint_transfer_functions(puma, q)
    M = ref.inertia(puma, q)
    for j, link in enumerate(data):
        G, Jm = link["G"], link["Jm"]
        assert tf.J[j] == pytest.approx(Jm + (M[j, j] - G**2 * Jm) / G**2, rel=1e-12)
        assert tf.J[j] == pytest.approx(M[j, j] / G**2, rel=1e-12)  # the rotor once, not twice
        assert tf.B[j] == link["B"]
    # joint 6: the link inertia about its own axis is Izz6 + m6·(rx² + ry²) = 4e-5 at any pose
    last = data[5]
    Izz = last["I_vec_Ixx_Iyy_Izz_Ixy_Iyz_Ixz"][2]
    assert tf.J[5] == pytest.approx(last["Jm"] + Izz / last["G"] ** 2, rel=1e-9)
    assert tf.pole[1] == pytest.approx(-data[1]["B"] / tf.J[1])
    num, den = tf.tf(1)
    assert list(num) == [1.0] and list(den) == [tf.J[1], tf.B[1]]


def test_joint_transfer_function_needs_a_gear_ratio(twolink):
    with pytest.raises(ValueError, match="gear ratio"):
        A.joint_transfer_functions(twolink, twolink.qz)


# --------------------------------------------------------------------------- exercise 3


def test_exercise_arm_gravity_load_matches_the_closed_form():
    arm = A.twolink_exercise_arm()
    m1, m2, r1, r2, a1, g = 0.45, 0.35, 0.08, 0.08, 0.16, 9.81
    sweep = A.gravity_load_map(arm, joints=(0, 1), resolution=13)
    q1, q2 = np.meshgrid(*sweep.axes, indexing="ij")
    G1 = g * ((m1 * r1 + m2 * a1) * np.cos(q1) + m2 * r2 * np.cos(q1 + q2))
    G2 = g * m2 * r2 * np.cos(q1 + q2)
    np.testing.assert_allclose(sweep.values, np.stack([G1, G2], -1), atol=1e-12)


def test_exercise_arm_joint1_inertia_against_q2():
    arm = A.twolink_exercise_arm()
    m1, m2, r1, r2, a1 = 0.45, 0.35, 0.08, 0.08, 0.16
    curve = A.inertia_curve(arm, element=(0, 0), joint=1, resolution=37)
    q2 = curve.axes[0]
    expected = m1 * r1**2 + m2 * (a1**2 + r2**2 + 2 * a1 * r2 * np.cos(q2))
    np.testing.assert_allclose(curve.values[:, 0], expected, atol=1e-14)
    assert curve.extremes()[0].ratio == pytest.approx(
        (m1 * r1**2 + m2 * (a1 + r2) ** 2) / (m1 * r1**2 + m2 * (a1 - r2) ** 2)
    )


def test_joint_grid_names_a_bad_joint(puma):
    with pytest.raises(ValueError, match="joint index 6"):
        A.joint_grid(puma, (1, 6), 5)


# --------------------------------------------------------------------------- studies

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "name",
    [
        "gravity-load",
        "inertia-variation",
        "payload",
        "base-wrench",
        "manipulability",
        "joint-dynamics",
        "twolink-exercise",
    ],
)
def test_analysis_study_writes_its_figure_and_summary(name, tmp_path):
    from symdyn.apps.studies import analyses, registry

    assert registry()[name][1] is analyses.STUDIES[name][1]
    text = analyses.STUDIES[name][1](tmp_path, quick=True)
    figures = sorted(tmp_path.glob("analysis_*.png"))
    assert figures and all(f.read_bytes()[:8] == PNG_SIGNATURE and f.stat().st_size > 5000 for f in figures)
    assert (tmp_path / "summary.txt").read_text() == text + "\n"


def test_gravity_study_reports_the_grid_extreme_and_the_load_at_qz(puma, tmp_path):
    from symdyn.apps.studies import analyses

    text = analyses.gravity_load(tmp_path, quick=True)
    g2 = A.gravity_load_map(puma, resolution=9).extremes()[0]
    assert f"max {g2.max:+.3f} N·m" in text
    assert f"G2 = {ref.gravload(puma, puma.qz)[1]:.3f} N·m" in text
