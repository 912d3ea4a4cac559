"""Contact dynamics, generated (issue 43, first slice): `robot.with_contacts({frame: "point" |
"surface"})` and `contact_fdyn(q, v, tau)` → (a, force), `contact_impulse(q, v_before)` →
(v_after, impulse), equal to Pinocchio's constraintDynamics and impulseDynamics
(RigidConstraintModel, CONTACT_3D / CONTACT_6D, LOCAL_WORLD_ALIGNED), and the constraints held:
a point contact's classical acceleration and a surface's spatial acceleration are zero after
contact_fdyn, their velocities zero after contact_impulse."""

import numpy as np
import pytest

from symdyn.codegen.entry import load
from symdyn.model import arms
from symdyn.model.random_robots import random_tree_robot
from tests.test_task_space import states, with_random_frames

pin = pytest.importorskip("pinocchio", reason="contact dynamics are checked against Pinocchio (the test extra)")
peer = pytest.importorskip("symdyn.bench.task_space")
from symdyn.bench import contact_peer  # noqa: E402

RTOL = 1e-10


def _relative(got, want) -> float:
    return float(np.abs(np.asarray(got) - want).max() / max(1.0, np.abs(want).max()))


def pinocchio_setup(robot):
    """Pinocchio's model of the robot (symdyn's description) with its contact set as rigid constraints."""
    return contact_peer.setup(robot, *peer.peer_model(robot.with_frames([name for name, _ in robot.contacts])))


def pinocchio_contacts(robot, q, v, tau, setup=None):
    """Pinocchio's (a, λ, v⁺, Λ) at one state, the forces in the robot's world axes."""
    return contact_peer.contacts(robot, q, v, tau, setup or pinocchio_setup(robot))


def pinocchio_derivatives(robot, q, v, tau, setup):
    """Pinocchio's contact derivatives at one state, in symdyn's order and world."""
    return contact_peer.derivatives(robot, q, v, tau, setup)


def assert_as_pinocchio(robot, f, q, v, tau, derivatives=()):
    """contact_fdyn and contact_impulse of the loaded model `f` at each state, and the derivative
    functions named in `derivatives` ("fdyn", "impulse"), equal to Pinocchio's (RTOL relative)."""
    setup = pinocchio_setup(robot)
    for i in range(len(q)):
        a, force, v_after, impulse = pinocchio_contacts(robot, q[i], v[i], tau[i], setup)
        got_a, got_f = f.contact_fdyn(q[i], v[i], tau[i])
        assert _relative(got_a, a) < RTOL and _relative(got_f, force) < RTOL
        got_v, got_i = f.contact_impulse(q[i], v[i])
        assert _relative(got_v, v_after) < RTOL and _relative(got_i, impulse) < RTOL
        if derivatives:
            want_fdyn, want_impulse = pinocchio_derivatives(robot, q[i], v[i], tau[i], setup)
        if "fdyn" in derivatives:
            for got, want in zip(f.contact_fdyn_derivatives(q[i], v[i], tau[i]), want_fdyn):
                assert _relative(got, want) < RTOL
        if "impulse" in derivatives:
            for got, want in zip(f.contact_impulse_derivatives(q[i], v[i]), want_impulse):
                assert _relative(got, want) < RTOL


@pytest.fixture(scope="module")
def legged():
    """A random tree on a free base, a point contact on one branch and a surface on another; its
    base frame is turned (the forces' world axes are not Pinocchio's)."""
    robot = with_random_frames(random_tree_robot(4, n=5, base_joint="free"), 4).nofriction(all=True)
    assert not np.allclose(np.array(robot.base, dtype=float)[:3, :3], np.eye(3))
    robot = robot.with_frames(["f2", "f5"]).with_contacts({"f2": "point", "f5": "surface"})
    return robot, load(robot, "numpy")


@pytest.mark.slow  # 2 s of compiling per tree
@pytest.mark.parametrize(
    "seed, contacts",
    [(seed, {"f1": "point", "f5": "point"}) for seed in (0, 1, 2, 7)]
    + [(seed, {"f2": "point", "f5": "point"}) for seed in (8, 9, 11)]
    + [(10, {"f2": "point", "f5": "surface"})],
)
def test_random_trees_contacts_equal_pinocchios(seed, contacts):
    """Random trees on free bases — turned base frames, gravity along any axis — on the lazy C
    target: contact_fdyn and contact_impulse equal Pinocchio's (a property test over trees)."""
    robot = with_random_frames(random_tree_robot(seed, n=5, base_joint="free"), seed).nofriction(all=True)
    robot = robot.with_frames(list(contacts)).with_contacts(contacts)
    q, v, _ = states(robot, 20, seed=seed)
    tau = np.random.default_rng(seed).uniform(-5, 5, (20, robot.nv))
    assert_as_pinocchio(robot, load(robot, "c"), q, v, tau)


def test_contact_dynamics_and_impulses_equal_pinocchios(legged):
    robot, f = legged
    q, v, _ = states(robot, 30, seed=2)
    tau = np.random.default_rng(2).uniform(-5, 5, (30, robot.nv))
    got_a, got_f = f.contact_fdyn(q, v, tau)  # a batch
    got_v, got_i = f.contact_impulse(q, v)
    assert got_f.shape == (30, 9) and got_i.shape == (30, 9)
    for i in range(30):
        a, force, v_after, impulse = pinocchio_contacts(robot, q[i], v[i], tau[i])
        assert _relative(got_a[i], a) < RTOL and _relative(got_f[i], force) < RTOL
        assert _relative(got_v[i], v_after) < RTOL and _relative(got_i[i], impulse) < RTOL


def test_the_contacts_hold_after_the_solve(legged):
    """The point's classical acceleration and the surface's spatial acceleration vanish after
    contact_fdyn; both frames' velocities after contact_impulse (the generated task space)."""
    robot, f = legged
    q, v, _ = states(robot, 10, seed=5)
    tau = np.random.default_rng(5).uniform(-5, 5, (10, robot.nv))
    a, _ = f.contact_fdyn(q, v, tau)
    acc = f.frame_acceleration(q, v, a)
    vw = f.frame_velocity(q, v)  # LOCAL: the surface's ω × v in its own axes, turned below
    pose = f.frame_pose(q)
    lin = np.einsum("nij,nj->ni", pose[:, 1, :3, :3], vw[:, 1, :3])
    ang = np.einsum("nij,nj->ni", pose[:, 1, :3, :3], vw[:, 1, 3:])
    scale = max(1.0, np.abs(a).max())
    assert np.abs(acc[:, 0, :3]).max() < 1e-9 * scale  # point: classical acceleration of its origin
    assert np.abs(acc[:, 1, :3] - np.cross(ang, lin)).max() < 1e-9 * scale  # surface: spatial = 0
    assert np.abs(acc[:, 1, 3:]).max() < 1e-9 * scale
    v_after, _ = f.contact_impulse(q, v)
    after = f.frame_velocity(q, v_after)
    assert np.abs(after[:, 0, :3]).max() < 1e-10 and np.abs(after[:, 1]).max() < 1e-10


def test_a_fixed_arm_with_its_hand_on_a_surface():
    """The Panda's hand on a surface through the lazy C target, the derivatives too: a fixed base,
    one chain (its directions in two vectors of the C's forward mode, `symdyn.codegen.tangents`)."""
    robot = arms.load("panda").nofriction(all=True).with_contacts({"panda_hand": "surface"})
    f = load(robot, "c")  # the lazy C target: only the functions called are built
    q, v, _ = states(robot, 5, seed=7)
    tau = np.random.default_rng(7).uniform(-10, 10, (5, robot.nv))
    assert_as_pinocchio(robot, f, q, v, tau, derivatives=("fdyn", "impulse"))


def test_derivatives_equal_pinocchios(legged):
    """contact_fdyn_derivatives and contact_impulse_derivatives (a batch of 200 states) against
    Pinocchio's analytical derivatives, state by state, 1e-10 relative to each output's size."""
    robot, f = legged
    count = 200
    q, v, _ = states(robot, count, seed=11)
    tau = np.random.default_rng(11).uniform(-5, 5, (count, robot.nv))
    fdyn = f.contact_fdyn_derivatives(q, v, tau)
    impulse = f.contact_impulse_derivatives(q, v)
    assert [x.shape[1:] for x in fdyn] == [(11,), (9,), (11, 11), (11, 11), (11, 11), (9, 11), (9, 11), (9, 11)]
    setup = pinocchio_setup(robot)
    for i in range(count):
        want_fdyn, want_impulse = pinocchio_derivatives(robot, q[i], v[i], tau[i], setup)
        for got, want in zip(fdyn, want_fdyn):
            assert _relative(got[i], want) < RTOL
        for got, want in zip(impulse, want_impulse):
            assert _relative(got[i], want) < RTOL


def _c_derivatives_as_pinocchio(robot, kind):
    """The C target's contact_<kind>_derivatives on `robot` at 40 states: equal to Pinocchio's,
    a batch (the threaded kernel) equal to single calls, a NaN refused by the batch."""
    f = load(robot, "c")
    count = 40
    q, v, _ = states(robot, count, seed=17)
    tau = np.random.default_rng(17).uniform(-5, 5, (count, robot.nv))
    function = getattr(f, f"contact_{kind}_derivatives")
    args = (q, v, tau) if kind == "fdyn" else (q, v)
    batch = function(*args)
    setup = pinocchio_setup(robot)
    for i in range(count):
        single = function(*(x[i] for x in args))
        want = pinocchio_derivatives(robot, q[i], v[i], tau[i], setup)[kind == "impulse"]
        for got, many, expected in zip(single, batch, want):
            assert np.array_equal(got, many[i])
            assert _relative(got, expected) < RTOL
    bad = q.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN|finite"):
        function(bad, *args[1:])


@pytest.mark.slow  # 9 s of generating and compiling: make test is at its three minutes
@pytest.mark.parametrize("kind", ["fdyn", "impulse"])
def test_the_c_targets_derivatives_equal_pinocchios(legged, kind):
    """The C target's own derivatives (the KKT parts, then dense products: `emit.ckkt`) on the
    random tree on a free base with a point and a surface contact, whose position derivatives are
    exact zeros there."""
    _c_derivatives_as_pinocchio(legged[0], kind)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["fdyn", "impulse"])
def test_the_c_targets_derivatives_on_a_planar_base(kind):
    """The same on a planar base (two points: its 8 velocities take no surface besides)."""
    robot = with_random_frames(random_tree_robot(5, n=5, base_joint="planar"), 5).nofriction(all=True)
    robot = robot.with_frames(["f4", "f5"]).with_contacts({"f4": "point", "f5": "point"})
    _c_derivatives_as_pinocchio(robot, kind)


def _central(f, robot, q, v, tau, h=1e-6):
    """Central differences of f(q, v, tau) → (x, λ) in the tangent space of q and by v and tau."""
    columns = {"q": [], "v": [], "tau": []}
    for k in range(robot.nv):
        e = np.zeros(robot.nv)
        e[k] = h
        plus, minus = f(robot.integrate(q, e), v, tau), f(robot.integrate(q, -e), v, tau)
        columns["q"].append([(p - m) / (2 * h) for p, m in zip(plus, minus)])
        plus, minus = f(q, v + e, tau), f(q, v - e, tau)
        columns["v"].append([(p - m) / (2 * h) for p, m in zip(plus, minus)])
        if tau is not None:
            plus, minus = f(q, v, tau + e), f(q, v, tau - e)
            columns["tau"].append([(p - m) / (2 * h) for p, m in zip(plus, minus)])
    return {key: [np.stack([c[j] for c in cols], axis=1) for j in range(2)] for key, cols in columns.items() if cols}


def test_derivatives_are_the_central_differences_of_the_functions(legged):
    """The derivatives against central differences of contact_fdyn and contact_impulse themselves
    (q moved on its manifold: robot.integrate), and the constraints' own derivatives: J da/dz =
    −∂(J a + γ)/∂z keeps the contact accelerations at zero to first order."""
    robot, f = legged
    q, v, _ = states(robot, 3, seed=13)
    tau = np.random.default_rng(13).uniform(-5, 5, (3, robot.nv))
    for i in range(3):
        a, force, da_dq, da_dv, da_dtau, df_dq, df_dv, df_dtau = f.contact_fdyn_derivatives(q[i], v[i], tau[i])
        fd = _central(f.contact_fdyn, robot, q[i], v[i], tau[i])
        for got, want in [(da_dq, fd["q"][0]), (da_dv, fd["v"][0]), (da_dtau, fd["tau"][0])]:
            assert _relative(got, want) < 1e-6
        for got, want in [(df_dq, fd["q"][1]), (df_dv, fd["v"][1]), (df_dtau, fd["tau"][1])]:
            assert _relative(got, want) < 1e-6
        v_after, impulse, dv_dq, dv_dv, di_dq, di_dv = f.contact_impulse_derivatives(q[i], v[i])
        fd = _central(lambda x, y, _: f.contact_impulse(x, y), robot, q[i], v[i], None)
        for got, want in [(dv_dq, fd["q"][0]), (dv_dv, fd["v"][0]), (di_dq, fd["q"][1]), (di_dv, fd["v"][1])]:
            assert _relative(got, want) < 1e-6
        J = np.concatenate([f.frame_jacobian_aligned(q[i])[0, :3], f.frame_jacobian_aligned(q[i])[1]])
        assert np.abs(J @ da_dtau).max() < 1e-10 * max(1.0, np.abs(da_dtau).max())  # τ moves no contact
        assert np.abs(J @ dv_dv).max() < 1e-10 * max(1.0, np.abs(dv_dv).max())  # J v⁺ = 0 for every v⁻


def test_a_rank_deficient_contact_set_is_refused_by_name(twolink):
    """A surface on the two-link arm's tool: 6 rows, 2 joints — the forces are not unique."""
    robot = twolink.nofriction(all=True).with_contacts({"tool": "surface"})
    with pytest.raises(ValueError, match=r"the rows of 'tool' \(surface\) depend on those before it \(none\)"):
        load(robot, "numpy")


def test_contact_sets_are_refused_by_name():
    robot = random_tree_robot(3, n=3, base_joint="free")
    with pytest.raises(ValueError, match="no frame 'lnk2'.*link2"):
        robot.with_contacts({"lnk2": "point"})
    with pytest.raises(ValueError, match="kind 'line' is neither 'point'"):
        robot.with_contacts({"link2": "line"})
    assert robot.with_contacts({"link2": "point"}).fingerprint() != robot.fingerprint()


@pytest.mark.slow
@pytest.mark.parametrize("feet", [4, 2])
def test_solo12_through_generated_c(feet):
    """Solo 12 read from its URDF, four feet (and two) as point contacts, through the generated C,
    against Pinocchio's constraint and impulse dynamics and their derivatives on the same model
    (example-robot-data)."""
    from tests.test_task_space import FEET, _solo_file
    from symdyn.model import Robot

    robot = Robot.from_urdf(str(_solo_file()), tips="all", base_joint="free").nofriction(all=True)
    robot = robot.with_contacts({foot: "point" for foot in FEET[:feet]})
    f = load(robot, "c")
    q, v, _ = states(robot, 20, seed=9)
    tau = np.random.default_rng(9).uniform(-2, 2, (20, robot.nv))
    assert_as_pinocchio(robot, f, q, v, tau, derivatives=("fdyn", "impulse"))


def test_contact_sets_of_one_robot_share_the_derivation(tmp_path, monkeypatch):
    """Each set is a model of its own (its own fingerprint and code) on one joint-space derivation."""
    from symdyn.derivation.entry import derive

    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = arms.load("twolink").nofriction(all=True)
    first = derive(robot.with_contacts({"tool": "point"}), "newton-euler")
    second = derive(robot.with_frames(["tool"]).with_contacts({"tool": "surface"}), "newton-euler")
    assert not first.stats["from_cache"] and second.stats["from_cache"]
    assert second.robot.contacts == (("tool", "surface"),)  # the caller's robot, not the cached one's
    assert robot.with_contacts({"tool": "point"}).fingerprint() != robot.fingerprint()


@pytest.mark.slow
@pytest.mark.parametrize("soles", [("left_sole_link", "right_sole_link"), ("left_sole_link",)])
def test_talos_on_its_soles_through_generated_c(soles):
    """Talos (example-robot-data, a free base, 36 velocities) on two surface contacts and on one,
    through the generated C, against Pinocchio's constraint and impulse dynamics on its own reading
    of the same file."""
    from symdyn.model import Robot
    from symdyn.model.example_robots import robots_folder

    try:
        path = robots_folder() / "talos_data" / "robots" / "talos_full_v2.urdf"
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    locked = {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}
    robot = Robot.from_urdf(str(path), tips="all", base_joint="free", locked=locked).nofriction(all=True)
    robot = robot.with_contacts({sole: "surface" for sole in soles})
    f = load(robot, "c")
    q, v, _ = states(robot, 10, seed=21)
    tau = np.random.default_rng(21).uniform(-5, 5, (10, robot.nv))
    assert_as_pinocchio(robot, f, q, v, tau)
    if len(soles) == 2:  # the derivatives too (under a minute to generate and compile), at three states
        assert_as_pinocchio(robot, f, q[:3], v[:3], tau[:3], derivatives=("fdyn", "impulse"))


@pytest.mark.slow  # 4 s of generating and compiling
@pytest.mark.parametrize("kind", ["fdyn", "impulse"])
def test_the_c_derivatives_plain_loops_equal_the_numpy_targets(tmp_path, legged, kind):
    """The C target's derivatives as a compiler without GCC's vector types runs them (the tangents'
    lane loop, every product kernel's plain loops), equal to the NumPy target's at 5 states."""
    import ctypes
    import shutil
    import subprocess

    from symdyn.codegen import lazy
    from symdyn.codegen.emit import identifier

    if shutil.which("cc") is None:
        pytest.skip("needs a C compiler (cc)")
    robot, f = legged
    name = f"contact_{kind}_derivatives"
    source = lazy.scalar_units(robot, [name])[name].replace("defined(__GNUC__)", "defined(SYMDYN_NO_VECTORS_)")
    (tmp_path / "plain.c").write_text(source)
    subprocess.run(
        ["cc", "-O1", "-shared", "-fPIC", "-o", str(tmp_path / "plain.so"), str(tmp_path / "plain.c")], check=True
    )
    function = getattr(ctypes.CDLL(str(tmp_path / "plain.so")), f"{identifier(robot.name)}_{name}")
    q, v, tau = states(robot, 5, seed=23)
    for i in range(len(q)):
        args = (q[i], v[i], tau[i]) if kind == "fdyn" else (q[i], v[i])
        want = getattr(f, name)(*args)
        got = [np.zeros_like(w) for w in want]
        pointers = [np.ascontiguousarray(x, dtype=float) for x in args] + got
        function(*(x.ctypes.data_as(ctypes.c_void_p) for x in pointers))
        for g, w in zip(got, want):
            assert _relative(g, w) < 1e-12
