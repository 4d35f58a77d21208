"""Periodic bouncing (the paper's reference [5]) and its multipliers.

A dynamically symmetric carrier (J_x = J_y) whose point moves harmonically along the
symmetry axis, z = a sin(W t), the axis vertical and the shape a sphere centred on it,
bounces on the plane with constant spin.  d = CS x n = 0 at the impacts, so the spin
stays and the vertical motion is the classical ball on a vibrating table: the height of S
is that of a ball over a table at s(t) = A sin(W t), A = nu a (nu = m/(m+M)).

**The table, derived here** (g, restitution e, T = 2 pi/W, Gamma = A W^2/g).  A
symmetric orbit with one impact every n periods leaves the table with v = g n T/2 and
meets it at the same phase phi; Newton's law with the table's velocity u = A W cos(phi)
gives (1 - e) v = (1 + e) u, so

    cos(phi) = Gamma_n / Gamma,   Gamma_n = (1 - e) n pi / (1 + e)      (existence)

Linearising the impact-to-impact map (t_k, v_k) -> (t_k+1, v_k+1) at the orbit
(flight time from s(t) + v tau - g tau^2/2 = s(t + tau)) gives

    DP = [[1, kappa], [sigma, sigma kappa - e + 2 e v/(v + u)]],
    kappa = n T/(v + u),  sigma = -(1 + e) A W^2 sin(phi),
    det DP = e^2,  tr DP = 1 + e^2 - (1 + e)^2 Gamma sin(phi),

so the branch sin(phi) > 0 is born at Gamma_n (tr = 1 + det) and doubles its period at
tr = -(1 + det), i.e.

    Gamma_pd = sqrt(Gamma_n^2 + (2 (1 + e^2)/(1 + e)^2)^2).

**The carrier.** Its periodic orbits are found as fixed points of the impact-to-impact
map computed by the runtime (Newton with a finite-difference Jacobian on the phase, Z_C',
omega and the tilt), and their multipliers as the eigenvalues of the monodromy
``Phi_2 S Phi_1`` from mid-flight to mid-flight: the flights' variational equations
integrated by the runtime, and the saltation matrix of the impact

    S = Dg + (f+ - Dg f- - g_t) grad(h)^T / (grad(h) . f- + h_t)

from CasADi's derivatives of the emitted gap and impact functions.  Tilt modes (omega_x,
omega_y and the tilt of the axis) are included; the vertical block must reproduce DP's
eigenvalues, which the tests check, as they check the monodromy against finite
differences of the full hybrid runtime.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

import casadi as ca
import numpy as np
import sympy as sp

from .. import layout, shapes
from .. import notation as nt
from ..runtime.driver import prepare
from ..runtime.session import Session
from ..scene import Scene, SceneError, load_scene
from .floquet import UNIT_TOL, complex_pairs, growth, runs_verdict
from .variational import Monodromy

V = layout.VERTICAL


# ---- the ball on a vibrating table, in closed form -------------------------------------
def existence_threshold(e: float, n: int = 1) -> float:
    return (1 - e) * n * math.pi / (1 + e)


def period_doubling_threshold(e: float, n: int = 1) -> float:
    return math.hypot(existence_threshold(e, n), 2 * (1 + e * e) / (1 + e) ** 2)


def table_orbit(e: float, n: int, Gamma: float) -> dict:
    """The symmetric n-orbit's phase (sin(phi) > 0 branch) and the eigenvalues of DP."""
    c = existence_threshold(e, n) / Gamma
    if c > 1:
        raise ValueError(f"no period-{n} orbit: Gamma = {Gamma:.6g} is below the "
                         f"existence threshold {existence_threshold(e, n):.6g}")
    phi = math.acos(c)
    tr = 1 + e * e - (1 + e) ** 2 * Gamma * math.sin(phi)
    det = e * e
    rho = np.roots([1.0, -tr, det])
    return {"phi": phi, "trace": tr, "det": det, "multipliers": rho}


# ---- the carrier --------------------------------------------------------------------------
def bouncing_scene(e: float = 0.5, a: float = 0.1, W: float = 30.0, spin: float = 3.0,
                   inertia=(0.1, 0.1, 0.15), M: float = 1.0, m: float = 0.25,
                   radius: float = 0.5, n: int = 1, g: float = 9.81) -> dict:
    """The reference-[5] scene, started on the analytic symmetric orbit just after an
    impact (the axis vertical, spinning)."""
    nu = m / (m + M)
    Gamma = nu * a * W * W / g
    orbit = table_orbit(e, n, Gamma)
    phi = orbit["phi"]
    t0 = phi / W
    T = 2 * math.pi / W
    v = g * n * T / 2
    return {"name": f"bouncing n={n}",
            "body": {"mass": M, "inertia": list(inertia), "shape": "sphere",
                     "radius": radius},
            "point": {"mass": m, "law": ["0", "0", f"{a}*sin({W}*t)"]},
            "plane": {"restitution": e},
            "initial": {"time": t0, "com": [0.0, 0.0, radius + nu * a * math.sin(phi)],
                        "com_velocity": [0.0, 0.0, v], "omega": [0.0, 0.0, spin],
                        "quaternion": [1.0, 0.0, 0.0, 0.0]},
            "run": {"duration": n * T, "method": "lie", "rtol": 1e-12, "atol": 1e-14,
                    "g": g, "outputs": ["omega", "height", "impacts"], "model": "vertical"}}


@dataclass
class Bounce:
    scene: Scene
    n: int
    period: float                 # n T
    t_impact: float               # the phase of the impact (time)
    post_impact: np.ndarray       # vertical-layout state just after the impact
    newton_residual: float
    multipliers: np.ndarray
    monodromy: np.ndarray
    fd_difference: float
    vertical_multipliers: np.ndarray
    analytic: dict
    t_mid: float = 0.0            # mid-flight, where the monodromy and long runs start
    mid_state: np.ndarray | None = None
    long_runs: list = field(default_factory=list)

    @property
    def other_multipliers(self) -> np.ndarray:
        """The spin and tilt modes: the block of omega and n (decoupled from the
        vertical block at the symmetric orbit)."""
        return np.linalg.eigvals(self.monodromy[2:, 2:])

    def checks(self) -> dict:
        """Each check's discrepancy, its bound and whether it holds."""
        a = np.sort_complex(self.vertical_multipliers)
        b = np.sort_complex(np.asarray(self.analytic["multipliers"], dtype=complex))
        scale = max(1.0, float(np.max(np.abs(self.monodromy))))
        rows = {"newton_residual": (self.newton_residual, 1e-9),
                "finite_difference": (self.fd_difference, 1e-5 * scale),
                "vertical_vs_table": (float(np.max(np.abs(a - b))), 1e-6)}
        return {k: {"value": v, "bound": bound, "ok": bool(v <= bound)}
                for k, (v, bound) in rows.items()}

    def as_dict(self) -> dict:
        return {"kind": "periodic bouncing", "n": self.n, "period": self.period,
                "t_impact": self.t_impact, "post_impact_state": self.post_impact.tolist(),
                "multipliers": complex_pairs(self.multipliers),
                "moduli": [float(abs(r)) for r in self.multipliers],
                "vertical_multipliers": complex_pairs(self.vertical_multipliers),
                "analytic_table_multipliers": complex_pairs(self.analytic["multipliers"]),
                "spin_and_tilt_multipliers": complex_pairs(self.other_multipliers),
                "checks": self.checks(), "verdict": self.verdict(),
                "long_runs": self.long_runs}

    @property
    def unstable(self) -> bool:
        """Some multiplier outside the unit circle (the verdict's test)."""
        return float(np.max(np.abs(self.multipliers))) > 1 + UNIT_TOL

    def verdict(self, tol: float = UNIT_TOL) -> str:
        vert = float(np.max(np.abs(self.vertical_multipliers)))
        other = float(np.max(np.abs(self.other_multipliers)))
        if max(vert, other) > 1 + tol:
            which = " and ".join(name for name, v in (("vertical", vert), ("tilt", other))
                                 if v > 1 + tol)
            return f"unstable ({which} modes: max |rho| = {max(vert, other):.6f})"
        if vert < 1 - tol:
            text = (f"linearly stable: vertical modes decay (|rho| <= {vert:.6f}), spin "
                    f"and tilt modes on the unit circle (max |rho| = {other:.6f}: neutral)")
        else:
            text = f"critical (max |rho| = {max(vert, other):.6f})"
        if self.long_runs:
            text += "; perturbed runs: " + "; ".join(
                f"deviations in {label} {runs_verdict(self.long_runs, sfx)}"
                for label, sfx in (("(omega, n)", ""), ("omega", "_omega")))
        return text


class HybridMap:
    """Runs of the full hybrid model (vertical layout) through the compiled runtime, with
    the momentum form in flight (method ``lie``: K and the parabola of C constant between
    impacts, updated by the impact map)."""

    def __init__(self, scene):
        scene = load_scene(scene)
        if scene.rough:
            from ..runtime.choice import candidates
            kind = candidates(scene)[0][0]
            raise SceneError("[plane].friction", "derive stability answers a scene on the "
                                                 "plane as the periodic bouncing of reference "
                                                 "[5], on a smooth plane (friction = 0), or "
                                                 "one in free flight (no [plane]); this scene's "
                                                 f"plane has friction {scene.friction:g} "
                                                 f"(model {kind}): derive simulate runs it")
        if scene.model not in ("auto", "vertical"):
            raise SceneError("[run].model", "periodic bouncing runs the vertical model: "
                                            f"remove it or set it to \"vertical\" (got "
                                            f"{scene.model!r})")
        # the analysis reads impacts and states, never the pose: the vertical model
        # answers whatever outputs the scene asks of a run
        prep = prepare(replace(scene, model="vertical", outputs=("impacts",)))
        self.prep = prep
        self.scene = prep.scene
        self.session = Session(prep.library, chunk=4096)
        self.session.set_law(self.scene.law)

    def run(self, t0: float, q0, duration: float):
        sc = replace(self.scene, t0=float(t0), duration=float(duration))
        from ..runtime.driver import options
        return self.session.run(sc.t0, sc.duration, np.asarray(q0, dtype=float),
                                options(sc, "vertical"), self.prep.parameters)

    def to_next_impact(self, t0: float, q0, horizon: float):
        """Post-impact time and state of the first impact after t0 (None if none)."""
        raw = self.run(t0, q0, horizon)
        for i, k in enumerate(raw.kinds):
            if k == 2:                      # the row just after an event
                return raw.t[i], raw.q[i]
        return None

    def at(self, t0: float, q0, duration: float):
        raw = self.run(t0, q0, duration)
        if raw.status != "done":
            raise RuntimeError(f"hybrid run ended with {raw.status}")
        return raw.q[-1]


def _pack(q) -> np.ndarray:
    """Newton's unknowns: Z_C', omega, n_x, n_y (Z_C follows from h = 0, n_z from |n|)."""
    return np.r_[q[V.Zd], q[V.omega], q[V.n][:2]]


def _unpack(x, t, hybrid: HybridMap) -> np.ndarray:
    """A post-impact state on the plane: Z_C from the gap h = 0 at time t."""
    Zd, omega, n_xy = x[0], x[1:4], x[4:6]
    nz = math.sqrt(max(1.0 - n_xy @ n_xy, 0.0))
    q = V.assemble(Z=0.0, Zd=Zd, omega=omega, n=np.r_[n_xy, nz])
    # h is affine in Z_C with slope 1: one gap evaluation fixes it
    h0 = hybrid_gap(hybrid, t, q)
    q[V.Z] -= h0
    return q


@lru_cache(maxsize=None)
def _generic(shape: str) -> ca.Function:
    """The vertical model's gap, impact map and flight RHS as one CasADi function of
    (q, u, p, e, centre, size) with their Jacobians in q and u, built from the generated
    ``.casadi`` functions (the derivation, generic in every number) for the surface
    ``shape`` of derive/shapes.py."""
    from ..paths import GENERATED

    def load(name):
        return ca.Function.load(str(GENERATED / "casadi" / f"{name}.casadi"))
    gap, impact, rhs = load("vertical_gap"), load("vertical_impact"), load("vertical_flight_rhs")
    lowest = load(f"lowest_point_{shape}")
    q, u, p = ca.SX.sym("q", V.nq), ca.SX.sym("u", 9), ca.SX.sym("p", 6)
    e, c = ca.SX.sym("e"), ca.SX.sym("c", 3)
    ax = ca.SX.sym("size", shapes.of(shape).size_count)
    sv = lowest(q[V.n], c, ax)
    h = gap(q, u, sv, p)[0]
    q_plus = impact(q, u, sv, p, e)[0]
    f = rhs(q, u, p)
    outs = [h, ca.jacobian(h, q), ca.jacobian(h, u), q_plus, ca.jacobian(q_plus, q),
            ca.jacobian(q_plus, u), f]
    # the partial derivatives in t go through u(t); they must not need the law's third
    # derivative (u[6:9] are the accelerations): h and the impact map do not read them
    for k in (2, 5):
        if ca.depends_on(outs[k][:, 6:9], ca.vertcat(q, u)) or \
                not outs[k][:, 6:9].is_zero():
            raise AssertionError("the gap or the impact map reads the point's acceleration")
    return ca.Function("bounce", [q, u, p, e, c, ax], outs)


def _evaluate(hybrid: HybridMap, t: float, q) -> dict:
    """Gap, impact map, RHS and their derivatives in q and t at (t, q) for the scene."""
    sc = hybrid.scene
    u = sc.law.point(t)
    out = _generic(sc.shape)(np.asarray(q, dtype=float), u, np.array(sc.p), sc.e,
                             np.array(sc.center), np.array(sc.size))
    h, dh_q, dh_u, qp, dqp_q, dqp_u, f = (np.array(v.full()) for v in out)
    du_dt = np.r_[u[3:9], 0.0, 0.0, 0.0]        # (x', ..., z'', third derivatives unused)
    return {"h": float(h.ravel()[0]), "h_q": dh_q.ravel(), "h_t": float((dh_u @ du_dt).ravel()[0]),
            "q_plus": qp.ravel(), "g_q": dqp_q, "g_t": (dqp_u @ du_dt).ravel(),
            "f": f.ravel()}


def hybrid_gap(hybrid: HybridMap, t: float, q) -> float:
    return _evaluate(hybrid, t, q)["h"]


def impact_state(hybrid: HybridMap, t: float, q_minus) -> np.ndarray:
    return _evaluate(hybrid, t, q_minus)["q_plus"]


def saltation(hybrid: HybridMap, t: float, q_minus) -> np.ndarray:
    """S at an impact at (t, q-): Dg + (f+ - Dg f- - g_t) grad h^T / (grad h . f- + h_t)."""
    at = _evaluate(hybrid, t, q_minus)
    f_plus = _evaluate(hybrid, t, at["q_plus"])["f"]
    Dg, grad_h = at["g_q"], at["h_q"]
    denom = float(grad_h @ at["f"] + at["h_t"])
    return Dg + np.outer(f_plus - Dg @ at["f"] - at["g_t"], grad_h) / denom


def saltation_of_functions(fns: dict, t: float, q_minus) -> np.ndarray:
    """The same saltation matrix from CasADi functions of (t, q): ``fns["gap"]`` (h, v_n),
    ``fns["impact"]`` (q+, I) and ``fns["rhs"]`` (for a law given as such functions,
    e.g. the planner's B-spline)."""
    tt = ca.SX.sym("t")
    x = ca.SX.sym("x", len(q_minus))
    h = fns["gap"](tt, x)[0]
    g_plus = fns["impact"](tt, x)[0]
    d = ca.Function("d", [tt, x], [ca.jacobian(g_plus, x), ca.jacobian(g_plus, tt),
                                    ca.jacobian(h, x), ca.jacobian(h, tt), g_plus])
    Dg, g_t, grad_h, h_t, gp = (np.array(v.full()) for v in d(t, q_minus))
    f_minus = np.array(fns["rhs"](t, q_minus).full()).ravel()
    f_plus = np.array(fns["rhs"](t, gp.ravel()).full()).ravel()
    grad_h = grad_h.ravel()
    denom = float(grad_h @ f_minus + h_t.ravel()[0])
    return Dg + np.outer(f_plus - Dg @ f_minus - g_t.ravel(), grad_h) / denom


def _about_z(scene: Scene) -> bool:
    """The shape is symmetric about the body z axis: its support map turns with a turn
    about z (checked on directions that no shape of a lesser symmetry passes)."""
    shape = shapes.of(scene.shape)
    d = np.random.default_rng(0).normal(size=(16, 3))
    turn = np.array([[math.cos(0.7), -math.sin(0.7), 0.0], [math.sin(0.7), math.cos(0.7), 0.0],
                     [0.0, 0.0, 1.0]])
    S, S_turned = shape.support_rows(d, scene.size), shape.support_rows(d @ turn.T, scene.size)
    return bool(np.allclose(S_turned, S @ turn.T, rtol=0, atol=1e-12 * scene.body_size))


def reference5(scene: Scene) -> dict:
    """The amplitude a, frequency W and spin of a scene of reference [5], checked: J_x =
    J_y, x = y = 0, z = a sin(W t) (a, W > 0), a shape symmetric about Oz and centred on
    it, the axis vertical, omega = (0, 0, spin).  SceneError names what breaks."""
    if not scene.contact_possible:
        raise SceneError("[plane]", "periodic bouncing needs the plane and a shape")
    if abs(scene.J[0] - scene.J[1]) > 1e-12 * scene.J[0]:
        raise SceneError("[body].inertia", "periodic bouncing of reference [5] needs a "
                                           f"symmetric carrier, J_x = J_y (got {scene.J[:2]})")
    if not (scene.law.is_zero(0) and scene.law.is_zero(1)):
        raise SceneError("[point].law", "the point must move along the symmetry axis: "
                                        "x = y = 0")
    amp, factor = sp.sympify(scene.law.sympy()[2]).as_coeff_Mul()
    ok = isinstance(factor, sp.sin) and amp.is_number and float(amp) > 0
    if ok:
        W = sp.expand(factor.args[0]).coeff(nt.t)
        ok = W.is_number and float(W) > 0 and sp.expand(factor.args[0] - W * nt.t) == 0
    if not ok:
        raise SceneError("[point].law[2]", "must be a*sin(W*t) with numbers a, W > 0 "
                                           f"(got {scene.law_text[2]!r})")
    if scene.center[0] or scene.center[1] or not _about_z(scene):
        raise SceneError("[body]", "the shape must be symmetric about Oz and centred on it")
    if not np.allclose(scene.A0[2], (0.0, 0.0, 1.0), atol=1e-12):
        raise SceneError("[initial]", "the symmetry axis must start vertical (body z up)")
    if scene.omega[0] or scene.omega[1]:
        raise SceneError("[initial].omega", "must be (0, 0, spin): a spin about the axis")
    return {"a": float(amp), "W": float(W), "spin": float(scene.omega[2])}


def table_guess(scene: Scene, n: int) -> np.ndarray:
    """Newton's start: (impact time, post-impact Z_C', omega, n_x, n_y) of the table's
    symmetric n-orbit, with the scene's spin.  SceneError below the existence
    threshold."""
    p = reference5(scene)
    nu = scene.m / (scene.m + scene.M)
    Gamma = nu * p["a"] * p["W"] ** 2 / scene.g
    try:
        orbit = table_orbit(scene.e, n, Gamma)
    except ValueError as exc:
        raise SceneError("[point].law[2]", str(exc)) from None
    T = 2 * math.pi / p["W"]
    return np.r_[orbit["phi"] / p["W"], scene.g * n * T / 2, 0.0, 0.0, p["spin"], 0.0, 0.0]


def find_orbit(scene, n: int = 1, tol: float = 1e-11, max_iter: int = 12,
               hybrid: HybridMap | None = None):
    """Newton on the impact-to-impact map from the table's orbit; returns (t_impact,
    post-impact state, residual, hybrid)."""
    hybrid = hybrid or HybridMap(scene)
    T = 2 * math.pi / reference5(hybrid.scene)["W"]
    x = table_guess(hybrid.scene, n)

    def P(xv):
        q0 = _unpack(xv[1:], xv[0], hybrid)
        nxt = hybrid.to_next_impact(xv[0], q0, 1.5 * n * T)
        if nxt is None:
            raise RuntimeError("no impact within 1.5 periods of the orbit")
        t1, q1 = nxt
        return np.r_[t1 - n * T, _pack(q1)]
    residual = np.inf
    for _ in range(max_iter):
        F = P(x) - x
        residual = float(np.max(np.abs(F)))
        if residual < tol:
            break
        Jm = np.empty((len(x), len(x)))
        for k in range(len(x)):
            dx = np.zeros(len(x))
            dx[k] = 1e-7 * max(1.0, abs(x[k]))
            Jm[:, k] = ((P(x + dx) - (x + dx)) - (P(x - dx) - (x - dx))) / (2 * dx[k])
        step = np.linalg.lstsq(Jm, -F, rcond=None)[0]
        x = x + step
    return x[0], _unpack(x[1:], x[0], hybrid), residual, hybrid


def analyse(scene, n: int = 1, fd_eps: float = 1e-6, check: bool = True,
            long_periods: int = 0, perturbations=(1e-6, 1e-4, 1e-2),
            progress: bool = False) -> Bounce:
    """The n-orbit of a reference-[5] scene (a path, dict or Scene) and its multipliers;
    where no multiplier is outside the unit circle (the spin and tilt modes are on it),
    ``long_periods`` > 0 adds perturbed runs of the hybrid runtime of each size in
    ``perturbations`` (:func:`long_run`)."""
    t_imp, q_plus, residual, hybrid = find_orbit(scene, n)
    s = hybrid.scene
    p = reference5(s)
    W = p["W"]
    T = n * 2 * math.pi / W
    mono = Monodromy(s)
    # mid-flight to mid-flight: flight to the next impact, saltation, flight to mid-flight
    t_mid = t_imp + 0.5 * T
    q_mid, _ = mono.flow(t_imp, q_plus, 0.5 * T)
    q_minus, Phi1 = mono.flow(t_mid, q_mid, 0.5 * T)
    S = saltation(hybrid, t_imp + T, q_minus)
    q_after = impact_state(hybrid, t_imp + T, q_minus)
    q_end, Phi2 = mono.flow(t_imp + T, q_after, 0.5 * T)
    M = Phi2 @ S @ Phi1
    rho = np.linalg.eigvals(M)
    # finite differences of the full hybrid runtime, mid-flight to mid-flight
    fd = np.full_like(M, np.nan)
    for k in range(M.shape[0] if check else 0):
        dq = np.zeros(M.shape[0])
        dq[k] = fd_eps
        plus = hybrid.at(t_mid, q_mid + dq, T)
        minus = hybrid.at(t_mid, q_mid - dq, T)
        fd[:, k] = (plus - minus) / (2 * fd_eps)
    fd_diff = float(np.max(np.abs(fd - M))) if check else float("nan")
    vertical = np.linalg.eigvals(M[:2, :2])
    nu = s.m / (s.m + s.M)
    Gamma = nu * p["a"] * W * W / s.g
    out = Bounce(s, n, T, t_imp, q_plus, residual, rho, M, fd_diff, vertical,
                 table_orbit(s.e, n, Gamma), t_mid, q_mid)
    if long_periods and not out.unstable:
        from ..progress import Bar
        bar = Bar("perturbed runs", progress, delay=0.5)
        try:
            out.long_runs = [long_run(hybrid, t_mid, q_mid, T, long_periods, eps,
                                      report=lambda f, k=k: bar.update(
                                          (k + f) / len(perturbations)))
                             for k, eps in enumerate(perturbations)]
        finally:
            bar.close()
    return out


def long_run(hybrid: HybridMap, t_mid: float, q_mid, T: float, periods: int, eps: float,
             seed: int = 0, report=None, states: list | None = None) -> dict:
    """Perturb omega and the axis n of the orbit's mid-flight state by ``eps`` (a fixed
    random direction, omega's part scaled by max(1, |omega|), n renormalised, as
    :func:`derive.stability.floquet.long_run` perturbs a rotation) and follow the hybrid
    runtime (its impacts, the momentum form in flight) for ``periods`` periods, sampled
    at mid-flight once per period (appended to ``states`` if given).  The orbit's omega
    and n are constant, so a deviation is the sample's distance from them."""
    base = np.asarray(q_mid, dtype=float)
    q = perturbed(base, eps, seed)
    both, omega = [], []
    status, t = "done", t_mid
    for k in range(periods + 1):
        if states is not None:
            states.append(q.copy())
        both.append(float(np.max(np.abs(q[2:] - base[2:]))))
        omega.append(float(np.max(np.abs(q[V.omega] - base[V.omega]))))
        if k == periods:
            break
        raw = hybrid.run(t, q, T)
        if raw.status != "done":            # e.g. chattering into contact: the run stops
            status = raw.status
            break
        t, q = t + T, raw.q[-1]
        if report and k % 64 == 0:
            report(k / periods)
    return {"eps": eps, "periods": periods, **growth(np.array(both)),
            **{f"{k}_omega": v for k, v in growth(np.array(omega)).items()},
            "status": status}


def perturbed(q_mid, eps: float, seed: int = 0) -> np.ndarray:
    """The start of :func:`long_run`: omega moved by eps max(1, |omega|) and n by eps
    (renormalised), in a random direction fixed by ``seed``."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=6)
    d /= np.linalg.norm(d)
    q = np.array(q_mid, dtype=float)
    q[V.omega] += eps * d[:3] * max(1.0, float(np.linalg.norm(q[V.omega])))
    tilted = q[V.n] + eps * d[3:]
    q[V.n] = tilted / np.linalg.norm(tilted)
    return q
