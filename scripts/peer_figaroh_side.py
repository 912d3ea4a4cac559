"""FIGAROH's half of `scripts/peer_figaroh.py`: run in FIGAROH's own environment (not symdyn's).

    /tmp/figv/bin/python scripts/peer_figaroh_side.py DATA.npz NOMINAL.urdf TRUTH.urdf OUT.json [REPEATS]

Reads the q, q̇, q̈, τ that symdyn simulated (fit and validation trajectories) and identifies the
arm with FIGAROH's own steps, as `BaseIdentification.solve(decimate=False, wls=…)` chains them:
`build_regressor_basic` (Pinocchio's joint-torque regressor, joint-major rows) →
`get_index_eliminate` / `build_regressor_reduced` (zero columns, tolerance 0.001 as `solve`) →
`QRDecomposer(tolerance=1e-6).double_decomposition` (base parameters and the OLS estimate) →
`relative_stdev` (OLS relative σ) and `BaseIdentification._calculate_joint_variances` /
`_solve_weighted_least_squares` (WLS).  Two configurations: the rigid bodies alone (FIGAROH's
default) and with friction (fv, fs), actuator inertia (Ia) and offset (off) — the same parameter
set as symdyn's (FV, FS, IA, FO).  Writes each one's numbers as JSON and the validation
predictions as OUT.npz.
"""

from __future__ import annotations

import json
import sys
import time
import warnings

import numpy as np

warnings.filterwarnings("ignore")


def _bare():
    from figaroh.identification.base_identification import BaseIdentification

    class Bare(BaseIdentification):
        """BaseIdentification without its YAML and data loading: only its WLS methods are called."""

        def load_trajectory_data(self, data_source=None):
            raise NotImplementedError

    return Bare


def main() -> None:
    data_path, nominal_urdf, truth_urdf, out = sys.argv[1:5]
    repeats = int(sys.argv[5]) if len(sys.argv) > 5 else 3
    import pinocchio as pin

    import figaroh
    from figaroh.identification.identification_tools import relative_stdev
    from figaroh.identification.parameter import add_standard_additional_parameters, get_standard_parameters
    from figaroh.tools.qrdecomposition import QRDecomposer
    from figaroh.tools.regressor import build_regressor_basic, build_regressor_reduced, get_index_eliminate
    from figaroh.tools.robot import Robot

    _Bare = _bare()
    d = np.load(data_path)
    robot = Robot(nominal_urdf, package_dirs=".")
    truth_model = pin.buildModelFromUrdf(truth_urdf)
    n = robot.model.nv
    # the physics check: Pinocchio's RNEA on the true arm's URDF against symdyn's noise-free torques
    truth_data = truth_model.createData()
    tau_rnea = np.array(
        [pin.rnea(truth_model, truth_data, q, v, a) for q, v, a in zip(d["fit_q"], d["fit_qd"], d["fit_qdd"])]
    )
    physics = float(np.abs(tau_rnea - d["fit_tau_clean"]).max() / np.abs(d["fit_tau_clean"]).max())

    report = {
        "figaroh": getattr(figaroh, "__version__", "?"),
        "pinocchio": pin.__version__,
        "physics_max_rel": physics,
        "configs": {},
    }
    predictions = {}
    for label, extras in (("rigid", False), ("motor", True)):
        config = {
            "has_friction": extras,
            "has_actuator_inertia": extras,
            "has_joint_offset": extras,
            "is_joint_torques": True,
            "is_external_wrench": False,
            "act_idxv": list(range(n)),
            "active_joints": list(robot.model.names[1:]),
        }

        def standard(model):
            p = get_standard_parameters(model, config)
            p.update(add_standard_additional_parameters(model, config))  # zeros: the data have none
            return p

        params_std, params_true = standard(robot.model), standard(truth_model)
        tau = d["fit_tau"].T.flatten()  # joint-major, as FIGAROH stacks the rows
        times = []
        for _ in range(repeats):  # the median of `repeats` runs of the whole chain
            t0 = time.perf_counter()
            W = build_regressor_basic(robot, d["fit_q"], d["fit_qd"], d["fit_qdd"], config)
            t1 = time.perf_counter()
            idx_e, params_r = get_index_eliminate(W, params_std, tol_e=0.001)
            W_e = build_regressor_reduced(W, idx_e)
            qr = QRDecomposer(tolerance=1e-6)
            W_b, base_dict, names, phi_ols, phi_nom = qr.double_decomposition(tau, W_e, params_r, params_std)
            rel_ols = relative_stdev(W_b, phi_ols, tau)  # FIGAROH's OLS relative σ (%), rounded to 0.01
            t2 = time.perf_counter()
            # WLS as BaseIdentification does it (joint residual variances from the OLS fit)
            ident = _Bare.__new__(_Bare)
            ident.identif_config = config
            ident.phi_base = phi_ols
            _, diag_sigma = ident._calculate_joint_variances(W_b, tau, n)
            phi_wls, rel_wls = ident._solve_weighted_least_squares(W_b, tau, diag_sigma)
            t3 = time.perf_counter()
            times.append((t1 - t0, t2 - t1, t3 - t2))
        t_reg, t_ols, t_wls = np.median(np.array(times), axis=0)
        # σ unrounded, by FIGAROH's own formulas (relative_stdev; _solve_weighted_least_squares's C_X)
        r = tau - W_b @ phi_ols
        std_ols = np.sqrt(np.diag(r @ r / (W_b.shape[0] - len(phi_ols)) * np.linalg.inv(W_b.T @ W_b)))
        Wt = W_b * np.sqrt(1.0 / (diag_sigma + 1e-12))[:, None]
        std_wls = np.sqrt(np.diag(np.linalg.inv(Wt.T @ Wt)))
        M = qr.get_M()
        true_base = M @ np.array([params_true[k] for k in params_r])
        # validation: the same columns of the validation trajectory's regressor
        W_v = build_regressor_reduced(
            build_regressor_basic(robot, d["val_q"], d["val_qd"], d["val_qdd"], config), idx_e
        )[:, qr.get_base_indices()]
        entry = {
            "columns": W.shape[1],
            "kept": len(params_r),
            "names": list(names),
            "true": true_base.tolist(),
            "nominal": np.asarray(phi_nom).tolist(),
            "condition": float(np.linalg.cond(W_b)),
            "seconds_regressor": t_reg,
            "seconds_qr_ols": t_ols,
            "seconds_wls": t_wls,
            "rank_check": int(np.linalg.matrix_rank(W_e)),
            "methods": {},
        }
        for method, phi, std, rel in (("ols", phi_ols, std_ols, rel_ols), ("wls", phi_wls, std_wls, rel_wls)):
            fit_res = (tau - W_b @ phi).reshape(n, -1)
            pred = (W_v @ phi).reshape(n, -1).T
            predictions[f"{label}_{method}"] = pred
            entry["methods"][method] = {
                "values": np.asarray(phi).tolist(),
                "std": std.tolist(),
                "relative": np.asarray(rel).tolist(),
                "rms_fit": np.sqrt(np.mean(fit_res**2, axis=1)).tolist(),
                "rms_val": np.sqrt(np.mean((pred - d["val_tau"]) ** 2, axis=0)).tolist(),
            }
        report["configs"][label] = entry
    with open(out, "w") as f:
        json.dump(report, f)
    np.savez(out.removesuffix(".json") + ".npz", **predictions)


if __name__ == "__main__":
    main()
