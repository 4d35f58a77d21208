"""An independent Newton–Euler formulation of the rough plane (plain NumPy).

Written from first principles, without reading derive/friction.py, derive/
friction_models.py or derive/darboux_keller.py.  Two bodies:

* the carrier, mass M, principal central inertia diag(J) about its centre O;
* the point, mass m, at r = OP(t) in body axes, moved by the carrier along a
  prescribed path (r, r', r'' given): the carrier exerts F on it at P, it exerts -F on
  the carrier there.

The plane pushes on the carrier's material point at S (s = OS, body axes) with R
(fixed axes; rho = A^T R in body axes).  Body axes for the dynamics, n = A^T e_Z.

Continuous motion (a_O: the absolute acceleration of O in body axes):

  carrier, Newton   M a_O = -M g n + rho - F
  point,   Newton   m a_P = -m g n + F,  a_P = a_O + w' x r + w x (w x r) + 2 w x r' + r''
  carrier, Euler    J w' + w x J w = s x rho - r x F                 (about O)
  the material point at S, as S moves over the surface with s' (body axes):
                    a_S = a_O + w' x s + w x (w x s) + w x s'

* sliding along the unit horizontal sigma: R = N (e_Z - mu sigma), one constraint
  n . a_S = 0: ten unknowns (a_O, w', F, N);
* sticking: R free, three constraints a_S = 0: twelve unknowns (a_O, w', F, R).

Impulses (positions, attitude and r' unchanged; Pi the impulse on the point):

  M dV_O = rho - Pi,   m (dV_O + dw x r) = Pi,   J dw = s x rho - r x Pi

nine unknowns for a contact impulse P = A rho; the velocity of S changes by
dV_O + dw x s, whose matrix in P (fixed axes) is the inverse inertia at S.

Everything is solved with numpy.linalg.solve on the stacked linear system.
"""
from __future__ import annotations

import numpy as np

E_Z = np.array([0.0, 0.0, 1.0])


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def split(q, u, params):
    q = np.asarray(q, dtype=float)
    u = np.asarray(u, dtype=float)
    M, m, Jx, Jy, Jz, g = np.asarray(params, dtype=float)
    return (q[0:3], q[3:6], q[6:9], q[9:18].reshape(3, 3), u[0:3], u[3:6], u[6:9],
            M, m, np.diag([Jx, Jy, Jz]), g)


def velocity_of_S(q, u, s, params):
    """Fixed axes: V_O + A (w x s), with V_O from V_C (OC = m/(m+M) r)."""
    X, V, w, A, r, rd, _, M, m, _, _ = split(q, u, params)
    nu = m / (m + M)
    vO = A.T @ V - nu * (rd + np.cross(w, r))
    return A @ (vO + np.cross(w, np.asarray(s, float)))


def kinetic_energy(q, u, params):
    X, V, w, A, r, rd, _, M, m, J, _ = split(q, u, params)
    nu = m / (m + M)
    vO = A.T @ V - nu * (rd + np.cross(w, r))
    vP = vO + rd + np.cross(w, r)
    return 0.5 * M * vO @ vO + 0.5 * w @ J @ w + 0.5 * m * vP @ vP


# ---- impulses -------------------------------------------------------------------------------
def impulse_response(q, u, s, params, P):
    """(dV_C fixed, dw body, Pi body, dv_S fixed) for a contact impulse P (fixed) at S."""
    X, V, w, A, r, rd, _, M, m, J, _ = split(q, u, params)
    s = np.asarray(s, float)
    rho = A.T @ np.asarray(P, float)
    I3 = np.eye(3)
    K = np.zeros((9, 9))      # unknowns (dV_O, dw, Pi)
    b = np.zeros(9)
    K[0:3, 0:3] = M * I3
    K[0:3, 6:9] = I3
    b[0:3] = rho
    K[3:6, 0:3] = m * I3
    K[3:6, 3:6] = -m * skew(r)         # m (dw x r) = -m r x dw
    K[3:6, 6:9] = -I3
    K[6:9, 3:6] = J
    K[6:9, 6:9] = skew(r)
    b[6:9] = np.cross(s, rho)
    x = np.linalg.solve(K, b)
    dVO, dw, Pi = x[0:3], x[3:6], x[6:9]
    dVP = dVO + np.cross(dw, r)
    dVC = A @ ((M * dVO + m * dVP) / (M + m))
    dvS = A @ (dVO + np.cross(dw, s))
    return dVC, dw, Pi, dvS


def inverse_inertia_at_S(q, u, s, params):
    """The 3x3 matrix of P -> dv_S (fixed axes), column by column."""
    return np.column_stack([impulse_response(q, u, s, params, e)[3] for e in np.eye(3)])


def apply_impulse(q, u, s, params, P):
    q = np.asarray(q, float).copy()
    dVC, dw, _, _ = impulse_response(q, u, s, params, P)
    q[3:6] += dVC
    q[6:9] += dw
    return q


def drive_work(q, u, s, params, P):
    """Work of the drive (carrier on point and back) over the impact: Pi . r' (r'
    constant during the impact)."""
    _, _, Pi, _ = impulse_response(q, u, s, params, P)
    return float(Pi @ np.asarray(u, float)[3:6])


# ---- contact -------------------------------------------------------------------------------
def _rows(q, u, s, sdot, params):
    """The 9 rows of the two bodies' laws for unknowns (a_O, w', F) with rho kept apart:
    K x + Kr rho = b; and a_S = Sa x + c."""
    X, V, w, A, r, rd, rdd, M, m, J, g = split(q, u, params)
    s, sdot = np.asarray(s, float), np.asarray(sdot, float)
    n = A.T @ E_Z
    I3 = np.eye(3)
    K = np.zeros((9, 9))
    Kr = np.zeros((9, 3))
    b = np.zeros(9)
    K[0:3, 0:3] = M * I3
    K[0:3, 6:9] = I3
    Kr[0:3] = -I3
    b[0:3] = -M * g * n
    K[3:6, 0:3] = m * I3
    K[3:6, 3:6] = -m * skew(r)
    K[3:6, 6:9] = -I3
    b[3:6] = -m * g * n - m * (np.cross(w, np.cross(w, r)) + 2 * np.cross(w, rd) + rdd)
    K[6:9, 3:6] = J
    K[6:9, 6:9] = skew(r)
    Kr[6:9] = -skew(s)
    b[6:9] = -np.cross(w, J @ w)
    Sa = np.zeros((3, 9))
    Sa[:, 0:3] = I3
    Sa[:, 3:6] = -skew(s)              # w' x s = -s x w'
    c = np.cross(w, np.cross(w, s)) + np.cross(w, sdot)
    return K, Kr, b, Sa, c


def _finish(q, u, params, x):
    X, V, w, A, r, rd, rdd, M, m, J, g = split(q, u, params)
    aO, wd = x[0:3], x[3:6]
    aP = aO + np.cross(wd, r) + np.cross(w, np.cross(w, r)) + 2 * np.cross(w, rd) + rdd
    aC = (M * aO + m * aP) / (M + m)
    return np.concatenate([V, A @ aC, wd, (A @ skew(w)).ravel()])


def sliding(q, u, s, sdot, params, mu, sigma):
    """(dq, N, a_S fixed) sliding along the unit horizontal sigma (fixed X, Y)."""
    A = np.asarray(q, float)[9:18].reshape(3, 3)
    K, Kr, b, Sa, c = _rows(q, u, s, sdot, params)
    direction = A.T @ (E_Z - mu * np.array([sigma[0], sigma[1], 0.0]))   # rho = N direction
    n = A.T @ E_Z
    full = np.zeros((10, 10))
    rhs = np.zeros(10)
    full[:9, :9] = K
    full[:9, 9] = Kr @ direction
    rhs[:9] = b
    full[9, :9] = n @ Sa
    rhs[9] = -n @ c
    x = np.linalg.solve(full, rhs)
    a_S = A @ (Sa @ x[:9] + c)
    return _finish(q, u, params, x), x[9], a_S


def sticking(q, u, s, sdot, params):
    """(dq, R fixed, a_S fixed) with a_S = 0."""
    A = np.asarray(q, float)[9:18].reshape(3, 3)
    K, Kr, b, Sa, c = _rows(q, u, s, sdot, params)
    full = np.zeros((12, 12))
    rhs = np.zeros(12)
    full[:9, :9] = K
    full[:9, 9:12] = Kr @ A.T          # rho = A^T R
    rhs[:9] = b
    full[9:12, :9] = Sa
    rhs[9:12] = -c
    x = np.linalg.solve(full, rhs)
    a_S = A @ (Sa @ x[:9] + c)
    return _finish(q, u, params, x), x[9:12], a_S


# ---- the impact's rates in the normal impulse, from the inverse inertia at S -----------------
def slip_rate(Wm, v, mu):
    """dv/dp while slipping: Coulomb on the increments, dP = (-mu v_t/|v_t|, 1)."""
    vt = np.asarray(v, float)[:2]
    sig = vt / np.linalg.norm(vt)
    return Wm @ np.array([-mu * sig[0], -mu * sig[1], 1.0])


def stick_rate(Wm):
    """The tangential impulse rate tau that keeps dv_t/dp = 0 (a 2x2 solve of the
    tangential rows), and dv_n/dp with it."""
    tau = np.linalg.solve(Wm[:2, :2], -Wm[:2, 2])
    return tau, Wm[2, 2] + Wm[2, :2] @ tau


def resliding_rays(Wm, mu, n=20000):
    """Every unit sigma with W_tn - mu W_tt sigma = c sigma, c > 0, found by scanning the
    circle for sign changes of the cross product and refining by bisection."""
    def cross(th):
        sig = np.array([np.cos(th), np.sin(th)])
        d = Wm[:2, 2, None] - mu * Wm[:2, :2] @ sig
        return sig[0] * d[1] - sig[1] * d[0], (sig * d).sum(axis=0)

    ths = np.linspace(-np.pi, np.pi, n + 1)
    vals = cross(ths)[0]
    rays = []
    for k in np.flatnonzero((vals[:-1] == 0.0) | (vals[:-1] * vals[1:] < 0.0)):
        lo, hi = ths[k], ths[k + 1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if cross(np.array([lo]))[0][0] * cross(np.array([mid]))[0][0] <= 0.0:
                hi = mid
            else:
                lo = mid
        th = 0.5 * (lo + hi)
        c_ = float(cross(np.array([th]))[1][0])
        if c_ > 0.0:
            rays.append((c_, np.array([np.cos(th), np.sin(th)])))
    return rays


def impact_by_small_steps(Wm, v0, mu, e, steps_per_unit=4000):
    """The energetic impact by plain time-stepping in the normal impulse, independent of
    the event-driven integration: steps of h in p; in each, the tangential impulse that
    would stop the slip, -W_tt^-1 (v_t + W_tn h), is taken when inside Coulomb's cone
    (|.| <= mu h), else its projection onto the cone's edge when the slip is stopping or
    reversing within the step, else -mu h v_t/|v_t|.  Ends where the work of the normal
    impulse after compression reaches (1 - e^2) of its value at the end of compression.
    First order in h: (P, v after)."""
    Wm, v = np.asarray(Wm, float), np.asarray(v0, float).copy()
    h = abs(v0[2]) / Wm[2, 2] / steps_per_unit
    P = np.zeros(3)
    En, Ec = 0.0, None
    Wtt_inv = np.linalg.inv(Wm[:2, :2])
    for _ in range(100 * steps_per_unit):
        stop = -Wtt_inv @ (v[:2] + Wm[:2, 2] * h)
        speed = np.linalg.norm(v[:2])
        if np.linalg.norm(stop) <= mu * h:
            dPt = stop
        elif speed <= mu * h * np.linalg.norm(Wm[:2, :2], 2) + np.linalg.norm(Wm[:2, 2]) * h:
            dPt = stop * (mu * h / np.linalg.norm(stop))
        else:
            dPt = -mu * h * v[:2] / speed
        dP = np.array([dPt[0], dPt[1], h])
        v_new = v + Wm @ dP
        En += 0.5 * (v[2] + v_new[2]) * h
        if Ec is None and v_new[2] >= 0.0:
            Ec = En
        v, P = v_new, P + dP
        if Ec is not None and En >= (1.0 - e * e) * Ec:
            return P, v
    raise RuntimeError("no end")


def under_wrench(q, u, s, sdot, params, R, T):
    """A contact wrench at S given (fixed axes): the force R at S and a couple T (spin
    friction and rolling resistance), which adds A^T T to the carrier's Euler equation.
    Returns (dq, a_S fixed, the angular acceleration in fixed axes A w')."""
    A = np.asarray(q, float)[9:18].reshape(3, 3)
    K, Kr, b, Sa, c = _rows(q, u, s, sdot, params)
    rhs = b - Kr @ (A.T @ np.asarray(R, float))
    rhs[6:9] += A.T @ np.asarray(T, float)
    x = np.linalg.solve(K, rhs)
    return _finish(q, u, params, x), A @ (Sa @ x + c), A @ x[3:6]
