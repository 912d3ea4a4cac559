"""A single rigid body on a free or planar base (a drone, a puck: no joints, nv = 6 or 3) is a
valid model (issue 44): the reference, the derivations and every generated function equal
Pinocchio's one-joint model; URDF and MJCF files of one body (its rotors welded) read on their
base joint; MuJoCo's inverse dynamics is symdyn's after the state conversion; a fixed base
without a joint is refused, saying why.
"""

from __future__ import annotations

import numpy as np
import pytest

import symdyn
from symdyn import reference
from symdyn.model import Link, Robot
from tests.conftest import tiered

pin = pytest.importorskip("pinocchio", reason="the peer (the test extra)")

STATES = 200
URDF = """<robot name="quad">
  <link name="body">
    <inertial><origin xyz="0.01 -0.02 0.03" rpy="0.1 0.2 0.3"/><mass value="1.2"/>
      <inertia ixx="0.011" iyy="0.012" izz="0.02" ixy="0.001" ixz="0" iyz="-0.0005"/></inertial>
  </link>
{rotors}
</robot>
"""
ROTOR = """  <link name="rotor{k}"><inertial><mass value="0.05"/>
    <inertia ixx="1e-5" iyy="1e-5" izz="2e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="mount{k}" type="fixed"><parent link="body"/><child link="rotor{k}"/>
    <origin xyz="{x} {y} 0.03"/></joint>"""


def _rotors() -> str:
    places = [(0.2, 0.2), (-0.2, 0.2), (-0.2, -0.2), (0.2, -0.2)]
    return "\n".join(ROTOR.format(k=k + 1, x=x, y=y) for k, (x, y) in enumerate(places))


def _body(seed: int) -> Link:
    """A random physical rigid body: mass, COM, rotated principal moments."""
    rng = np.random.default_rng(seed)
    moments = np.sort(rng.uniform(0.01, 0.05, 3))
    moments[2] = min(moments[2], 0.9 * (moments[0] + moments[1]))  # the triangle inequality
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    I = Q @ np.diag(moments) @ Q.T
    return Link(m=float(rng.uniform(0.5, 3)), r=tuple(rng.uniform(-0.1, 0.1, 3)), I=tuple(map(tuple, (I + I.T) / 2)))


def _states(robot: Robot, seed: int = 0):
    rng = np.random.default_rng(seed)
    q = robot.integrate(robot.neutral(), rng.normal(size=(STATES, robot.nv)) * 2)
    v, a = rng.normal(size=(2, STATES, robot.nv))
    return q, v, a


def _close(a, b, what: str, tol: float = 1e-12) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, f"{what}: shape {a.shape}, expected {b.shape}"
    err = np.abs(a - b).max() / (1 + np.abs(b).max())
    assert err < tol, f"{what}: {err:.2e}"


@pytest.fixture(scope="module", params=["free", "planar"])
def drone(request):
    body = _body(7 if request.param == "free" else 8)
    return Robot(name=f"lone_{request.param}", links=(), base_joint=request.param, base_body=body, gravity=(0, 0, 9.81))


def _pinocchio(robot: Robot, q, v, a):
    """Pinocchio's τ, M, q̈ and derivatives of the one-joint model at the states."""
    from symdyn.bench.peers import pinocchio_model
    from symdyn.bench.reduced import pin_configuration

    model = pinocchio_model(robot)
    data = model.createData()
    out: dict = {k: [] for k in ("tau", "M", "fdyn", "dtau_dq", "dtau_dv")}
    for x, vi, ai in zip(pin_configuration(model, q), v, a):
        tau = pin.rnea(model, data, x, vi, ai).copy()
        out["tau"].append(tau)
        out["M"].append(pin.crba(model, data, x).copy())
        out["fdyn"].append(pin.aba(model, data, x, vi, tau).copy())
        dq, dv, _ = pin.computeRNEADerivatives(model, data, x, vi, ai)
        out["dtau_dq"].append(dq.copy())
        out["dtau_dv"].append(dv.copy())
    out["M"] = [np.triu(M) + np.triu(M, 1).T for M in out["M"]]
    return {k: np.array(x) for k, x in out.items()}


def test_the_reference_and_both_derivations_are_pinocchios(drone):
    q, v, a = _states(drone)
    want = _pinocchio(drone, q, v, a)
    assert (drone.n, drone.nv) == (0, {"free": 6, "planar": 3}[drone.base_joint])
    _close(reference.rne(drone, q, v, a), want["tau"], "reference τ")
    _close(reference.inertia(drone, q), want["M"], "reference M")
    ne, lagrange = symdyn.derive(drone, "newton-euler"), symdyn.derive(drone, "lagrange")
    assert (ne.M - lagrange.M).expand() == 0 * ne.M
    assert (ne.tau - lagrange.tau).expand() == 0 * ne.tau


@pytest.mark.parametrize("target", tiered(["c", "numpy"], 1))  # NumPy's programs are C's: make test-all
def test_every_generated_function_is_pinocchios(drone, target):
    from symdyn.derivation.regressor import parameter_values

    q, v, a = _states(drone)
    want = _pinocchio(drone, q, v, a)
    f = symdyn.load(drone, target=target)
    _close(f.tau(q, v, a), want["tau"], f"{target} τ")
    _close(f.M(q), want["M"], f"{target} M")
    _close(f.fdyn(q, v, want["tau"]), want["fdyn"], f"{target} q̈", 1e-10)
    _close(f.G(q) + f.Cqd(q, v), reference.rne(drone, q, v, 0 * a), f"{target} G + C·v")
    tau, dq, dv = f.tau_derivatives(q, v, a)
    _close(dq, want["dtau_dq"], f"{target} ∂τ/∂q")
    _close(dv, want["dtau_dv"], f"{target} ∂τ/∂v")
    pi = np.array([float(x) for x in parameter_values(drone)])
    Y = f.Y(q, v, a)
    assert Y.shape[-2:] == (drone.nv, 10)
    _close(Y @ pi, want["tau"], f"{target} Y·π")


def test_the_task_space_of_the_body_is_pinocchios(drone):
    from symdyn.bench.task_space import FUNCTIONS, evaluate, peer_model

    assert [f.name for f in drone.task_frames] == ["base"]  # the body itself, by default
    q, v, a = _states(drone, seed=1)
    model, ids = peer_model(drone)
    want = evaluate(drone, model, ids, q, v, a)
    f = symdyn.load(drone, target="numpy")
    for name in FUNCTIONS:
        args = {"q": (q,), "qv": (q, v), "qva": (q, v, a)}
        got = getattr(f, name)(
            *(
                args["qva"]
                if name == "frame_acceleration"
                else args["qv"]
                if "drift" in name or name == "frame_velocity"
                else args["q"]
            )
        )
        _close(got, want[name], f"task space {name}")


def test_a_urdf_of_one_body_with_welded_rotors_reads_on_a_free_base():
    text = URDF.format(rotors=_rotors())
    robot = Robot.from_urdf(text, base_joint="free")
    assert (robot.n, robot.nq, robot.nv) == (0, 7, 6)
    assert robot.base_body.m == pytest.approx(1.4)  # the body and its four rotors
    assert {"body", "rotor1", "rotor4"} <= set(robot.frame_names)
    assert "one body, no joints" in str(robot) and "no moving joint (one body)" in str(robot)
    same = Robot.from_urdf(text, tips="all", base_joint="free")
    assert same.fingerprint() == robot.fingerprint() or same.base_body == robot.base_body
    model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    data = model.createData()
    q, v, a = _states(robot)
    want = np.array([pin.rnea(model, data, x, vi, ai).copy() for x, vi, ai in zip(q, v, a)])
    _close(reference.rne(robot, q, v, a), want, "the URDF drone against Pinocchio's reading of it")
    rotor = robot.with_frames(["rotor2"])
    pose = symdyn.load(rotor, target="numpy").frame_pose(q[:5])
    for x, T in zip(q[:5], pose):
        pin.framesForwardKinematics(model, data, x)
        _close(T[0], data.oMf[model.getFrameId("rotor2")].homogeneous, "rotor2's pose")


def test_an_mjcf_body_with_a_freejoint_is_the_model_and_mujocos_inverse_agrees(tmp_path):
    mujoco = pytest.importorskip("mujoco", reason="MJCF files are compiled by MuJoCo (the test extra)")
    path = tmp_path / "drone.xml"
    path.write_text(
        """<mujoco model="drone"><worldbody><body name="core" pos="0 0 1"><freejoint name="fly"/>
      <inertial pos="0.01 0 0.02" quat="0.9 0.1 0.2 0.3" mass="1.2" diaginertia="0.01 0.012 0.02"/>
      <body name="rotor1" pos="0.2 0 0.03"><inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 2e-5"/>
      <site name="prop1"/></body></body></worldbody></mujoco>"""
    )
    robot = Robot.from_mjcf(str(path))
    assert (robot.n, robot.base_joint, robot.mjcf.free_joint) == (0, "free", "fly")
    assert robot.base_body.m == pytest.approx(1.25) and "prop1" in robot.frame_names
    from symdyn.model.mjcf.compile import compile_mjcf
    from symdyn.model.mjcf.state import to_mujoco_force

    m = compile_mjcf(str(path)).model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(20):
        qpos = m.qpos0 + rng.uniform(-0.5, 0.5, m.nq)
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        d.qpos[:], d.qvel[:], d.qacc[:] = qpos, rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)
        mujoco.mj_inverse(m, d)
        q, v, a = robot.from_mujoco_state(d.qpos.copy(), d.qvel.copy(), d.qacc.copy())
        got = to_mujoco_force(robot, q, reference.rne(robot, q, v, a))
        np.testing.assert_allclose(got, d.qfrc_inverse, atol=1e-9 * max(1, np.abs(d.qfrc_inverse).max()))


def test_no_joint_on_a_fixed_base_is_refused_saying_why():
    with pytest.raises(ValueError, match="no links and a fixed base: nothing moves"):
        Robot(name="rock", links=(), base_body=None)
    from symdyn.model.urdf.xml import URDFError

    with pytest.raises(URDFError, match=r"no joint below 'body' moves: .* base_joint='free'"):
        Robot.from_urdf(URDF.format(rotors=_rotors()))


def test_the_command_line_prints_generates_and_draws_a_drone(tmp_path, capsys):
    from symdyn.cli import main

    path = tmp_path / "quad.urdf"
    path.write_text(URDF.format(rotors=_rotors()))
    assert main(["print", str(path), "--base-joint", "free", "--term", "M", "--no-cache"]) == 0
    assert "M66 = " in capsys.readouterr().out
    assert main(["generate", str(path), "--base-joint", "free", "--target", "c", "--out", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "quad.c").stat().st_size > 0
    assert main(["show", str(path), "--base-joint", "free", "--out", str(tmp_path / "quad.png")]) == 0
    assert (tmp_path / "quad.png").stat().st_size > 0
    assert main(["print", str(path), "--term", "M", "--no-cache"]) == 2
    assert "needs --base-joint free" in capsys.readouterr().err


def test_hector_quadrotor_from_example_robot_data_equals_pinocchio():
    """A drone nobody here wrote (example-robot-data's hector quadrotor: a URDF with no moving
    joint) read on a free base: the reference and the generated C equal Pinocchio's model of the
    same file on its free-flyer, at 200 states."""
    from symdyn.model.example_robots import robots_folder

    try:
        path = robots_folder() / "hector_description" / "robots" / "quadrotor_base.urdf"
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    robot = Robot.from_urdf(str(path), base_joint="free")
    assert (robot.n, robot.nv) == (0, 6) and robot.base_body.m == pytest.approx(1.477)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    q, v, a = _states(robot)
    want = np.array([pin.rnea(model, data, x, vi, ai).copy() for x, vi, ai in zip(q, v, a)])
    _close(reference.rne(robot, q, v, a), want, "hector's reference τ")
    _close(symdyn.load(robot, target="c").tau(q, v, a), want, "hector's generated τ")


@pytest.mark.parametrize("base_joint", ["free", "planar"])
def test_a_lone_body_is_identified_from_its_base_wrench(base_joint, tmp_path):
    """Identification of a drone: data with the base's pose, velocity, acceleration and wrench and no
    joint column; noise-free data give the body back (its mass, COM and inertia on a free base)."""
    from symdyn.identify import fit, simulate
    from symdyn.identify.simulate import fourier

    truth = _body(11)
    robot = Robot(name="drone", links=(), base_joint=base_joint, base_body=truth, gravity=(0, 0, 9.81))
    data = simulate(robot, fourier(robot), perturb=0.0)
    assert data.q.shape[1] == robot.nq and data.n == 0 and "q1" not in data.columns("q")
    from symdyn.identify.data import load_data, write_csv

    data = load_data(write_csv(tmp_path / "flight.csv", data), joints=robot)  # through the file: no joint column
    body = fit(robot, data).robot.base_body
    assert float(body.m) == pytest.approx(float(truth.m), rel=1e-10)
    if base_joint == "free":  # a planar base does not see every inertial parameter
        np.testing.assert_allclose(np.array(body.r, dtype=float), truth.r, atol=1e-10)
        np.testing.assert_allclose(np.array(body.I, dtype=float), np.array(truth.I), atol=1e-10)
