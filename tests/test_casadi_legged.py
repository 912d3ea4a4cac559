"""The legged OCP's plain baseline (`symdyn.numeric.casadi_legged`): a free-base recursion written in
CasADi SX, equal to the numeric reference's τ and to Pinocchio's frames and impact."""

import numpy as np
import pytest
from symdyn.model.random_robots import random_tree_robot
from symdyn.numeric import casadi_legged, reference
from tests.test_task_space import states, with_random_frames

pin = pytest.importorskip(
    "pinocchio", reason="the frames and the impact are checked against Pinocchio (the test extra)"
)
peer = pytest.importorskip("symdyn.bench.task_space")


@pytest.mark.parametrize("seed", [3, 8])
def test_the_plain_free_base_functions_equal_the_reference_and_pinocchio(seed):
    from tests.test_contacts import pinocchio_contacts

    robot = with_random_frames(random_tree_robot(seed, n=5, base_joint="free"), seed).with_frames(["f4", "f5"])
    contacts = ("f4", "f5")
    f = casadi_legged.functions(robot, contacts)
    q, v, a = states(robot, 20, seed=seed)
    model, ids = peer.peer_model(robot)
    want = peer.evaluate(robot, model, ids, q, v, a)
    for i in range(len(q)):
        np.testing.assert_allclose(
            f["tau"](q[i], v[i], a[i]).full().ravel(), reference.rne(robot, q[i], v[i], a[i]), rtol=1e-11, atol=1e-11
        )
        np.testing.assert_allclose(f["frame_pose"](q[i]).full(), want["frame_pose"][i].reshape(-1, 4), atol=1e-12)
        np.testing.assert_allclose(
            f["frame_jacobian_aligned"](q[i]).full(),
            want["frame_jacobian_aligned"][i].reshape(-1, robot.nv),
            atol=1e-12,
        )
        np.testing.assert_allclose(f["frame_drift"](q[i], v[i]).full(), want["frame_drift"][i], rtol=1e-11, atol=1e-11)
    frictionless = robot.nofriction(all=True)
    f = casadi_legged.functions(frictionless, contacts)
    held = frictionless.with_contacts({c: "point" for c in contacts})
    for i in range(5):
        v_after, impulse = (x.full().ravel() for x in f["contact_impulse"](q[i], v[i]))
        np.testing.assert_allclose(v_after, pinocchio_contacts(held, q[i], v[i], a[i])[2], rtol=1e-10, atol=1e-10)
        # the impulse: M (v+ - v-) = J^T impulse with the reference's M, and the feet stopped (J v+ = 0)
        J = f["frame_jacobian_aligned"](q[i]).full()
        Jc = np.vstack([J[6 * k : 6 * k + 3] for k in range(len(contacts))])
        M = reference.inertia(frictionless, q[i])
        np.testing.assert_allclose(M @ (v_after - v[i]), Jc.T @ impulse, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(Jc @ v_after, 0, atol=1e-12)


def test_a_base_that_is_not_free_is_refused():
    with pytest.raises(NotImplementedError, match="free base"):
        casadi_legged.functions(random_tree_robot(2, n=3))
