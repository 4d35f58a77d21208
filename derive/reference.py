"""Exact reference solutions of the paper, for tests and benchmarks.

Each takes a free-flight :class:`~derive.scene.Scene` (or builds one) and times
``t`` and returns the state in the ``general`` layout (N, 18); ``mu`` is the paper's
reduced mass ``mM/(m+M)`` (``Scene.reduced_mass``):

* :func:`free_parabola` — the centre of mass C in flight (E1.2), for any scene;
* :func:`axisymmetric` — J_x = J_y, x = y = 0: theta constant and
  ``psi' = K/(J_x + mu z^2)``, ``phi' = omega_z0 (1 - J_z/(J_x + mu z^2))`` (E3.11–E3.14),
  the attitude ``A = R_K Rz(psi) Rx(theta0) Rz(phi)``; the integral of
  ``1/(J_x + mu z^2)`` is in closed form for ``z = a sin(W t + b)`` (and cosines), else by
  adaptive Gauss–Kronrod quadrature to 1e-14;
* :func:`planar` — z = 0, omega = (0, 0, omega_z): omega_z from the integral (4.2) in
  closed form, its angle by quadrature, ``A = A0 Rz(phi)``;
* :func:`stationary` — the stationary rotations of C4.1–C4.3 with their point laws:
  omega constant, ``A = A0 Rz(omega (t - t0))``; :func:`stationary_scene` builds them.
"""
from __future__ import annotations

import math

import numpy as np
import sympy as sp
from scipy.integrate import quad

from . import layout
from . import notation as nt
from .runtime.geometry import momentum_frame, rotation_x, rotation_z
from .scene import DEFAULT_SCENE, Scene, parse_scene

G = layout.GENERAL


def free_parabola(scene: Scene, t) -> tuple[np.ndarray, np.ndarray]:
    """X_C, Y_C, Z_C and their rates in flight (E1.2)."""
    dt = np.asarray(t, dtype=float) - scene.t0
    r0, v0 = np.asarray(scene.com), np.asarray(scene.com_velocity)
    g = np.array([0.0, 0.0, -scene.g])
    R = r0 + dt[:, None] * v0 + 0.5 * dt[:, None] ** 2 * g
    V = v0 + dt[:, None] * g
    return R, V


def _cumulative(fun, t0: float, ts: np.ndarray) -> np.ndarray:
    """int_{t0}^{t} fun for every t in ts (sorted), by adaptive quadrature per interval."""
    out = np.empty(len(ts))
    acc, last = 0.0, t0
    for k, tk in enumerate(ts):
        if tk > last:
            piece, _ = quad(fun, last, tk, epsabs=1e-14, epsrel=1e-13, limit=200)
            acc += piece
            last = tk
        out[k] = acc
    return out


def _harmonic(expr: sp.Expr):
    """(a, W, b) when expr is a sin(W t + b) or a cos(W t + b) (then b + pi/2), else None."""
    t = nt.t
    a, W, b = sp.Wild("a", exclude=[t]), sp.Wild("W", exclude=[t]), sp.Wild("b", exclude=[t])
    for fn, shift in ((sp.sin, 0.0), (sp.cos, math.pi / 2)):
        m = sp.expand(expr).match(a * fn(W * t + b))
        if m and m[W] != 0:
            return float(m[a]), float(m[W]), float(m[b]) + shift
    return None


def inverse_inertia_integral(scene: Scene, ts: np.ndarray, J: float) -> np.ndarray:
    """``int_{t0}^{t} ds / (J + mu z(s)^2)`` for the scene's z(t).

    For z = a sin(W s + b): with theta = W s + b, A = J, B = mu a^2,
    ``int dtheta/(A + B sin^2 theta) = G(theta)/sqrt(A (A + B))``, G the continuous
    angle of (sqrt(A) cos theta, sqrt(A + B) sin theta)."""
    mu = scene.reduced_mass
    z = scene.law.sympy()[2]
    h = _harmonic(z)
    if h is not None:
        a, W, b = h
        A, B = J, mu * a * a

        def G(theta):
            g = np.arctan2(np.sqrt(A + B) * np.sin(theta), np.sqrt(A) * np.cos(theta))
            return g + 2 * np.pi * np.round((theta - g) / (2 * np.pi))
        theta = W * np.asarray(ts) + b
        theta0 = W * scene.t0 + b
        return (G(theta) - G(theta0)) / (W * math.sqrt(A * (A + B)))
    zf = sp.lambdify(nt.t, z, modules="math")
    return _cumulative(lambda s: 1.0 / (J + mu * zf(s) ** 2), scene.t0, np.asarray(ts))


def axisymmetric(scene: Scene, t) -> np.ndarray:
    """The quadrature solution of section 3 in the general layout."""
    if abs(scene.J[0] - scene.J[1]) > 1e-12 * max(scene.J) or scene.law.sympy()[0] != 0 \
            or scene.law.sympy()[1] != 0:
        raise ValueError("axisymmetric reference: needs J_x = J_y and x = y = 0")
    ts = np.asarray(t, dtype=float)
    A0, w0 = scene.A0, np.asarray(scene.omega, dtype=float)
    z0 = float(sp.sympify(scene.law.sympy()[2]).subs(nt.t, scene.t0))
    Jx, Jz, mu = scene.J[0], scene.J[2], scene.reduced_mass
    K_body = np.array([(Jx + mu * z0 ** 2) * w0[0], (Jx + mu * z0 ** 2) * w0[1], Jz * w0[2]])
    K, R_K, psi0, theta0, phi0 = momentum_frame(A0 @ K_body, A0)  # E3.11: cos = J_z w_z0/K
    integral = inverse_inertia_integral(scene, ts, Jx)
    psi = psi0 + K * integral
    phi = phi0 + w0[2] * (ts - scene.t0) - w0[2] * Jz * integral
    z = np.asarray(scene.law.jets(ts)[6])
    psi_dot = K / (Jx + mu * z ** 2)
    s0 = math.sin(theta0)
    omega = np.column_stack([psi_dot * s0 * np.sin(phi), psi_dot * s0 * np.cos(phi),
                             np.full(len(ts), w0[2])])
    A = R_K[None] @ rotation_z(psi) @ rotation_x(np.full(len(ts), theta0)) @ rotation_z(phi)
    R, V = free_parabola(scene, ts)
    return G.assemble(com=R, com_velocity=V, omega=omega, A=A.reshape(len(ts), 9))


def planar(scene: Scene, t) -> np.ndarray:
    """The plane motion of section 4 (z = 0, omega along z) in the general layout."""
    if scene.law.sympy()[2] != 0 or scene.omega[0] != 0 or scene.omega[1] != 0:
        raise ValueError("planar reference: needs z = 0 and omega(0) along z")
    ts = np.asarray(t, dtype=float)
    mu, Jz = scene.reduced_mass, scene.J[2]
    x, y = scene.law.sympy()[0], scene.law.sympy()[1]
    xd, yd = sp.diff(x, nt.t), sp.diff(y, nt.t)
    # (4.2): [J_z + mu (x^2 + y^2)] omega_z + mu (x y' - y x') = kappa
    Kz = (Jz + mu * (x ** 2 + y ** 2)) * sp.Symbol("w") + mu * (x * yd - y * xd)
    kappa = float(Kz.subs({sp.Symbol("w"): scene.omega[2], nt.t: scene.t0}))
    omega_z = (kappa - mu * (x * yd - y * xd)) / (Jz + mu * (x ** 2 + y ** 2))
    wz_math = sp.lambdify(nt.t, omega_z, modules="math")
    wz = np.array([wz_math(float(tk)) for tk in ts])
    phi = _cumulative(wz_math, scene.t0, ts)
    A = scene.A0[None] @ rotation_z(phi)
    R, V = free_parabola(scene, ts)
    omega = np.column_stack([np.zeros(len(ts)), np.zeros(len(ts)), wz])
    return G.assemble(com=R, com_velocity=V, omega=omega, A=A.reshape(len(ts), 9))


def stationary_scene(case: str, omega: float = 2.0, duration: float = 3.0,
                     inertia=(0.10, 0.12, 0.14), **law) -> dict:
    """A free-flight scene whose point follows the law of C4.1, C4.2 or C4.3 and whose
    body starts in the stationary rotation omega = (0, 0, omega)."""
    import tomllib
    doc = tomllib.loads(DEFAULT_SCENE)
    doc.pop("plane")
    w = repr(float(omega))
    if case == "C4.1":
        a, W = law.get("a", 0.2), law.get("W", 3.0)
        laws = ["0", "0", f"{a}*sin({W}*t)"]
    elif case == "C4.2":
        x0, y0 = law.get("x0", 0.1), law.get("y0", -0.05)
        a, b = law.get("a", 0.15), law.get("b", 0.05)
        laws = [repr(x0), repr(y0), f"{a}*cos({w}*t) + {b}*sin({w}*t)"]
    elif case == "C4.3":
        R, a, b = law.get("R", 0.15), law.get("a", 0.1), law.get("b", 0.0)
        half = repr(float(omega) / 2)
        laws = [f"{R}*cos({half}*t)", f"-{R}*sin({half}*t)",
                f"{a}*cos({half}*t) + {b}*sin({half}*t)"]
    else:
        raise ValueError(f"unknown stationary case {case!r}")
    doc["body"]["inertia"] = list(inertia)
    doc["point"]["law"] = laws
    doc["initial"].update(omega=[0.0, 0.0, float(omega)], time=0.0)
    doc["run"].update(duration=duration, outputs=["pose"], model="general")
    return doc


def stationary(scene: Scene, t) -> np.ndarray:
    """omega = (0, 0, omega) constant; the body turns uniformly about its z axis."""
    ts = np.asarray(t, dtype=float)
    w = scene.omega[2]
    A = scene.A0[None] @ rotation_z(w * (ts - scene.t0))
    R, V = free_parabola(scene, ts)
    omega = np.tile(np.asarray(scene.omega, dtype=float), (len(ts), 1))
    return G.assemble(com=R, com_velocity=V, omega=omega, A=A.reshape(len(ts), 9))


def scene_of(doc) -> Scene:
    return parse_scene(doc) if isinstance(doc, dict) else doc


def vertical_bounce(scene: Scene, t) -> tuple[np.ndarray, np.ndarray]:
    """C2.4: the carrier translates (omega = 0) with P on the vertical line through O,
    moving uniformly, z = z0 + w t, and S on that line (a sphere centred on it, the axis
    vertical).  Then d = 0 at every impact, the height of S is a quadratic between
    impacts and every impact time is the root of a quadratic.  Returns the general layout
    at ``t`` and the impact times."""
    t_sym = nt.t
    zf = sp.expand(scene.law.sympy()[2])
    w = float(sp.diff(zf, t_sym))
    z0 = float(zf.subs(t_sym, 0))
    if scene.law.sympy()[0] != 0 or scene.law.sympy()[1] != 0 or sp.diff(zf, t_sym, 2) != 0 \
            or any(scene.omega) or not np.allclose(scene.A0[2], [0, 0, 1]) \
            or scene.shape != "sphere" or scene.center[0] or scene.center[1]:
        raise ValueError("vertical bounce: needs x = y = 0, z linear in t, omega = 0, the "
                         "body z axis vertical and a sphere centred on it")
    g, e, nu = scene.g, scene.e, scene.m / (scene.m + scene.M)
    offset = scene.center[2] - scene.size[0]            # OS_z for n = e_z

    def height(Z, tau):
        return Z + offset - nu * (z0 + w * tau)
    ts = np.asarray(t, dtype=float)
    t_end = scene.t0 + scene.duration
    tk, Zk, Vk = scene.t0, scene.com[2], scene.com_velocity[2]
    segments, impacts = [(tk, Zk, Vk)], []
    while True:
        # height(Z(tau), tau) = -g/2 s^2 + (Vk - nu w) s + height(Zk, tk) = 0, s = tau - tk
        a, b, c = -0.5 * g, Vk - nu * w, height(Zk, tk)
        disc = b * b - 4 * a * c
        if disc < 0:
            break
        s = (-b - math.sqrt(disc)) / (2 * a)
        if s <= 1e-15 or tk + s > t_end:
            break
        tk = tk + s
        Zk = Zk + Vk * s - 0.5 * g * s * s
        v_minus = (Vk - g * s) - nu * w
        Vk = nu * w - e * v_minus                      # v_n+ = -e v_n-, d = 0
        impacts.append(tk)
        segments.append((tk, Zk, Vk))
        if len(impacts) > 10000:
            break
    starts = np.array([sg[0] for sg in segments])
    idx = np.searchsorted(starts, ts, side="right") - 1
    out = np.empty((len(ts), G.nq))
    R, V = free_parabola(scene, ts)
    out[:, G.horizontal], out[:, G.horizontal_velocity] = R[:, 0:2], V[:, 0:2]
    for k, (tau, i) in enumerate(zip(ts, idx)):
        t_i, Z_i, V_i = segments[i]
        s = tau - t_i
        out[k, G.Z] = Z_i + V_i * s - 0.5 * g * s * s
        out[k, G.Zd] = V_i - g * s
    out[:, G.omega] = 0.0
    out[:, G.A] = scene.A0.reshape(-1)
    return out, np.array(impacts)


def _first_landing(h, hd, t0: float, t_end: float, step: float):
    """The first time after ``t0`` at which the height ``h`` (rate ``hd``) comes down to
    zero, S leaving the plane at ``t0`` if it is there; None if it does not before
    ``t_end``.  Each scan interval is split at the zeros of the rate, so that a flight
    or a dip shorter than the interval is not missed."""
    from scipy.optimize import brentq
    if h(t0) <= 0 and hd(t0) < 0:
        return t0
    s0 = t0
    while s0 < t_end:
        s1 = min(s0 + step, t_end)
        points = [s0]
        d0, d1 = hd(s0), hd(s1)
        if (d0 > 0 > d1) or (d0 < 0 < d1):
            points.append(brentq(hd, s0, s1, xtol=1e-15, rtol=1e-15))
        elif d0 == 0.0 and d1 != 0.0 and s0 > t0:
            points.append(s0)
        points.append(s1)
        for a, b in zip(points, points[1:]):
            ha, hb = h(a), h(b)
            leaving = a == t0 and hd(a) >= 0
            if (ha > 0 or leaving) and hb <= 0 and b > a:
                if ha <= 0:
                    return None if hb == ha else b
                return brentq(h, a, b, xtol=1e-15, rtol=1e-15)
        s0 = s1
    return None


def translational_bounce(scene: Scene, t, max_events: int = 100000):
    """A translating carrier (omega = 0, the body z axis vertical, a sphere centred on it,
    P on the vertical through O with any law z(t)): C2.4 holds, d = 0 at every impact.

    Flights are exact parabolas of Z_C; the height of S is ``Z_C + offset - nu z(t)`` with
    the analytic law, its first downward zero located by scanning (steps of 1/200 of the
    law's time scale, with the sign of its rate to catch dips between samples) and Brent's
    method to 1e-15.  At impact ``v_n+ = -e v_n-`` with ``v_n = Z_C' - nu z'``.  When the
    rebound is too small to resolve (below 1e-9 m/s) S rests: ``Z_C = -offset + nu z(t)``
    while the reaction ``(m + M)(g + nu z'')`` stays positive; lift-off where it turns
    negative.  Returns the general layout at ``t``, the impact times and the rest
    intervals."""
    from scipy.optimize import brentq
    tt = nt.t
    zf = scene.law.sympy()[2]
    if scene.law.sympy()[0] != 0 or scene.law.sympy()[1] != 0 or any(scene.omega) \
            or not np.allclose(scene.A0[2], [0, 0, 1]) or scene.shape != "sphere" \
            or scene.center[0] or scene.center[1]:
        raise ValueError("translational bounce: needs x = y = 0, omega = 0, the body z "
                         "axis vertical and a sphere centred on it")
    z = sp.lambdify(tt, zf, modules="math")
    zd = sp.lambdify(tt, sp.diff(zf, tt), modules="math")
    zdd = sp.lambdify(tt, sp.diff(zf, tt, 2), modules="math")
    g, e, nu = scene.g, scene.e, scene.m / (scene.m + scene.M)
    offset = scene.center[2] - scene.size[0]
    t_end = scene.t0 + scene.duration
    ts_law = np.linspace(scene.t0, t_end, 4001)
    amp = max(np.ptp([z(v) for v in ts_law]), 1e-12)
    acc = max(max(abs(zdd(v)) for v in ts_law), 1e-12)
    dt_scan = min(math.sqrt(amp / acc) / 200.0, scene.duration / 2000.0)

    def flight_h(tk, Zk, Vk):  # noqa: D401
        return lambda s: Zk + Vk * (s - tk) - 0.5 * g * (s - tk) ** 2 + offset - nu * z(s)

    def flight_hd(tk, Vk):
        return lambda s: Vk - g * (s - tk) - nu * zd(s)

    segments = []          # (kind, t_start, Z, V): kind "flight" or "rest"
    impacts = []
    tk, Zk, Vk = scene.t0, scene.com[2], scene.com_velocity[2]
    kind = "flight"
    while tk < t_end and len(impacts) < max_events:
        segments.append((kind, tk, Zk, Vk))
        if kind == "rest":
            # lift-off where g + nu z'' < 0
            reaction = lambda s: g + nu * zdd(s)      # noqa: E731
            s0 = tk
            found = None
            while s0 < t_end:
                s1 = min(s0 + dt_scan, t_end)
                if reaction(s0) >= 0 > reaction(s1):
                    found = brentq(reaction, s0, s1, xtol=1e-15, rtol=1e-15)
                    break
                s0 = s1
            if found is None:
                break
            tk, Zk, Vk, kind = found, -offset + nu * z(found), nu * zd(found), "flight"
            continue
        h, hd = flight_h(tk, Zk, Vk), flight_hd(tk, Vk)
        hit = _first_landing(h, hd, tk, t_end, dt_scan)
        if hit is None:
            break
        V_hit = Vk - g * (hit - tk)
        Z_hit = Zk + Vk * (hit - tk) - 0.5 * g * (hit - tk) ** 2
        v_minus = V_hit - nu * zd(hit)
        if v_minus >= 0:                                   # a graze
            tk, Zk, Vk = hit + 1e-12, Z_hit, V_hit
            continue
        impacts.append(hit)
        v_plus = -e * v_minus
        tk, Zk, Vk = hit, Z_hit, nu * zd(hit) + v_plus
        # impacts accumulate: the next flight would last under 1e-9 of the run
        pull = g + nu * zdd(hit)
        if pull > 0 and 2 * v_plus / pull < 1e-9 * scene.duration:
            kind = "rest"
            Zk, Vk = -offset + nu * z(hit), nu * zd(hit)
    ts = np.asarray(t, dtype=float)
    out = np.empty((len(ts), G.nq))
    R, V = free_parabola(scene, ts)
    out[:, G.horizontal], out[:, G.horizontal_velocity] = R[:, 0:2], V[:, 0:2]
    starts = np.array([sg[1] for sg in segments])
    idx = np.clip(np.searchsorted(starts, ts, side="right") - 1, 0, len(segments) - 1)
    for k, (tau, i) in enumerate(zip(ts, idx)):
        kind, t_i, Z_i, V_i = segments[i]
        if kind == "rest":
            out[k, G.Z], out[k, G.Zd] = -offset + nu * z(tau), nu * zd(tau)
        else:
            s = tau - t_i
            out[k, G.Z], out[k, G.Zd] = Z_i + V_i * s - 0.5 * g * s * s, V_i - g * s
    out[:, G.omega] = 0.0
    out[:, G.A] = scene.A0.reshape(-1)
    rests = [sg[1] for sg in segments if sg[0] == "rest"]
    return out, np.array(impacts), rests
