"""A reference integrator of the base model, written apart from the runtime and from the
derivation (derive/base.py): a body on its face, driven by its points and rotors, with
exact stick and slip events, lift-off and tipping.  The C runtime of phase 2 is checked
against it, and it is checked against closed forms (tests/test_base_closed_forms.py).

**Dynamics**: Newton–Euler of the carrier and of each point and rotor, in the face frame
(derive/face.py; the body turns about the vertical only): a point's absolute acceleration
``a_O + w' e_z x rho + w e_z x (w e_z x rho) + 2 w e_z x rho' + rho''`` needs the force
``m (a + g e_z)`` from the carrier; a rotor needs the torque ``I (psi'' a + omega x psi'
a)`` from it.  With the contact's normal force N at the centre of pressure cp and the
friction (F, T_z) on the face, the carrier's force and Euler equations are six linear
equations in ``(a_x, a_y, w', N, N x_cp, N y_cp)`` while it slips and in ``(F_x, F_y,
T_z, N, N x_cp, N y_cp)`` while it sticks, solved numerically.  Nothing here uses the
moments.

**Friction over the face**: Coulomb at every point (Contensou).  Its integrals about the
instant centre ``r0 = e_z x v/w`` reduce to one integral over the angle about r0 (the
radial ones are polynomial), which SciPy's adaptive quad evaluates to 1e-13 with
breakpoints at the corners (a rectangle) or the tangents (a disc seen from outside);
derive/face.py evaluates the same integrals in closed form or by fixed rules.  The limit
surface's gauge ``max W.xi / D_s(xi)`` by SLSQP on the unit sphere of twists.

**Events**:

* stick -> slip where the gauge of the wrench the rest needs reaches 1 (static
  coefficient), the slip starting against the twist that attains it (the friction of a
  slip opposes it), then along the stable direction of the slip's flow;
* slip -> stick or reversal where the slip (v, l w) reaches 0: the slip is integrated in
  the time ``s`` with ``dt/ds = |xi|`` (so the end is approached without the friction's
  direction flipping), stopped at ``|xi| = 1e-11`` of the velocity scale and carried to
  0 by the linear decay; then sticking if the gauge is at most 1, else sliding off again
  along the stable direction of the slip's flow;
* lift-off (N = 0), tipping (cp on the face's edge) and, with linear pressure, the face
  starting to lift at an edge (cp leaving the kern: face_lifting): the run stops with
  that status; also where a stick or a slip starts past one (the cp of its own reaction:
  a reversal's slip, not the rest that cannot hold).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import IntegrationWarning, quad, solve_ivp
from scipy.optimize import minimize

from .face import Face


@dataclass(frozen=True)
class Point:
    """A point of mass ``mass`` on the law ``law(t) -> (rho, rho', rho'')`` (face frame,
    from O)."""
    mass: float
    law: Callable


@dataclass(frozen=True)
class Rotor:
    """A rotor of axial moment ``inertia`` about the unit ``axis`` (face frame), turning
    at ``law(t) -> (psi', psi'')`` relative to the body (its mass and locked inertia are
    the carrier's)."""
    inertia: float
    axis: tuple
    law: Callable


@dataclass
class System:
    M: float
    J: tuple                     # J_O in the face frame (diagonal)
    face: Face
    points: tuple = ()
    rotors: tuple = ()
    mu: float = 0.5              # kinetic
    mu_static: float | None = None
    pressure: str = "uniform"
    g: float = 9.81
    jumps: tuple = ()            # times where a law's velocity jumps (momentum kept)

    @property
    def mass(self) -> float:
        return self.M + sum(p.mass for p in self.points)

    @property
    def mu_s(self) -> float:
        return self.mu if self.mu_static is None else self.mu_static


# ---- friction integrals about the instant centre (adaptive quadrature) -----------------------
def _pressure(sys: System, N: float, cp) -> tuple[float, np.ndarray]:
    f = sys.face
    if sys.pressure == "uniform":
        return N / f.area, np.zeros(2)
    Ix, Iy = _moments(f)
    return N / f.area, N * np.array([(cp[0] - f.centre[0]) / Ix, (cp[1] - f.centre[1]) / Iy])


def _quad(fn, a: float, b: float) -> float:
    """The integral to round-off: asked past what doubles give (epsabs 1e-16), QUADPACK
    says so ("roundoff error is detected") on every integral whose value is near 0, which
    is this reference's intent, not a failure; its other warnings (the subdivision limit,
    a divergent integral) still reach the caller."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="The occurrence of roundoff error",
                                category=IntegrationWarning)
        val, _ = quad(fn, a, b, limit=200, epsabs=1e-16, epsrel=1e-13)
    return val


def _integrals(f: Face, r0, P_c: float, k) -> tuple:
    """G = int p (r - r0)/|r - r0| dA, E = int p |r - r0| dA (p = P_c + k.(r - c)) by
    adaptive quadrature of one-dimensional integrals: a rectangle as the signed triangles
    (r0, V_i, V_i+1), r = r0 + t q(s), dA = t A2 ds dt, the t-integral exact and the s-one
    by quad; a disc in polar coordinates about r0 (the angle by quad; seen from outside,
    through sin(theta - theta_c) = (R/delta) sin(phi), smooth at the tangents)."""
    c = np.asarray(f.centre, dtype=float)
    P0 = P_c + k @ (r0 - c)
    if f.kind == "rectangle":
        a, b = f.half
        V = [c + [a, -b], c + [a, b], c + [-a, b], c + [-a, -b]]
        G, E = np.zeros(2), 0.0
        for i in range(4):
            A, B = V[i] - r0, V[(i + 1) % 4] - r0
            A2 = A[0] * B[1] - A[1] * B[0]
            if A2 == 0.0:
                continue

            def q(s, A=A, B=B):
                return A + s * (B - A)

            def part(s, j, q=q):
                qs = q(s)
                L = math.hypot(*qs)
                kq = k @ qs
                if j < 2:
                    return qs[j] / L * (P0 / 2 + kq / 3)
                return L * (P0 / 3 + kq / 4)
            G += A2 * np.array([_quad(lambda s: part(s, 0), 0, 1),
                                _quad(lambda s: part(s, 1), 0, 1)])
            E += A2 * _quad(lambda s: part(s, 2), 0, 1)
        return G, E
    R = f.half[0]
    dx, dy = float(r0[0] - c[0]), float(r0[1] - c[1])
    delta = math.hypot(dx, dy)
    kx, ky = float(k[0]), float(k[1])

    def parts(th, lo, hi, jac=1.0):
        """(e_x m1, e_y m1, m2) times jac at the angle th: m_j = int_lo^hi rho^j p rho-
        moments along the ray (pure floats: the integrand is called thousands of times)."""
        ex, ey = math.cos(th), math.sin(th)
        ke = kx * ex + ky * ey
        m1 = P0 * (hi ** 2 - lo ** 2) / 2 + ke * (hi ** 3 - lo ** 3) / 3
        m2 = P0 * (hi ** 3 - lo ** 3) / 3 + ke * (hi ** 4 - lo ** 4) / 4
        return ex * m1 * jac, ey * m1 * jac, m2 * jac
    if delta < R:
        def at(th):
            de = dx * math.cos(th) + dy * math.sin(th)
            return parts(th, 0.0, -de + math.sqrt(R * R - delta * delta + de * de))
        span = (0.0, 2 * math.pi)
    else:
        th_c = math.atan2(-dy, -dx)

        def at(ph):
            sn = R / delta * math.sin(ph)
            th = th_c + math.asin(sn)
            de = dx * math.cos(th) + dy * math.sin(th)
            root = R * math.cos(ph)
            return parts(th, -de - root, -de + root, R / delta * math.cos(ph)
                         / math.sqrt(1 - sn * sn))
        span = (-math.pi / 2, math.pi / 2)
    G = np.array([_quad(lambda x: at(x)[0], *span), _quad(lambda x: at(x)[1], *span)])
    return G, _quad(lambda x: at(x)[2], *span)


FAR = 3.0      # r0 this many face sizes from the centroid: the slip field is smooth over
               # the face, and the triangles about r0 would cancel each other (area ~ |r0|)


def _far(f: Face, mu: float, P_c: float, k, twist) -> tuple[np.ndarray, float]:
    """The friction integrals over the face directly, where the instant centre is far
    (the integrand analytic on the face): Gauss–Legendre 40 x 40 over a rectangle, 40
    radii times 96 angles over a disc (converged to round-off at 3 sizes)."""
    x, wt = np.polynomial.legendre.leggauss(40)
    c = np.asarray(f.centre, dtype=float)
    if f.kind == "rectangle":
        a, b = f.half
        X, Y = np.meshgrid(a * x, b * x, indexing="ij")
        off = np.column_stack([X.ravel(), Y.ravel()])
        weights = np.outer(a * wt, b * wt).ravel()
    else:
        R = f.half[0]
        r, wr = R * (x + 1) / 2, R * wt / 2
        th = (np.arange(96) + 0.5) * 2 * math.pi / 96
        off = np.column_stack([np.outer(r, np.cos(th)).ravel(), np.outer(r, np.sin(th)).ravel()])
        weights = np.outer(wr * r, np.full(96, 2 * math.pi / 96)).ravel()
    pts = off + c
    pw = weights * (P_c + off @ k)
    vx, vy, w = twist
    ux, uy = vx - w * pts[:, 1], vy + w * pts[:, 0]
    speed = np.hypot(ux, uy)
    fx, fy = -mu * pw * ux / speed, -mu * pw * uy / speed
    return (np.array([fx.sum(), fy.sum(), (pts[:, 0] * fy - pts[:, 1] * fx).sum()]),
            float(mu * (pw * speed).sum()))


def friction(sys: System, mu: float, N: float, cp, twist) -> tuple[np.ndarray, float]:
    """((F_x, F_y, T_z), D): the friction on the body for the slip twist (v_x, v_y, w)
    at O, and the power it takes.  With w != 0 the slip turns about the instant centre
    r0 = e_z x v/w: F = -mu sgn(w) e_z x G, T_z = -mu sgn(w) (r0.G + E), D = mu |w| E."""
    f = sys.face
    vx, vy, w = (float(x) for x in twist)
    P_c, k = _pressure(sys, N, cp)
    speed = math.hypot(vx, vy)
    if abs(w) * f.size <= 1e-13 * speed:
        if speed == 0.0:
            return np.zeros(3), 0.0
        centre = np.asarray(f.centre) + k / N * np.array(_moments(f))   # cp, linear
        F = -mu * N * np.array([vx, vy]) / speed
        return np.array([F[0], F[1], centre[0] * F[1] - centre[1] * F[0]]), mu * N * speed
    r0 = np.array([-vy / w, vx / w])
    if math.hypot(*(r0 - np.asarray(f.centre))) > FAR * f.size:
        return _far(f, mu, P_c, k, (vx, vy, w))
    G, E = _integrals(f, r0, P_c, k)
    sg = 1.0 if w > 0 else -1.0
    return (np.array([mu * sg * G[1], -mu * sg * G[0], -mu * sg * (r0 @ G + E)]),
            mu * abs(w) * E)


def _moments(f: Face) -> tuple:
    """(int x^2 dA, int y^2 dA) about the centroid: the linear pressure's gradient is N (cp
    - c) over them, and its centroid's shift per unit gradient is them over N."""
    if f.kind == "rectangle":
        a, b = f.half
        return (4 * a ** 3 * b / 3, 4 * a * b ** 3 / 3)
    return (math.pi * f.half[0] ** 4 / 4,) * 2


def limit_gauge(sys: System, N: float, cp, wrench, start=None) -> tuple[float, np.ndarray]:
    """(gamma, xi*): max over scaled twists xi = (v_x, v_y, l w) of W.xi/D_s(xi), as
    1/min D_s on the plane W_s.xi = 1 (D_s a norm: a convex problem in two coordinates,
    its gradient minus the slip's friction), by BFGS from ``start`` or W's direction."""
    ell = sys.face.size
    scale = np.array([1.0, 1.0, 1.0 / ell])
    Ws = np.asarray(wrench, dtype=float) * scale
    nW = np.linalg.norm(Ws)
    if nW == 0.0:
        return 0.0, np.array([1.0, 0.0, 0.0])
    e0 = Ws / nW
    u1 = np.cross(e0, np.eye(3)[int(np.argmin(np.abs(e0)))])
    u1 /= np.linalg.norm(u1)
    basis = np.vstack([u1, np.cross(e0, u1)])

    def both(c):
        xi = e0 / nW + c @ basis
        fr, D = friction(sys, sys.mu_s, N, cp, xi * scale)
        return D, basis @ (-fr * scale)
    c0 = np.zeros(2)
    if start is not None and np.asarray(start) @ e0 > 0:
        s = np.asarray(start, dtype=float)
        c0 = basis @ (s / (s @ e0) / nW)
    res = minimize(both, c0, jac=True, method="BFGS", options={"gtol": 1e-15, "maxiter": 300})
    xi = e0 / nW + res.x @ basis
    return 1.0 / float(res.fun), xi / np.linalg.norm(xi)


# ---- Newton–Euler ------------------------------------------------------------------------------
def _skew_z(w, r):
    return np.array([-w * r[1], w * r[0], 0.0])


def _cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors (NumPy's cross is slow on one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


@dataclass
class Balance:
    """What the six equations give at one instant."""
    N: float
    cp: np.ndarray
    acc: np.ndarray | None = None          # (a_x, a_y, w') in the face frame (slip)
    wrench: np.ndarray | None = None       # (F_x, F_y, T_z) the rest needs (stick)


def _terms(sys: System, t: float, v, w):
    """The six equations of the carrier, ``col x + known = (F_x, F_y, N, tau_c)``, with x
    = (a_x, a_y, w') (O's absolute acceleration, face frame, and the yaw's): the force
    ``M a + sum f_j + M g e_z`` and the torque about O ``J w' e_z + omega x J omega + sum
    rho_j x f_j + the rotors' reactions``, where ``f_j = m_j (a_j + g e_z)`` is the force
    the carrier exerts on point j.  The contact's torque about O is ``tau_c = (y_cp N + h
    F_y, -x_cp N - h F_x, T_z)``."""
    g = sys.g
    J = np.diag(sys.J)
    om = np.array([0.0, 0.0, w])
    unit = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    col_F = np.zeros((3, 3))
    col_T = np.zeros((3, 3))
    known_F = np.array([0.0, 0.0, sys.M * g])
    known_T = _cross(om, J @ om)
    col_F[0, 0] = col_F[1, 1] = sys.M
    col_T[2, 2] = sys.J[2]
    for p in sys.points:
        rho, rd, rdd = (np.asarray(x, dtype=float) for x in p.law(t))
        known_a = _cross(om, _cross(om, rho)) + 2 * _cross(om, rd) + rdd
        fk = p.mass * (known_a + np.array([0.0, 0.0, g]))
        known_F += fk
        known_T += _cross(rho, fk)
        for i, da in enumerate((*unit, _cross([0.0, 0.0, 1.0], rho))):
            col_F[:, i] += p.mass * da
            col_T[:, i] += _cross(rho, p.mass * da)
    for r in sys.rotors:
        a = np.asarray(r.axis, dtype=float)
        psid, psidd = r.law(t)
        known_T += r.inertia * (psidd * a + _cross(om, psid * a))
    return col_F, col_T, known_F, known_T


def balance_slip(sys: System, t: float, v, w, wrench_of) -> Balance:
    """The slip at the face-frame twist (v, w); ``wrench_of(N, cp) -> (F_x, F_y, T_z)``
    (with linear pressure the wrench depends on cp, and cp on the wrench: iterated to the
    fixed point, which is the solution of an affine system)."""
    col_F, col_T, known_F, known_T = _terms(sys, t, v, w)
    N = known_F[2]                        # the vertical
    h = sys.face.height

    def solve(cp_guess):
        Fx, Fy, Tz = wrench_of(N, cp_guess)
        A = np.zeros((5, 5))              # unknowns (a_x, a_y, w', x_cp, y_cp)
        b = np.zeros(5)
        A[0, :3], b[0] = col_F[0], Fx - known_F[0]
        A[1, :3], b[1] = col_F[1], Fy - known_F[1]
        A[2, :3], A[2, 4], b[2] = col_T[0], -N, h * Fy - known_T[0]
        A[3, :3], A[3, 3], b[3] = col_T[1], N, -h * Fx - known_T[1]
        A[4, :3], b[4] = col_T[2], Tz - known_T[2]
        if N == 0.0:                      # (at the lift-off itself: no cp, the rates
            acc = np.linalg.solve(A[[0, 1, 4], :3], b[[0, 1, 4]])   # without it)
            return np.concatenate([acc, [math.nan, math.nan]])
        return np.linalg.solve(A, b)
    x = solve(np.asarray(sys.face.centre, dtype=float))
    if sys.pressure != "uniform":
        for _ in range(100):
            x_new = solve(x[3:5])
            done = np.max(np.abs(x_new - x)) <= 1e-15 * (1 + np.max(np.abs(x)))
            x = x_new
            if done:
                break
    return Balance(N=N, cp=x[3:5], acc=x[:3])


def balance_stick(sys: System, t: float) -> Balance:
    """At rest (a = 0, w = w' = 0): the wrench the rest needs, N and cp."""
    _, _, known_F, known_T = _terms(sys, t, np.zeros(2), 0.0)
    N = known_F[2]
    h = sys.face.height
    Fx, Fy, Tz = known_F[0], known_F[1], known_T[2]
    with np.errstate(divide="ignore", invalid="ignore"):   # (N = 0: the lift-off itself)
        cp = np.array([-h * Fx - known_T[1], known_T[0] - h * Fy]) / np.float64(N)
    return Balance(N=N, cp=cp, wrench=np.array([Fx, Fy, Tz]))


def _margin(face: Face, bal: Balance, margin) -> float:
    """A margin of cp as an event function: N times it while N > 0, negative where N < 0
    (cp = moment/N means nothing there: past N = 0 it comes back into the face, and a step
    ending past the lift-off would miss a tip before it).  N cp is the moment the face
    gives, finite through N = 0."""
    if bal.N > 0:
        return bal.N * margin(bal.cp)
    if bal.N == 0:
        return 0.0
    return bal.N * (face.size + math.hypot(bal.cp[0] - face.centre[0],
                                           bal.cp[1] - face.centre[1]))


def _tie(sys: System, name: str, N: float) -> str:
    """A tip or the face lifting located where N is within 1e-9 of the weight of 0 is the
    lift-off (cp in the face up to N = 0; at smaller N, cp is the moment's round-off)."""
    small = not N > 1e-9 * sys.mass * sys.g
    return "lift_off" if name in ("tipping", "face_lifting") and small else name


# ---- the run -------------------------------------------------------------------------------------
@dataclass
class Run:
    status: str = "done"
    events: list = field(default_factory=list)      # (t, kind)
    states: list = field(default_factory=list)      # y at each event
    approaches: list = field(default_factory=list)  # at each stop of a slip: its unit
                                                    # scaled twist (v_x, v_y, l w) as it ends
    samples: list = field(default_factory=list)     # (t, X_O, Y_O, psi, X_O', Y_O', psi')

    def times(self, kind: str) -> list:
        return [t for t, k in self.events if k == kind]

    def note(self, t: float, kind: str, y) -> None:
        self.events.append((t, kind))
        self.states.append(np.array(y, dtype=float))

    def rename_last(self, kind: str) -> None:
        self.events[-1] = (self.events[-1][0], kind)


def _turn(psi):
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [s, c]])


class Integrator:
    """``Integrator(system).run(y0, t0, t_end, samples)``: y = (X_O, Y_O, psi, X_O',
    Y_O', psi') in fixed axes."""

    def __init__(self, sys: System, rtol: float = 1e-12, atol: float = 1e-14,
                 v_scale: float | None = None):
        self.sys = sys
        self.rtol, self.atol = rtol, atol
        self.ell = sys.face.size
        self.v_scale = v_scale or math.sqrt(sys.g * self.ell)
        self.eps = 1e-11 * self.v_scale
        self.time_scale = self.ell / self.v_scale

    # the slip twist in the face frame, scaled: xi = (v_x, v_y, l w)
    def twist(self, y) -> np.ndarray:
        v = _turn(y[2]).T @ y[3:5]
        return np.array([v[0], v[1], y[5]])

    def _wrench_of(self, twist, mu):
        return lambda N, cp: friction(self.sys, mu, N, cp, twist)[0]

    def rates(self, t, y, direction=None) -> tuple[np.ndarray, Balance]:
        """dy/dt in slip; ``direction``: a unit scaled twist for the friction at rest."""
        tw = self.twist(y)
        fric = tw if direction is None else direction * np.array([1.0, 1.0, 1.0 / self.ell])
        bal = balance_slip(self.sys, t, tw[:2], tw[2], self._wrench_of(fric, self.sys.mu))
        ax, ay, wd = bal.acc
        a = _turn(y[2]) @ np.array([ax, ay])
        return np.array([y[3], y[4], y[5], a[0], a[1], wd]), bal

    def _flow(self, t, y, d):
        """The scaled twist's rate at rest, with the friction of direction d."""
        dy, _ = self.rates(t, y, direction=d)
        acc = _turn(y[2]).T @ dy[3:5]
        return np.array([acc[0], acc[1], self.ell * dy[5]])

    def start_direction(self, t, y, guess) -> np.ndarray | None:
        """The direction a slip from rest takes: the stable fixed point of d -> the flow's
        direction, from ``guess``; None when the flow points back (no slip)."""
        d = np.asarray(guess, dtype=float)
        d /= np.linalg.norm(d)
        for _ in range(2000):
            G = self._flow(t, y, d)
            along = G @ d
            step = G - along * d
            if np.linalg.norm(step) <= 1e-13 * (abs(along) + 1e-300):
                break
            d = d + 0.5 * step / max(np.linalg.norm(G), 1e-300)
            d /= np.linalg.norm(d)
        return d if self._flow(t, y, d) @ d > 0 else None

    def run(self, y0, t0: float, t_end: float, samples=()) -> Run:
        sys = self.sys
        out = Run()
        y = np.asarray(y0, dtype=float).copy()
        t = t0
        marks = sorted(set([s for s in samples if t0 <= s <= t_end] + [t_end]))
        jumps = sorted(j for j in sys.jumps if t0 < j < t_end)
        xi = None
        mode = "slip" if np.any(self.twist(y)) else "rest"
        last_onset = None
        while True:
            if mode == "rest":            # at rest at t: stick, or slide off
                bal = balance_stick(sys, t)
                if bal.N <= 0:
                    out.status = "lift_off"
                    out.note(t, "lift_off", y)
                    break
                gam, xi = limit_gauge(sys, bal.N, bal.cp, bal.wrench, xi)
                mode = "stick" if gam < 1.0 - 1e-12 or (gam <= 1.0 + 1e-12 and
                                                         not self._rising(t, gam, xi)) \
                    else "onset"
                if mode == "stick" and out.events and out.events[-1] == (t, "reversal"):
                    out.rename_last("stick")
            if mode == "onset":           # the slip starts against xi* (friction opposes it)
                if last_onset == t:
                    raise RuntimeError(f"the slip at {t} stops as it starts")
                last_onset = t
                d = self.start_direction(t, y, -xi)
                if d is None:
                    d = -xi
                if not (out.events and out.events[-1] == (t, "reversal")):
                    out.note(t, "slip", y)
                t, y = self._onset(t, y, d)
                mode = "slip"
            stop = min([m for m in marks if m > t] + [j for j in jumps if j > t] + [t_end])
            if mode == "stick":
                t, y, ev, xi = self._stick(t, y, stop, xi)
            else:
                t, y, ev = self._slip(t, y, stop)
            if ev in ("lift_off", "tipping", "face_lifting"):
                out.status = ev
                out.note(t, ev, y)
                break
            if ev == "stop":              # the slip reached 0: stick or reverse (decided
                out.note(t, "reversal", y)              # at rest; a stick renames it)
                out.approaches.append(self.approach)
                mode = "rest"
                continue
            if ev == "breakaway":
                mode = "onset"
                continue
            # a mark, a jump or the end
            if jumps and abs(t - jumps[0]) <= 1e-15 * max(1.0, abs(t)):
                y = self._jump(t, jumps.pop(0), y)
                mode = "slip" if np.any(self.twist(y)) else "rest"
            tol = 1e-15 * max(1.0, abs(t))
            while marks and marks[0] <= t + tol:     # (a mark passed in an event: dropped)
                if abs(marks.pop(0) - t) <= tol:
                    out.samples.append((t, *y))
            if t >= t_end:
                break
        if out.status != "done":
            out.samples.append((t, *y))
        return out

    def _onset(self, t, y, d):
        """The first instants of a slip from rest along the scaled direction d, by its
        Taylor series: the twist's rate is G(t) = G0 + G1 (t - t0) with the friction held
        along d, so after delta the twist is G0 delta + G1 delta^2/2 (0 at t0) and O has
        moved by its integral; delta is where the twist reaches 1e2 of the stop's
        threshold (an error of delta^3 G'': below 1e-20 of the slip's scale)."""
        h = 1e-7 * self.time_scale
        G0 = self._flow(t, y, d)
        G1 = (self._flow(t + h, y, d) - self._flow(t - h, y, d)) / (2 * h)
        a, b = G0 @ d, G1 @ d
        seed = 1e2 * self.eps
        disc = a * a + 2 * b * seed       # a delta + b delta^2/2 = seed, its least root > 0
        if disc < 0 or a + math.sqrt(max(disc, 0.0)) <= 0:
            raise RuntimeError(f"the slip from rest at {t} does not start")
        delta = 2 * seed / (a + math.sqrt(disc))
        xi = G0 * delta + G1 * delta * delta / 2
        moved = G0 * delta * delta / 2 + G1 * delta ** 3 / 6
        y = y.copy()
        R = _turn(y[2])
        y[0:2] += R @ moved[:2]
        y[2] += moved[2] / self.ell
        R = _turn(y[2])
        y[3:5] = R @ xi[:2]
        y[5] = xi[2] / self.ell
        return t + delta, y

    def _rising(self, t, gam, xi) -> bool:
        """Whether the gauge at rest grows through 1 at t (then the body cannot stick)."""
        dt = 1e-6 * self.time_scale
        bal = balance_stick(self.sys, t + dt)
        later, _ = limit_gauge(self.sys, bal.N, bal.cp, bal.wrench, xi)
        return later > gam

    def _jump(self, t, at, y):
        """Across a jump of the laws' velocities at t the momenta are kept (friction and
        gravity give no impulse): P and L about O's vertical before = after (the laws
        read just before and just after)."""
        sys = self.sys
        eps = 1e-13 * max(1.0, abs(at))

        def momenta(tt, v, w):
            P = sys.M * np.array([v[0], v[1], 0.0])
            Lz = sys.J[2] * w
            for p in sys.points:
                rho, rd, _ = (np.asarray(x, dtype=float) for x in p.law(tt))
                vel = np.array([v[0], v[1], 0.0]) + _skew_z(w, rho) + rd
                P += p.mass * vel
                Lz += p.mass * (rho[0] * vel[1] - rho[1] * vel[0])
            for r in sys.rotors:
                Lz += r.inertia * r.law(tt)[0] * r.axis[2]
            return np.array([P[0], P[1], Lz])
        tw = self.twist(y)
        before = momenta(t - eps, tw[:2], tw[2])
        after0 = momenta(t + eps, np.zeros(2), 0.0)
        cols = np.column_stack([momenta(t + eps, e[:2], e[2]) - after0 for e in np.eye(3)])
        new = np.linalg.solve(cols, before - after0)
        y = y.copy()
        y[3:5] = _turn(y[2]) @ new[:2]
        y[5] = new[2]
        return y

    def _past_at_start(self, bal) -> str | None:
        """The end a stick or a slip is past where it starts (its events find crossings
        only): N at most 0, or the centre of pressure of its own reaction on or past the
        edge or the kern (a reversal's new slip jumps there at once)."""
        sys = self.sys
        if bal.N <= 0:
            return "lift_off"
        for name, margin in (("tipping", sys.face.edge_margin),
                             ("face_lifting", sys.face.kern_margin)):
            if (name == "tipping" or sys.pressure == "linear") and \
                    _margin(sys.face, bal, margin) <= 0:
                return _tie(sys, name, bal.N)
        return None

    def _stick(self, t, y, stop, xi_guess):
        sys = self.sys
        memo = {"xi": xi_guess}
        past = self._past_at_start(balance_stick(sys, t))
        if past:
            return t, y, past, xi_guess

        def gauge_event(tt, _):
            bal = balance_stick(sys, tt)
            gam, memo["xi"] = limit_gauge(sys, bal.N, bal.cp, bal.wrench, memo["xi"])
            return 1.0 - gam
        evs = self._end_events(lambda tt: balance_stick(sys, tt))
        gauge_event.terminal, gauge_event.direction = True, -1
        span = stop - t
        sol = solve_ivp(lambda tt, z: [0.0], (t, stop), [0.0], events=[gauge_event, *evs],
                        rtol=1e-13, atol=1e-15, max_step=span / 64 if span > 0 else np.inf)
        for k, name in enumerate(("breakaway", "lift_off", "tipping", "face_lifting")):
            if k < len(sol.t_events) and len(sol.t_events[k]):
                te = float(sol.t_events[k][0])
                if name == "breakaway":
                    bal = balance_stick(sys, te)
                    _, memo["xi"] = limit_gauge(sys, bal.N, bal.cp, bal.wrench, memo["xi"])
                return te, y, _tie(sys, name, balance_stick(sys, te).N), memo["xi"]
        return stop, y, "mark", memo["xi"]

    def _end_events(self, balance_at):
        sys = self.sys

        def lift(tt, *_):
            return balance_at(tt).N
        lift.terminal, lift.direction = True, -1

        def tip(tt, *_):
            return _margin(sys.face, balance_at(tt), sys.face.edge_margin)
        tip.terminal, tip.direction = True, -1
        evs = [lift, tip]
        if sys.pressure == "linear":
            def kern(tt, *_):
                return _margin(sys.face, balance_at(tt), sys.face.kern_margin)
            kern.terminal, kern.direction = True, -1
            evs.append(kern)
        return evs

    def _slip(self, t, y, stop):
        """Slip in the time s, dt/ds = rho = |xi|: z = (t, y)."""
        ell, eps = self.ell, self.eps

        def rho_of(z):
            return np.linalg.norm(self.twist(z[1:]) * np.array([1.0, 1.0, ell]))

        def f(s, z):
            dy, _ = self.rates(z[0], z[1:])
            return rho_of(z) * np.concatenate([[1.0], dy])

        def slow(s, z):
            return rho_of(z) - eps
        slow.terminal, slow.direction = True, -1

        def until(s, z):
            return z[0] - stop
        until.terminal, until.direction = True, 1

        def bal_of(z):
            return self.rates(z[0], z[1:])[1]
        ends = self._end_events(lambda *_: None)
        evs = []
        for ev in ends:
            name = ev.__name__

            def wrapped(s, z, name=name):
                b = bal_of(z)
                if name == "lift":
                    return b.N
                if name == "tip":
                    return _margin(self.sys.face, b, self.sys.face.edge_margin)
                return _margin(self.sys.face, b, self.sys.face.kern_margin)
            wrapped.terminal, wrapped.direction = True, -1
            evs.append(wrapped)
        z0 = np.concatenate([[t], y])
        past = self._past_at_start(bal_of(z0))
        if past:
            return t, y, past
        s_span = 1e30
        sol = solve_ivp(f, (0.0, s_span), z0, method="DOP853", events=[slow, until, *evs],
                        rtol=self.rtol, atol=self.atol)
        names = ("stop", "mark", "lift_off", "tipping", "face_lifting")
        for k, name in enumerate(names):
            if k < len(sol.t_events) and len(sol.t_events[k]):
                z = sol.y_events[k][0]
                if name == "stop":
                    # carry the linear decay to 0: rho(t) ~ rho + rho' dt
                    dy, _ = self.rates(z[0], z[1:])
                    xi = self.twist(z[1:]) * np.array([1.0, 1.0, ell])
                    acc = _turn(z[3]).T @ dy[3:5]
                    xid = np.array([acc[0], acc[1], ell * dy[5]])
                    rate = xi @ xid / np.linalg.norm(xi)
                    self.approach = xi / np.linalg.norm(xi)
                    dt = -np.linalg.norm(xi) / rate if rate < 0 else 0.0
                    yy = z[1:].copy()
                    yy[0:3] += 0.5 * dt * yy[3:6]
                    yy[3:6] = 0.0
                    return z[0] + dt, yy, "stop"
                if name == "mark":
                    return stop, z[1:], "mark"
                return z[0], z[1:], _tie(self.sys, name, bal_of(z).N)
        raise RuntimeError(f"slip integration ended without an event: {sol.message}")
