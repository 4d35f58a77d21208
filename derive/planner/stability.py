"""Multipliers of a planned hop, with the stability tools.

The orbit (vertical layout: Z_C, Z_C', omega, n) is followed from mid-flight to
mid-flight: the flights' variational equations ``Phi' = (df/dq) Phi`` with the derived
Jacobian (``vertical_flight_jacobian``), and at the impact the saltation matrix of
:func:`derive.stability.bouncing.saltation` (CasADi's derivatives of the emitted gap and
impact map, the law written as its polynomial piece around the impact).  Checks, as in
:mod:`derive.stability`: the monodromy against central finite differences of the hybrid
flow (re-integrated with its impact), and the two integrals of the hybrid map, |n|^2 and
K.n (K changes by I d at an impact and d = CS x n is normal to n), whose gradients must
be left eigenvectors with multiplier 1.
"""
from __future__ import annotations


import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from .. import layout
from ..stability.bouncing import saltation_of_functions
from ..stability.floquet import UNIT_TOL, complex_pairs
from .functions import Fast, load, lowest_point
from .law import Law

V = layout.VERTICAL

RTOL = 1e-12


class HopFlow:
    """Flights and impacts of the planned hop in the vertical layout (numbers)."""

    def __init__(self, tr, law: Law):
        self.tr, self.law = tr, law
        sc = tr.task.scene
        self.p = np.array(tr.p)
        self.f = load("vertical_flight_rhs")
        self.jac = load("vertical_flight_jacobian")
        self.gap = load("vertical_gap")
        self.imp = load("vertical_impact")
        self.fast = {name: Fast(fn) for name, fn in (("f", self.f), ("jac", self.jac),
                                                     ("gap", self.gap), ("imp", self.imp))}
        self.sc = sc

    def s_of(self, q):
        return np.array(lowest_point(self.sc.shape, q[V.n], self.sc.center,
                                     self.sc.size).full()).ravel()

    def u(self, t):
        return self.law.u(t)[:, 0]

    def rhs(self, t, q):
        return self.fast["f"](q, self.u(t), self.p)[0]

    def variational(self, t0, q0, t1):
        """(q(t1), Phi(t1, t0)) by DOP853, piece by piece of the law."""
        n = len(q0)

        def rhs(t, y):
            q = y[:n]
            u = self.u(t)
            dq = self.fast["f"](q, u, self.p)[0]
            A = self.fast["jac"](q, u, self.p)[0].reshape(n, n)
            return np.r_[dq, (A @ y[n:].reshape(n, n)).ravel()]
        y = np.r_[q0, np.eye(n).ravel()]
        for a, b in self._segments(t0, t1):
            y = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=RTOL, atol=RTOL * 1e-2).y[:, -1]
        return y[:n], y[n:].reshape(n, n)

    def _segments(self, t0, t1):
        h = self.law.T / self.law.spline.n
        knots = np.arange(np.ceil(t0 / h - 1e-9), np.floor(t1 / h + 1e-9) + 1) * h
        pts = np.unique(np.r_[t0, knots[(knots > t0) & (knots < t1)], t1])
        return list(zip(pts[:-1], pts[1:]))

    def hybrid(self, t0, q0, t1):
        """The nonlinear flow with its impacts from t0 to t1 (for finite differences)."""
        def h(t, q):
            return float(self.fast["gap"](q, self.u(t), self.s_of(q), self.p)[0][0])
        h.terminal, h.direction = True, -1
        t, q = t0, np.array(q0, float)
        while t < t1:
            sol = solve_ivp(self.rhs, (t, t1), q, method="DOP853", rtol=RTOL,
                            atol=RTOL * 1e-2, events=h)
            if sol.status == 1 and len(sol.t_events[0]):
                t = float(sol.t_events[0][0])
                qm = sol.y_events[0][0]
                q = self.fast["imp"](qm, self.u(t), self.s_of(qm), self.p, [self.sc.e])[0]
                nxt = min(t + 1e-9, t1)
                q = solve_ivp(self.rhs, (t, nxt), q, method="DOP853", rtol=RTOL,
                              atol=RTOL * 1e-2).y[:, -1]
                t = nxt
            else:
                t, q = t1, sol.y[:, -1]
        return q

    def casadi_near(self, piece: int):
        """rhs, gap and impact as functions of (t, q), the law as the polynomial of
        ``piece`` (for the saltation matrix's time derivatives)."""
        t = ca.SX.sym("t")
        q = ca.SX.sym("q", 8)
        P = self.law.polynomials_in_t()[piece]
        d = t - self.law.knots[piece]
        val = [P[c, 0] + d * (P[c, 1] + d * (P[c, 2] + d * P[c, 3])) for c in range(3)]
        d1 = [P[c, 1] + d * (2 * P[c, 2] + 3 * d * P[c, 3]) for c in range(3)]
        d2 = [2 * P[c, 2] + 6 * d * P[c, 3] for c in range(3)]
        u = ca.vertcat(*val, *d1, *d2)
        s = lowest_point(self.sc.shape, q[V.n], self.sc.center, self.sc.size)
        p = ca.DM(self.p)
        h, vn = self.gap(q, u, s, p)
        qp, I = self.imp(q, u, s, p, ca.DM([self.sc.e]))
        return {"rhs": ca.Function("rhs", [t, q], [self.f(q, u, p)]),
                "gap": ca.Function("gap", [t, q], [h, vn]),
                "impact": ca.Function("impact", [t, q], [qp, I])}


def integrals(flow: HopFlow, t, q) -> dict:
    """Gradients of |n|^2 and K.n at (t, q) (K from the derived kinetic moment)."""
    K = load("general_kinetic_moment")
    x = ca.SX.sym("q", V.nq)
    G = layout.GENERAL
    full = ca.SX.zeros(G.nq)                # the general state: C on the axis, A = (., ., n)
    full[G.Z], full[G.Zd], full[G.omega] = x[V.Z], x[V.Zd], x[V.omega]
    full[G.A] = ca.vertcat(1, 0, 0, 0, 1, 0, x[V.n])
    Kv = K(full, flow.u(t), flow.p)
    grad = ca.Function("grad", [x], [ca.gradient(ca.dot(Kv, x[V.n]), x),
                                     ca.gradient(ca.sumsqr(x[V.n]), x)])
    gKn, gn = (np.array(v.full()).ravel() for v in grad(q))
    return {"K.n": gKn, "|n|^2": gn}


def analyse(tr, law: Law, Q, fd_eps: float = 1e-6) -> dict:
    """Multipliers of the planned hop, their checks and the verdict."""
    flow = HopFlow(tr, law)
    T = law.T
    k = tr.N // 2
    t_mid = k * T / tr.N
    q_mid = np.asarray(Q[:, k], float)
    q_minus, Phi1 = flow.variational(t_mid, q_mid, T)
    fns = flow.casadi_near(tr.N - 1)
    S = saltation_of_functions(fns, T, q_minus)
    q_plus = np.array(fns["impact"](T, q_minus)[0].full()).ravel()
    q_end, Phi2 = flow.variational(T, q_plus, T + t_mid)
    M = Phi2 @ S @ Phi1
    rho = np.linalg.eigvals(M)
    fd = np.empty_like(M)
    for j in range(8):
        dq = np.zeros(8)
        dq[j] = fd_eps
        fd[:, j] = (flow.hybrid(t_mid, q_mid + dq, t_mid + T)
                    - flow.hybrid(t_mid, q_mid - dq, t_mid + T)) / (2 * fd_eps)
    grads = integrals(flow, t_mid, q_mid)
    trivial = {name: float(np.max(np.abs(g @ M - g))) for name, g in grads.items()}
    scale = max(1.0, float(np.max(np.abs(M))))
    checks = {"finite_difference": {"value": float(np.max(np.abs(fd - M))), "bound": 1e-5 * scale},
              "periodicity": {"value": float(np.max(np.abs(q_end - q_mid))), "bound": 1e-8}}
    checks.update({f"trivial {k}": {"value": v, "bound": 1e-8 * scale} for k, v in trivial.items()})
    for c in checks.values():
        c["ok"] = bool(c["value"] <= c["bound"])
    return {"multipliers": complex_pairs(rho), "moduli": sorted(float(abs(r)) for r in rho),
            "max_modulus": float(np.max(np.abs(rho))), "checks": checks,
            "verdict": verdict(rho), "stable": not verdict(rho).startswith("unstable")}


def verdict(rho, tol: float = UNIT_TOL) -> str:
    """Two multipliers are 1 by the integrals |n|^2 and K.n; the others decide, as in
    :meth:`derive.stability.bouncing.Bounce.verdict`: unstable when some |rho| > 1 + tol,
    otherwise linearly stable, the modes on the unit circle (spin, tilt) neutral."""
    mod = np.sort(np.abs(rho))[::-1]
    if mod[0] > 1 + tol:
        return f"unstable (max |rho| = {mod[0]:.6f})"
    on_circle = int(np.sum(np.abs(mod - 1) <= tol)) - 2
    inside = mod[np.abs(mod - 1) > tol]
    text = (f"linearly stable: every |rho| <= 1; besides the two multipliers 1 of the "
            f"integrals |n|^2 and K.n, {max(on_circle, 0)} on the unit circle (neutral)")
    if inside.size:
        text += f" and {inside.size} inside (max |rho| = {inside.max():.6f}: they decay)"
    return text
