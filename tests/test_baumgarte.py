"""Baumgarte gains on a contact set (`with_contacts(…, kp=, kd=)`): contact_fdyn holds
J a + γ = −kd J v − kp e, e measured from an `anchor` input, as Pinocchio's corrector does."""

import numpy as np
import pytest
from symdyn.codegen.entry import load
from symdyn.model.random_robots import random_tree_robot
from symdyn.bench.contact_peer import world_axes
from tests.test_contacts import RTOL, _relative, pinocchio_contacts
from tests.test_task_space import states, with_random_frames

pin = pytest.importorskip("pinocchio", reason="the corrector is checked against Pinocchio (the test extra)")
peer = pytest.importorskip("symdyn.bench.task_space")

KP, KD = 7.0, 3.0


@pytest.fixture(scope="module")
def tree():
    """A random tree on a free base with frames f2 (a point contact below) and f5 (a surface); its
    base frame is turned, so the anchors and forces are in a world that is not Pinocchio's."""
    return (
        with_random_frames(random_tree_robot(4, n=5, base_joint="free"), 4)
        .nofriction(all=True)
        .with_frames(["f2", "f5"])
    )


@pytest.fixture(scope="module")
def corrected(tree):
    """The tree with a point and a surface contact and both gains, and its NumPy functions."""
    robot = tree.with_contacts({"f2": "point", "f5": "surface"}, kp=KP, kd=KD)
    return robot, load(robot, "numpy")


def pinocchio_model(robot):
    """Pinocchio's model of the robot with its contact frames, and their frame ids."""
    return peer.peer_model(robot.with_frames([name for name, _ in robot.contacts]))


def pinocchio_corrected(robot, peer_model, q, turn: float, shift: float, rng):
    """Pinocchio's model, data and rigid constraints with the robot's gains, each anchored at its
    frame's placement at q moved by a rotation of `turn` rad about a random axis and a random shift
    of norm ~`shift` (the anchor world frame is the constraint's joint2_placement), and the anchor
    vector symdyn takes (XYZQUAT, position only for a point) — in the robot's world, which the
    base's placement takes Pinocchio's to."""
    from symdyn.bench.reduced import pin_configuration

    model, ids = peer_model
    base = pin.SE3(np.array(robot.base, dtype=float))
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin_configuration(model, np.atleast_2d(q))[0])
    models, datas, anchor = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData(), []
    for k, (_, kind) in enumerate(robot.contacts):
        frame, placed = model.frames[ids[k]], data.oMf[ids[k]]
        axis = rng.normal(size=3)
        rotation = placed.rotation @ pin.exp3(turn * axis / np.linalg.norm(axis))
        target = pin.SE3(rotation, placed.translation + shift * rng.normal(size=3))
        anchor += list(pin.SE3ToXYZQUAT(base * target)[: 3 if kind == "point" else 7])
        contact = pin.ContactType.CONTACT_3D if kind == "point" else pin.ContactType.CONTACT_6D
        cm = pin.RigidConstraintModel(
            contact, model, frame.parentJoint, frame.placement, 0, target, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        cm.m_baumgarte_parameters = pin.BaumgarteCorrectorParameters(*robot.baumgarte)
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    return model, data, models, datas, world_axes(robot), np.array(anchor)


def pinocchio_fdyn(setup, q, v, tau, derivatives: bool = False):
    """Pinocchio's (a, λ) — and with `derivatives` its six derivative blocks — at one state, the
    forces turned into the robot's world axes."""
    from symdyn.bench.reduced import pin_configuration

    model, data, models, datas, W, _ = setup
    x = pin_configuration(model, np.atleast_2d(q))[0]
    a = pin.constraintDynamics(model, data, x, v, tau, models, datas, pin.ProximalSettings(1e-14, 0.0, 1)).copy()
    out = [a, W @ data.lambda_c]
    if derivatives:
        pin.computeConstraintDynamicsDerivatives(model, data, models, datas)
        out += [
            data.ddq_dq,
            data.ddq_dv,
            data.ddq_dtau,
            W @ data.dlambda_dq,
            W @ data.dlambda_dv,
            W @ data.dlambda_dtau,
        ]
    return [np.array(x) for x in out]


def test_corrected_dynamics_equal_pinocchio_on_a_point_and_a_surface(tree, corrected):
    """Both gains, a point and a surface contact, anchors up to 80° and 10 cm away (the surface's
    log₆ is a series exact to 90°): a and f equal constraintDynamics with the corrector."""
    robot, f = corrected
    model = pinocchio_model(robot)
    rng = np.random.default_rng(3)
    q, v, tau = states(robot, 200, seed=4)
    for i in range(len(q)):
        setup = pinocchio_corrected(robot, model, q[i], rng.uniform(0, 1.4), rng.uniform(0, 0.06), rng)
        want = pinocchio_fdyn(setup, q[i], v[i], tau[i])
        got = f.contact_fdyn(q[i], v[i], tau[i], setup[-1])
        assert _relative(got[0], want[0]) < RTOL and _relative(got[1], want[1]) < RTOL
    plain = pinocchio_contacts(tree.with_contacts({"f2": "point", "f5": "surface"}), q[0], v[0], tau[0])
    assert _relative(plain[1], f.contact_fdyn(q[0], v[0], tau[0], setup[-1])[1]) > 1e-3  # the gains act
    scaled = setup[-1].copy()
    scaled[-4:] *= -2.5  # the surface's quaternion, another length and sign: the same rotation
    for a, b in zip(f.contact_fdyn(q[-1], v[-1], tau[-1], scaled), f.contact_fdyn(q[-1], v[-1], tau[-1], setup[-1])):
        assert _relative(a, b) < RTOL


@pytest.mark.slow
@pytest.mark.parametrize(
    "contacts, kp, kd, target",
    [({"f2": "point"}, KP, KD, "numpy"), ({"f5": "surface"}, 0.0, KD, "numpy"), ({"f2": "point"}, KP, KD, "c")],
    ids=["point-kp-kd", "surface-kd", "point-kp-kd-c"],
)
def test_corrected_derivatives_equal_pinocchio(tree, contacts, kp, kd, target):
    """Against Pinocchio's corrector; on the C target with a position gain the residuals are
    differentiated in the program (the quaternion's directions too, no vectors of directions: M⁻¹
    and Xᵀ are parts and the top rows X df − M⁻¹R1, `emit.ckkt._top`)."""
    robot = tree.with_contacts(contacts, kp=kp, kd=kd)
    f, model = load(robot, target), pinocchio_model(robot)
    rng = np.random.default_rng(5)
    q, v, tau = states(robot, 10, seed=6)
    for i in range(len(q)):
        setup = pinocchio_corrected(robot, model, q[i], 0.4, 0.05, rng)
        args = (q[i], v[i], tau[i]) + ((setup[-1],) if kp else ())
        for got, want in zip(f.contact_fdyn_derivatives(*args), pinocchio_fdyn(setup, q[i], v[i], tau[i], True)):
            assert _relative(got, want) < RTOL


def _central(robot, f, q, v, tau, anchor, h=1e-6):
    """Central differences of contact_fdyn's (a, f) along the tangent space of q."""
    da, df = [], []
    for j in range(robot.nv):
        e = np.zeros(robot.nv)
        e[j] = h
        (ap, fp), (am, fm) = (f.contact_fdyn(robot.integrate(q, s * e), v, tau, anchor) for s in (1, -1))
        da.append((ap - am) / (2 * h))
        df.append((fp - fm) / (2 * h))
    return np.array(da).T, np.array(df).T


def test_surface_position_gain_derivatives_are_exact_where_pinocchio_is_first_order(corrected):
    """kp on a surface: at the anchors (zero error) the derivatives equal Pinocchio's; away from them
    they equal central differences of contact_fdyn itself, while Pinocchio's
    computeConstraintDynamicsDerivatives (4.1, LOCAL_WORLD_ALIGNED) is off by the error's first order
    (it leaves out the derivative of the error's rotation into world axes: documented)."""
    robot, f = corrected
    model = pinocchio_model(robot)
    rng = np.random.default_rng(7)
    q, v, tau = states(robot, 4, seed=8)
    for i in range(len(q)):
        setup = pinocchio_corrected(robot, model, q[i], 0.0, 0.0, rng)
        got = f.contact_fdyn_derivatives(q[i], v[i], tau[i], setup[-1])
        for g, w in zip(got, pinocchio_fdyn(setup, q[i], v[i], tau[i], True)):
            assert _relative(g, w) < RTOL
        setup = pinocchio_corrected(robot, model, q[i], 0.5, 0.05, rng)
        got = f.contact_fdyn_derivatives(q[i], v[i], tau[i], setup[-1])
        da, df = _central(robot, f, q[i], v[i], tau[i], setup[-1])
        assert _relative(got[2], da) < 1e-7 and _relative(got[5], df) < 1e-7
        assert _relative(got[2], pinocchio_fdyn(setup, q[i], v[i], tau[i], True)[2]) > 1e-4


def test_the_anchor_is_required_with_a_position_gain_and_the_impact_has_no_gains(tree, corrected):
    """kp adds `anchor` (3 per point, 7 per surface), which the call then requires; the impact
    takes no gains (equal to the plain set's)."""
    robot, f = corrected
    q, v, tau = states(robot, 1)
    with pytest.raises(TypeError, match="anchor"):
        f.contact_fdyn(q[0], v[0], tau[0])
    with pytest.raises(ValueError, match="anchor"):
        f.contact_fdyn(q[0], v[0], tau[0], np.zeros(9))
    want = pinocchio_contacts(tree.with_contacts({"f2": "point", "f5": "surface"}), q[0], v[0], tau[0])[2:]
    for got, w in zip(f.contact_impulse(q[0], v[0]), want):
        assert _relative(got, w) < RTOL


@pytest.mark.slow
def test_a_damping_gain_alone_takes_no_anchor(tree):
    only_kd = load(tree.with_contacts({"f2": "point", "f5": "surface"}, kd=KD), "numpy")
    q, v, tau = states(tree, 1)
    a, force = only_kd.contact_fdyn(q[0], v[0], tau[0])
    assert a.shape == (tree.nv,) and force.shape == (9,)


def test_gains_are_checked_and_enter_the_model_not_the_derivation(tree):
    with pytest.raises(ValueError, match="kp .* finite and >= 0"):
        tree.with_contacts({"f2": "point"}, kp=-1.0)
    with pytest.raises(ValueError, match="kd .* finite and >= 0"):
        tree.with_contacts({"f2": "point"}, kd=float("nan"))
    with pytest.raises(ValueError, match="need a contact set"):
        tree.with_contacts({}, kp=1.0)
    plain, corrected = tree.with_contacts({"f2": "point"}), tree.with_contacts({"f2": "point"}, kp=KP)
    assert plain.fingerprint() != corrected.fingerprint()
    assert plain.dynamics_fingerprint() == corrected.dynamics_fingerprint() == tree.dynamics_fingerprint()


@pytest.mark.slow
def test_every_target_takes_the_anchor(corrected):
    """The C scalar and batch functions and CasADi's equal NumPy's with the anchor input."""
    robot, f = corrected
    q, v, tau = states(robot, 5, seed=9)
    anchor = np.r_[0.1, 0.2, 0.3, 0.2, 0.1, 0.4, 0.0, 0.0, 0.0, 1.0]
    for target in ("c", "casadi"):
        g = load(robot, target)
        for name in ("contact_fdyn", "contact_fdyn_derivatives"):
            for got, want in zip(
                getattr(g, name)(q[0], v[0], tau[0], anchor), getattr(f, name)(q[0], v[0], tau[0], anchor)
            ):
                assert _relative(np.asarray(got), want) < RTOL
    batch = load(robot, "c").contact_fdyn(q, v, tau, np.tile(anchor, (len(q), 1)))
    for i in range(len(q)):
        assert _relative(batch[0][i], f.contact_fdyn(q[i], v[i], tau[i], anchor)[0]) < RTOL
