"""Identification on floating bases (issue 35): the base body's parameters with the links'.

A floating base's data hold its pose, body-frame velocity and acceleration and the force and
moment on it (τ's base rows: what a force plate or a carrier measures; zero in free flight), with
the joints'.  Noise-free data simulated from a perturbed robot by the independent recursive
reference give back its base parameters to rounding, and the physically consistent robot (base
body included) reproduces its torques; data files carry the base's named columns and are refused
by name where they and the model disagree.
"""

from __future__ import annotations

import numpy as np
import pytest

from symdyn.identify import fit, load_data, simulate
from symdyn.identify.data import from_arrays, write_csv
from symdyn.identify.parameters import standard_vector, with_standard
from symdyn.identify.simulate import fourier
from symdyn.model.random_robots import random_tree_robot
from symdyn.numeric import reference as ref
from tests.conftest import tiered


def _robot(base: str):
    return random_tree_robot(2, n=3, base_joint=base)


def _data(robot, **options):
    return simulate(robot, fourier(robot, period=4.0, harmonics=4, rate=50.0), seed=1, **options)


@pytest.mark.parametrize("base", tiered(["planar", "free"], 1))
def test_noise_free_data_give_the_base_bodys_and_links_base_parameters_back(base):
    robot = _robot(base)
    data = _data(robot)
    assert (data.q.shape[1], data.tau.shape[1], data.base, data.n) == (robot.nq, robot.nv, base, robot.n)
    if base == "free":  # the simulated pose stays on the unit quaternions
        assert np.abs(np.linalg.norm(data.q[:, 3:7], axis=1) - 1).max() < 1e-12
    res = fit(robot, data, consistent=True)
    truth = res.map.values(data.truth)
    assert res.base.names[0].endswith("0")  # the base body's own parameters come first
    assert np.abs(res.base.values - truth).max() <= 1e-9 * np.abs(truth).max()
    scale = np.abs(data.tau).max()
    assert np.abs(res.predict(data.q, data.qd, data.qdd) - data.tau).max() <= 1e-9 * scale
    consistent = res.robot  # the base body identified too
    assert consistent.base_joint == base and consistent.base_body.m > 0
    assert np.abs(ref.rne(consistent, data.q, data.qd, data.qdd) - data.tau).max() <= 1e-8 * scale
    assert "equations (the base's" in res.summary()


def test_standard_parameters_of_a_floating_base_go_back_into_the_robot():
    robot = _robot("free")
    pi = standard_vector(robot)
    assert len(pi) == 10 + 14 * robot.n
    again = with_standard(robot, pi)
    q = robot.integrate(robot.neutral(), np.linspace(-1, 1, robot.nv))
    v, a = np.linspace(0.5, -0.7, robot.nv), np.linspace(-2, 1, robot.nv)
    assert np.allclose(ref.rne(again, q, v, a), ref.rne(robot, q, v, a), rtol=0, atol=1e-12)
    assert np.isclose(again.base_body.m, robot.base_body.m)


def test_floating_data_files_carry_the_bases_named_columns(tmp_path):
    robot = _robot("planar")
    data = _data(robot)
    path = write_csv(tmp_path / "puck.csv", data)
    header = path.read_text().splitlines()[0].split(",")
    assert header[:5] == ["t", "base_x", "base_y", "base_yaw", "q1"]
    assert {"base_vx", "base_dwz", "base_fx", "base_nz"} <= set(header)
    back = load_data(path, joints=robot)
    for k in ("q", "qd", "qdd", "tau"):
        assert np.array_equal(getattr(back, k), getattr(data, k)), k
    with pytest.raises(ValueError, match="column base_x describes a floating base"):
        load_data(path)  # without the model its base's columns cannot be read
    rows = [line.split(",") for line in path.read_text().splitlines()]
    drop = header.index("base_fx")
    short = tmp_path / "short.csv"
    short.write_text("\n".join(",".join(r[:drop] + r[drop + 1 :]) for r in rows) + "\n")
    with pytest.raises(ValueError, match="column base_fx is missing: a planar base's data give"):
        load_data(short, joints=robot)
    rows[3][header.index("base_vx")] = "nan"
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(ValueError, match=r"bad.csv:4: row 3, column base_vx: nan"):
        load_data(bad, joints=robot)
    with pytest.raises(ValueError, match="has no room for the base's"):
        from_arrays(data.t, data.q[:, :2], data.tau, qd=data.qd, qdd=data.qdd, joints=robot)
    with pytest.raises(ValueError, match="a planar base but the model 'tree2' has a free base"):
        fit(_robot("free"), data, consistent=False)


PUCK = """<robot name="puck">
  <link name="disc"><inertial><mass value="2"/><inertia ixx="0.1" iyy="0.1" izz="0.2" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
  <link name="arm"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
  <inertia ixx="0.01" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="disc"/><child link="arm"/><origin xyz="0.3 0 0"/>
  <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="5" velocity="3"/></joint>
</robot>
"""


def test_the_command_line_simulates_and_fits_a_floating_base(tmp_path):
    """A trajectory file with the base's columns, `identify simulate` and `identify fit` of a URDF read
    with --base-joint planar: the truth's base parameters back, the base body in the truth file."""
    import json

    from symdyn import Robot, cli
    from symdyn.identify.simulate import write_trajectory

    urdf = tmp_path / "puck.urdf"
    urdf.write_text(PUCK)
    robot = Robot.from_urdf(str(urdf), base_joint="planar")
    trajectory = write_trajectory(tmp_path / "traj.csv", fourier(robot, period=4, harmonics=4, rate=50), robot)
    assert trajectory.read_text().startswith("t,base_x,base_y,base_yaw,q1,base_vx,")
    model = [str(urdf), "--base-joint", "planar"]
    data = tmp_path / "data.csv"
    assert cli.main(["identify", "simulate", *model, str(trajectory), "--seed", "3", "--out", str(data)]) == 0
    truth = json.loads(data.with_suffix(".truth.json").read_text())
    assert truth["base_body"]["m"] != 2.0 and "XX0" in truth["standard"]  # the body perturbed, and identified
    out = tmp_path / "fit"
    assert cli.main(["identify", "fit", *model, str(data), "--out", str(out), "--no-consistent"]) == 0
    params = json.loads((out / "parameters.json").read_text())
    assert params["base"][0]["name"].endswith("0")
    for row in params["base"]:
        assert row["value"] == pytest.approx(truth["base"][row["name"]], rel=1e-8, abs=1e-10)


# make test-all: the CasADi route is in the main suite on a fixed-base arm
# (tests/test_identify_consistent.py::test_the_casadi_route_agrees_with_the_sdp_inside_the_cone)
@pytest.mark.slow
@pytest.mark.parametrize("base", ["planar", "free"])
def test_without_clarabel_the_casadi_route_is_as_accurate(base):
    """The fallback (IPOPT over a log-Cholesky factor, no extra) stops at the same residual as the
    SDP: the consistent robot reproduces the torques to 1e-8 of their scale (it stopped at 1e-6
    when IPOPT's tolerance was the SDP's, on a squared objective)."""
    robot = _robot(base)
    data = _data(robot)
    res = fit(robot, data, consistent=True, consistent_options={"method": "casadi"})
    scale = np.abs(data.tau).max()
    assert np.abs(ref.rne(res.robot, data.q, data.qd, data.qdd) - data.tau).max() <= 1e-8 * scale
