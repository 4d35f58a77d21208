"""Initial guesses: where IPOPT starts.

A reorientation by shape changes is second order in the size of the loops P makes (a
geometric phase), so the law "P at rest" is a critical point of the attitude at the end:
starting there, the Jacobian of the target constraint vanishes.  The guesses therefore
start from loops that already turn the body roughly the right way:

* a rotation vector phi (body axes) is wanted; for loops near O, the rotation is about
  ``-2 mu J^-1 area`` (``area`` the loop's vector area), J and mu r x v read from the
  derived kinetic moment (E1.6) at the start;
* a hop starts from the ball-on-a-vibrating-table orbit of reference [5]
  (:mod:`derive.stability.bouncing`): P oscillating along the vertical through the
  region's centre, the impact on the stable branch of the table's closed form.
"""
from __future__ import annotations

import math

import numpy as np

from .. import layout
from ..scene import SceneError
from ..stability.bouncing import existence_threshold, period_doubling_threshold
from .functions import load, lowest_point
from .transcribe import Transcription, initial_state


def smoothstep(tau):
    """0 -> 1 with zero first and second derivatives at both ends."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau ** 3 * (10 - 15 * tau + 6 * tau * tau)


def fit_ctrl(tr: Transcription, path, periodic: bool = False) -> np.ndarray:
    """Least-squares control points of the spline through path(tau) (n, dim)."""
    taus = np.linspace(0.0, 1.0, 8 * tr.N + 1)
    W = np.array([tr.spline.weights(t) for t in taus])
    Y = np.asarray(path(taus), dtype=float).reshape(len(taus), tr.dim)
    ctrl = np.linalg.lstsq(W, Y, rcond=None)[0]
    return ctrl


def inertia_at(tr: Transcription, r) -> np.ndarray:
    """J (E1.5) with P at r, from the derived kinetic moment: its columns are K at unit
    omega minus K at omega = 0, P at rest."""
    K = load("general_kinetic_moment")
    u = np.r_[r, np.zeros(6)]
    q = np.zeros(layout.GENERAL.nq)
    q[layout.GENERAL.A] = np.eye(3).ravel()
    base = np.array(K(q, u, tr.p).full()).ravel()
    cols = []
    for i in range(3):
        qi = q.copy()
        qi[6 + i] = 1.0
        cols.append(np.array(K(qi, u, tr.p).full()).ravel() - base)
    return np.array(cols).T


def rotation_vector(R) -> np.ndarray:
    """log of a rotation matrix as a vector (angle * axis)."""
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    angle = math.acos(c)
    v = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = math.sin(angle)
    if s < 1e-9:
        if angle < 1e-6:
            return v
        # near pi: the axis from the symmetric part
        w, V = np.linalg.eigh((R + R.T) / 2)
        return angle * V[:, np.argmax(w)]
    return v * angle / s


def loops(tr: Transcription, phi: np.ndarray, at_rest_ends: bool = True):
    """A path (function of tau) of loops through the start whose geometric phase is
    about the rotation vector phi (body axes)."""
    task = tr.task
    start, c, R = task.start, task.region_center, task.region_radius
    mu = task.scene.reduced_mass
    J = inertia_at(tr, start)
    area = -J @ phi / (2 * mu)
    a = float(np.linalg.norm(area))
    if a < 1e-12:
        axis = np.array([0.0, 0.0, 1.0])
        a = 1e-4
    else:
        axis = area / a
    # e1 towards the region's centre (more room), e2 = axis x e1
    towards = c - start
    towards -= axis * (axis @ towards)
    if np.linalg.norm(towards) < 1e-9:
        helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        towards = np.cross(axis, helper)
    e1 = -towards / np.linalg.norm(towards)     # the loop centre is start - rho e1
    e2 = np.cross(axis, e1)
    rho = R
    for _ in range(60):
        th = np.linspace(0, 2 * np.pi, 73)
        pts = start + rho * ((np.cos(th) - 1)[:, None] * e1 + np.sin(th)[:, None] * e2)
        if np.max(np.linalg.norm(pts - c, axis=1)) <= 0.9 * R:
            break
        rho *= 0.9
    k = max(1, math.ceil(a / (math.pi * rho * rho)))
    k = min(k, max(1, tr.N // 6))
    rho = min(rho, math.sqrt(a / (math.pi * k)))

    def path(tau):
        s = smoothstep(tau) if at_rest_ends else np.asarray(tau)
        al = 2 * math.pi * k * s
        return start + rho * ((np.cos(al) - 1)[:, None] * e1 + np.sin(al)[:, None] * e2)
    return path


def _rest_ctrl(tr: Transcription) -> np.ndarray:
    if tr.bodies:
        return tr.rest_ctrl()
    if tr.kind == "circle":
        return np.full((tr.spline.n_ctrl, 1), tr.task.circle[3])
    return np.tile(tr.task.start, (tr.spline.n_ctrl, 1))


def _attitude_guess(tr: Transcription, T: float, A_target, q0):
    """Loops (or an arc of the circle) that turn the drifting body towards A_target (of
    several bodies: :meth:`derive.planner.bodies.BodiesTranscription.attitude_ctrl`)."""
    if tr.bodies:
        return tr.attitude_ctrl(T, A_target, q0)
    rest = _rest_ctrl(tr)
    Q = tr.rk4_nodes(rest, q0, T)
    A_end = tr.layout.A_of(Q[:, -1])
    phi = rotation_vector(A_end.T @ A_target)
    task = tr.task
    if tr.kind == "circle":
        cx, cy, Rc, a0 = task.circle
        # the body's turn per unit of theta at the start: omega = -J^-1 (mu r x v), v = dr/dtheta
        r = np.array([cx + Rc * math.cos(a0), cy + Rc * math.sin(a0), 0.0])
        v = np.array([-Rc * math.sin(a0), Rc * math.cos(a0), 0.0])
        J = inertia_at(tr, r)
        mu = task.scene.reduced_mass
        rate = -np.linalg.solve(J, mu * np.cross(r, v))[2]
        dtheta = phi[2] / rate if abs(rate) > 1e-12 else 1.0
        if task.rest_at_ends:
            return fit_ctrl(tr, lambda tau: a0 + dtheta * smoothstep(tau))
        return fit_ctrl(tr, lambda tau: a0 + dtheta * np.asarray(tau))
    return fit_ctrl(tr, loops(tr, phi, task.rest_at_ends))


def fix_ends(tr: Transcription, ctrl) -> np.ndarray:
    """Honour the fixed control points exactly (bounds)."""
    ctrl = np.array(ctrl, dtype=float)
    lb = tr.lbx[:tr.n_c].reshape(tr.spline.n_ctrl, tr.dim, order="F")
    fixed = np.isfinite(lb) & (lb == tr.ubx[:tr.n_c].reshape(tr.spline.n_ctrl, tr.dim,
                                                             order="F"))
    ctrl[fixed] = lb[fixed]
    return ctrl


def touchdown_time(tr: Transcription, ctrl, q0) -> float:
    """The first T at which the gap at the end closes, with the given law shape."""
    sc = tr.task.scene

    def h_end(T):
        Q = tr.rk4_nodes(ctrl, q0, T)
        return tr.gap_value(Q[:, -1], tr.local_ctrl(ctrl, tr.N - 1), 1.0, T)[0]
    z = max(sc.com[2], 1e-3)
    T_hi = math.sqrt(2 * z / sc.g) * 1.5 + 0.1
    grid = np.linspace(0.02 * T_hi, 2 * T_hi, 60)
    prev_T, prev_h = None, None
    for T in grid:
        h = h_end(T)
        if prev_h is not None and prev_h > 0 >= h:
            lo, hi = prev_T, T
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                if h_end(mid) > 0:
                    lo = mid
                else:
                    hi = mid
            return 0.5 * (lo + hi)
        prev_T, prev_h = T, h
    raise SceneError("[initial].com", "the carrier does not reach the plane (check g and "
                                      "the height)")


def _nodes(tr: Transcription, ctrl, q0, T) -> np.ndarray:
    """w0 from a law: the ends honoured, the nodes marched by the NLP's own RK4."""
    ctrl = fix_ends(tr, ctrl)
    tr._T_guess = T
    return tr.pack(ctrl, tr.rk4_nodes(ctrl, q0, T), T)


def reorient_guess(tr: Transcription) -> np.ndarray:
    """Loops that turn the drifting body to target_matrix by the end of the horizon."""
    task = tr.task
    q0 = tr.layout.of_state(initial_state(task))
    T = task.horizon
    return _nodes(tr, _attitude_guess(tr, T, task.target, q0), q0, T)


def land_guess(tr: Transcription) -> np.ndarray:
    """The touchdown time of P at rest, then loops that turn the body to target_matrix
    (or OP to the vertical, for d = 0) by then, and the touchdown time of that law."""
    task = tr.task
    q0 = tr.layout.of_state(initial_state(task))
    rest = _rest_ctrl(tr)
    T = touchdown_time(tr, rest, q0)
    if task.at_touchdown == "attitude":
        ctrl = _attitude_guess(tr, T, task.target, q0)
    else:
        ctrl = _d_zero_guess(tr, T, q0, rest)
    ctrl = fix_ends(tr, ctrl)
    T = touchdown_time(tr, ctrl, q0)
    if task.horizon is not None:
        T = min(T, task.horizon)
    return _nodes(tr, ctrl, q0, T)


def _d_zero_guess(tr: Transcription, T, q0, rest):
    """Loops that turn OP towards the vertical by touchdown (d = -nu OP x n for a sphere
    centred at O)."""
    r = tr.task.start
    if tr.kind == "circle" or np.linalg.norm(r) < 1e-9:
        return rest
    Q = tr.rk4_nodes(rest, q0, T)
    n = tr.layout.n_of(Q[:, -1])
    target = n if r @ n > 0 else -n
    axis = np.cross(r, target)
    s = np.linalg.norm(axis)
    if s < 1e-12:
        return rest
    angle = math.atan2(s, r @ target / np.linalg.norm(r))
    # the body turns by phi: OP turns by -phi relative to the vertical
    return fit_ctrl(tr, loops(tr, -angle * axis / s, tr.task.rest_at_ends))


def hop_table(task) -> dict:
    """The reference-[5] orbit the hop starts from: P on the vertical through the
    region's centre, z = c_z + a sin(2 pi t/T + phase); returns a, phase, T, Z0, v0."""
    sc = task.scene
    nu = sc.m / (sc.m + sc.M)
    n = np.array([0.0, 0.0, 1.0])
    c = task.region_center
    OS = np.array(lowest_point(sc.shape, n, sc.center, sc.size).full()).ravel()
    e, g = sc.e, sc.g
    G1 = existence_threshold(e, 1)
    Gpd = period_doubling_threshold(e, 1)
    Gamma = 0.5 * (G1 + Gpd)
    # the acceleration a W^2 = Gamma g / nu must respect the task's bound
    Gamma = min(Gamma, 0.8 * task.max_acceleration * nu / g)
    phase = math.acos(min(1.0, G1 / Gamma)) if Gamma > 0 else 0.0
    # Z0 and T depend on a through r(0): fixed point, two passes suffice
    a, T = 0.0, 1.0
    for _ in range(20):
        r0 = c + np.array([0.0, 0.0, a * math.sin(phase)])
        Z0 = -n @ (OS - nu * r0)
        rise = task.apex_height - Z0
        if rise <= 0:
            raise SceneError("[plan].apex_height", f"must exceed the height of C at the "
                                                   f"impact (about {Z0:.4g})")
        v0 = math.sqrt(2 * g * rise)
        T = 2 * v0 / g
        W = 2 * math.pi / T
        a = min(Gamma * g / (nu * W * W), 0.8 * task.region_radius)
    return {"a": a, "phase": phase, "T": T, "Z0": Z0, "v0": v0, "Gamma": nu * a * W * W / g,
            "Gamma_1": G1, "Gamma_pd": Gpd}


def hop_guess(tr: Transcription) -> np.ndarray:
    """The orbit of the ball on a vibrating table (:func:`hop_table`)."""
    task = tr.task
    tab = hop_table(task)
    c = task.region_center
    a, ph = tab["a"], tab["phase"]

    def path(tau):
        tau = np.asarray(tau)
        z = c[2] + a * np.sin(2 * math.pi * tau + ph)
        return np.column_stack([np.full_like(tau, c[0]), np.full_like(tau, c[1]), z])
    ctrl = fit_ctrl(tr, path, periodic=True)
    T = tab["T"]
    if task.horizon is not None and T > task.horizon:
        raise SceneError("[plan].horizon", f"the period the apex needs ({T:.4g} s) exceeds "
                                           "the horizon")
    q0 = np.array([tab["Z0"], tab["v0"], 0.0, 0.0, task.scene.omega[2], 0.0, 0.0, 1.0])
    tr._T_guess = T
    Q = tr.rk4_nodes(ctrl, q0, T)
    return tr.pack(ctrl, Q, T)
