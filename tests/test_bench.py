"""Tests of the benchmark (symdyn.bench): the C harness compiles, runs and times
code that agrees with the reference; the Pinocchio C++ peer is fed the same arm
(its arm file, rebuilt as the C++ builds it, gives the reference's dynamics),
is cached by content and rebuilt when stale or damaged; the report compares
only with real peers and says what to install for a missing one.  The peer's
C++ itself is not compiled here (minutes); no timing assertions (the machine is
shared and noisy)."""

import math
import re
import sys
import types

import numpy as np
import pytest

from symdyn import models
from symdyn.bench import compare as bench
from symdyn.bench import pin_peer
from symdyn.model import Link, Robot
from symdyn.numeric import reference
from symdyn.codegen.entry import GENERATED
from tests.conftest import tiered

PUMA = GENERATED / "puma560"
FUNCTIONS = ("tau", "M", "C", "Cqd", "G", "fdyn", "tau_derivatives", "fdyn_derivatives", "Minv", "casadi_rnea")


@pytest.fixture(scope="module")
def harness_run(tmp_path_factory):
    """The shipped Puma 560 and CasADi's plain RNEA in one harness, run with 1000 calls."""
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SYMDYN_CACHE_DIR", str(cache))
        robot = models.load("puma560")
        states = bench.random_states(robot.nofriction(all=True), bench.POOL, seed=1)
        casadi_c = bench.casadi_rnea_c(robot, cache / "casadi")
        binary = bench.build_harness(PUMA / "puma560.c", PUMA / "puma560.h", casadi_c)
        path = bench.write_states(cache / "states.bin", *states)
        times, checks = bench.run_harness(binary, path, ncalls=1000, reps=3)
    return robot, states, times, checks


def test_harness_times_every_function(harness_run):
    _, _, times, checks = harness_run
    assert set(times) == set(FUNCTIONS) == set(checks)
    assert all(math.isfinite(t) and t > 0 for t in times.values()), times


def test_harness_outputs_agree_with_reference(harness_run):
    robot, states, _, checks = harness_run
    assert bench.check_harness(robot, checks, *states) < 1e-9
    assert checks["M"].shape == (36,) and checks["fdyn"].shape == (6,)


def test_harness_check_rejects_wrong_output(harness_run):
    robot, states, _, checks = harness_run
    wrong = dict(checks, M=checks["M"] + np.eye(6).ravel() * 1e-3)
    with pytest.raises(RuntimeError, match="M at state 3"):
        bench.check_harness(robot, wrong, *states)


def test_harness_checks_derivatives_against_central_differences(harness_run):
    robot, states, _, checks = harness_run
    assert checks["tau_derivatives"].shape == (36,) and checks["fdyn_derivatives"].shape == (36,)
    wrong = dict(checks, fdyn_derivatives=checks["fdyn_derivatives"] * (1 + 1e-4))
    with pytest.raises(RuntimeError, match="fdyn_derivatives at state 3"):
        bench.check_harness(robot, wrong, *states)


def test_states_pool_must_be_power_of_two(tmp_path):
    q = np.zeros((6, 6))
    with pytest.raises(ValueError, match="power-of-two"):
        bench.write_states(tmp_path / "s.bin", q, q, q, q)


def test_op_counts_read_from_generated_header(tmp_path):
    header = (
        "/*\n * operation counts (a - b counts as one add, negation is free):\n"
        " *   tau   230 mul, 171 add, 16 fun (417 total)  [newton-euler]\n"
        " *   fdyn  411 mul, 297 add, 6 div, 16 fun (730 total)  [newton-euler]\n */\n"
        "void m_tau(void) { /* 12 mul (99 total) is not in the header */ }\n"
    )
    (tmp_path / "m.c").write_text(header)
    assert bench.op_counts(tmp_path / "m.c") == {"tau": 417, "fdyn": 730}
    shipped = bench.op_counts(PUMA / "puma560.c")
    functions = re.findall(r"function: (\w+)\(", (PUMA / "puma560.h").read_text())
    assert sorted(shipped) == sorted(functions) and all(n > 0 for n in shipped.values())


def _row(function, ours, peer, theirs, ops=None, target=None, level=bench.C_PEER):
    return bench.Row(level, function, ours, peer, theirs, ops, target)


def test_table_has_speed_up_and_target_columns():
    rows = [
        _row("tau", (100.0, 125.0, 90.0), "Pinocchio rnea", (850.0, 900.0, 800.0), 369, 8),
        _row("M", (200.0,), "Pinocchio crba", (850.0,), 196, 6),
        _row("tau", (50.0,), "plain RNEA, CasADi C codegen", (100.0,), 369, 1, level=bench.C_BASELINE),
    ]
    assert [r.ratio for r in rows] == [8.5, 4.25, 2.0]
    assert rows[0].spread == (900.0 / 125.0, 800.0 / 90.0) and rows[1].spread is None
    assert [r.met for r in rows] == ["yes", "no", "yes"]
    text = bench.format_table(rows, ["Robotics Toolbox: not installed (roboticstoolbox-python): run `make bench`"])
    lines = text.splitlines()
    assert lines[0] == bench.C_PEER and lines.index(bench.C_BASELINE) == 6
    assert {"symdyn", "peer", "speed-up", "range", "ops", "target", "met"} <= set(lines[1].split())
    assert "8.50×" in text and "7.20–8.89" in text and "4.25×" in text and "n/a" not in text
    assert lines[-2] == bench.OPS_NOTE and lines[-1].endswith("run `make bench`")
    md = bench.markdown_table(rows).splitlines()
    assert md[0] == f"**{bench.C_PEER}**" and md[2].startswith("| function | symdyn ns")
    assert "| 8.50× | 7.20–8.89 | 369 | ≥ 8× | yes |" in md[4]


def test_a_row_needs_a_measured_peer():
    with pytest.raises(ValueError, match="'tau' vs 'Robotics Toolbox'"):
        _row("tau", (1.0,), "Robotics Toolbox", ())


def test_missing_toolbox_makes_no_row_and_says_make_bench(puma, monkeypatch):
    """Without the Toolbox the NumPy target is compared with nothing (formerly with symdyn's own
    reference, under a peer's column); every row's peer is an outside library."""
    bare = puma.nofriction(all=True)
    tau = lambda q, qd, qdd: reference.rne(bare, q, qd, qdd)  # noqa: E731
    monkeypatch.setattr(
        "symdyn.codegen.emit.clib.load_library", lambda c, h: types.SimpleNamespace(functions={"tau": tau})
    )
    monkeypatch.setattr(bench, "_import_path", lambda path, name: types.SimpleNamespace(tau=tau))
    monkeypatch.setattr(bench, "_paired_ns", lambda ours, peer, number, repeat, per=1: ((1.0,), (2.0,)))
    monkeypatch.setattr(bench, "_shipped_model", lambda: None)
    monkeypatch.setattr(bench, "toolbox_robot", lambda robot: None)
    states = bench.random_states(bare, bench.POOL, seed=2)
    missing = []
    rows = bench.python_level(
        puma,
        {"c": PUMA / "puma560.c", "h": PUMA / "puma560.h", "py": PUMA / "puma560.py"},
        states,
        None,
        print,
        missing,
    )
    assert [r.peer for r in rows] == ["pin.rnea", "pin.rneaInParallel, 1 thread"]
    assert missing == [f"Robotics Toolbox: not installed (roboticstoolbox-python): {pin_peer.HOW_TO_INSTALL}"]
    assert "make bench" in missing[0]


def test_every_c_row_compares_with_pinocchio_or_is_titled_a_baseline():
    for group, label, _, _, peer, algo, _ in bench.C_ROWS:
        if group == bench.C_PEER:
            assert peer.startswith("Pinocchio") and algo in pin_peer.ALGORITHMS, (label, peer)
        else:
            assert group == bench.C_BASELINE and "not a peer" in group and algo == "casadi_rnea"
    assert "Pinocchio C++" in bench.C_PEER and "same run" in bench.C_PEER


def test_model_option_defaults_to_the_puma_and_keeps_its_report():
    assert bench.model_names(None) == ["puma560"]
    assert bench.model_names(["panda", "iiwa14", "panda"]) == ["panda", "iiwa14"]
    assert bench._title(bench.C_PEER, "puma560") == bench.C_PEER
    assert bench._title(bench.C_PEER, "panda") == f"panda: {bench.C_PEER}"


def test_model_option_with_an_unknown_name_names_the_known_models(capsys):
    with pytest.raises(ValueError, match=r"unknown model 'kuka': known models are .*panda, iiwa14, ur5"):
        bench.main(["--model", "panda", "kuka", "--no-pin"])
    from symdyn import cli

    assert cli.main(["bench", "--model", "kuka"]) == 2
    assert "known models are" in capsys.readouterr().err


def test_arm_targets_are_issue_15s():
    for arm in ("panda", "iiwa14"):
        assert bench.TARGETS[arm] == {"rnea": 4, "crba": 4, "aba": 4, "computeCoriolisMatrix": 2, "pin.rnea": 3}
    assert set(bench.TARGETS[arm]) - {"pin.rnea"} <= set(pin_peer.ALGORITHMS)


# --------------------------------------------------------------------------- the C++ peer's arm file


def _read_arm(path):
    """The arm file parsed by its documented format (pin_peer.cpp's header): (joints, gravity)."""
    lines = path.read_text().splitlines()
    assert lines[0] == "symdyn-pin-arm 1" and lines[1].split()[0] == "n" and lines[2].split()[0] == "gravity"
    n, gravity = int(lines[1].split()[1]), np.array(lines[2].split()[1:], dtype=float)
    assert len(lines) == 3 + n
    joints = []
    for line in lines[3:]:
        kind, *v = line.split()
        v = np.array(v, dtype=float)
        assert kind in "RP" and len(v) == 26
        Ixx, Ixy, Ixz, Iyy, Iyz, Izz = v[19:25]
        joints.append(
            pin_peer.PeerJoint(
                kind == "R",
                tuple(v[:3]),
                tuple(map(tuple, v[3:15].reshape(3, 4))),
                v[15],
                tuple(v[16:19]),
                ((Ixx, Ixy, Ixz), (Ixy, Iyy, Iyz), (Ixz, Iyz, Izz)),
                v[25],
            )
        )
    return joints, gravity


def _model_like_the_cpp(joints, gravity):
    """A Pinocchio model built from PeerJoints as pin_peer.cpp's read_arm builds it."""
    import pinocchio as pin

    model, parent = pin.Model(), 0
    for i, j in enumerate(joints, start=1):
        axis = np.array(j.axis)
        aligned = [k for k in range(3) if np.array_equal(axis, np.eye(3)[k])]
        if aligned:
            joint = getattr(pin, f"JointModel{'R' if j.revolute else 'P'}{'XYZ'[aligned[0]]}")()
        else:
            joint = pin.JointModelRevoluteUnaligned(axis) if j.revolute else pin.JointModelPrismaticUnaligned(axis)
        placement = np.vstack([np.array(j.placement), [0, 0, 0, 1]])
        parent = model.addJoint(parent, joint, pin.SE3(placement), f"j{i}")
        model.appendBodyToJoint(parent, pin.Inertia(j.mass, np.array(j.com), np.array(j.inertia)), pin.SE3.Identity())
    model.armature = np.array([j.armature for j in joints])
    model.gravity = pin.Motion(np.array(gravity), np.zeros(3))
    return model


def _outputs(model, q, qd, qdd, tau):
    """What pin_peer.cpp prints on its check lines, computed by Pinocchio's Python bindings."""
    import pinocchio as pin

    data = model.createData()
    sym = lambda m: np.triu(m) + np.triu(m, 1).T  # noqa: E731
    M = sym(pin.crba(model, data, q))
    return {
        "rnea": pin.rnea(model, data, q, qd, qdd).copy(),
        "crba": M,
        "aba": pin.aba(model, data, q, qd, tau).copy(),
        "computeGeneralizedGravity": pin.computeGeneralizedGravity(model, data, q).copy(),
        "nonLinearEffects": pin.nonLinearEffects(model, data, q, qd).copy(),
        "computeCoriolisMatrix": pin.computeCoriolisMatrix(model, data, q, qd).copy(),
        "crba_cholesky": np.linalg.solve(M, tau - pin.nonLinearEffects(model, data, q, qd)),
        "computeRNEADerivatives": pin.computeRNEADerivatives(model, data, q, qd, qdd)[0].copy(),
        "computeABADerivatives": pin.computeABADerivatives(model, data, q, qd, tau)[0].copy(),
        "computeMinverse": sym(pin.computeMinverse(model, data, q)),
    }


def _modified_prismatic_arm():
    """Modified DH with a prismatic joint, offsets and rotor inertia: the other branches of the DH walk."""
    I = ((0.02, 0.001, 0.0), (0.001, 0.03, 0.002), (0.0, 0.002, 0.025))
    links = [
        Link(d=0.3, alpha=0.0, a=0.0, offset=0.2, m=2.0, r=(0.01, 0.02, 0.1), I=I, Jm=1e-4, G=50),
        Link(joint="prismatic", theta=0.4, a=0.1, alpha=-np.pi / 2, offset=0.05, m=1.5, r=(0.0, 0.03, -0.05), I=I),
        Link(d=0.1, a=0.25, alpha=np.pi / 3, m=0.8, r=(0.05, 0.0, 0.0), I=I, Jm=2e-4, G=-30),
    ]
    return Robot("mdh3", tuple(links), convention="modified")


@pytest.mark.parametrize("arm", tiered(["puma560", "mdh3", "panda"], 2))  # the Panda: make test-all
def test_arm_file_round_trip_gives_the_reference_dynamics(arm, puma, tmp_path):
    """The arm written for the C++ peer, read back and built as the C++ builds it, has the
    dynamics of symdyn's reference: the peer is timed on the very arm symdyn is (the Panda:
    a general-joint URDF arm, as `symdyn bench --model panda` feeds it)."""
    robot = {"puma560": puma, "mdh3": _modified_prismatic_arm()}.get(arm) or models.load(arm)
    robot = robot.nofriction(all=True)
    from symdyn.bench.peers import pinocchio_model

    joints, gravity = pin_peer.arm_joints(pinocchio_model(robot))
    path = pin_peer.write_arm(tmp_path / "arm.txt", joints, gravity)
    back, g = _read_arm(path)
    assert back == joints and np.array_equal(g, gravity)
    model = _model_like_the_cpp(back, g)
    q, qd, qdd, tau = bench.random_states(robot, 8, seed=3)
    for k in range(len(q)):
        outputs = _outputs(model, q[k], qd[k], qdd[k], tau[k])
        exact = {name: v for name, v in outputs.items() if not name.endswith("Derivatives")}
        assert pin_peer.check_peer(robot, exact, q, qd, qdd, tau, k=k) < 1e-10
        assert pin_peer.check_peer(robot, outputs, q, qd, qdd, tau, k=k) < 1e-8  # central differences


def test_unaligned_axes_reach_the_cpp_unchanged(tmp_path):
    """A general joint (any unit axis, any placement): written and rebuilt, Pinocchio gives the same τ."""
    import pinocchio as pin

    rng = np.random.default_rng(4)
    model = pin.Model()
    axes = [np.array([0.6, 0.8, 0.0]), np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.6, -0.8])]
    kinds = [pin.JointModelRevoluteUnaligned(axes[0]), pin.JointModelPZ(), pin.JointModelPrismaticUnaligned(axes[2])]
    for i, joint in enumerate(kinds, start=1):
        j = model.addJoint(i - 1, joint, pin.SE3.Random(), f"j{i}")
        model.appendBodyToJoint(j, pin.Inertia.Random(), pin.SE3.Identity())
    model.armature = np.array([0.1, 0.0, 0.2])
    joints, gravity = pin_peer.arm_joints(model)
    assert [(j.revolute, np.allclose(j.axis, a)) for j, a in zip(joints, axes)] == [
        (True, True),
        (False, True),
        (False, True),
    ]
    rebuilt = _model_like_the_cpp(*_read_arm(pin_peer.write_arm(tmp_path / "arm.txt", joints, gravity)))
    assert [rebuilt.joints[k].shortname() for k in (1, 2, 3)] == [
        "JointModelRevoluteUnaligned",
        "JointModelPZ",
        "JointModelPrismaticUnaligned",
    ]
    q, qd, qdd = rng.uniform(-1, 1, (3, 3))
    want = pin.rnea(model, model.createData(), q, qd, qdd)
    assert np.abs(pin.rnea(rebuilt, rebuilt.createData(), q, qd, qdd) - want).max() < 1e-12


def _model_like_the_cpp_tree(path):
    """A Pinocchio model built from a version-2 arm file (a tree on a fixed, free or planar root) as
    pin_peer.cpp's read_arm builds it, the file parsed by its documented format."""
    import pinocchio as pin

    lines = path.read_text().splitlines()
    assert lines[0] == "symdyn-pin-arm 2" and lines[1].split()[0] == "root"
    root, *b = lines[1].split()[1:]
    n, gravity = int(lines[2].split()[1]), np.array(lines[3].split()[1:], dtype=float)
    assert len(lines) == 4 + n
    model, index = pin.Model(), [0]
    if root != "none":
        kind = pin.JointModelFreeFlyer() if root == "free" else pin.JointModelPlanar()
        index = [model.addJoint(0, kind, pin.SE3.Identity(), "root_joint")]
        b = np.array(b, dtype=float)
        I = np.array([[b[4], b[5], b[6]], [b[5], b[7], b[8]], [b[6], b[8], b[9]]])
        model.appendBodyToJoint(index[0], pin.Inertia(b[0], b[1:4], I), pin.SE3.Identity())
    armature = np.zeros(0)
    for i, line in enumerate(lines[4:], start=1):
        up, rest = line.split(" ", 1)
        assert 0 <= int(up) < i
        (joint,), _ = _read_arm_lines([rest])
        j = _model_like_the_cpp([joint], (0, 0, 0))  # the joint's kind, placement, inertia as the C++ reads them
        index.append(model.addJoint(index[int(up)], j.joints[1], j.jointPlacements[1], f"j{i}"))
        model.appendBodyToJoint(index[-1], j.inertias[1], pin.SE3.Identity())
        armature = np.append(armature, joint.armature)
    model.armature = np.concatenate([np.zeros(model.nv - n), armature])
    model.gravity = pin.Motion(gravity, np.zeros(3))
    return model


def _read_arm_lines(joint_lines):
    """Version-1 joint lines parsed as _read_arm parses them."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "arm.txt"
        path.write_text(f"symdyn-pin-arm 1\nn {len(joint_lines)}\ngravity 0 0 0\n" + "\n".join(joint_lines) + "\n")
        return _read_arm(path)


@pytest.mark.parametrize("base", ["free", "planar", None])
def test_tree_arm_file_gives_the_reference_dynamics(base, tmp_path):
    """A random tree on a free, planar or fixed base, written as a version-2 arm file and rebuilt as
    pin_peer.cpp builds it (planar: q turned into x y cos sin as the C++ does), has the reference's
    τ, M and forward dynamics to 1e-10; the chain format is left as it was."""
    from symdyn.bench.peers import pinocchio_model
    from symdyn.model.random_robots import random_tree_robot

    robot = random_tree_robot(7, n=5, base_joint=base).nofriction(all=True)
    tree = pin_peer.tree_joints(pinocchio_model(robot))
    assert tree.root == (base or "none") and len(tree.joints) == robot.n
    path = pin_peer.write_arm(
        tmp_path / "arm.txt", tree.joints, tree.gravity, parents=tree.parents, root=tree.root, base=tree.base
    )
    model = _model_like_the_cpp_tree(path)
    assert model.nv == robot.nv
    rng = np.random.default_rng(2)
    q = robot.integrate(robot.neutral(), rng.normal(size=(4, robot.nv)))
    qd, qdd = rng.uniform(-2, 2, (2, 4, robot.nv))
    tau = reference.rne(robot, q, qd, qdd)
    x = q if base != "planar" else np.column_stack([q[:, :2], np.cos(q[:, 2]), np.sin(q[:, 2]), q[:, 3:]])
    outputs = _outputs(model, x[3], qd[3], qdd[3], tau[3])
    exact = {k: outputs[k] for k in ("rnea", "crba", "aba", "computeGeneralizedGravity", "crba_cholesky")}
    assert pin_peer.check_peer(robot, exact, q, qd, qdd, tau, rtol=1e-10) < 1e-10


def test_write_arm_keeps_the_chain_format_and_checks_a_tree(tmp_path):
    from symdyn.bench.peers import pinocchio_model

    joints, gravity = pin_peer.arm_joints(pinocchio_model(models.load("puma560")))
    assert pin_peer.write_arm(tmp_path / "a.txt", joints, gravity).read_text().startswith("symdyn-pin-arm 1\nn 6\n")
    with pytest.raises(ValueError, match="parents"):
        pin_peer.write_arm(tmp_path / "b.txt", joints, gravity, parents=[0, 0, 5, 0, 0, 0])
    with pytest.raises(ValueError, match="needs its base body"):
        pin_peer.write_arm(tmp_path / "c.txt", joints, gravity, root="free")


def test_arm_joints_refuse_what_the_cpp_cannot_build():
    import pinocchio as pin

    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    with pytest.raises(ValueError, match=r"joint 1 \(ball\) is a Pinocchio Spherical joint"):
        pin_peer.arm_joints(model)


def test_check_peer_names_a_wrong_algorithm(puma):
    robot = puma.nofriction(all=True)
    from symdyn.bench.peers import pinocchio_model

    q, qd, qdd, tau = bench.random_states(robot, 4, seed=5)
    outputs = _outputs(pinocchio_model(robot), q[3], qd[3], qdd[3], tau[3])
    outputs["computeMinverse"] = outputs["computeMinverse"] * (1 + 1e-6)
    with pytest.raises(RuntimeError, match="computeMinverse at state 3 differs"):
        pin_peer.check_peer(robot, outputs, q, qd, qdd, tau)


# --------------------------------------------------------------------------- the C++ peer's build


def test_cache_key_changes_with_source_flags_and_compiler():
    base = pin_peer.cache_key("int main(){}", "c++", pin_peer.CXXFLAGS, [])
    assert base == pin_peer.cache_key("int main(){}", "c++", pin_peer.CXXFLAGS, [])
    others = {
        pin_peer.cache_key("int main(){ }", "c++", pin_peer.CXXFLAGS, []),
        pin_peer.cache_key("int main(){}", "c++", ("-O2",), []),
        pin_peer.cache_key("int main(){}", "g++-nonexistent", pin_peer.CXXFLAGS, []),
        pin_peer.cache_key("int main(){}", "c++", pin_peer.CXXFLAGS, ["/elsewhere"]),
    }
    assert base not in others and len(others) == 4


@pytest.fixture
def fake_compiler(tmp_path, monkeypatch):
    """CXX that 'compiles' in no time (writes the source's first line to -o) and logs each call."""
    log = tmp_path / "calls"
    script = tmp_path / "fakecxx"
    script.write_text(
        '#!/bin/sh\n[ "$1" = --version ] && { echo fake 1.0; exit 0; }\necho x >> '
        + str(log)
        + '\nwhile [ $# -gt 0 ]; do [ "$1" = -o ] && out=$2; shift; done\n'
        'head -1 "$SRC" > "$out"\n'
    )
    script.chmod(0o755)
    source = tmp_path / "pin_peer.cpp"
    source.write_text("// version 1\n")
    monkeypatch.setenv("CXX", str(script))
    monkeypatch.setenv("SRC", str(source))
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(pin_peer, "SOURCE", source)
    monkeypatch.setattr(pin_peer, "include_dirs", lambda: [])
    return source, lambda: len(log.read_text().split()) if log.exists() else 0


def test_peer_is_built_once_and_rebuilt_when_stale_or_damaged(fake_compiler):
    source, calls = fake_compiler
    said = []
    binary = pin_peer.peer_binary(said.append)
    assert binary.read_text() == "// version 1\n" and calls() == 1
    assert said[0].startswith("building the Pinocchio C++ peer") and "minutes" in said[0]
    assert pin_peer.peer_binary(said.append) == binary and calls() == 1  # reused
    binary.write_text("// truncated")  # damaged: rebuilt
    assert pin_peer.peer_binary(said.append) == binary and calls() == 2
    assert binary.read_text() == "// version 1\n"
    source.write_text("// version 2\n")  # stale: a new key
    fresh = pin_peer.peer_binary(said.append)
    assert fresh != binary and fresh.read_text() == "// version 2\n" and calls() == 3


def test_missing_pinocchio_says_make_bench(monkeypatch):
    monkeypatch.setitem(sys.modules, "cmeel", None)
    with pytest.raises(pin_peer.PeerUnavailable, match=r"Pinocchio is not installed \(pin\): run `make bench`"):
        pin_peer.include_dirs()


def test_failed_build_names_the_command(fake_compiler, monkeypatch, tmp_path):
    broken = tmp_path / "brokencxx"
    broken.write_text("#!/bin/sh\necho 'pin_peer.cpp:1: error: nope' >&2\nexit 1\n")
    broken.chmod(0o755)
    monkeypatch.setenv("CXX", str(broken))
    with pytest.raises(pin_peer.PeerUnavailable, match=r"(?s)compiling the Pinocchio C\+\+ peer failed.*error: nope"):
        pin_peer.peer_binary(lambda msg: None)


def test_an_unwritable_cache_folder_does_not_stop_the_harness(tmp_path, monkeypatch, capsys):
    """The cache is an optimisation: with a cache folder that cannot be created (under a
    regular file, which stops root too) the harness is built in a temporary folder, runs,
    and its τ is the reference's; one warning names the folder."""
    (tmp_path / "afile").write_text("not a folder")
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path / "afile" / "cache"))
    twolink = GENERATED / "twolink"
    binary = bench.build_harness(twolink / "twolink.c", twolink / "twolink.h")
    assert not str(binary).startswith(str(tmp_path))
    robot = models.load("twolink")
    states = bench.random_states(robot, bench.POOL, seed=2)
    _, checks = bench.run_harness(binary, bench.write_states(tmp_path / "states.bin", *states), 10, 1, ("tau",))
    q, qd, qdd, _ = (s[3] for s in states)
    assert np.abs(checks["tau"] - reference.rne(robot, q, qd, qdd)).max() < 1e-12
    assert "afile/cache is not writable" in capsys.readouterr().err


def test_the_batched_section_times_checked_variants_and_bounds_them_by_the_ceilings(tmp_path):
    """`symdyn bench --batched` on the two-link arm at small sizes: every variant's output was checked
    against the reference before timing (a wrong peer raises), the costs are the header's op counts and
    the signature's sizes, and the bound is the larger of ops/peak and bytes/bandwidth."""
    from symdyn.bench import batched
    from symdyn.codegen.emit.c import read_signatures

    ceil = batched.ceilings(2, copy_bytes=8e6, iters=20_000, rounds=1)
    assert all(x > 0 for x in (*ceil.ops, *ceil.bandwidth, *ceil.store))  # NaN would fail too
    robot = models.load("twolink")
    result = batched.run(
        robot, sizes=(10, 1001), functions=("tau", "M"), threads=2, log=lambda m: None, rounds=1, budget=0.002
    )
    assert set(result.times) == {("tau", 10), ("tau", 1001), ("M", 10), ("M", 1001)}
    assert {"loop", "simd/1", "simd/T", "pin/1", "pin/T", "casadi/T"} <= set(result.times[("tau", 1001)])
    head = (GENERATED / "twolink" / "twolink.c").read_text()
    tau_line = re.search(r"\*\s+tau\s+(\d+) mul, (\d+) add(?:, (\d+) fun)?", head)
    ops = int(tau_line[1]) + int(tau_line[2]) + batched.FUN_OPS * int(tau_line[3] or 0)
    assert result.costs["tau"] == (ops, 8 * 4 * 2) and result.costs["M"][1] == 8 * (2 + 4)
    sig = {s.name for s in read_signatures((GENERATED / "twolink" / "twolink.h").read_text())}
    assert set(result.costs) <= sig
    compute, memory = ceil.bound_ns(*result.costs["M"])
    assert math.isclose(compute, result.costs["M"][0] / ceil.ops[1] * 1e9)
    assert math.isclose(memory, result.costs["M"][1] / ceil.bandwidth[1] * 1e9)
    text = batched.format_report([result], ceil)
    assert "mul-add peak" in text and "÷ bound" in text
    assert batched.plot([result], tmp_path / "b.png").stat().st_size > 1000


def test_max_bytes_skips_a_batch_too_large_and_is_a_command_line_option():
    """`--max-bytes` (the note the batched section prints names it) leaves out a function and size
    whose outputs would take more memory; it must be positive."""
    from symdyn.bench import batched, compare

    result = batched.run(
        models.load("twolink"), sizes=(10,), functions=("tau",), threads=1, max_bytes=100, log=lambda m: None
    )
    assert not result.times and result.notes == ["tau at N = 10: outputs 0.0 GB > --max-bytes, skipped"]
    with pytest.raises(ValueError, match="--max-bytes must be a positive number of bytes, got 0.0"):
        compare.main(["--model", "twolink", "--batched", "--max-bytes", "0"])


def test_the_task_space_help_names_every_case(capsys, monkeypatch):
    from symdyn.bench import task_bench
    from symdyn.cli import main

    monkeypatch.setenv("COLUMNS", "2000")  # argparse would wrap a name at its hyphen
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    missing = [case for case in task_bench.CASES if not re.search(rf"(?<![\w-]){case}(?![\w-])", text)]
    assert not missing, missing
