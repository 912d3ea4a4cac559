"""Identification (issue 24): data in, least squares on the exact base regressor, the simulated bench.

Noise-free data from a perturbed arm give back its base parameters to rounding; with noise, the
95 % intervals hold the truth at the nominal rate and are as wide as the estimates' real spread;
bad files are errors that name the column and the row; the command line runs the loop.  The
torques the data hold come from the independent recursive reference (`reference.rne`), never from
the regressor under test.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from symdyn import cli
from symdyn.identify import Data, fit, load_data, simulate
from symdyn.identify.data import from_arrays, write_csv
from symdyn.identify.parameters import base_map, standard_vector
from symdyn.identify.simulate import fourier, perturbed, write_trajectory
from symdyn.model import arms
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref
from tests.conftest import tiered

#: The generated code that evaluates Y in these tests: NumPy loads at once, C would compile per worker.
TARGET = "numpy"
#: Random arms with prismatic joints, motors and asymmetric Coulomb friction.
RANDOM = ArmOptions(n_min=2, n_max=3, symbolic=0.0, prismatic=0.5, motor=1.0)


def _errors(res, truth, data) -> np.ndarray:
    """|β̂ − β| relative to |β|, or to the size s_k = ‖τ‖/‖Y_k‖ a parameter needs to show in the
    torques where β is smaller than that (a zero or negligible parameter)."""
    true = base_map(res.prior).values(truth)
    from symdyn.identify.estimate import regressor_rows

    Y = regressor_rows(res.prior, data.q, data.qd, data.qdd, target=TARGET).reshape(-1, len(true))
    s = np.linalg.norm(data.tau) / np.linalg.norm(Y, axis=0)
    return np.abs(res.base.values - true) / np.maximum(np.abs(true), s)


def _arm(case):
    return arms.load(case) if isinstance(case, str) else random_arm(case, RANDOM)


@pytest.mark.parametrize("case", tiered(["twolink", "puma560", 1, 4, 11], 3))  # random arms 4 and 11: make test-all
def test_noise_free_data_give_the_base_parameters_and_the_torques_back(case):
    robot = _arm(case)
    traj = fourier(robot, period=5, harmonics=5, rate=40, seed=1, rest=0.5)
    data = simulate(robot, traj, perturb=0.2, seed=3)
    res = fit(robot, data, consistent=False, target=TARGET)
    assert _errors(res, data.truth, data).max() < 1e-8
    scale = np.abs(data.tau).max()
    assert np.abs(res.predict(data.q, data.qd, data.qdd) - data.tau).max() < 1e-8 * scale
    assert res.rms.max() < 1e-8 * scale
    # the standard parameters behind the estimate reproduce the data through the full regressor
    pi = res.standard()
    assert np.allclose(res.map.P @ pi, res.base.values, rtol=0, atol=1e-9 * np.abs(res.base.values).max())


def test_random_arms_hold_prismatic_joints_and_coulomb_friction():
    """The random cases above cover what the issue asks: prismatic joints and Coulomb friction."""
    robots = [random_arm(seed, RANDOM) for seed in (1, 4, 11)]
    assert sum(link.joint == "prismatic" for r in robots for link in r.links) >= 4
    assert all(any(link.Tc != (0, 0) for link in r.links) for r in robots)


def test_base_map_rewrites_the_full_regressor_exactly(puma):
    from symdyn import load

    bmap = base_map(puma)
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-2, 2, (20, 6)) for _ in range(3))
    Y = load("puma560", TARGET).Y(q, qd, qdd)
    pi = standard_vector(puma)
    full = Y @ pi
    assert np.allclose(Y[:, :, list(bmap.columns)] @ (bmap.P @ pi), full, rtol=1e-12, atol=1e-12 * abs(full).max())
    assert np.allclose(full, ref.rne(puma, q, qd, qdd), rtol=1e-10, atol=1e-10)


def test_parallel_decimation_keeps_the_identity_and_wls_equals_ols_without_noise(twolink):
    data = simulate(twolink, fourier(twolink, period=4, harmonics=4, rate=200, seed=4, rest=0.5), seed=2)
    decimated = Data(**{**data.__dict__, "decimate": 6})
    for method in ("wls", "ols"):
        res = fit(twolink, decimated, method, consistent=False, target=TARGET)
        assert res.samples == -(-data.N // 6)
        assert _errors(res, data.truth, data).max() < 1e-8
    # filtering τ alone, not Y with it, breaks τ = Y β: the fit sees it
    from symdyn.identify.data import lowpass

    wrong = Data(**{**data.__dict__, "tau": lowpass(data.tau, 2.0, 200.0)})
    assert _errors(fit(twolink, wrong, consistent=False, target=TARGET), data.truth, data).max() > 1e-4


def test_calibration_intervals_hold_the_truth_at_the_nominal_rate_and_are_not_inflated(twolink):
    """50 noise seeds, one true arm and one trajectory; joint 2 four times noisier than joint 1 (WLS).
    Coverage of the 95 % intervals within ±0.03 of 0.95 (650 intervals: σ of the rate 0.009), and the
    reported σ within 15 % of the estimates' spread across seeds (an inflated σ passes the first, not
    the second)."""
    traj = fourier(twolink, period=5, harmonics=5, rate=60, seed=1, rest=0.5)
    truth = perturbed(twolink, 0.2, seed=5)
    true = base_map(twolink).values(truth)
    clean = simulate(twolink, traj, truth=truth)
    sigma = np.array([0.01, 0.04]) * np.sqrt(np.mean(clean.tau**2, axis=0)).max()
    est, std = [], []
    for seed in range(50):
        res = fit(
            twolink, simulate(twolink, traj, truth=truth, noise=sigma, seed=100 + seed), consistent=False, target=TARGET
        )
        est.append(res.base.values)
        std.append(res.base.std)
        assert np.allclose(res.sigma, sigma, rtol=0.25)  # the WLS weights find each joint's noise
    est, std = np.array(est), np.array(std)
    coverage = np.mean(np.abs(est - true) <= 1.959964 * std)
    assert abs(coverage - 0.95) <= 0.03, coverage
    ratio = np.median(std.mean(axis=0) / est.std(axis=0, ddof=1))
    assert 0.85 <= ratio <= 1.15, ratio


def test_wls_weights_are_each_joints_own_noise(puma):
    """Noise 100× apart between the shoulder and the wrist: each joint's σ is estimated from its own
    equations (Gautier & Khalil), not from the joint OLS residual, which would carry the shoulder's
    noise into the wrist's through β̂ (the Panda's wrist looked 4× noisier that way)."""
    traj = fourier(puma, period=5, harmonics=5, rate=80, seed=1, rest=0.5)
    noise = np.array([1.0, 1.0, 0.3, 0.01, 0.01, 0.01])
    res = fit(puma, simulate(puma, traj, seed=4, noise=noise), consistent=False, target=TARGET)
    assert np.allclose(res.sigma, noise, rtol=0.2), res.sigma / noise


# --------------------------------------------------------------------------- data in


def _csv(tmp_path, text: str, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


GOOD = "t,q1,q2,tau1,tau2\n0,0,0,1,2\n0.1,0.1,0.2,1,2\n0.2,0.2,0.3,1,2\n"


@pytest.mark.parametrize(
    "text, words",
    [
        ("t,q1,q2,tau1\n0,0,0,1\n0.1,0,0,1\n", ["tau2", "missing"]),
        ("q1,q2,tau1,tau2\n0,0,1,2\n", ["'t'"]),
        ("t,q1,q3,tau1,tau3\n0,0,0,1,2\n", ["q2", "missing"]),
        ("t,q1,q2,tau1,tau2\n0,0,0,1,2\n0.1,0,0,1,2\n0.1,0,0,1,2\n", ["row 3", "column t", "data.csv:4"]),
        ("t,q1,q2,tau1,tau2\n0,0,0,1,2\n0.1,0,nan,1,2\n", ["row 2", "column q2", "data.csv:3"]),
        ("t,q1,q2,tau1,tau2\n0,0,0,1,2\n0.1,0,0,abc,2\n", ["row 2", "column tau1", "'abc'"]),
        ("t,q1,q2,tau1,tau2\n0,0,0,1,2\n0.1,0,0,1\n", ["row 2", "4 fields"]),
        ("t,q1,q2,q3,tau1,tau2,tau3\n0,0,0,0,1,2,3\n", ["3 joints", "q3", "twolink"]),
    ],
)
def test_bad_data_is_an_error_naming_the_column_and_row(tmp_path, twolink, text, words):
    with pytest.raises(ValueError) as exc:
        load_data(_csv(tmp_path, text), joints=twolink, cutoff=None)
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_the_model_checks_the_joint_count_in_fit(tmp_path, puma):
    data = from_arrays(
        np.arange(3) * 0.1, np.zeros((3, 2)), np.zeros((3, 2)), qd=np.zeros((3, 2)), qdd=np.zeros((3, 2))
    )
    with pytest.raises(ValueError, match="column q3 is missing"):
        fit(puma, data, consistent=False, target=TARGET)


def test_motor_currents_with_a_torque_constant_and_npz(tmp_path, twolink):
    text = "t,q1,q2,qd1,qd2,qdd1,qdd2,i1,i2\n0,0,0,0,0,0,0,1,2\n0.1,0,0,0,0,0,0,3,4\n"
    data = load_data(_csv(tmp_path, text), torque_constant=[0.5, 2.0], joints=twolink)
    assert np.array_equal(data.tau, [[0.5, 4.0], [1.5, 8.0]])
    with pytest.raises(ValueError, match="no column i1"):
        load_data(_csv(tmp_path, GOOD, "g.csv"), torque_constant=0.1)
    np.savez(tmp_path / "d.npz", t=data.t, q=data.q, qd=data.qd, qdd=data.qdd, tau=data.tau)
    again = load_data(tmp_path / "d.npz", joints=2)
    assert np.array_equal(again.tau, data.tau) and np.array_equal(again.q, data.q)
    np.savez(
        tmp_path / "bad.npz",
        t=data.t,
        q1=data.q[:, 0],
        q2=[0.0, np.inf],
        tau1=data.tau[:, 0],
        tau2=data.tau[:, 1],
        qd1=data.t,
        qd2=data.t,
        qdd1=data.t,
        qdd2=data.t,
    )
    with pytest.raises(ValueError, match="row 2, column q2"):
        load_data(tmp_path / "bad.npz")


def test_filtered_differentiation_of_sampled_angles(tmp_path, twolink):
    """q alone at 500 Hz, quantised to 1e-5 rad: the low-passed central differences follow the true
    q̇ and q̈ (away from the ends), and the fit from them is close to the truth."""
    traj = fourier(twolink, period=4, harmonics=4, rate=500, seed=3)
    data = simulate(twolink, traj, seed=1, quantisation=1e-5)
    path = write_csv(tmp_path / "q.csv", data, derivatives=False)
    read = load_data(path, joints=twolink)
    edge = 150  # 3/cutoff = 0.3 s at each end: filtfilt's edge transients
    assert np.array_equal(read.t, traj.t[edge:-edge])
    assert np.abs(read.qd - traj.qd[edge:-edge]).max() < 2e-3 * np.abs(traj.qd).max()
    assert np.abs(read.qdd - traj.qdd[edge:-edge]).max() < 2e-2 * np.abs(traj.qdd).max()
    assert any("Butterworth" in note for note in read.notes)
    res = fit(twolink, read, consistent=False, target=TARGET)
    assert np.abs(res.base.values - base_map(twolink).values(data.truth)).max() < 0.05 * np.abs(res.base.values).max()


def test_unexcited_parameters_are_named(twolink):
    traj = fourier(twolink, period=4, harmonics=3, rate=50, seed=1)
    still = traj.q.copy()
    still[:, 1] = 0.3  # joint 2 never moves
    zero = np.zeros_like(traj.qd[:, 1])
    data = simulate(
        twolink,
        type(traj)(traj.t, still, np.column_stack([traj.qd[:, 0], zero]), np.column_stack([traj.qdd[:, 0], zero])),
    )
    with pytest.raises(ValueError, match="FV2"):
        fit(twolink, data, consistent=False, target=TARGET)


# --------------------------------------------------------------------------- the command line


def test_command_line_simulates_fits_and_validates(tmp_path, twolink):
    for name, seed in (("fit", 1), ("check", 2)):
        write_trajectory(
            tmp_path / f"{name}-trajectory.csv", fourier(twolink, period=4, harmonics=4, rate=50, seed=seed, rest=0.5)
        )
        assert (
            cli.main(
                [
                    "identify",
                    "simulate",
                    "twolink",
                    str(tmp_path / f"{name}-trajectory.csv"),
                    "--perturb",
                    "0.2",
                    "--seed",
                    "9",
                    "--out",
                    str(tmp_path / f"{name}.csv"),
                ]
            )
            == 0
        )
    truth = json.loads((tmp_path / "fit.truth.json").read_text())
    out = tmp_path / "result"
    assert (
        cli.main(
            [
                "identify",
                "fit",
                "twolink",
                str(tmp_path / "fit.csv"),
                "--validate",
                str(tmp_path / "check.csv"),
                "--out",
                str(out),
                "--no-consistent",
                "--target",
                TARGET,
            ]
        )
        == 0
    )
    params = json.loads((out / "parameters.json").read_text())
    for row in params["base"]:
        assert row["value"] == pytest.approx(truth["base"][row["name"]], rel=1e-8, abs=1e-10)
    summary = (out / "summary.txt").read_text()
    assert "validation on" in summary and "condition number" in summary
    assert {p.name for p in out.iterdir()} >= {
        "summary.txt",
        "parameters.json",
        "fit.png",
        "validation.png",
        "parameters.png",
    }
    assert cli.main(["identify", "fit", "twolink", str(tmp_path / "nothere.csv"), "--out", str(out)]) == 2


def test_the_consistent_robot_reproduces_noise_free_data_and_its_urdf_carries_it(tmp_path):
    """A URDF arm (a continuous joint, a massless link, a prismatic joint along a generic axis with
    damping and friction): from noise-free data the physically consistent robot's torques (the
    reference recursion) equal the data's, every pseudo-inertia is positive semidefinite, and the
    identified.urdf read back carries its inertials."""
    from pathlib import Path

    from symdyn import Robot
    from symdyn.model import command_line

    path = Path(__file__).parent / "urdf" / "prismatic_continuous.urdf"
    robot = command_line.load(str(path))
    data = simulate(robot, fourier(robot, period=4, harmonics=4, rate=50, seed=1, rest=0.5), seed=2)
    res = fit(robot, data, consistent=True, target=TARGET)
    assert _errors(res, data.truth, data).max() < 1e-8
    tau = ref.rne(res.robot, data.q, data.qd, data.qdd)
    assert np.abs(tau - data.tau).max() < 1e-8 * np.abs(data.tau).max()
    assert min(res.consistent.margins) >= -1e-9
    written = res.write(tmp_path, figures=False, urdf_source=path)
    assert tmp_path / "identified.urdf" in written
    again = Robot.from_urdf(tmp_path / "identified.urdf")
    inertial = [k for k in range(14 * robot.n) if k % 14 < 10]  # XX…M: what a URDF's <inertial> holds
    assert np.abs(standard_vector(again)[inertial] - res.standard()[inertial]).max() < 1e-9
    assert "not at hand" not in (tmp_path / "summary.txt").read_text()


def test_joints_at_rest_are_left_out_where_the_speed_was_differentiated(tmp_path, puma):
    """q-only data with a 0.5 s hold, a 17-bit encoder: q̇ differentiated from q is noise at rest,
    and sign(q̇)·Tc with it; fit leaves those equations out (rest_speed, by default where load_data
    differentiated q).  Kept, they leave joint 1 with a residual of ~4.5 N·m (measured); left out,
    the fit predicts the exact torques to a few hundredths of a N·m."""
    traj = fourier(puma, period=6, harmonics=4, rate=200, seed=2, rest=0.5)
    data = simulate(puma, traj, perturb=0.2, seed=3, quantisation=2 * np.pi / 2**17)
    qonly = load_data(write_csv(tmp_path / "q.csv", data, derivatives=False), joints=puma)
    assert qonly.differentiated and not data.differentiated

    def error(res):  # RMS per joint against the exact torques
        return np.sqrt(np.mean((res.predict(data.q, data.qd, data.qdd) - data.tau) ** 2, axis=0))

    kept = error(fit(puma, qonly, consistent=False, rest_speed=0.0, target=TARGET))
    left_out = error(fit(puma, qonly, consistent=False, target=TARGET))
    assert kept[0] > 0.5 and left_out.max() < 0.1, (kept, left_out)
    with pytest.raises(ValueError, match="rest_speed must be a speed >= 0"):
        fit(puma, qonly, consistent=False, rest_speed=-1.0, target=TARGET)
