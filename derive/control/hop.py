"""Per-hop feedback on the impact-to-impact (Poincare) map of a periodic hop, and the
mirror law it is compared with.

The hop is that of the paper's reference [5] (:mod:`derive.stability.bouncing`): a
symmetric carrier whose point moves on its axis as the gait z = a sin(W t), the axis
vertical, bounces like a ball on a table moving as nu a sin(W t).  The controller acts
once per hop, right after each impact: it reads the impact's time and C's upward
velocity and sets the gait of the coming hop, ``a_k = a* + delta_k``, blended in from
the law in use over half a period (a smoothstep, so x and x' go on continuously and only
x'' jumps at the impact).  ``delta_k = -K s_k`` with ``s_k`` the deviation of (the
impact's phase, Z_C' after it, the gait of the hop before) from the orbit's, and K a
discrete LQR gain (or deadbeat) of the linearised map

    s_k+1 = A s_k + B delta_k.

A, the open-loop part, is the impact-to-impact Jacobian built from the variational
equations of the flight (:class:`derive.stability.variational.Monodromy`) and the
saltation matrix of the impact (:func:`derive.stability.bouncing.saltation`); B and the
gait's own column come from finite differences of re-simulated hops (the law enters the
flight through u(t), which the variational model does not differentiate).  The tests
check A against finite differences of the hybrid runtime, the vertical multipliers
against the table's closed form, and the closed loop's per-hop convergence against the
eigenvalues of A - B K.

The mirror law (Buehler and Koditschek's juggler) acts at every sample instead: the
"table" nu z mirrors the "ball" Z_C - R about its rest height, b = -kappa(E) y, with
kappa growing with the ball's energy deficit, E = y'^2/2 + g y.
"""
from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from .. import layout, shapes
from ..runtime.driver import options, prepare
from ..runtime.session import Session
from ..runtime.loop import STOP, CController, Loop, Segments, hermite
from ..scene import Scene, SceneError
from ..stability import bouncing

KNOTS_PER_PERIOD = 32     # the gait sampled by cubic Hermite pieces
BLEND = 0.5               # the new gait blends in over this many periods after an impact
SPAN = 3.0                # periods of law set at each impact (the next impact is in one)


@dataclass(frozen=True)
class Gait:
    """z = a sin(W t) on the symmetry axis (x = y = 0)."""
    a: float
    W: float

    def jet(self, t):
        """z, z', z'' at t (sine and cosine by the C library, as crt_hop.c has them: the
        Python and the C controllers write the same law to the last bit)."""
        wt = self.W * np.asarray(t, dtype=float)
        s = np.array([math.sin(x) for x in np.ravel(wt)]).reshape(np.shape(wt))
        c = np.array([math.cos(x) for x in np.ravel(wt)]).reshape(np.shape(wt))
        return self.a * s, self.a * self.W * c, -self.a * self.W ** 2 * s

    @property
    def period(self) -> float:
        return 2 * math.pi / self.W


def _smoothstep(x):
    """sigma(x): 0 with zero slope at 0, 1 with zero slope from 1 on (3 x^2 - 2 x^3)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x)


def blend_law(t0: float, u0, old: Gait, new: Gait, period: float) -> Segments:
    """The law from t0: the old gait, corrected to the law's value and rate at t0 (u0:
    x, y, z, x', y', z', ...), blended into the new gait over BLEND periods by a
    smoothstep; cubic Hermite pieces KNOTS_PER_PERIOD per period over SPAN periods.  Its
    value and rate at t0 are u0's exactly (so the runtime takes it as continuous)."""
    h = period / KNOTS_PER_PERIOD
    n = int(round(SPAN * KNOTS_PER_PERIOD))
    t = t0 + h * np.arange(n + 1)
    zo0, vo0, _ = old.jet(t0)
    dz, dv = u0[2] - zo0, u0[5] - vo0            # the law in use against the old gait
    zo, vo, _ = old.jet(t)
    zo, vo = zo + dz + dv * (t - t0), vo + dv
    zn, vn, _ = new.jet(t)
    tb = BLEND * period
    s, ds = _smoothstep((t - t0) / tb)
    z = zo + s * (zn - zo)
    v = vo + s * (vn - vo) + ds / tb * (zn - zo)
    z[0], v[0] = u0[2], u0[5]
    xyz = np.zeros((n + 1, 3))
    vxyz = np.zeros((n + 1, 3))
    xyz[:, 2], vxyz[:, 2] = z, v
    xyz[0, :2], vxyz[0, :2] = u0[0:2], u0[3:5]
    coef = np.stack([hermite(t[i], xyz[i], vxyz[i], t[i + 1], xyz[i + 1], vxyz[i + 1])
                     for i in range(n)])
    return Segments(t, coef)


# ---- the hop map: one hop of the hybrid runtime under a gait change ---------------------------
class HopMap:
    """Hops of a reference-[5] scene through the compiled runtime: from a post-impact
    state at time t under the gait ``old``, the new gait blended in, to the next impact."""

    def __init__(self, scene: Scene):
        self.params = bouncing.reference5(scene)
        self.gait = Gait(self.params["a"], self.params["W"])
        self.prep = prepare(replace(scene, model="vertical", outputs=("impacts",)))
        self.scene = self.prep.scene
        self.session = Session(self.prep.library, chunk=4096)
        self.session.set_law(self.scene.law)
        self.V = layout.VERTICAL

    def hop(self, t0: float, q0, old: Gait, new: Gait):
        """(t1, q1): the next impact's time and post-impact state, or None.  The run
        starts on the old gait (its law, so that the first call's u is the old gait's),
        and the new gait blends in."""
        T = new.period
        seen = {}

        def controller(call):
            if call.reason == "start":
                return blend_law(call.t, call.u, old, new, T)
            if call.reason == "event" and call.event == "impact":
                seen["t"] = call.t
                return STOP
            return None
        sc = replace(self.scene, t0=float(t0), duration=float(2.0 * T))
        self.session.set_law(self.law_of(old))
        raw = self.session.run(sc.t0, sc.duration, np.asarray(q0, dtype=float),
                               options(sc, "vertical"), self.prep.parameters, loop=Loop(controller))
        if "t" not in seen:
            return None
        return seen["t"], raw.q[-1]

    def law_of(self, gait: Gait):
        """The gait as a law program (cached by its text)."""
        from ..scene.law import compile_law
        return compile_law(("0", "0", f"{float(gait.a)!r}*sin({float(gait.W)!r}*t)"))


def _section(hm: HopMap, t: float, q) -> np.ndarray:
    """Section coordinates of a post-impact state: (t, Z_C', omega, n_x, n_y)."""
    V = hm.V
    return np.r_[t, q[V.Zd], q[V.omega], q[V.n][:2]]


def _state(hm: HopMap, x, gait: Gait | None = None) -> np.ndarray:
    """A post-impact state on the plane from section coordinates: Z_C from h = 0 with the
    point where the gait in use puts it at that time."""
    sc = replace(hm.scene, law=hm.law_of(gait or hm.gait))
    return bouncing._unpack(x[1:], x[0], _Hybrid(hm, sc))


class _Hybrid:
    """What bouncing's helpers read of a hybrid map: the scene (its law the gait's)."""

    def __init__(self, hm: HopMap, scene: Scene | None = None):
        self.scene = scene or hm.scene


# ---- the linearised map --------------------------------------------------------------------
@dataclass
class Orbit:
    """A periodic hop under the gait: the impact's time (mod the period) and section
    coordinates (t, Z_C', omega, n_x, n_y) just after it."""
    gait: Gait
    x: np.ndarray
    residual: float

    @property
    def t(self) -> float:
        return float(self.x[0])

    @property
    def v(self) -> float:
        return float(self.x[1])


def hop_section(hm: HopMap, x, old: Gait, new: Gait) -> np.ndarray | None:
    """The map in section coordinates, the next impact's time taken back one period."""
    out = hm.hop(x[0], _state(hm, x, old), old, new)
    if out is None:
        return None
    t1, q1 = out
    return _section(hm, t1 - new.period, q1)


def find_orbit(hm: HopMap, gait: Gait, guess=None, tol: float = 1e-12,
               max_iter: int = 12) -> Orbit:
    """Newton on the hop map of a constant gait, from the table's orbit (or ``guess``)."""
    if guess is None:
        x = bouncing.table_guess(_with_gait(hm.scene, gait), 1)
    else:
        x = np.array(guess, dtype=float)
    residual = math.inf
    for _ in range(max_iter):
        F = hop_section(hm, x, gait, gait) - x
        residual = float(np.max(np.abs(F)))
        if residual < tol:
            break
        J = _fd(lambda y: hop_section(hm, y, gait, gait) - y, x)
        x = x + np.linalg.lstsq(J, -F, rcond=None)[0]
    return Orbit(gait, x, residual)


def _with_gait(scene: Scene, gait: Gait) -> Scene:
    from ..scene.law import compile_law
    law = compile_law(("0", "0", f"{float(gait.a)!r}*sin({float(gait.W)!r}*t)"))
    return replace(scene, law=law, law_text=law.text)



def _fd(fn, x, rel: float = 1e-7) -> np.ndarray:
    """Central differences of fn at x, a column per entry."""
    cols = []
    for k in range(len(x)):
        dx = np.zeros(len(x))
        dx[k] = rel * max(1.0, abs(x[k]))
        cols.append((fn(x + dx) - fn(x - dx)) / (2 * dx[k]))
    return np.column_stack(cols)


def jacobian_fd(hm: HopMap, orbit: Orbit) -> np.ndarray:
    """d(next section)/d(section, a of the hop before, a of the coming hop) by central
    differences of re-simulated hops (7 x 9)."""
    g, x = orbit.gait, orbit.x

    def fn(y):
        old, new = Gait(y[7], g.W), Gait(y[8], g.W)
        return hop_section(hm, y[:7], old, new)
    return _fd(fn, np.r_[x, g.a, g.a])


def jacobian_variational(hm: HopMap, orbit: Orbit) -> np.ndarray:
    """d(next section)/d(section) of the gait's orbit from the variational equations of
    the flight and the saltation matrix of the impact (7 x 7):

        dq(t1-) = Phi (dq0 - f(t0, q0) dt0),   dt1 = -grad h . dq(t1-) / (grad h . f- + h_t),
        dq1+ = S dq(t1-) + f+ dt1,

    the deviations of the state compared at the orbit's impact time t1 (Phi from
    derive.stability.variational, S from derive.stability.bouncing.saltation)."""
    from ..stability.variational import Monodromy
    g = orbit.gait
    sc = _with_gait(hm.scene, g)
    hybrid = _Hybrid(hm, sc)
    t0, x0 = orbit.t, orbit.x
    q0 = _state(hm, x0, g)
    T = g.period
    D = _fd(lambda y: _state(hm, y, g), x0, rel=1e-8)           # d q0 / d x0 (8 x 7)
    f0 = bouncing._evaluate(hybrid, t0, q0)["f"]
    q_minus, Phi = Monodromy(sc).flow(t0, q0, T)
    t1 = t0 + T
    at = bouncing._evaluate(hybrid, t1, q_minus)
    grad_h, h_t = at["h_q"], at["h_t"]
    S = bouncing.saltation(hybrid, t1, q_minus)
    f_plus = bouncing._evaluate(hybrid, t1, at["q_plus"])["f"]
    dq0 = D.copy()
    dq0[:, 0] -= f0                                             # dt0 shifts the start
    dq_minus = Phi @ dq0
    dt1 = -(grad_h @ dq_minus) / float(grad_h @ at["f"] + h_t)
    dq_plus = S @ dq_minus + np.outer(f_plus, dt1)
    V = hm.V
    return np.vstack([dt1, dq_plus[V.Zd], dq_plus[V.omega], dq_plus[V.n][:2]])


# ---- the gain --------------------------------------------------------------------------------
@dataclass
class Design:
    """A per-hop controller's design: the orbit, the linearised map of s = (dt, dv, da of
    the hop before) with the input da of the coming hop, the gain and what it predicts."""
    orbit: Orbit
    A: np.ndarray                 # 3 x 3
    B: np.ndarray                 # 3 x 1
    K: np.ndarray                 # 1 x 3
    gain: str
    jacobian_variational: np.ndarray = field(repr=False)
    jacobian_fd: np.ndarray = field(repr=False)

    @property
    def open_loop(self) -> np.ndarray:
        """The multipliers of the hop's vertical block (the gait held)."""
        return np.linalg.eigvals(self.A[:2, :2])

    @property
    def closed_loop(self) -> np.ndarray:
        return np.linalg.eigvals(self.A - self.B @ self.K)


def _weights(orbit: Orbit, state_weight: float, input_weight: float):
    """The LQR's weights on deviations scaled to the orbit: the phase in radians of the
    gait, the velocity relative to the orbit's, the correction relative to a."""
    W, v, a = orbit.gait.W, orbit.v, orbit.gait.a
    Q = state_weight * np.diag([W * W, 1.0 / (v * v), 1.0 / (a * a)])
    R = np.array([[input_weight / (a * a)]])
    return Q, R


def design(hm: HopMap, gait: Gait, gain: str = "lqr", state_weight: float = 1.0,
           input_weight: float = 1.0, orbit: Orbit | None = None) -> Design:
    """Find the gait's orbit, linearise its hop map (A's vertical block from the
    variational equations and the saltation matrix, the gait's columns by finite
    differences of re-simulated hops) and compute the gain."""
    from scipy.linalg import solve_discrete_are
    orbit = orbit or find_orbit(hm, gait)
    Jv = jacobian_variational(hm, orbit)
    Jf = jacobian_fd(hm, orbit)
    A = np.zeros((3, 3))
    A[:2, :2] = Jv[:2, :2]
    A[:2, 2] = Jf[:2, 7]                      # the gait of the hop before (its blend)
    B = np.zeros((3, 1))
    B[:2, 0] = Jf[:2, 8]
    B[2, 0] = 1.0
    if gain == "deadbeat":
        C = np.column_stack([B, A @ B, A @ A @ B])
        if abs(np.linalg.det(C)) < 1e-12 * np.linalg.norm(C) ** 3:
            raise SceneError("[control].gain", "deadbeat needs a controllable hop map")
        K = np.array([[0.0, 0.0, 1.0]]) @ np.linalg.inv(C) @ np.linalg.matrix_power(A, 3)
    else:
        Q, R = _weights(orbit, state_weight, input_weight)
        P = solve_discrete_are(A, B, Q, R)
        K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    return Design(orbit, A, B, K, gain, Jv, Jf)


# ---- the controller ---------------------------------------------------------------------------
class HopController:
    """Per-hop feedback: after each impact, the coming hop's gait amplitude
    a* - K s (clamped to ``limit`` of a*), blended in from the law in use; the gait of
    the design at the start.  ``layout``: the plant model's state layout (vertical, or
    general when pushes need it)."""

    def __init__(self, design: Design, layout_: layout.Layout = layout.VERTICAL,
                 limit: float = 0.5):
        self.design, self.layout, self.limit = design, layout_, limit
        self.gait = design.orbit.gait
        self.a_prev = self.gait.a
        self.law_end = -np.inf             # the end of the law it set last
        self.history: list = []            # (t, s, delta) of every impact

    def deviation(self, t: float, q) -> np.ndarray:
        g, orbit = self.gait, self.design.orbit
        T = g.period
        dt = (t - orbit.t + 0.5 * T) % T - 0.5 * T
        return np.array([dt, q[self.layout.Zd] - orbit.v, self.a_prev - g.a])

    def __call__(self, call):
        law = self._decide(call)
        if law is not None:
            self.law_end = float(law.knots[-1])
        return law

    def _decide(self, call):
        g = self.gait
        if call.reason == "start":
            self.a_prev = g.a
            return blend_law(call.t, call.u, g, g, g.period)
        if call.reason != "event" or call.event != "impact":
            # no impact for a while (resting contact, a long flight): within a period of
            # the law's end the gait goes on from the law in use (beyond its last knot the
            # last cubic would go on, unbounded)
            if call.t < self.law_end - g.period:
                return None
            held = Gait(self.a_prev, g.W)
            return blend_law(call.t, call.u, held, held, g.period)
        s = self.deviation(call.t, call.q)
        delta = float(-(self.design.K @ s)[0])
        delta = max(-self.limit * g.a, min(self.limit * g.a, delta))
        old, new = Gait(self.a_prev, g.W), Gait(g.a + delta, g.W)
        self.history.append((call.t, s, delta))
        self.a_prev = new.a
        return blend_law(call.t, call.u, old, new, g.period)


class OpenLoopGait:
    """The same law machinery with the gait held: the open loop the feedback is compared
    with (the plant runs the same sampled gait)."""

    def __init__(self, gait: Gait):
        self.gait = gait

    def __call__(self, call):
        if call.reason == "start":
            return blend_law(call.t, call.u, self.gait, self.gait, self.gait.period)
        if call.reason == "event" and call.event == "impact":
            return blend_law(call.t, call.u, self.gait, self.gait, self.gait.period)
        return None


# ---- the mirror law -------------------------------------------------------------------------
class MirrorLaw:
    """Buehler and Koditschek's mirror law for the reference-[5] hop: every ``period``,
    the table b = nu z is steered towards -kappa(E) y of the ball y = Z_C - R (C over
    the table's rest height), predicted on its parabola one period ahead, kappa =
    kappa0 + kappa1 (E* - E), E = y'^2/2 + g y, E* = g apex; a cubic from the law's value
    and rate now to the target's at the next sample."""

    def __init__(self, scene: Scene, apex: float, period: float = 0.002,
                 kappa0: float | None = None, kappa1: float = 0.5,
                 layout_: layout.Layout = layout.VERTICAL, z_limit: float | None = None):
        # kappa0 = (1 - e)/(1 + e): at the target energy the table's mirrored motion gives
        # back what the impact takes (Buehler and Koditschek's choice for restitution e)
        if kappa0 is None:
            kappa0 = (1.0 - scene.e) / (1.0 + scene.e)
        self.nu = scene.m / (scene.m + scene.M)
        self.R = -shapes.of(scene.shape).lowest((0.0, 0.0, 1.0), scene.center,
                                                scene.size)[2]   # O above S, axis vertical
        self.g, self.period = scene.g, period
        self.E_star = scene.g * apex
        self.kappa0, self.kappa1, self.layout = kappa0, kappa1, layout_
        self.z_limit = z_limit if z_limit is not None else 0.5 * scene.max_distance

    def target(self, y: float, yd: float) -> tuple:
        E = 0.5 * yd * yd + self.g * y
        kappa = self.kappa0 + self.kappa1 * (self.E_star - E) / max(self.E_star, 1e-12)
        kappa = min(max(kappa, 0.0), 1.0)
        z, zd = -kappa * y / self.nu, -kappa * yd / self.nu
        if abs(z) > self.z_limit:
            z, zd = math.copysign(self.z_limit, z), 0.0
        return z, zd

    def __call__(self, call):
        q, L = call.q, self.layout
        h = self.period
        y, yd = q[L.Z] - self.R, q[L.Zd]
        y1, yd1 = y + yd * h - 0.5 * self.g * h * h, yd - self.g * h   # C's parabola
        z1, zd1 = self.target(y1, yd1)
        u = call.u
        x0, v0 = u[0:3], u[3:6]
        x1, v1 = np.array([0.0, 0.0, z1]), np.array([0.0, 0.0, zd1])
        coef = hermite(call.t, x0, v0, call.t + h, x1, v1)
        return Segments(np.array([call.t, call.t + h]), coef[None])


# ---- steering the apex -----------------------------------------------------------------------
def orbit_apex(hm: HopMap, orbit: Orbit) -> float:
    """The highest Z_C of a hop of the orbit above C's rest height (P at O on the plane:
    Z_C = R for the sphere centred on its axis)."""
    g = hm.scene.g
    nu = hm.scene.m / (hm.scene.m + hm.scene.M)
    z_impact = orbit.gait.jet(orbit.t)[0]
    return orbit.v ** 2 / (2 * g) + nu * z_impact


def gait_for_apex(hm: HopMap, apex: float, tol: float = 1e-10) -> tuple:
    """The gait whose period-1 orbit rises to ``apex``: the frequency W found by the
    secant method, the amplitude scaled with it to keep Gamma = nu a W^2 / g (so the
    orbit stays as far beyond its thresholds); (gait, orbit)."""
    g0 = hm.gait
    Gamma_a = g0.a * g0.W ** 2

    def at(W):
        gait = Gait(Gamma_a / (W * W), W)
        orbit = find_orbit(hm, gait)
        return orbit_apex(hm, orbit) - apex, gait, orbit
    # the table's estimate: v = pi g / W, apex ~ v^2 / (2 g)
    W1 = math.pi * hm.scene.g / math.sqrt(2 * hm.scene.g * apex)
    W0 = g0.W
    f0, *_ = at(W0)
    f1, gait, orbit = at(W1)
    for _ in range(30):
        if abs(f1) < tol or f1 == f0:
            break
        W0, W1, f0 = W1, W1 - f1 * (W1 - W0) / (f1 - f0), f1
        f1, gait, orbit = at(W1)
    if abs(f1) > 1e-6 * max(apex, 1e-3):
        raise SceneError("[control].apex_height", f"no period-1 hop of this body rises to "
                                                  f"{apex:g} (closest {apex + f1:g})")
    return gait, orbit


# ---- the same controller in C ------------------------------------------------------------------
class _HopParams(ctypes.Structure):
    """``crt_hop_params`` (generated/control/crt_hop.h)."""
    _fields_ = [("K", ctypes.c_double * 3), ("t_star", ctypes.c_double),
                ("v_star", ctypes.c_double), ("a_star", ctypes.c_double),
                ("W", ctypes.c_double), ("T", ctypes.c_double), ("tb", ctypes.c_double),
                ("h", ctypes.c_double), ("limit", ctypes.c_double), ("n", ctypes.c_int),
                ("zd", ctypes.c_int), ("a_prev", ctypes.c_double),
                ("law_end", ctypes.c_double)]


@lru_cache(maxsize=1)
def _hop_library():
    """crt_hop.c compiled with the runtime's flags (once per machine, cached)."""
    from ..cbuild import build_shared, runtime_flags
    from ..paths import c_sources
    from ..runtime.build import runtime_dir
    folder = c_sources("control")
    sources = {name: (folder / name).read_bytes() for name in ("crt_hop.c", "crt_hop.h")}
    sources["crt_call.h"] = (runtime_dir() / "crt_call.h").read_bytes()
    # no contraction into fused multiply-adds: the C rounds as NumPy does, so the two
    # routes write the same law (tests/test_hop_control.py compares them)
    flags = tuple(f for f in runtime_flags() if not f.startswith("-ffp-contract"))
    lib = ctypes.CDLL(str(build_shared(sources, flags=flags + ("-ffp-contract=off",),
                                       name="crt_hop")))
    lib.crt_hop_sizeof.restype = ctypes.c_int
    if lib.crt_hop_sizeof() != ctypes.sizeof(_HopParams):
        raise RuntimeError("crt_hop.c's crt_hop_params differs from derive.control.hop's")
    return lib


def c_controller(design: Design, layout_: layout.Layout = layout.VERTICAL,
                 limit: float = 0.5) -> CController:
    """The per-hop feedback of ``design`` as the C controller crt_hop.c (called by the C
    runtime with no Python per call); its memory holds the design's numbers."""
    lib = _hop_library()
    g, orbit = design.orbit.gait, design.orbit
    T = g.period
    params = _HopParams((ctypes.c_double * 3)(*design.K.ravel()), orbit.t, orbit.v, g.a,
                        g.W, T, BLEND * T, T / KNOTS_PER_PERIOD, limit,
                        int(round(SPAN * KNOTS_PER_PERIOD)), layout_.Zd, g.a, -np.inf)
    address = ctypes.cast(lib.crt_hop_controller, ctypes.c_void_p).value
    return CController(address, params, keep=(lib,))
