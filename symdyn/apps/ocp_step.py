"""One multiple-shooting interval as compiled code with explicit derivatives.

`rk4_step(fdyn, n, substeps)` is (q, q̇, τ, h) → (q⁺, q̇⁺), `substeps` RK4 steps
of q̈ = fdyn(q, q̇, τ) with τ held, as a `casadi.external` whose Jacobian and
Hessian of λᵀstep (what IPOPT's exact-Hessian solve asks for) are written out:
forward sensitivities through the stages for the Jacobian, and one
forward-over-reverse sweep for the Hessian, each fdyn call contributing its
Jacobian and the Hessian of μᵀfdyn (CasADi's SX AD of the one call), multiplied
into the sweeps' derivative blocks inside one SX kernel per call.  CasADi's own AD
through the 16 calls of an interval spends ~4× this arithmetic on bookkeeping;
the derivatives are the same to rounding (tests/test_ocp_step.py).
"""

from __future__ import annotations

import casadi as ca

__all__ = ["rk4_step", "step_functions", "FLAGS"]

#: -O3 (the sweeps' -O1 build was ~1.5× slower before the per-call kernels; Puma, 4
#: substeps: ~20 s to build, once).
FLAGS = ("-O3", "-fPIC", "-shared")

#: RK4: the stage inputs y_j = x + A_j·dt·k_{j-1} and the weights of x⁺ = x + dt/6 Σ W_j k_j.
_A = (0.0, 0.5, 0.5, 1.0)
_W = (1.0, 2.0, 2.0, 1.0)


def _call_kernels(
    fdyn: ca.Function, n: int, m: int, derivatives: ca.Function | None = None
) -> tuple[ca.Function, ca.Function]:
    """What one fdyn call adds to the sweeps, as SX functions (straight-line code once
    compiled: the products with the m-column derivative blocks are unrolled, not the
    sparse loops of MX's matrix product, which cost more than fdyn's own derivatives).

    forward (q, q̇, τ, Dy) → (q̈, A = ∂q̈/∂(q, q̇, τ), Dq̈ = A·[Dy; E_τ]), A from
    `derivatives` (q, q̇, τ) → (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹) when given (symdyn's generated
    fdyn_derivatives: about half the operations of CasADi's AD of fdyn), else by AD;
    reverse (q, q̇, τ, μ, A, Dy, Dμ) → (Aₓᵀμ, AₓᵀDμ + (H·W)ₓ, A_τᵀDμ + (H·W)_τ), with
    H = ∂²(μᵀq̈)/∂(q, q̇, τ)² (CasADi's SX AD of the one call), W = [Dy; E_τ], and
    Aₓ, A_τ the (q, q̇) and τ columns of A.  Dy: 2n × m, E_τ picks τ out of z.
    """
    q, qd, tau, mu = (ca.SX.sym(s, n) for s in ("q", "qd", "tau", "mu"))
    Dy, Dmu, A = ca.SX.sym("Dy", 2 * n, m), ca.SX.sym("Dmu", n, m), ca.SX.sym("A", n, 3 * n)
    z = ca.vertcat(q, qd, tau)
    qdd = fdyn(q, qd, tau)
    W = ca.vertcat(Dy, ca.horzcat(ca.SX(n, 2 * n), ca.SX.eye(n), ca.SX(n, m - 3 * n)))
    if derivatives is None:
        qdd_f, dqdd = qdd, ca.jacobian(qdd, z)
    else:
        qdd_f, *blocks = derivatives(q, qd, tau)
        dqdd = ca.horzcat(*blocks)
    forward = ca.Function("fdyn_forward", [q, qd, tau, Dy], [qdd_f, dqdd, ca.mtimes(dqdd, W)])
    HW = ca.mtimes(ca.hessian(ca.dot(mu, qdd), z)[0], W)
    Ax, At = A[:, : 2 * n], A[:, 2 * n :]
    reverse = ca.Function(
        "fdyn_reverse",
        [q, qd, tau, mu, A, Dy, Dmu],
        [ca.mtimes(Ax.T, mu), ca.mtimes(Ax.T, Dmu) + HW[: 2 * n, :], ca.mtimes(At.T, Dmu) + HW[2 * n :, :]],
    )
    return forward, reverse


def step_functions(
    fdyn: ca.Function, n: int, substeps: int, derivatives: ca.Function | None = None
) -> list[ca.Function]:
    """The step and, under the names `casadi.external` looks up, its Jacobian
    (`jac_rk4`), reverse mode (`adj1_rk4`) and the Jacobian of that (`jac_adj1_rk4`),
    as MX functions calling fdyn's SX derivatives (fdyn's Jacobian from `derivatives`,
    (q, q̇, τ) → (q̈, ∂q̈/∂q, ∂q̈/∂q̇, M⁻¹), when given)."""
    m = 3 * n + 1  # z = (q, q̇, τ, h)
    forward, reverse = _call_kernels(fdyn, n, m, derivatives)
    i0, i1, i2, i3 = ca.MX.sym("i0", n), ca.MX.sym("i1", n), ca.MX.sym("i2", n), ca.MX.sym("i3")
    tau, h = i2, i3
    dt = h / substeps
    e_h = ca.horzcat(ca.DM(1, m - 1), 1)  # structural zeros stay out of the products
    x = ca.vertcat(i0, i1)
    Dx = ca.MX(ca.horzcat(ca.DM.eye(2 * n), ca.DM(2 * n, n + 1)))
    tape = []  # per substep: (stages [(y, Dy, k, Dk, A)], K, DK)
    for _ in range(substeps):
        stages = []
        for j in range(4):
            if j == 0:
                y, Dy = x, Dx
            else:
                k_prev, Dk_prev = stages[-1][2], stages[-1][3]
                y = x + _A[j] * dt * k_prev
                Dy = Dx + _A[j] * (dt * Dk_prev + ca.mtimes(k_prev, e_h) / substeps)
            qdd, A, Dqdd = forward(y[:n], y[n:], tau, Dy)
            k = ca.vertcat(y[n:], qdd)
            Dk = ca.vertcat(Dy[n:, :], Dqdd)
            stages.append((y, Dy, k, Dk, A))
        K = sum(w * s[2] for w, s in zip(_W, stages))
        DK = sum(w * s[3] for w, s in zip(_W, stages))
        tape.append((stages, K, DK))
        x, Dx = x + dt / 6 * K, Dx + dt / 6 * DK + ca.mtimes(K, e_h) / (6 * substeps)

    outs = [x[:n], x[n:]]
    J = Dx  # ∂(q⁺, q̇⁺)/∂z, 2n × m
    step = ca.Function("rk4", [i0, i1, i2, i3], outs, ["i0", "i1", "i2", "i3"], ["o0", "o1"])
    o0, o1 = ca.MX.sym("out_o0", n), ca.MX.sym("out_o1", n)
    blocks = [(0, n), (n, 2 * n), (2 * n, 3 * n), (3 * n, m)]
    jac_step = ca.Function(
        "jac_rk4",
        [i0, i1, i2, i3, o0, o1],
        [J[r0:r1, c0:c1] for r0, r1 in ((0, n), (n, 2 * n)) for c0, c1 in blocks],
        ["i0", "i1", "i2", "i3", "out_o0", "out_o1"],
        [f"jac_o{a}_i{b}" for a in range(2) for b in range(4)],
    )

    a0, a1 = ca.MX.sym("adj_o0", n), ca.MX.sym("adj_o1", n)
    lam = ca.vertcat(a0, a1)
    grad = ca.mtimes(J.T, lam)  # zbar = Jᵀλ
    adj_names = ["i0", "i1", "i2", "i3", "out_o0", "out_o1", "adj_o0", "adj_o1"]
    adj_step = ca.Function(
        "adj1_rk4",
        [i0, i1, i2, i3, o0, o1, a0, a1],
        [grad[c0:c1] for c0, c1 in blocks],
        adj_names,
        [f"adj_i{b}" for b in range(4)],
    )

    H = _hessian(tape, lam, tau, reverse, n, m, dt, substeps, e_h)
    outs_adj = [ca.MX.sym(f"out_adj_i{b}", c1 - c0) for b, (c0, c1) in enumerate(blocks)]
    entries = []
    for b, (r0, r1) in enumerate(blocks):
        entries += [H[r0:r1, c0:c1] for c0, c1 in blocks]
        entries += [ca.MX(r1 - r0, n), ca.MX(r1 - r0, n)]  # ∂/∂ nominal outputs: 0
        entries += [J[0:n, r0:r1].T, J[n : 2 * n, r0:r1].T]  # ∂/∂λ: Jᵀ
    inputs = [
        f"jac_adj_i{b}_{x}" for b in range(4) for x in ("i0", "i1", "i2", "i3", "out_o0", "out_o1", "adj_o0", "adj_o1")
    ]
    jac_adj = ca.Function(
        "jac_adj1_rk4",
        [i0, i1, i2, i3, o0, o1, a0, a1, *outs_adj],
        entries,
        adj_names + [f"out_adj_i{b}" for b in range(4)],
        inputs,
    )
    return [step, jac_step, adj_step, jac_adj]


def _hessian(tape, lam, tau, reverse, n: int, m: int, dt, substeps: int, e_h):
    """∂²(λᵀ step)/∂z² (m × m): the reverse sweep for the adjoints, each adjoint
    differentiated along all m directions of z at once (forward over reverse)."""
    xb, Dxb = lam, ca.MX(2 * n, m)  # adjoint of x and its derivative along z
    Dtaub, Dhb = ca.MX(n, m), ca.MX(1, m)
    for stages, K, DK in reversed(tape):  # the forward pass's K = Σ W_j k_j and its derivative
        Dhb += (ca.mtimes(K.T, Dxb) + ca.mtimes(xb.T, DK)) / (6 * substeps)
        kb = [dt / 6 * w * xb for w in _W]
        Dkb = [w / 6 * (dt * Dxb + ca.mtimes(xb, e_h) / substeps) for w in _W]
        for j in reversed(range(4)):
            y, Dy, _, _, A = stages[j]
            mu, Dmu = kb[j][n:], Dkb[j][n:, :]
            ybx, Dybx, Dtb = reverse(y[:n], y[n:], tau, mu, A, Dy, Dmu)
            yb = ca.vertcat(ca.MX(n, 1), kb[j][:n]) + ybx
            Dyb = ca.vertcat(ca.MX(n, m), Dkb[j][:n, :]) + Dybx
            Dtaub += Dtb
            xb, Dxb = xb + yb, Dxb + Dyb
            if j > 0:
                c, (_, _, k_prev, Dk_prev, _) = _A[j], stages[j - 1]
                kb[j - 1] = kb[j - 1] + c * dt * yb
                Dkb[j - 1] = Dkb[j - 1] + c * (dt * Dyb + ca.mtimes(yb, e_h) / substeps)
                Dhb += c / substeps * (ca.mtimes(k_prev.T, Dyb) + ca.mtimes(yb.T, Dk_prev))
    return ca.vertcat(Dxb, Dtaub, Dhb)


def rk4_step(fdyn: ca.Function, n: int, substeps: int, derivatives: ca.Function | None = None) -> ca.Function:
    """The interval (q, q̇, τ, h) → (q⁺, q̇⁺) as a `casadi.external` on compiled code with
    its explicit derivatives (`step_functions`), built once into the cache."""
    from ..codegen.emit.casadi import compiled

    step, *functions = step_functions(fdyn, n, substeps, derivatives)
    return compiled(step, derivatives=functions, flags=FLAGS)
