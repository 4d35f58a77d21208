"""The reference of tests/test_rough_slip_onset.py: scene rough_slip_across.json's slip
from its onset state, integrated apart from the runtime.

The carrier and its point under Newton's and Euler's laws (derive/verify/reaction.py's
solve: the reaction and the accelerations of the bodies, written apart from the runtime's
C), the plane's friction a regularized Coulomb law R_t = -mu_f N v/sqrt(|v|^2 + eps^2)
(smooth: no mode, no direction to choose at the onset), SciPy's Radau at rtol 1e-10 until
N reaches 0.  Prints the lift-off time and N along the way for eps 1e-6 and 1e-7 (their
difference: the regularization's share).  About 10 s:

    python tests/data/rough_slip_across_scipy.py
"""
from __future__ import annotations

import json
import pathlib

import numpy as np
from scipy.integrate import solve_ivp

from derive.scene import parse_scene
from derive.verify import reaction as rx

DATA = json.loads((pathlib.Path(__file__).parent / "rough_slip_across.json").read_text())


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def integrate(eps: float, t_end: float = 12.47):
    scene = parse_scene(DATA["scene"], "rough_slip_across")
    b = rx.Bodies.of(scene)
    total = b.M + b.m
    t0, q0 = DATA["slip_onset"]["t"], np.array(DATA["slip_onset"]["q"])

    def moments(t, w):
        jets = rx.law_rows(scene, [t])
        r, rd = jets.points[0, :, 0:3], jets.points[0, :, 3:6]
        return jets, b.masses @ r / total, b.masses @ (rd + np.cross(w, r)) / total

    def model_q(t, y):             # y: O's position and velocity (fixed), A, omega
        A, w = y[6:15].reshape(3, 3), y[15:18]
        jets, sm, first = moments(t, w)
        q = np.concatenate([y[0:3] + A @ sm, A @ (A.T @ y[3:6] + first), w, A.ravel()])
        return q, jets

    def reaction(t, y):
        q, jets = model_q(t, y)
        k = rx.kinematics(b, q[None], jets)
        v = k.v_S[0, :2]
        return k, rx.solve(b, k, np.array([False]), (v / np.sqrt(v @ v + eps ** 2))[None])

    def rates(t, y):
        k, R = reaction(t, y)
        A, w = y[6:15].reshape(3, 3), y[15:18]
        n, rho = k.n[0], A.T @ R.R[0]
        size = 6 + 3 * len(b.masses)
        K, f = np.zeros((size, size)), np.zeros(size)
        K[0:3, 0:3], f[0:3] = b.M * np.eye(3), -b.M * b.g * n + rho
        K[3:6, 3:6] = np.diag(b.J)
        f[3:6] = -np.cross(w, w * b.J + k.h_r[0]) - k.h_rd[0] + np.cross(k.s[0], rho)
        for j, mj in enumerate(b.masses):
            F = slice(6 + 3 * j, 9 + 3 * j)
            rj, rdj, rddj = k.r[0, j], k.rd[0, j], k.rdd[0, j]
            K[0:3, F], K[3:6, F] = np.eye(3), _skew(rj)
            K[F, 0:3], K[F, 3:6], K[F, F] = mj * np.eye(3), -mj * _skew(rj), -np.eye(3)
            f[F] = -mj * b.g * n - mj * (np.cross(w, np.cross(w, rj)) + 2 * np.cross(w, rdj)
                                         + rddj)
        x = np.linalg.solve(K, f)
        return np.concatenate([y[3:6], A @ x[0:3], (A @ _skew(w)).ravel(), x[3:6]])

    A0, w0 = q0[9:18].reshape(3, 3), q0[6:9]
    _, sm, first = moments(t0, w0)
    y0 = np.concatenate([q0[0:3] - A0 @ sm, A0 @ (A0.T @ q0[3:6] - first), A0.ravel(), w0])

    def lift(t, y):
        return reaction(t, y)[1].N[0]
    lift.terminal, lift.direction = True, -1
    sol = solve_ivp(rates, (t0, t_end), y0, method="Radau", rtol=1e-10, atol=1e-13,
                    events=lift, dense_output=True)
    return sol, (lambda t: reaction(t, sol.sol(t)))


if __name__ == "__main__":
    for eps in (1e-6, 1e-7):
        sol, at = integrate(eps)
        print(f"eps {eps:g}: N reaches 0 at t = {sol.t_events[0][0]:.8f}")
        for t in (12.445, 12.45, 12.4516163309, 12.454):
            k, R = at(t)
            print(f"  t = {t}: N = {R.N[0]:.4g} N, slip {np.hypot(*k.v_S[0, :2]):.4g} m/s")
